"""Load sharing between a ram and the guide beam (seed 004), event-driven and vectorized.

The lateral force Fl of one ram is applied incrementally from 0. The ram starts as a beam
pinned in both bushings (stage I). Two events change the structure:

* clamp: the ram's slope at bushing A reaches theta_max = 2Z / l_s; from then on A acts as a
  clamp (stage II: clamped at A, pinned at E) for further load;
* guide: the deflection at the load point B reaches Z_gb; from then on the guide beam
  (clamped at both ends) and the ram act as parallel springs (stage III).

Each increment is split by the compliances of the current state, so the final forces are
the sums over stages. The paper's six cases (the orderings of Fl, F_theta and F_Z, see
:func:`paper_case`) all fall out of this one loop; ``stages`` records which stages occurred
as bit flags (I = 1, II = 2, III = 4).

One difference from the paper: for cases 5-6 it assumes the clamp forms before the guide
engages. That is exact for case 5 (F_theta < F_Z). In case 6 (F_Z < F_theta < Fl) the guide
engages first, the ram then carries only its share of further load, and it clamps only if
that share lifts its force to F_theta; otherwise the result is stages I + III. The solver
follows the events, i.e. the physics, and the README says so.

Units: SI (rad, N, N m, m). Arrays broadcast over samples.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from steer_monitor.errors import ModelError
from steer_monitor.model.beams import (
    clamped_clamped_compliance,
    clamped_pinned_compliance,
    clamped_pinned_reactions,
    pinned_pinned_compliance,
    pinned_pinned_reactions,
    pinned_pinned_slope_at_a,
)
from steer_monitor.model.gear import Gaps, GearParams
from steer_monitor.model.kinematics import RapsonState, rapson_state

__all__ = [
    'CASE_NAMES',
    'STAGE_CLAMPED',
    'STAGE_GUIDE',
    'STAGE_PINNED',
    'Compliances',
    'LoadSharing',
    'ShareScalar',
    'compliances',
    'critical_forces',
    'load_sharing',
    'load_sharing_at',
    'load_sharing_scalar',
    'load_sharing_scalars',
    'paper_case',
]

STAGE_PINNED = 1   # I: ram pinned in both bushings
STAGE_CLAMPED = 2  # II: ram clamped at A, pinned at E
STAGE_GUIDE = 4    # III: guide beam carries load in parallel with the ram

CASE_NAMES = {
    1: 'Fl < F_theta < F_Z: ram pinned, stage I',
    2: 'Fl < F_Z < F_theta: ram pinned, stage I',
    3: 'F_theta < Fl < F_Z: ram clamps, guide idle, stages I + II',
    4: 'F_Z < Fl < F_theta: guide engages, ram pinned, stages I + III',
    5: 'F_theta < F_Z < Fl: ram clamps, then guide may engage, stages I + II (+ III)',
    6: 'F_Z < F_theta < Fl: guide engages, then ram may clamp, stages I + III (+ II)',
}

Array = NDArray[np.float64]


@dataclass(frozen=True)
class Compliances:
    """Per-unit-load compliances at each sample [m/N, rad/N]; shape of the samples.

    ``pinned`` lambda1, ``clamped`` lambda2, ``slope`` theta_A of the pinned ram,
    ``guide`` lambda_gb. Ram values include the Euler amplification when the gear asks for it.
    """

    pinned: Array
    clamped: Array
    slope: Array
    guide: Array


@dataclass(frozen=True)
class LoadSharing:
    """Result of :func:`load_sharing`; every array has the broadcast sample shape. SI units.

    Attributes:
        lateral: Fl, lateral force on one ram's crosshead [N].
        axial: Fa, axial ram force [N].
        ram_force: F_r, part of Fl the ram carries (sum over stages) [N].
        guide_force: F_gb, part of Fl the guide beam carries [N].
        k_gl: F_gb / Fl (0 where Fl = 0).
        deflection: ram deflection at the load point B [m].
        r_a, r_e: bushing reactions at A (near) and E (far) [N].
        m_a: clamp moment at A [N m].
        f_theta: pinned-ram force that closes the angular gap [N].
        f_z: pinned-ram force that closes the guide gap [N].
        case: the paper's case 1..6 (int8).
        stages: bit flags of the stages that carried load (uint8; see STAGE_*).
    """

    lateral: Array
    axial: Array
    ram_force: Array
    guide_force: Array
    k_gl: Array
    deflection: Array
    r_a: Array
    r_e: Array
    m_a: Array
    f_theta: Array
    f_z: Array
    case: NDArray[np.int8]
    stages: NDArray[np.uint8]


def compliances(gear: GearParams, state: RapsonState) -> Compliances:
    """Beam compliances of ram and guide beam at the given kinematic state."""
    ei_r = gear.youngs_modulus * gear.ram_inertia
    ei_g = gear.youngs_modulus * gear.guide_beam_inertia
    lam1 = pinned_pinned_compliance(state.near, state.far, ei_r)
    lam2 = clamped_pinned_compliance(state.near, state.far, ei_r)
    slope = pinned_pinned_slope_at_a(state.near, state.far, ei_r)
    if gear.euler_amplification:
        if np.any(state.axial >= state.euler):
            worst = float(np.max(state.axial / state.euler))
            msg = f'axial ram force reaches {worst:.2f} of the Euler force: the ram buckles'
            raise ModelError(msg)
        amp = state.amplification
        lam1, lam2, slope = lam1 * amp, lam2 * amp, slope * amp
    lam_g = clamped_clamped_compliance(state.guide_a, state.guide_b, ei_g)
    return Compliances(lam1, lam2, slope, lam_g)


def _gap_arrays(gear: GearParams, two_z: ArrayLike, z_gb: ArrayLike) -> tuple[Array, Array]:
    tz = np.asarray(two_z, dtype=float)
    zg = np.asarray(z_gb, dtype=float)
    for name, value in (('two_z', tz), ('z_gb', zg)):
        if not np.all(np.isfinite(value)) or np.any(value < 0):
            msg = f'clearance {name} must be finite and >= 0 m'
            raise ModelError(msg)
    return tz / gear.bushing_length, zg


def critical_forces(gear: GearParams, state: RapsonState, two_z: ArrayLike,
                    z_gb: ArrayLike) -> tuple[Array, Array]:
    """(F_theta, F_Z) [N]: pinned-ram forces that close the angular and the guide gap."""
    theta_max, zg = _gap_arrays(gear, two_z, z_gb)
    c = compliances(gear, state)
    return theta_max / c.slope, zg / c.pinned


def paper_case(lateral: ArrayLike, f_theta: ArrayLike, f_z: ArrayLike) -> NDArray[np.int8]:
    """The paper's case number 1..6 from the ordering of Fl, F_theta and F_Z (ties go low)."""
    fl, ft, fz = np.broadcast_arrays(np.asarray(lateral, float), np.asarray(f_theta, float),
                                     np.asarray(f_z, float))
    theta_first = ft <= fz
    below_both = fl <= np.minimum(ft, fz)
    above_both = fl > np.maximum(ft, fz)
    case = np.where(theta_first, 3, 4)
    case = np.where(below_both, np.where(theta_first, 1, 2), case)
    case = np.where(above_both, np.where(theta_first, 5, 6), case)
    return case.astype(np.int8)


def load_sharing(gear: GearParams, alpha: ArrayLike, torque: ArrayLike,
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
    theta_max, zg = _gap_arrays(gear, two_z, z_gb)
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


def load_sharing_at(gear: GearParams, alpha: ArrayLike, gaps: Gaps,
                    speed: ArrayLike | None = None) -> LoadSharing:
    """Load sharing with the tiller torque taken from the gear's torque curve.

    ``alpha`` in rad; ``speed`` ship speed in m/s (service speed when None).
    """
    torque = gear.torque(alpha, speed)
    return load_sharing(gear, alpha, torque, gaps.two_z, gaps.z_gb)


@dataclass(frozen=True, slots=True)
class ShareScalar:
    """:class:`LoadSharing` of one sample as plain floats (same fields, same units)."""

    lateral: float
    axial: float
    ram_force: float
    guide_force: float
    k_gl: float
    deflection: float
    r_a: float
    r_e: float
    m_a: float
    f_theta: float
    f_z: float
    case: int
    stages: int


def _closed_forms(gear: GearParams, m_abs: Any, tan_a: Any, cos_a: Any) -> tuple[Any, ...]:
    """The closed forms before the event loop, of one sample (floats) or many (1-d arrays),
    from |M| [N m] and tan, cos of |alpha|: the same operations in the same order either way,
    which is what keeps :func:`load_sharing_scalar` and :func:`load_sharing_scalars` equal to
    the bit. -> (a, b [m], Fa, Fl [N], lambda1, lambda2 [m/N], theta_A [rad/N], lambda_gb
    [m/N]), the ram's compliances without the Euler amplification."""
    span, h = gear.bushing_span, gear.stock_to_ram
    travel = h * tan_a
    b = span / 2.0 + travel
    a = span - b
    ag = gear.guide_beam_span / 2.0 - travel
    bg = gear.guide_beam_span - ag
    axial = m_abs * (cos_a * cos_a) / (gear.rams * h)
    fl = axial * tan_a
    ei = gear.youngs_modulus * gear.ram_inertia
    lam1 = a * a * b * b / (3.0 * ei * span)
    lam2 = a * a * a * b * b * (3.0 * span + b) / (12.0 * ei * span**3)
    slope = b * (span * span - b * b) / (6.0 * ei * span)
    lam_g = (ag * ag * ag) * (bg * bg * bg) / (3.0 * gear.youngs_modulus * gear.guide_beam_inertia
                                               * gear.guide_beam_span**3)
    return a, b, axial, fl, lam1, lam2, slope, lam_g


def _clamp_factors(span: float, a: Any, b: Any) -> tuple[Any, Any]:
    """Per unit of clamped-ram force: the far bushing's reaction and the clamp moment [m] (as
    :func:`_closed_forms`, for floats or arrays alike)."""
    return a * a * (3.0 * span - a) / (2.0 * span**3), a * b * (span + b) / (2.0 * span**2)


def load_sharing_scalar(gear: GearParams, alpha: float, torque: float, two_z: float,
                        z_gb: float) -> ShareScalar:
    """One sample of :func:`load_sharing` in plain float arithmetic, for live use.

    The same closed forms and the same event loop, without numpy's per-call overhead (about
    twenty times faster on one sample); ``test_loadshare`` checks the two agree.
    """
    if not (math.isfinite(two_z) and two_z >= 0 and math.isfinite(z_gb) and z_gb >= 0):
        msg = 'clearance two_z and z_gb must be finite and >= 0 m'
        raise ModelError(msg)
    a_abs, m_abs = abs(alpha), abs(torque)
    span = gear.bushing_span
    tan_a = math.tan(a_abs)
    a, b, axial, fl, lam1, lam2, slope, lam_g = _closed_forms(gear, m_abs, tan_a, math.cos(a_abs))
    if gear.euler_amplification:
        f_eu = math.pi**2 * (gear.youngs_modulus * gear.ram_inertia) / (b * b)
        if axial >= f_eu:
            msg = f'axial ram force reaches {axial / f_eu:.2f} of the Euler force: the ram buckles'
            raise ModelError(msg)
        amp = 1.0 / (1.0 - axial / f_eu)
        lam1, lam2, slope = lam1 * amp, lam2 * amp, slope * amp
    f_theta = (two_z / gear.bushing_length) / slope if slope > 0 else math.inf
    f_z = z_gb / lam1 if lam1 > 0 else math.inf

    applied = f_pinned = f_clamped = f_guide = deflection = 0.0
    clamped = guide = False
    stages = 0
    for _ in range(3):
        lam_r = lam2 if clamped else lam1
        share = lam_g / (lam_r + lam_g) if guide else 1.0
        to_end = fl - applied
        to_clamp = math.inf if clamped else max((f_theta - f_pinned) / share, 0.0)
        to_guide = math.inf if guide else max((z_gb - deflection) / lam_r, 0.0) if lam_r > 0 else math.inf
        step = min(to_end, to_clamp, to_guide)
        if step > 0:
            stages |= STAGE_CLAMPED if clamped else STAGE_PINNED
            if guide:
                stages |= STAGE_GUIDE
        ram_step = share * step
        if clamped:
            f_clamped += ram_step
        else:
            f_pinned += ram_step
        f_guide += step - ram_step
        deflection += lam_r * ram_step
        applied += step
        clamped = clamped or to_clamp <= step
        guide = guide or to_guide <= step

    re_c, ma_c = _clamp_factors(span, a, b)
    theta_first = f_theta <= f_z
    if fl <= min(f_theta, f_z):
        case = 1 if theta_first else 2
    elif fl > max(f_theta, f_z):
        case = 5 if theta_first else 6
    else:
        case = 3 if theta_first else 4
    return ShareScalar(
        lateral=fl, axial=axial, ram_force=f_pinned + f_clamped, guide_force=f_guide,
        k_gl=f_guide / fl if fl > 0 else 0.0, deflection=deflection,
        r_a=f_pinned * b / span + f_clamped * (1.0 - re_c), r_e=f_pinned * a / span + f_clamped * re_c,
        m_a=f_clamped * ma_c, f_theta=f_theta, f_z=f_z, case=case, stages=stages)


def _each(fn: Callable[[float], float], x: Array) -> Array:
    """``fn`` of each element in Python float arithmetic (the C library's function, as
    :func:`load_sharing_scalar` calls it)."""
    return np.fromiter(map(fn, x.tolist()), float, x.size)


def load_sharing_scalars(gear: GearParams, alpha: ArrayLike, torque: ArrayLike, two_z: ArrayLike,
                         z_gb: ArrayLike) -> LoadSharing:
    """:func:`load_sharing_scalar` of many samples (1-d arrays of one length, SI), the same
    numbers to the bit.

    :func:`load_sharing` agrees with the scalar solver to rounding only (its own closed forms,
    numpy's transcendental functions); a replay that must write the node's bytes needs the
    scalar's. Here every step is the scalar's, in its order: +, -, *, / and comparisons are
    IEEE-754 operations that round the same in numpy as in Python, the branches are ``where``
    of the same comparisons (Python's ``max(x, 0.0)`` and ``min`` included, NaN and signed
    zeros alike), tan and cos are the scalar's own calls of the C library, element by
    element, and the per-sample powers are products in both (a C ``pow`` would differ from
    them, and between libraries). ``test_loadshare`` compares every field's bits. Raises the
    scalar's :class:`ModelError` for the first sample it would raise on."""
    alpha = np.asarray(alpha, float).ravel()
    n = alpha.size
    torque, two_z, z_gb = (np.broadcast_to(np.asarray(x, float).ravel(), (n,)) for x in (torque, two_z, z_gb))
    if n == 0:
        e = np.empty(0)
        return LoadSharing(e, e, e, e, e, e, e, e, e, e, e, np.empty(0, np.int8), np.empty(0, np.uint8))
    bad = ~(np.isfinite(two_z) & (two_z >= 0) & np.isfinite(z_gb) & (z_gb >= 0))
    if bad.any():
        msg = 'clearance two_z and z_gb must be finite and >= 0 m'
        raise ModelError(msg)
    a_abs, m_abs = np.abs(alpha), np.abs(torque)
    span = gear.bushing_span
    tan_a = _each(math.tan, a_abs)
    with np.errstate(divide='ignore', invalid='ignore', over='ignore'):
        a, b, axial, fl, lam1, lam2, slope, lam_g = _closed_forms(gear, m_abs, tan_a, _each(math.cos, a_abs))
        if gear.euler_amplification:
            f_eu = math.pi**2 * (gear.youngs_modulus * gear.ram_inertia) / (b * b)
            buckles = np.flatnonzero(axial >= f_eu)
            if buckles.size:
                i = int(buckles[0])
                msg = f'axial ram force reaches {axial[i] / f_eu[i]:.2f} of the Euler force: the ram buckles'
                raise ModelError(msg)
            amp = 1.0 / (1.0 - axial / f_eu)
            lam1, lam2, slope = lam1 * amp, lam2 * amp, slope * amp
        f_theta = np.where(slope > 0, (two_z / gear.bushing_length) / slope, math.inf)
        f_z = np.where(lam1 > 0, z_gb / lam1, math.inf)

        applied, f_pinned, f_clamped, f_guide, deflection = (np.zeros(n) for _ in range(5))
        clamped, guide = np.zeros(n, bool), np.zeros(n, bool)
        stages = np.zeros(n, np.uint8)
        for _ in range(3):
            lam_r = np.where(clamped, lam2, lam1)
            share = np.where(guide, lam_g / (lam_r + lam_g), 1.0)
            to_end = fl - applied
            x = (f_theta - f_pinned) / share
            to_clamp = np.where(clamped, math.inf, np.where(0.0 > x, 0.0, x))     # max(x, 0.0)
            x = (z_gb - deflection) / lam_r
            to_guide = np.where(guide, math.inf, np.where(lam_r > 0, np.where(0.0 > x, 0.0, x), math.inf))
            step = np.where(to_clamp < to_end, to_clamp, to_end)                  # min(to_end, to_clamp, to_guide)
            step = np.where(to_guide < step, to_guide, step)
            loaded = step > 0
            stages |= np.where(loaded, np.where(clamped, STAGE_CLAMPED, STAGE_PINNED), 0).astype(np.uint8)
            stages |= np.where(loaded & guide, STAGE_GUIDE, 0).astype(np.uint8)
            ram_step = share * step
            f_clamped = np.where(clamped, f_clamped + ram_step, f_clamped)
            f_pinned = np.where(clamped, f_pinned, f_pinned + ram_step)
            f_guide = f_guide + (step - ram_step)
            deflection = deflection + lam_r * ram_step
            applied = applied + step
            clamped = clamped | (to_clamp <= step)
            guide = guide | (to_guide <= step)

        re_c, ma_c = _clamp_factors(span, a, b)
        theta_first = f_theta <= f_z
        lower = np.where(f_z < f_theta, f_z, f_theta)                             # min(f_theta, f_z)
        upper = np.where(f_z > f_theta, f_z, f_theta)                             # max(f_theta, f_z)
        case = np.where(fl <= lower, np.where(theta_first, 1, 2),
                        np.where(fl > upper, np.where(theta_first, 5, 6), np.where(theta_first, 3, 4)))
        k_gl = np.where(fl > 0, f_guide / fl, 0.0)
    return LoadSharing(
        lateral=fl, axial=axial, ram_force=f_pinned + f_clamped, guide_force=f_guide, k_gl=k_gl,
        deflection=deflection, r_a=f_pinned * b / span + f_clamped * (1.0 - re_c),
        r_e=f_pinned * a / span + f_clamped * re_c, m_a=f_clamped * ma_c, f_theta=f_theta, f_z=f_z,
        case=case.astype(np.int8), stages=stages)
