"""Load sharing between a ram and the guide beam (paper 004): one solver for every case.

The lateral force Fl of one ram is applied incrementally from 0. The ram starts as a beam
pinned in both bushings (stage I). Two events change the structure:

* clamp: the ram's slope at bushing A reaches theta_max = 2Z / l_s, i.e. its pinned force
  reaches F_theta; from then on A acts as a clamp (stage II: clamped at A, pinned at E) for
  further load;
* guide: the deflection at the load point B reaches Z_gb (the pinned ram's force F_Z); from
  then on the guide beam (clamped at both ends) and the ram act as parallel springs (stage III),
  the ram taking lambda_gb / (lambda_r + lambda_gb) of each further increment.

Within a stage every quantity is linear in the load, so the loading is resolved event by event
in closed form (:func:`_resolve`: at most two events, then the end), and the final forces are
the sums over the stages. The paper's six cases (the orderings of Fl, F_theta and F_Z, see
:func:`paper_case`) all fall out of this one function; ``stages`` records which stages carried
load as bit flags (I = 1, II = 2, III = 4). ``test/model/loadshare_oracle.py`` loads the ram
step by step as paper 004 words it, a test compares the two on every case, and the beams'
closed forms are checked against a finite-element solution.

One difference from the paper: for cases 5-6 it assumes the clamp forms before the guide
engages. That is exact for case 5 (F_theta < F_Z). In case 6 (F_Z < F_theta < Fl) the guide
engages first, the ram then carries only its share of further load, and it clamps only if
that share lifts its force to F_theta; otherwise the result is stages I + III. The solver
follows the events, i.e. the physics, and the README says so.

One implementation, compiled with numba: the arrays of a profile (every angle cell of a log at
every clearance pair, tens of millions of states), the live monitor's single state and a
replay's batches of them all run the same element function, so they agree to the bit.
Compiled code also releases the GIL, so the node's estimator thread does not hold up its bus
reader.

Units: SI (rad, N, N m, m). Arrays broadcast over samples.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from steer_monitor.compiled import njit
from steer_monitor.errors import ModelError
from steer_monitor.model import beams
from steer_monitor.model.friction import FrictionParams, friction_law, normal_forces
from steer_monitor.model.gear import Clearances, GearParams
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
    'declared_residuals',
    'friction_normals',
    'load_sharing',
    'load_sharing_at',
    'load_sharing_scalar',
    'paper_case',
    'CASE_WORDS',
    'case_words',
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

#: the outputs of the element function, in its order (see :class:`LoadSharing`)
_FIELDS = ('lateral', 'axial', 'ram_force', 'guide_force', 'k_gl', 'deflection', 'r_a', 'r_e', 'm_a', 'f_theta',
           'f_z', 'case', 'stages')
_NF = len(_FIELDS)

_jit = njit(cache=True, nogil=True, error_model='numpy')
_inline = njit(cache=True, nogil=True, error_model='numpy', inline='always')
# the beams' closed forms, compiled from their one definition
_pp_compliance = _inline(beams.pinned_pinned_compliance)
_pp_slope = _inline(beams.pinned_pinned_slope_at_a)
_pp_reactions = _inline(beams.pinned_pinned_reactions)
_cp_compliance = _inline(beams.clamped_pinned_compliance)
_cp_reactions = _inline(beams.clamped_pinned_reactions)
_cc_compliance = _inline(beams.clamped_clamped_compliance)
_euler_force = _inline(beams.euler_force)
_normal_forces = _inline(normal_forces)
_friction_law = _inline(friction_law)


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


def compliances(gear: GearParams, state: RapsonState) -> Compliances:
    """Beam compliances of ram and guide beam at the given kinematic state."""
    ei_r = gear.youngs_modulus * gear.ram_inertia
    ei_g = gear.youngs_modulus * gear.guide_beam_inertia
    lam1 = beams.pinned_pinned_compliance(state.near, state.far, ei_r)
    lam2 = beams.clamped_pinned_compliance(state.near, state.far, ei_r)
    slope = beams.pinned_pinned_slope_at_a(state.near, state.far, ei_r)
    if gear.euler_amplification:
        if np.any(state.axial >= state.euler):
            worst = float(np.max(state.axial / state.euler))
            msg = f'axial ram force reaches {worst:.2f} of the Euler force: the ram buckles'
            raise ModelError(msg)
        amp = state.amplification
        lam1, lam2, slope = lam1 * amp, lam2 * amp, slope * amp
    lam_g = beams.clamped_clamped_compliance(state.guide_a, state.guide_b, ei_g)
    return Compliances(lam1, lam2, slope, lam_g)


def _checked_gaps(two_z: ArrayLike, z_gb: ArrayLike) -> tuple[Array, Array]:
    tz = np.asarray(two_z, dtype=float)
    zg = np.asarray(z_gb, dtype=float)
    for name, value in (('two_z', tz), ('z_gb', zg)):
        if value.ndim == 0:
            x = float(value)
            if not (math.isfinite(x) and x >= 0):
                msg = f'clearance {name} must be finite and >= 0 m'
                raise ModelError(msg)
        elif not np.all(np.isfinite(value)) or np.any(value < 0):
            msg = f'clearance {name} must be finite and >= 0 m'
            raise ModelError(msg)
    return tz, zg


def critical_forces(gear: GearParams, state: RapsonState, two_z: ArrayLike,
                    z_gb: ArrayLike) -> tuple[Array, Array]:
    """(F_theta, F_Z) [N]: pinned-ram forces that close the angular and the guide gap."""
    tz, zg = _checked_gaps(two_z, z_gb)
    c = compliances(gear, state)
    return tz / gear.bushing_length / c.slope, zg / c.pinned


#: what carries one ram's lateral force in each of the paper's cases, in a table's words:
#: pinned (1, 2: below both events), clamped at bushing A (3), the guide beam sharing (4), both
#: (5: clamped first; 6: the guide first, the clamp only if the ram's share reaches F_theta)
CASE_WORDS = {1: 'ram, pinned', 2: 'ram, pinned', 3: 'ram, clamped at A', 4: 'ram + guide beam',
              5: 'ram clamped + guide beam', 6: 'ram + guide beam (clamps after)'}


def case_words(case: int) -> str:
    """A row's paper case in words, its number after them: ``'ram + guide beam (case 4)'``."""
    return f'{CASE_WORDS.get(int(case), "?")} (case {int(case)})'


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


def _constants(gear: GearParams) -> NDArray[np.float64]:
    """The gear as the kernels take it: H, L, L_gb, n, E, J_r, J_gb, l_s, Euler (1/0)."""
    return np.array([gear.stock_to_ram, gear.bushing_span, gear.guide_beam_span, float(gear.rams),
                     gear.youngs_modulus, gear.ram_inertia, gear.guide_beam_inertia, gear.bushing_length,
                     1.0 if gear.euler_amplification else 0.0])


def _gear_constants(gear: GearParams) -> NDArray[np.float64]:
    """:func:`_constants` of the gear, worked out once per gear (it is frozen)."""
    k = gear.__dict__.get('_share_constants')
    if k is None:
        k = _constants(gear)
        object.__setattr__(gear, '_share_constants', k)
    return k


@_inline
def _state(alpha: float, torque: float, k: NDArray[np.float64]) -> tuple:
    """The closed forms of one sample before any event: (Fa, Fl [N], lambda1, lambda2 [m/N],
    theta_A [rad/N], lambda_gb [m/N], a, b [m], buckled). The ram's compliances carry the
    Euler amplification when the gear asks for it; ``buckled`` when the axial force reaches the
    Euler force."""
    h, span, g_span, rams, e, j_r, j_g = k[0], k[1], k[2], k[3], k[4], k[5], k[6]
    a_abs, m_abs = abs(alpha), abs(torque)
    tan_a = math.tan(a_abs)
    cos_a = math.cos(a_abs)
    travel = h * tan_a
    b = span / 2.0 + travel
    a = span - b
    ag = g_span / 2.0 - travel
    axial = m_abs * (cos_a * cos_a) / (rams * h)
    fl = axial * tan_a
    ei = e * j_r
    lam1 = _pp_compliance(a, b, ei)
    lam2 = _cp_compliance(a, b, ei)
    slope = _pp_slope(a, b, ei)
    lam_g = _cc_compliance(ag, g_span - ag, e * j_g)
    buckled = False
    if k[8] != 0.0:
        f_eu = _euler_force(ei, b)
        buckled = axial >= f_eu
        amp = 1.0 / (1.0 - axial / f_eu)
        lam1, lam2, slope = lam1 * amp, lam2 * amp, slope * amp
    return axial, fl, lam1, lam2, slope, lam_g, a, b, buckled


@_inline
def _resolve(fl: float, lam1: float, lam2: float, lam_g: float, f_theta: float, f_z: float) -> tuple:
    """The load Fl applied from 0 with the clamp at the pinned ram force ``f_theta`` and the
    guide at ``f_z``: (F of the ram while pinned, F of the ram while clamped, F of the guide
    beam [N], stage flags). Each stage is linear; the events come in the order of the forces
    (both at once when equal)."""
    if not fl > 0.0:
        if fl == 0.0:
            return 0.0, 0.0, 0.0, 0
        return math.nan, math.nan, math.nan, 0        # not a number in, not a number out
    if fl <= f_theta and fl <= f_z:                  # no event: pinned throughout (cases 1, 2)
        return fl, 0.0, 0.0, STAGE_PINNED
    s2 = lam_g / (lam2 + lam_g)                     # the clamped ram's share once the guide carries
    if f_theta <= f_z:                               # the ram clamps first
        stages = STAGE_PINNED if f_theta > 0.0 else 0
        rest = fl - f_theta
        extra = (f_z - f_theta) * lam1 / lam2        # load in stage II until the deflection reaches Z_gb
        if rest <= extra:
            return f_theta, rest, 0.0, stages | STAGE_CLAMPED
        if extra > 0.0:
            stages |= STAGE_CLAMPED
        rest -= extra
        return f_theta, extra + s2 * rest, (1.0 - s2) * rest, stages | STAGE_CLAMPED | STAGE_GUIDE
    stages = STAGE_PINNED if f_z > 0.0 else 0       # the guide touches first
    s1 = lam_g / (lam1 + lam_g)                     # the pinned ram's share with the guide
    rest = fl - f_z
    need = (f_theta - f_z) / s1                     # load until the ram's force reaches F_theta
    if rest <= need:
        return f_z + s1 * rest, 0.0, (1.0 - s1) * rest, stages | STAGE_PINNED | STAGE_GUIDE
    rest -= need
    return (f_theta, s2 * rest, (1.0 - s1) * need + (1.0 - s2) * rest,
            stages | STAGE_PINNED | STAGE_CLAMPED | STAGE_GUIDE)


@_inline
def _element(alpha: float, torque: float, two_z: float, z_gb: float, k: NDArray[np.float64]) -> tuple:
    """One sample: the values of ``_FIELDS`` in order, then whether the ram buckled."""
    axial, fl, lam1, lam2, slope, lam_g, a, b, buckled = _state(alpha, torque, k)
    f_theta = (two_z / k[7]) / slope if slope > 0.0 else math.inf
    f_z = z_gb / lam1 if lam1 > 0.0 else math.inf
    f_pinned, f_clamped, f_guide, stages = _resolve(fl, lam1, lam2, lam_g, f_theta, f_z)
    rp_a, rp_e = _pp_reactions(a, b)
    rc_a, rc_e, mc_a = _cp_reactions(a, b)
    theta_first = f_theta <= f_z
    if fl <= min(f_theta, f_z):
        case = 1 if theta_first else 2
    elif fl > max(f_theta, f_z):
        case = 5 if theta_first else 6
    else:
        case = 3 if theta_first else 4
    return (fl, axial, f_pinned + f_clamped, f_guide, f_guide / fl if fl > 0.0 else 0.0,
            lam1 * f_pinned + lam2 * f_clamped, f_pinned * rp_a + f_clamped * rc_a,
            f_pinned * rp_e + f_clamped * rc_e, f_clamped * mc_a, f_theta, f_z, case, stages, buckled)


@_jit
def _solve(alpha: Array, torque: Array, two_z: Array, z_gb: Array, k: Array, out: Array) -> int:
    """:func:`_element` of each sample (1-d arrays of one length) into ``out`` (13, n); the
    index of the first sample whose ram buckles, or -1."""
    for i in range(alpha.size):
        r = _element(alpha[i], torque[i], two_z[i], z_gb[i], k)
        if r[13]:
            return i
        out[0, i], out[1, i], out[2, i], out[3, i], out[4, i], out[5, i] = r[0], r[1], r[2], r[3], r[4], r[5]
        out[6, i], out[7, i], out[8, i], out[9, i], out[10, i] = r[6], r[7], r[8], r[9], r[10]
        out[11, i], out[12, i] = r[11], r[12]
    return -1


@_jit
def _solve_one(alpha: float, torque: float, two_z: float, z_gb: float, k: Array) -> tuple:
    return _element(alpha, torque, two_z, z_gb, k)


@_jit
def _normals_grid(alpha: Array, torque: Array, two_z: Array, z_gb: Array, k: Array, n_b: Array, f_gb: Array) -> int:
    """For each cell (``alpha``, ``torque``; (C,)) and clearance pair (``two_z``, ``z_gb``; (G,)):
    N_A + N_E and |F_gb| into ``n_b`` and ``f_gb`` (C, G). The cell's closed forms once, the
    events per pair; -1, or the first cell whose ram buckles."""
    ls = k[7]
    for c in range(alpha.size):
        axial, fl, lam1, lam2, slope, lam_g, a, b, buckled = _state(alpha[c], torque[c], k)
        if buckled:
            return c
        rp_a, rp_e = _pp_reactions(a, b)
        rc_a, rc_e, mc_a = _cp_reactions(a, b)
        for g in range(two_z.size):
            f_theta = (two_z[g] / ls) / slope if slope > 0.0 else math.inf
            f_z = z_gb[g] / lam1 if lam1 > 0.0 else math.inf
            fp, fc, fg, _ = _resolve(fl, lam1, lam2, lam_g, f_theta, f_z)
            n_a, n_e = _normal_forces(fp * rp_a + fc * rc_a, fp * rp_e + fc * rc_e, fc * mc_a, ls)
            n_b[c, g] = n_a + n_e
            f_gb[c, g] = abs(fg)
    return -1


@_jit
def _declared(alpha: Array, torque: Array, direction: Array, forces: Array, two_z: float, z_gb: float, k: Array,
              friction: Array, area: float, open_2z: bool, open_zgb: bool, out: Array) -> int:
    """Per sample, each ram's pressure residual against the declared model [Pa] and whether
    judged (:func:`declared_residuals`) into ``out`` (n, 3); the index of the first sample
    whose ram buckles, or -1."""
    for i in range(alpha.size):
        if not math.isfinite(torque[i]):
            out[i, 0] = out[i, 1] = math.nan
            out[i, 2] = 0.0
            continue
        r = _element(alpha[i], torque[i], two_z, z_gb, k)
        if r[13]:
            return i
        if (open_2z and r[0] > r[9]) or (open_zgb and r[0] > r[10]):
            out[i, 0] = out[i, 1] = math.nan
            out[i, 2] = 0.0
            continue
        n_a, n_e = _normal_forces(r[6], r[7], r[8], k[7])
        f_fr = _friction_law(friction[0], friction[1], friction[2], n_a, n_e, r[3])
        predicted = math.copysign(r[1], alpha[i]) + direction[i] * f_fr
        out[i, 0] = (forces[i, 0] - predicted) / area
        out[i, 1] = (forces[i, 1] - predicted) / area
        out[i, 2] = 1.0
    return -1


def declared_residuals(gear: GearParams, alpha: NDArray[np.float64], torque: NDArray[np.float64],
                       direction: NDArray[np.float64], forces: NDArray[np.float64], gaps: Clearances,
                       friction: FrictionParams, *, open_2z: bool = False, open_zgb: bool = False) -> Array:
    """Each ram's pressure residual against the declared model [Pa] at samples (n,) moving in
    ``direction`` (+-1) at angle ``alpha`` [rad] under tiller torque ``torque`` [N m], the
    rams' forces ``forces`` (n, 2) [N], with clearances ``gaps`` and the friction law's
    ``friction``: (force - (sign(alpha) Fa + direction F_fr)) / A_r, with Fa and F_fr the
    numbers of :func:`load_sharing` and :func:`~steer_monitor.model.friction.friction_force`
    element by element, in one compiled pass (the live monitor judges its residual with it
    once a second). Returns (n, 3): the two residuals and whether the sample is judged (1.0 /
    0.0; its residuals NaN where not): not where the torque is not finite (beyond the angles a
    fitted torque was learned at), nor where the solution clamps the ram (Fl > F_theta) with
    ``open_2z`` or has the slipper touch the beam (Fl > F_Z) with ``open_zgb`` (a clearance
    the data bound from below only: they never saw that happen)."""
    _checked_gaps(gaps.two_z, gaps.z_gb)
    a = np.ascontiguousarray(alpha, dtype=float)
    t = np.ascontiguousarray(torque, dtype=float)
    d = np.ascontiguousarray(direction, dtype=float)
    f = np.ascontiguousarray(forces, dtype=float)
    if a.ndim != 1 or t.shape != a.shape or d.shape != a.shape or f.shape != (a.shape[0], 2):
        msg = (f'declared residuals need samples of one shape (n,) and forces (n, 2), got {a.shape}, {t.shape}, '
               f'{d.shape} and {f.shape}')
        raise ValueError(msg)
    out = np.empty((a.shape[0], 3))
    coef = np.array([friction.seal, friction.mu_bushing, friction.mu_guide], float)
    bad = _declared(a, t, d, f, float(gaps.two_z), float(gaps.z_gb), _gear_constants(gear), coef,
                    float(gear.ram_area), bool(open_2z), bool(open_zgb), out)
    if bad >= 0:
        raise _buckled(gear, float(a[bad]), float(t[bad]))
    return out


def _buckled(gear: GearParams, alpha: float, torque: float) -> ModelError:
    st = rapson_state(gear, alpha, torque)
    return ModelError(f'axial ram force reaches {float(st.axial / st.euler):.2f} of the Euler force: '
                      f'the ram buckles')


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
    tz, zg = _checked_gaps(two_z, z_gb)
    a, t = np.asarray(alpha, float), np.asarray(torque, float)
    if a.ndim == 1 and t.shape == a.shape and tz.ndim == 0 and zg.ndim == 0:
        # samples (n,) at one clearance pair (the live monitor's batches): no broadcasting
        n = a.shape[0]
        shape: tuple[int, ...] = (n,)
        flat = [np.ascontiguousarray(a), np.ascontiguousarray(t), np.full(n, float(tz)), np.full(n, float(zg))]
    else:
        arrays = np.broadcast_arrays(a, t, tz, zg)
        shape = arrays[0].shape
        flat = [np.ascontiguousarray(x, dtype=float).reshape(-1) for x in arrays]
    out = np.empty((_NF, flat[0].size))
    bad = _solve(*flat, _gear_constants(gear), out)
    if bad >= 0:
        raise _buckled(gear, float(flat[0][bad]), float(flat[1][bad]))
    rows = [out[i].reshape(shape) for i in range(_NF)]
    rows[11] = rows[11].astype(np.int8)       # case
    rows[12] = rows[12].astype(np.uint8)      # stages
    return LoadSharing(*rows)


def load_sharing_at(gear: GearParams, alpha: ArrayLike, gaps: Clearances,
                    speed: ArrayLike | None = None) -> LoadSharing:
    """Load sharing with the tiller torque taken from the gear's torque curve.

    ``alpha`` in rad; ``speed`` ship speed in m/s (service speed when None).
    """
    torque = gear.torque(alpha, speed)
    return load_sharing(gear, alpha, torque, gaps.two_z, gaps.z_gb)


def load_sharing_scalar(gear: GearParams, alpha: float, torque: float, two_z: float,
                        z_gb: float) -> ShareScalar:
    """One sample of :func:`load_sharing` as plain floats, for live use: the same element
    function, so the same numbers to the bit, without the arrays' set-up."""
    if not (math.isfinite(two_z) and two_z >= 0 and math.isfinite(z_gb) and z_gb >= 0):
        msg = 'clearance two_z and z_gb must be finite and >= 0 m'
        raise ModelError(msg)
    r = _solve_one(float(alpha), float(torque), float(two_z), float(z_gb), _gear_constants(gear))
    if r[13]:
        raise _buckled(gear, alpha, torque)
    return ShareScalar(r[0], r[1], r[2], r[3], r[4], r[5], r[6], r[7], r[8], r[9], r[10], int(r[11]), int(r[12]))


def friction_normals(gear: GearParams, alpha: ArrayLike, torque: ArrayLike, two_z: ArrayLike,
                     z_gb: ArrayLike) -> tuple[Array, Array]:
    """The friction law's loads on a grid: for each angle and torque (C,) [rad, N m] and each
    clearance pair (G,) [m], N_A + N_E and |F_gb| [N], shapes (C, G) (the declared friction
    law, :mod:`~steer_monitor.model.friction`). The clearance profile's inner loop: each cell's
    closed forms are worked out once for all the pairs."""
    tz, zg = _checked_gaps(two_z, z_gb)
    a = np.ascontiguousarray(alpha, dtype=float).reshape(-1)
    t = np.ascontiguousarray(np.broadcast_to(np.asarray(torque, float), a.shape), dtype=float).reshape(-1)
    tz, zg = (np.ascontiguousarray(x, dtype=float).reshape(-1) for x in np.broadcast_arrays(tz, zg))
    n_b = np.empty((a.size, tz.size))
    f_gb = np.empty((a.size, tz.size))
    bad = _normals_grid(a, t, tz, zg, _constants(gear), n_b, f_gb)
    if bad >= 0:
        raise _buckled(gear, float(a[bad]), float(t[bad]))
    return n_b, f_gb
