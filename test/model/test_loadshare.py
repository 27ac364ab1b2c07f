"""The load-sharing solver: against the FE contact solution, the paper's six cases, the
stepwise solver paper 004 words (``loadshare_oracle``), and the R-18 landmarks of
paper 004."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest

from steer_monitor.errors import ModelError
from steer_monitor.model import (
    STAGE_CLAMPED,
    STAGE_GUIDE,
    STAGE_PINNED,
    Clearances,
    load_sharing,
    load_sharing_at,
    load_sharing_scalar,
    ram_inertia,
    rapson_state,
)
from steer_monitor.model.loadshare import compliances
from test.model.beam_fem import contact_solution

GAPS_MM = [(0.6, 0.25), (0.1, 0.25), (0.05, 0.05), (0.2, 0.1), (0.3, 0.0), (0.0, 0.3), (0.0, 0.0)]
ANGLES_DEG = [2.5, 7.5, 10.0, 15.0, 21.0, 27.5, 35.0]


@pytest.mark.parametrize('gap_2z_mm,gap_zgb_mm', GAPS_MM)
@pytest.mark.parametrize('alpha_deg', ANGLES_DEG)
def test_matches_fe_contact_solution(r18, alpha_deg, gap_2z_mm, gap_zgb_mm):
    """Final state of the incremental solver = the unique solution of the contact problem."""
    alpha = math.radians(alpha_deg)
    gaps = Clearances.from_mm(gap_2z_mm, gap_zgb_mm)
    res = load_sharing_at(r18, alpha, gaps)
    st = rapson_state(r18, alpha, r18.torque(alpha))
    fe = contact_solution(
        r18.bushing_span, r18.youngs_modulus * r18.ram_inertia, float(st.near),
        r18.guide_beam_span, r18.youngs_modulus * r18.guide_beam_inertia, float(st.guide_a),
        float(st.lateral), gaps.two_z / r18.bushing_length, gaps.z_gb)
    scale = float(st.lateral)
    tol = dict(rel=1e-3, abs=1e-3 * scale)
    assert float(res.ram_force) == pytest.approx(fe.ram_force, **tol)
    assert float(res.guide_force) == pytest.approx(fe.guide_force, **tol)
    assert float(res.r_a) == pytest.approx(fe.r_a, **tol)
    assert float(res.r_e) == pytest.approx(fe.r_e, **tol)
    assert float(res.m_a) == pytest.approx(fe.m_a, rel=1e-3, abs=1e-3 * scale * r18.bushing_span)
    assert float(res.deflection) == pytest.approx(fe.deflection, rel=1e-3, abs=1e-9)
    assert bool(res.stages & STAGE_GUIDE) == fe.guide_contact or fe.guide_force < 1e-6 * scale


def _inputs_for(r18, alpha_deg, fl_kn, f_theta_kn, f_z_kn):
    """Clearances and torque that put Fl, F_theta and F_Z where a case wants them."""
    alpha = math.radians(alpha_deg)
    st = rapson_state(r18, alpha, 1.0)
    c = compliances(r18, st)
    two_z = f_theta_kn * 1e3 * float(c.slope) * r18.bushing_length
    z_gb = f_z_kn * 1e3 * float(c.pinned)
    torque = fl_kn * 1e3 / float(st.lateral)  # lateral is linear in torque
    return alpha, torque, two_z, z_gb


I, II, III = STAGE_PINNED, STAGE_CLAMPED, STAGE_GUIDE  # noqa: E741  the paper's stage numerals


@pytest.mark.parametrize('fl,f_theta,f_z,case,stages', [
    (100, 200, 300, 1, I),
    (100, 300, 200, 2, I),
    (200, 100, 300, 3, I | II),
    (200, 300, 100, 4, I | III),
    (600, 100, 150, 5, I | II | III),     # clamps at 100 kN, then reaches the guide
    (200, 100, 150, 5, I | II),           # clamped ram stiffer: guide never reached
    (2000, 150, 100, 6, I | II | III),    # guide engages, then ram force reaches F_theta
    (300, 150, 100, 6, I | III),          # guide takes most of the rest: ram never clamps
], ids=['case1', 'case2', 'case3', 'case4', 'case5', 'case5-no-guide', 'case6', 'case6-no-clamp'])
def test_six_cases(r18, fl, f_theta, f_z, case, stages):
    alpha, torque, two_z, z_gb = _inputs_for(r18, 20.0, fl, f_theta, f_z)
    res = load_sharing(r18, alpha, torque, two_z, z_gb)
    assert int(res.case) == case
    assert int(res.stages) == stages
    assert float(res.lateral) == pytest.approx(fl * 1e3)
    assert float(res.f_theta) == pytest.approx(f_theta * 1e3)
    assert float(res.f_z) == pytest.approx(f_z * 1e3)
    assert float(res.ram_force + res.guide_force) == pytest.approx(fl * 1e3)
    if not stages & III:
        assert float(res.guide_force) == 0.0
    if not stages & II:
        assert float(res.m_a) == 0.0
    if stages & II:
        assert float(res.m_a) > 0.0


def test_case6_clamp_happens_exactly_at_f_theta(r18):
    """In case 6 the ram clamps when its own force, not the applied load, reaches F_theta."""
    alpha, torque, two_z, z_gb = _inputs_for(r18, 20.0, 2000, 150, 100)
    st = rapson_state(r18, alpha, torque)
    c = compliances(r18, st)
    share = float(c.guide / (c.pinned + c.guide))
    fl_clamp = 100e3 + (150e3 - 100e3) / share
    just_below = load_sharing(r18, alpha, torque * (fl_clamp * 0.999) / 2000e3, two_z, z_gb)
    just_above = load_sharing(r18, alpha, torque * (fl_clamp * 1.001) / 2000e3, two_z, z_gb)
    assert int(just_below.stages) == I | III
    assert int(just_above.stages) == I | II | III


def test_vectorized_equals_per_sample(r18):
    """One element function: an array and its samples one at a time give the same bits."""
    rng = np.random.default_rng(1)
    alpha = rng.uniform(-0.6, 0.6, 300)
    torque = r18.torque(alpha) * rng.uniform(0.2, 3.0, 300)
    two_z = rng.uniform(0, 0.8e-3, 300)
    z_gb = rng.uniform(0, 0.4e-3, 300)
    vec = load_sharing(r18, alpha, torque, two_z, z_gb)
    for i in range(0, 300, 7):
        one = load_sharing(r18, alpha[i], torque[i], two_z[i], z_gb[i])
        for field in _SHARE_FIELDS:
            assert getattr(one, field).tobytes() == getattr(vec, field)[i].tobytes(), field
        assert int(one.case) == int(vec.case[i])
        assert int(one.stages) == int(vec.stages[i])


_SHARE_FIELDS = ('lateral', 'axial', 'ram_force', 'guide_force', 'k_gl', 'deflection', 'r_a', 'r_e', 'm_a',
                 'f_theta', 'f_z')


def _scalar_cases(gear, rng, n):
    """Angles, torques and clearances over every case, with the edges the branches turn on:
    zero angle, torque and clearances, the Euler limit's neighbourhood, and exact ties of
    the load with a critical force."""
    alpha = rng.uniform(-0.65, 0.65, n)
    alpha[:20] = [0.0, -0.0, 1e-12, -1e-9] * 5
    torque = gear.torque(alpha) * rng.uniform(0.0, 3.0, n)
    torque[20:40] = 0.0
    torque[40:60] *= -1.0
    two_z = rng.choice([0.0, -0.0, 1e-9, 0.05e-3, 0.2e-3, 0.6e-3, 1.5e-3], n)
    z_gb = rng.choice([0.0, -0.0, 1e-9, 0.05e-3, 0.25e-3, 1e-3], n)
    # ties: the clearances that make F_theta or F_Z exactly the sample's lateral force
    for i in range(60, 120):
        one = load_sharing_scalar(gear, float(alpha[i]), float(torque[i]), 1.0, 1.0)
        if one.lateral > 0 and math.isfinite(one.f_theta):
            two_z[i] = one.lateral / one.f_theta if i % 2 else two_z[i]
            z_gb[i] = one.lateral / one.f_z if not i % 2 else z_gb[i]
    return alpha, torque, two_z, z_gb


def _without_buckling(gear, alpha, torque, two_z, z_gb):
    keep = [i for i in range(alpha.size) if _buckles(gear, alpha[i], torque[i]) is None]
    return alpha[keep], torque[keep], two_z[keep], z_gb[keep]


@pytest.mark.parametrize('euler', [False, True])
def test_the_scalar_is_the_array_to_the_bit(r18, euler):
    """The live monitor's one-state call gives the array's numbers bit for bit, every field,
    in every case and on the branches' edges (a replay writes the node's bytes with arrays)."""
    from dataclasses import replace
    gear = replace(r18, euler_amplification=euler)
    rng = np.random.default_rng(11)
    alpha, torque, two_z, z_gb = _without_buckling(gear, *_scalar_cases(gear, rng, 3000))
    vec = load_sharing(gear, alpha, torque, two_z, z_gb)
    cases = set()
    for i in range(alpha.size):
        one = load_sharing_scalar(gear, float(alpha[i]), float(torque[i]), float(two_z[i]), float(z_gb[i]))
        for field in _SHARE_FIELDS:
            assert np.float64(getattr(one, field)).tobytes() == getattr(vec, field)[i].tobytes(), (i, field)
        assert (one.case, one.stages) == (int(vec.case[i]), int(vec.stages[i])), i
        cases.add(one.case)
    assert cases == {1, 2, 3, 4, 5, 6}


@pytest.mark.parametrize('euler', [False, True])
def test_the_closed_form_is_the_stepwise_loading(r18, euler):
    """Each event resolved in closed form = the ram loaded step by step as paper 004
    words it (the oracle, a numpy loop over the events), to rounding: every field, every case,
    the stages that carried load, on the branches' edges and ties."""
    from dataclasses import replace

    from test.model.loadshare_oracle import load_sharing_stepwise
    gear = replace(r18, euler_amplification=euler)
    rng = np.random.default_rng(12)
    alpha, torque, two_z, z_gb = _without_buckling(gear, *_scalar_cases(gear, rng, 4000))
    two_z, z_gb = np.abs(two_z), np.abs(z_gb)
    new = load_sharing(gear, alpha, torque, two_z, z_gb)
    ref = load_sharing_stepwise(gear, alpha, torque, two_z, z_gb)
    for field in _SHARE_FIELDS:
        got, want = getattr(new, field), getattr(ref, field)
        scale = np.maximum(np.abs(ref.lateral), 1.0) * (1e-3 if field == 'deflection' else 1.0)
        if field in ('f_theta', 'f_z'):
            scale = np.abs(want)
        if field == 'k_gl':
            scale = np.ones_like(want)
        assert np.all((np.abs(got - want) <= 1e-12 * np.where(np.isfinite(scale), scale, 1.0)) | (got == want)), field
    assert np.array_equal(new.stages, ref.stages)
    assert np.array_equal(new.case, ref.case)
    assert set(new.case.tolist()) == {1, 2, 3, 4, 5, 6}


def test_friction_normals_on_a_grid_are_the_solvers(r18):
    """The profile's grid kernel (each cell's closed forms once, every clearance pair) gives
    the friction law's loads of :func:`load_sharing` at each cell and pair, bit for bit."""
    from steer_monitor.model.friction import normal_forces
    from steer_monitor.model.loadshare import friction_normals
    rng = np.random.default_rng(5)
    alpha = rng.uniform(0.0, 0.61, 40)
    torque = r18.torque(alpha) * rng.uniform(0.5, 1.5, 40)
    two_z = rng.choice([0.0, 0.1e-3, 0.3e-3, 0.6e-3, 1.5e-3], 25)
    z_gb = rng.choice([0.0, 0.05e-3, 0.25e-3, 0.6e-3], 25)
    n_b, f_gb = friction_normals(r18, alpha, torque, two_z, z_gb)
    ls = load_sharing(r18, alpha[:, None], torque[:, None], two_z[None, :], z_gb[None, :])
    n_a, n_e = normal_forces(ls.r_a, ls.r_e, ls.m_a, r18.bushing_length)
    assert n_b.shape == f_gb.shape == (40, 25)
    assert np.array_equal(n_b, n_a + n_e) and np.array_equal(f_gb, np.abs(ls.guide_force))
    with pytest.raises(ModelError, match='clearance z_gb must be finite'):
        friction_normals(r18, alpha, torque, two_z, -z_gb)


@pytest.mark.parametrize('open_2z, open_zgb', [(False, False), (True, False), (False, True), (True, True)])
@pytest.mark.parametrize('two_z_mm, z_gb_mm', [(0.6, 0.25), (0.0, 0.0), (1.5, 0.05), (0.1, 0.6)])
def test_declared_residuals_are_the_solver_and_the_friction_law(r18, two_z_mm, z_gb_mm, open_2z, open_zgb):
    """The live residual's one compiled pass (declared_residuals) gives, sample by sample, what
    load_sharing and friction_force give: (force - (sign(alpha) Fa + direction F_fr)) / A_r
    for each ram, bit for bit (the same element function and the same friction law, compiled;
    as the grid kernel above); not judged (NaN, 0) where the torque is not finite, or where
    the ram clamps (Fl > F_theta) or the slipper touches (Fl > F_Z) at a clearance said open."""
    from steer_monitor.model.friction import FrictionParams, friction_force
    from steer_monitor.model.loadshare import declared_residuals
    rng = np.random.default_rng(11)
    alpha = rng.uniform(-0.61, 0.61, 300)
    alpha[:3] = (0.0, -0.0, 1e-9)
    torque = r18.torque(np.abs(alpha)) * rng.uniform(0.2, 1.5, alpha.size)
    torque[[5, 77]] = (np.nan, np.inf)
    direction = rng.choice([-1.0, 1.0], alpha.size)
    forces = rng.uniform(-3e5, 3e5, (alpha.size, 2))
    friction = FrictionParams(7.5e3, 0.11, 0.07)
    gaps = Clearances.from_mm(two_z_mm, z_gb_mm)
    rows = declared_residuals(r18, alpha, torque, direction, forces, gaps, friction, open_2z=open_2z,
                              open_zgb=open_zgb)
    known = np.isfinite(torque)
    ls = load_sharing(r18, alpha[known], torque[known], gaps.two_z, gaps.z_gb)
    f_fr = friction_force(friction, ls.r_a, ls.r_e, ls.m_a, ls.guide_force, r18.bushing_length)
    predicted = np.copysign(ls.axial, alpha[known]) + direction[known] * f_fr
    judged = np.zeros(alpha.size, bool)
    judged[known] = ~((open_2z & (ls.lateral > ls.f_theta)) | (open_zgb & (ls.lateral > ls.f_z)))
    assert rows.shape == (alpha.size, 3)
    assert np.array_equal(rows[:, 2], judged.astype(float))
    want = (forces[known] - predicted[:, None]) / r18.ram_area
    assert np.array_equal(rows[known][judged[known], :2], want[judged[known]])
    assert np.isnan(rows[~judged, :2]).all()
    if open_2z and (two_z_mm, z_gb_mm) == (0.1, 0.6):      # a small 2Z clamps at some loads, not all
        assert 0 < judged[known].sum() < known.sum()
    assert not judged[~known].any()


def test_declared_residuals_refuse_as_the_solver_does(r18):
    """Samples of several shapes, a ram that buckles, a clearance below 0 (Clearances refuses one;
    the solver checks what it is given): one line each."""
    from dataclasses import replace
    from types import SimpleNamespace

    from steer_monitor.model.friction import FrictionParams
    from steer_monitor.model.loadshare import declared_residuals
    a, d, f = np.array([0.3, 0.5, 0.6]), np.ones(3), np.zeros((3, 2))
    with pytest.raises(ValueError, match=r'declared residuals need samples of one shape \(n,\) and forces \(n, 2\), '
                                         r'got \(3,\), \(2,\), \(3,\) and \(3, 2\)'):
        declared_residuals(r18, a, np.ones(2), d, f, Clearances.from_mm(0.6, 0.25), FrictionParams())
    with pytest.raises(ValueError, match=r'got \(3,\), \(3,\), \(3,\) and \(3,\)'):
        declared_residuals(r18, a, np.ones(3), d, np.zeros(3), Clearances.from_mm(0.6, 0.25), FrictionParams())
    gear = replace(r18, euler_amplification=True)
    torque = np.array([1e6, 1e9, 1e10])
    with pytest.raises(ModelError, match=re.escape(_buckles(gear, a[1], torque[1]))):
        declared_residuals(gear, a, torque, d, f, Clearances.from_mm(0.6, 0.25), FrictionParams())
    with pytest.raises(ModelError, match='clearance z_gb must be finite and >= 0 m'):
        declared_residuals(r18, a, np.ones(3), d, f, SimpleNamespace(two_z=0.6e-3, z_gb=-1e-4), FrictionParams())


def _buckles(gear, alpha, torque):
    from steer_monitor.model import load_sharing_scalar
    try:
        load_sharing_scalar(gear, float(alpha), float(torque), 0.0, 0.0)
    except ModelError as exc:
        return str(exc)
    return None


def test_arrays_raise_as_the_scalar_does(r18):
    """The first sample the scalar solver refuses gives its message; bad clearances too."""
    from dataclasses import replace
    gear = replace(r18, euler_amplification=True)
    alpha = np.array([0.3, 0.5, 0.6])
    torque = np.array([1e6, 1e9, 1e10])
    first = _buckles(gear, alpha[1], torque[1])
    assert first is not None and first != _buckles(gear, alpha[2], torque[2])
    with pytest.raises(ModelError, match=re.escape(first)):
        load_sharing(gear, alpha, torque, 0.6e-3, 0.25e-3)
    with pytest.raises(ModelError, match='clearance two_z must be finite and >= 0 m'):
        load_sharing(r18, alpha, torque, np.array([0.6e-3, -1e-4, 0.6e-3]), 0.25e-3)
    empty = load_sharing(r18, np.empty(0), np.empty(0), 0.6e-3, 0.25e-3)
    assert empty.k_gl.shape == (0,) and empty.case.dtype == np.int8


def test_sign_of_angle_and_torque_does_not_matter(r18):
    gaps = Clearances.from_mm(0.6, 0.25)
    a = math.radians(25.0)
    pos = load_sharing_at(r18, a, gaps)
    neg = load_sharing_at(r18, -a, gaps)
    assert float(neg.k_gl) == pytest.approx(float(pos.k_gl))
    assert float(neg.ram_force) == pytest.approx(float(pos.ram_force))


@pytest.mark.parametrize('two_z,z_gb,msg', [
    (-1e-4, 1e-4, 'clearance two_z must be finite and >= 0 m'),
    (1e-4, float('nan'), 'clearance z_gb must be finite and >= 0 m'),
])
def test_bad_gaps_raise(r18, two_z, z_gb, msg):
    with pytest.raises(ModelError, match=msg):
        load_sharing(r18, 0.3, 5e5, two_z, z_gb)


def test_buckling_is_an_error_with_euler_amplification(r18):
    from dataclasses import replace
    gear = replace(r18, euler_amplification=True)
    with pytest.raises(ModelError, match='the ram buckles'):
        load_sharing(gear, math.radians(30), 1e11, 0.6e-3, 0.25e-3)


# --- the R-18 landmarks of paper 004 -------------------------------------------------------

@pytest.fixture(scope='module')
def sweep(r18):
    alpha_deg = np.round(np.arange(0.0, 35.0001, 0.1), 4)
    return alpha_deg, load_sharing_at(r18, np.radians(alpha_deg), Clearances.from_mm(0.600, 0.250))


def test_ram_inertia_from_diameters():
    assert ram_inertia(0.240, 0.160) * 1e12 == pytest.approx(130_690_254, abs=1)


def test_euler_amplification_at_35_deg(r18):
    st = rapson_state(r18, math.radians(35.0), 1000e3)
    assert round(float(st.amplification), 4) == 1.0031


def test_guide_to_ram_stiffness_ratio(r18):
    alpha = np.radians(np.arange(0, 35.01, 0.5))
    c = compliances(r18, rapson_state(r18, alpha, 1.0))
    ratio = c.pinned / c.guide
    assert np.all((ratio >= 7) & (ratio <= 15)), (ratio.min(), ratio.max())


def test_guide_idle_up_to_10_deg_then_carries(sweep):
    alpha_deg, res = sweep
    assert np.all(res.k_gl[alpha_deg <= 10.0] == 0.0)
    assert res.k_gl[np.isclose(alpha_deg, 11.0)][0] > 0.0
    # Case 4 of the paper: ram pinned throughout, guide engaged above 10 deg.
    assert set(np.unique(res.case[alpha_deg > 10.5])) == {4}


def test_ram_equals_guide_near_21_deg(sweep):
    alpha_deg, res = sweep
    diff = res.ram_force - res.guide_force
    crossing = alpha_deg[np.argmax((diff[:-1] > 0) & (diff[1:] <= 0)) + 1]
    assert 20.0 <= crossing <= 22.0


def test_k_gl_peak_near_27_5_deg(sweep):
    alpha_deg, res = sweep
    window = (alpha_deg >= 25.0) & (alpha_deg <= 30.0)
    assert float(res.k_gl[window].max()) == pytest.approx(0.59, abs=0.02)
    band = (alpha_deg >= 21.0) & (alpha_deg <= 35.0)
    assert np.all((res.k_gl[band] >= 0.49) & (res.k_gl[band] <= 0.61))
    assert float(res.k_gl[np.isclose(alpha_deg, 27.5)][0]) == pytest.approx(0.59, abs=0.01)
