"""The pure physics core: numpy arrays and typed records in and out, SI units inside.

No ROS, CAN, MCAP or file I/O is imported anywhere below this package.

Its names are loaded on first use (PEP 562): importing one module of the core (the parameters
loader needs the gear's records) does not load the compiled load-sharing solver (numba,
about 70 MB), which only the estimation and the live model need.
"""

from __future__ import annotations

import importlib
from typing import Any

#: where each name of the package lives
_WHERE = {
    'BacklashResult': 'steer_monitor.model.backlash',
    'CASE_NAMES': 'steer_monitor.model.loadshare',
    'chain_backlash': 'steer_monitor.model.backlash',
    'ChainJoint': 'steer_monitor.model.backlash',
    'clamped_clamped_compliance': 'steer_monitor.model.beams',
    'clamped_pinned_compliance': 'steer_monitor.model.beams',
    'clamped_pinned_reactions': 'steer_monitor.model.beams',
    'Clearance': 'steer_monitor.model.isofits',
    'clearance_of': 'steer_monitor.model.isofits',
    'critical_forces': 'steer_monitor.model.loadshare',
    'euler_force': 'steer_monitor.model.beams',
    'Fit': 'steer_monitor.model.isofits',
    'friction_force': 'steer_monitor.model.friction',
    'FrictionParams': 'steer_monitor.model.friction',
    'gap_sensitivity': 'steer_monitor.model.landmarks',
    'Clearances': 'steer_monitor.model.gear',
    'GapSensitivity': 'steer_monitor.model.landmarks',
    'GearParams': 'steer_monitor.model.gear',
    'grade_for_limit': 'steer_monitor.model.backlash',
    'GradeCheck': 'steer_monitor.model.backlash',
    'hole_tolerance': 'steer_monitor.model.isofits',
    'it_value': 'steer_monitor.model.isofits',
    'Landmarks': 'steer_monitor.model.landmarks',
    'landmarks': 'steer_monitor.model.landmarks',
    'load_sharing': 'steer_monitor.model.loadshare',
    'load_sharing_at': 'steer_monitor.model.loadshare',
    'load_sharing_scalar': 'steer_monitor.model.loadshare',
    'LoadSharing': 'steer_monitor.model.loadshare',
    'normal_forces': 'steer_monitor.model.friction',
    'paper_case': 'steer_monitor.model.loadshare',
    'parse_fit': 'steer_monitor.model.isofits',
    'pinned_pinned_compliance': 'steer_monitor.model.beams',
    'pinned_pinned_reactions': 'steer_monitor.model.beams',
    'pinned_pinned_slope_at_a': 'steer_monitor.model.beams',
    'ram_inertia': 'steer_monitor.model.gear',
    'rapson_arm': 'steer_monitor.model.backlash',
    'rapson_state': 'steer_monitor.model.kinematics',
    'RapsonState': 'steer_monitor.model.kinematics',
    'shaft_tolerance': 'steer_monitor.model.isofits',
    'STAGE_CLAMPED': 'steer_monitor.model.loadshare',
    'STAGE_GUIDE': 'steer_monitor.model.loadshare',
    'STAGE_PINNED': 'steer_monitor.model.loadshare',
    'Tolerance': 'steer_monitor.model.isofits',
    'TorqueCurve': 'steer_monitor.model.torque',
}

__all__ = sorted(_WHERE)


def __getattr__(name: str) -> Any:
    if name in _WHERE:
        value = getattr(importlib.import_module(_WHERE[name]), name)
        globals()[name] = value
        return value
    msg = f'module {__name__!r} has no attribute {name!r}'
    raise AttributeError(msg)


def __dir__() -> list[str]:
    return sorted(__all__)
