"""The load-sharing solver as paper 004 words it, kept as a test oracle: the ram loaded
step by step, vectorized over samples with numpy, the structure switched at each event (the
slope at A reaches theta_max: clamp; the deflection at B reaches Z_gb: guide), three steps
covering every case. ``steer_monitor.model.loadshare`` resolves the same events in closed form
(one compiled element function); ``test_loadshare`` compares the two. The beams'
compliances and the gaps' checks are the package's own (what is compared is how the events
are resolved). Not used by the package.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from steer_monitor.model.beams import (
    clamped_pinned_reactions,
    pinned_pinned_reactions,
)
from steer_monitor.model.gear import GearParams
from steer_monitor.model.kinematics import rapson_state
from steer_monitor.model.loadshare import (
    STAGE_CLAMPED,
    STAGE_GUIDE,
    STAGE_PINNED,
    LoadSharing,
    _checked_gaps,
    compliances,
    paper_case,
)

__all__ = ['load_sharing_stepwise']

Array = NDArray[np.float64]


def load_sharing_stepwise(gear: GearParams, alpha: ArrayLike, torque: ArrayLike,
                 two_z: ArrayLike, z_gb: ArrayLike) -> LoadSharing:
    """Share one ram's lateral load between ram and guide beam.

    Args:
        gear: geometry and material.
        alpha: rudder angle [rad], any shape.
        torque: tiller torque [N m], broadcast with alpha (magnitude is used).
        two_z: diametral ram/bushing clearance 2Z [m], broadcast.
        z_gb: slipper/guide-beam clearance Z_gb [m], broadcast.

    Returns:
        :class:`LoadSharing` with arrays of the broadcast shape.
    """
    tz, zg = _checked_gaps(two_z, z_gb)
    theta_max = tz / gear.bushing_length
    state = rapson_state(gear, alpha, torque)
    comp = compliances(gear, state)
    shape = np.broadcast_shapes(state.lateral.shape, theta_max.shape, zg.shape)
    fl = np.broadcast_to(state.lateral, shape)
    lam1 = np.broadcast_to(comp.pinned, shape)
    lam2 = np.broadcast_to(comp.clamped, shape)
    lam_g = np.broadcast_to(comp.guide, shape)
    f_theta = np.broadcast_to(theta_max / comp.slope, shape)
    zg = np.broadcast_to(zg, shape)

    applied = np.zeros(shape)
    f_pinned = np.zeros(shape)   # ram force carried while pinned (stage I, and I with III)
    f_clamped = np.zeros(shape)  # ram force carried while clamped
    f_guide = np.zeros(shape)
    deflection = np.zeros(shape)
    clamped = np.zeros(shape, dtype=bool)
    guide = np.zeros(shape, dtype=bool)
    stages = np.zeros(shape, dtype=np.uint8)
    inf = np.inf

    # At most two events (clamp, guide) then the end: three increments cover every case.
    for _ in range(3):
        lam_r = np.where(clamped, lam2, lam1)
        ram_share = np.where(guide, lam_g / (lam_r + lam_g), 1.0)
        to_end = fl - applied
        with np.errstate(divide='ignore', invalid='ignore'):
            to_clamp = np.where(clamped, inf, (f_theta - f_pinned) / ram_share)
            to_guide = np.where(guide, inf, (zg - deflection) / lam_r)
        to_clamp = np.maximum(to_clamp, 0.0)
        to_guide = np.maximum(to_guide, 0.0)
        step = np.minimum(to_end, np.minimum(to_clamp, to_guide))
        loaded = step > 0
        stages |= np.where(loaded, np.where(clamped, STAGE_CLAMPED, STAGE_PINNED), 0).astype(np.uint8)
        stages |= np.where(loaded & guide, STAGE_GUIDE, 0).astype(np.uint8)
        ram_step = ram_share * step
        f_pinned += np.where(clamped, 0.0, ram_step)
        f_clamped += np.where(clamped, ram_step, 0.0)
        f_guide += step - ram_step
        deflection += lam_r * ram_step
        applied += step
        clamped = clamped | (to_clamp <= step)
        guide = guide | (to_guide <= step)

    rp_a, rp_e = pinned_pinned_reactions(state.near, state.far)
    rc_a, rc_e, mc_a = clamped_pinned_reactions(state.near, state.far)
    ram_force = f_pinned + f_clamped
    with np.errstate(divide='ignore', invalid='ignore'):
        k_gl = np.where(fl > 0, f_guide / np.where(fl > 0, fl, 1.0), 0.0)
    f_z = zg / lam1
    return LoadSharing(
        lateral=np.array(fl),
        axial=np.array(np.broadcast_to(state.axial, shape)),
        ram_force=ram_force,
        guide_force=f_guide,
        k_gl=k_gl,
        deflection=deflection,
        r_a=f_pinned * rp_a + f_clamped * rc_a,
        r_e=f_pinned * rp_e + f_clamped * rc_e,
        m_a=f_clamped * mc_a,
        f_theta=np.array(f_theta),
        f_z=f_z,
        case=paper_case(fl, f_theta, f_z),
        stages=stages,
    )


