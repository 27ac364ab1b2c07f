"""The pure physics core: numpy arrays and typed records in and out, SI units inside.

No ROS, CAN, MCAP or file I/O is imported anywhere below this package.
"""

from steer_monitor.model.backlash import (
    BacklashResult,
    ChainJoint,
    GradeCheck,
    chain_backlash,
    grade_for_limit,
    rapson_arm,
)
from steer_monitor.model.beams import (
    clamped_clamped_compliance,
    clamped_pinned_compliance,
    clamped_pinned_reactions,
    euler_force,
    pinned_pinned_compliance,
    pinned_pinned_reactions,
    pinned_pinned_slope_at_a,
)
from steer_monitor.model.fits import (
    Clearance,
    Fit,
    Tolerance,
    clearance_of,
    hole_tolerance,
    it_value,
    parse_fit,
    shaft_tolerance,
)
from steer_monitor.model.friction import FrictionParams, friction_force, normal_forces
from steer_monitor.model.gear import Gaps, GearParams, ram_inertia
from steer_monitor.model.kinematics import RapsonState, rapson_state
from steer_monitor.model.loadshare import (
    CASE_NAMES,
    STAGE_CLAMPED,
    STAGE_GUIDE,
    STAGE_PINNED,
    LoadSharing,
    critical_forces,
    load_sharing,
    load_sharing_at,
    load_sharing_scalar,
    paper_case,
)
from steer_monitor.model.study import GapSensitivity, Landmarks, gap_sensitivity, landmarks
from steer_monitor.model.torque import TorqueCurve

__all__ = [
    'BacklashResult',
    'CASE_NAMES',
    'ChainJoint',
    'Clearance',
    'Fit',
    'FrictionParams',
    'Gaps',
    'GapSensitivity',
    'GearParams',
    'GradeCheck',
    'Landmarks',
    'LoadSharing',
    'RapsonState',
    'STAGE_CLAMPED',
    'STAGE_GUIDE',
    'STAGE_PINNED',
    'Tolerance',
    'TorqueCurve',
    'chain_backlash',
    'clamped_clamped_compliance',
    'clamped_pinned_compliance',
    'clamped_pinned_reactions',
    'clearance_of',
    'critical_forces',
    'euler_force',
    'friction_force',
    'gap_sensitivity',
    'grade_for_limit',
    'hole_tolerance',
    'it_value',
    'landmarks',
    'load_sharing',
    'load_sharing_at',
    'load_sharing_scalar',
    'normal_forces',
    'paper_case',
    'parse_fit',
    'pinned_pinned_compliance',
    'pinned_pinned_reactions',
    'pinned_pinned_slope_at_a',
    'ram_inertia',
    'rapson_arm',
    'rapson_state',
    'shaft_tolerance',
]
