"""The estimator on a ship's operation: stepped and drifting speed, pump changes, stop-start
motion of a dead-band autopilot. Seeds and clearances here are not the ones the estimator
was tuned on (seeds 1-4 at 2Z 0.6 / Z_gb 0.25 mm)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from steer_monitor import sim
from steer_monitor.estimate import fit as F
from steer_monitor.estimate.analyze import analyze
from steer_monitor.estimate.batch import estimate_clearances, make_rows
from steer_monitor.estimate.moments import SPEED_Z, Moments, bin_keys, speed_ratio
from steer_monitor.estimate.observe import build_observations
from steer_monitor.estimate.plausible import SIGNS, refusal
from test.estimate.conftest import holds

MIN_2Z = 0.05e-3
DEG = math.pi / 180
KNOT = 1852.0 / 3600.0


@pytest.mark.slow
@pytest.mark.parametrize('two_z, z_gb, seed', [(0.4, 0.2, 101), (0.3, 0.3, 102), (0.6, 0.1, 103)])
def test_clean_realistic_voyage_is_declared_and_covered(r18, simulate_signals, two_z, z_gb, seed):
    """25 minutes of the realistic programme on the clean plant: nothing adopted, the
    residual's systematic part well under 0.5 bar, the friction intervals hold the truth, and
    the clearances' profiles hold it within their 99 % sets (2Z's one-sided where the ram never
    clamps; seed 103's true Z_gb of 0.1 mm lies at a deviance of 3.85, on the edge of its 95 %
    interval)."""
    signals, s = simulate_signals('realistic:1500', two_z, z_gb, seed=seed)
    assert len(np.unique(np.round(s.plant.speed / KNOT))) >= 4        # the speed moved
    a = analyze(r18, signals, min_clearance_2z=MIN_2Z)
    bar = a.declared.ram_area * 1e5
    assert a.verdict == 'declared' and a.effect is None, a.message
    assert a.declared.smooth_rms / bar < 0.5 * 0.5       # half the 0.5 bar a clean voyage's systematic misfit may reach
    e = a.final
    assert holds(e, 1, z_gb * 1e-3) and holds(e, 0, two_z * 1e-3)
    assert e.seal_friction.contains(9e3) and e.mu_bushing.contains(0.13) and e.mu_guide.contains(0.05)


def _drifting_rows(r18, speed_kn, n=6000, seed=0):
    """Rows of the declared load (seal friction only) at speeds ``speed_kn`` (n,)."""
    rng = np.random.default_rng(seed)
    alpha = rng.uniform(-0.55, 0.55, n)
    d = rng.choice([-1, 1], n).astype(np.int8)
    v = speed_kn * KNOT
    fa = np.abs(r18.torque(alpha, v)) * np.cos(alpha) ** 2 / (r18.rams * r18.stock_to_ram)
    y = np.sign(alpha) * fa + d * 9e3
    keys = bin_keys(alpha, d, v)
    return keys, np.abs(alpha), v * v, y


def test_speed_ratio_makes_the_load_exact_within_a_speed_class(r18):
    """A speed that drifts inside one 0.25 kn class: with each row's V^2 / V_c^2 the torque
    columns fit the load to rounding; with the class's mean V^2 (the old binning) the rows'
    spread of +-3 % of the load stays in the residual (kN)."""
    rng = np.random.default_rng(1)
    speed = rng.uniform(8.0, 8.249, 6000)
    keys, aa, v2, y = _drifting_rows(r18, speed)
    basis = F.TorqueBasis(r18.max_rudder)
    exact = Moments.from_rows(keys, aa, v2, np.stack([np.ones_like(y), speed_ratio(keys, v2), y], 1), (SPEED_Z,))
    mean = Moments.from_rows(keys, aa, v2, np.stack([np.ones_like(y), y], 1), ())
    rms = {}
    for name, mom in (('exact', exact), ('mean', mean)):
        load = F.axial_load(r18, basis, mom, F.torque_prefit(r18, basis, mom))
        fit = F.fit_at(r18, basis, mom, 1.5e-3, 0.6e-3, load)
        rms[name] = math.sqrt(fit.rss / fit.n)
    assert rms['exact'] < 300.0                       # the spline's own misfit of the PCHIP curve
    assert rms['mean'] > 5 * rms['exact']


def test_speed_scale_columns_take_a_load_scale_error_per_speed_group(r18):
    """A speed log that reads 0.5 % high at 10 kn (the load there 1 % low against V^2): the
    seal friction stays right with the per-group load scale, and is pulled without it."""
    rng = np.random.default_rng(2)
    speed = np.where(rng.random(8000) < 0.4, 10.0, 15.0)   # 15 kn the larger group: the reference
    keys, aa, v2, y = _drifting_rows(r18, speed, n=8000, seed=3)
    logged = np.where(speed == 10.0, 1.005, 1.0) * speed * KNOT
    keys = bin_keys(np.where(keys & 2, 1.0, -1.0) * aa, np.where(keys & 1, 1, -1).astype(np.int8), logged)
    v2 = logged ** 2
    mom = Moments.from_rows(keys, aa, v2, np.stack([np.ones_like(y), speed_ratio(keys, v2), y], 1), (SPEED_Z,))
    basis = F.TorqueBasis(r18.max_rudder)
    cols = F.speed_scale_columns(mom)
    assert [c.name for c in cols] == ['load_scale_10kn']
    load = F.axial_load(r18, basis, mom, F.torque_prefit(r18, basis, mom))
    with_scale = F.fit_at(r18, basis, mom, 1.5e-3, 0.6e-3, load, cols)
    without = F.fit_at(r18, basis, mom, 1.5e-3, 0.6e-3, load)
    assert with_scale.get('seal_friction_n') == pytest.approx(9e3, rel=0.01)
    assert with_scale.get('load_scale_10kn') == pytest.approx(1 / 1.005 ** 2 - 1, rel=0.05)
    assert math.sqrt(with_scale.rss / with_scale.n) < 0.6 * math.sqrt(without.rss / without.n)


def test_stop_start_motion_is_not_taken_for_steady(r18_params, r18, can_db):
    """The dead-band autopilot stops and starts the rudder many times a minute. Grid points
    where the plant's rudder stood are almost never taken as steady motion (the 0.6 s
    window alone took a few percent of them: each is a residual of the whole friction)."""
    from steer_monitor.can.decoder import Decoder
    db, smap = can_db
    s = sim.run(r18_params, sim.SimConfig(program='pumps:1,autopilot_db:600'), db, smap, 7)
    obs = build_observations(Decoder(db, smap).decode_arrays(s.frames), r18.ram_area)
    p = s.plant
    k = np.clip(np.round((obs.t_ns - p.start_ns) / 1e7).astype(int), 0, p.t.size - 1)
    standing = np.zeros(obs.t_ns.size, bool)
    for off in range(-2, 3):                          # the plant stood within 20 ms of the point
        standing |= p.rate[np.clip(k + off, 0, p.t.size - 1)] == 0
    moving = obs.moving
    assert moving.sum() > 2000
    assert np.mean(standing[moving]) < 0.005


def test_unphysical_stribeck_is_refused_with_its_reason(r18, simulate_signals):
    """Friction *below* the declared law near zero speed fits as a negative Stribeck
    amplitude: screened, it may fit well, but it is never adopted, and the screening says
    why."""
    signals, _ = simulate_signals('voyage', 0.6, 0.25, ('stribeck:f_st_n=-8e3,v_s_mm_s=8',), seed=5)
    a = analyze(r18, signals, min_clearance_2z=MIN_2Z)
    assert a.effect != 'stribeck'
    st = next(s for s in a.screening if s.name == 'stribeck')
    assert st.values['f_st_n'] < 0 and not st.passes
    assert 'negative Stribeck amplitude' in st.refused


@pytest.mark.parametrize('effect, coef', sorted(SIGNS))
def test_refusal_names_each_unphysical_sign(effect, coef):
    assert refusal(effect, {coef: 1e-3}) is None
    text = refusal(effect, {coef: -2.5})
    assert text is not None and text.startswith('refused: ') and f'{coef} = -2.5' in text
    assert refusal('pressure_offset', {'offset_ram1_n': -1e3}) is None      # a sign of no physics


def test_whole_log_rows_are_the_same_when_cut(r18, simulate_signals):
    """The steadiness erosion looks one grid point past a span's ends, so a log cut in two
    gives the same steady instants as the whole (the node's window relies on it)."""
    signals, _ = simulate_signals('pumps:1,autopilot_db:120', 0.6, 0.25, seed=8)
    whole = build_observations(signals, r18.ram_area)
    cut = int(whole.t_ns[whole.t_ns.size // 2])
    a = build_observations(signals, r18.ram_area, start_ns=int(whole.t_ns[0]), end_ns=cut)
    b = build_observations(signals, r18.ram_area, start_ns=cut, end_ns=int(whole.t_ns[-1]) + 1)
    np.testing.assert_array_equal(np.concatenate([a.direction, b.direction]), whole.direction)
    est = estimate_clearances(r18, whole, make_rows(whole))
    assert est.rows > 500


@pytest.mark.slow
def test_a_delay_that_explains_nothing_is_not_adopted(r18, simulate_signals):
    """Found by the accuracy study (autopilot, 2Z 0.4 / Z_gb 0.2 mm, seed 109, clean plant):
    a 0.05 s angle delay scored 15 % better held out, yet left the systematic part where the
    declared model had it (0.14 bar, inside the noise): what it takes from the mean square is
    none of the residual's covariance with the next instant. It passes screening and is not
    an effect: the verdict stays 'declared' and says so."""
    signals, _ = simulate_signals('autopilot:1500', 0.4, 0.2, seed=109)
    a = analyze(r18, signals, min_clearance_2z=MIN_2Z)
    assert a.verdict == 'declared' and a.effect is None, a.message
    assert 'angle_delay passed screening but takes nothing systematic' in a.message
