"""The simulator: the declared plant's laws, the helm programmes, each undeclared effect, and
reproducibility to the byte."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from steer_monitor import sim
from steer_monitor.cli import simulate as simulate_cli
from steer_monitor.errors import ParameterError
from steer_monitor.model import load_sharing
from steer_monitor.params import gear_from_params

DEG = math.pi / 180


def _run(r18_params, can_db, program='hard_over_2', seed=1, **kw):
    db, smap = can_db
    return sim.run(r18_params, sim.SimConfig(program=program, **kw), db, smap, seed)


def test_pressure_law_and_friction_law(r18_params, can_db):
    """A_r (p_stbd - p_port) = sign(alpha) Fa + sign(rate) F_fr with F_fr from the bushing and
    guide reactions, recomputed here from the model and the truth parameters."""
    s = _run(r18_params, can_db)
    p, gear = s.plant, gear_from_params(r18_params)
    cfg = sim.SimConfig()
    ls = load_sharing(gear, p.alpha, gear.torque(p.alpha, p.speed), cfg.gaps.two_z, cfg.gaps.z_gb)
    n_a = np.maximum(np.abs(ls.r_a), 2 * np.abs(ls.m_a) / gear.bushing_length)
    f_fr = cfg.seal_friction + cfg.mu_bushing * (n_a + np.abs(ls.r_e)) + cfg.mu_guide * np.abs(ls.guide_force)
    force = gear.ram_area * (p.pressures['pressure_r1_stbd'] - p.pressures['pressure_r1_port'])
    moving = p.rate != 0
    expected = np.sign(p.alpha) * ls.axial + np.where(moving, np.sign(p.rate) * f_fr, 0.0)
    assert np.allclose(force, expected, rtol=1e-9, atol=1e-6)
    # At midships there is no lateral load: the moving ram's friction is the seals' alone.
    mid = moving & (np.abs(p.alpha) < 0.05 * DEG)
    assert mid.any()
    friction_part = force - np.sign(p.alpha) * ls.axial
    assert np.allclose(np.abs(friction_part[mid]), cfg.seal_friction, rtol=0.02)
    assert np.all(np.minimum(p.pressures['pressure_r1_stbd'], p.pressures['pressure_r1_port']) == pytest.approx(2e5))


@pytest.mark.parametrize('program,pumps,limit_s', [('hard_over_2', 2, 28.0), ('hard_over_1', 1, None)])
def test_solas_hard_over(r18_params, can_db, program, pumps, limit_s):
    p = _run(r18_params, can_db, program).plant
    a = np.degrees(p.alpha)
    leave = np.argmax((p.order < 0) & (a > 30))
    arrive = leave + np.argmax(a[leave:] <= -30 + 0.5)
    took = p.t[arrive] - p.t[leave]
    assert a.max() > 34.4 and a.min() < -29.4
    assert np.all(p.pumps[leave:arrive] == pumps)
    # Ram speed pumps x 15 mm/s: the swing takes the integral of H / (cos^2 * v) over the angle.
    h, v = 0.6, pumps * 0.015
    ideal = h / v * (math.tan(35 * DEG) + math.tan(30 * DEG))
    assert took == pytest.approx(ideal, rel=0.05)
    if limit_s is not None:
        assert took < limit_s


def test_zigzag_switches_on_heading(r18_params, can_db):
    p = _run(r18_params, can_db, 'zigzag_10').plant
    switches = np.nonzero(np.diff(np.sign(p.order)) != 0)[0]
    assert len(switches) >= 4
    for i in switches[:4]:
        assert abs(np.degrees(p.heading[i + 1])) == pytest.approx(10.0, abs=0.2)


def test_rudder_rests_in_holds(r18_params, can_db):
    p = _run(r18_params, can_db, 'hold:30').plant
    assert np.all(p.rate == 0) and np.all(p.alpha == 0)


@pytest.mark.parametrize('effect,check', [
    ('viscous', 'friction'), ('temp_friction', 'friction'), ('pressure_friction', 'friction'),
    ('stribeck', 'friction'), ('angle_delay', 'angle'), ('pressure_offset', 'offset'),
])
def test_each_effect_changes_what_it_says(r18_params, can_db, effect, check):
    base = _run(r18_params, can_db, 'hard_over_2', seed=4, noise=False)
    e = sim.parse_effect(effect)
    with_e = _run(r18_params, can_db, 'hard_over_2', seed=4, noise=False, effects=(e,))
    moving = base.plant.rate != 0
    if check == 'friction':
        df = with_e.plant.friction[moving] - base.plant.friction[moving]
        v = 0.6 / np.cos(base.plant.alpha[moving]) ** 2 * np.abs(base.plant.rate[moving])
        if effect == 'viscous':
            assert np.allclose(df, e['c_ns_per_m'] * v)
        elif effect == 'temp_friction':
            t_c = base.plant.oil_temp[moving] - 273.15
            assert np.allclose(with_e.plant.friction[moving] / base.plant.friction[moving],
                               1 + e['k_per_k'] * (t_c - e['t_ref_c']))
        elif effect == 'stribeck':
            assert np.allclose(df, e['f_st_n'] * np.exp(-(v / (e['v_s_mm_s'] * 1e-3)) ** 2))
        else:
            assert np.all(df > 0)
    elif check == 'angle':
        t = (with_e.sensors.t_ns['rudder'] - with_e.plant.start_ns) / 1e9
        assert np.allclose(with_e.sensors.exact['rudder_angle'], np.interp(t - 0.25, base.plant.t, base.plant.alpha))
    else:
        diff = with_e.sensors.exact['pressure_r1_stbd'] - base.sensors.exact['pressure_r1_stbd']
        assert np.allclose(diff, 3e5)
        assert np.array_equal(with_e.sensors.exact['pressure_r2_stbd'], base.sensors.exact['pressure_r2_stbd'])


def test_band_friction_adds_its_force_inside_the_band_only(r18_params, can_db):
    base = _run(r18_params, can_db, 'hard_over_2', seed=4, noise=False)
    e = sim.parse_effect('band_friction:f_n=8e3,lo_deg=10,hi_deg=20')
    with_e = _run(r18_params, can_db, 'hard_over_2', seed=4, noise=False, effects=(e,))
    moving = base.plant.rate != 0
    deg = np.degrees(np.abs(base.plant.alpha))
    band = moving & (deg >= 10) & (deg <= 20)
    df = with_e.plant.friction - base.plant.friction
    assert band.sum() > 100 and np.allclose(df[band], 8e3) and np.allclose(df[~band], 0.0)


def test_ram_inertia_takes_mass_times_the_rams_acceleration(r18_params, r18, can_db):
    """Against an independent derivative: the ram's position H tan(alpha) differenced twice.
    The same motion with no mass (mass_kg=0, the same rate lag) is the reference."""
    base = _run(r18_params, can_db, 'zigzag_10', seed=4, noise=False,
                effects=(sim.parse_effect('ram_inertia:mass_kg=0'),))
    with_e = _run(r18_params, can_db, 'zigzag_10', seed=4, noise=False,
                  effects=(sim.parse_effect('ram_inertia:mass_kg=5e4'),))
    p = base.plant
    assert np.array_equal(p.alpha, with_e.plant.alpha)
    dp = {k: with_e.plant.pressures[k] - p.pressures[k] for k in p.pressures}
    force = (dp['pressure_r1_stbd'] - dp['pressure_r1_port']) * r18.ram_area
    x = r18.stock_to_ram * np.tan(p.alpha)                   # the ram's position along its axis
    dt = p.t[1] - p.t[0]
    acc = np.gradient(np.gradient(x, dt), dt)
    smooth = np.ones(p.t.size, bool)                          # away from the valve's switching steps
    jerk = np.abs(np.diff(p.rate, n=2, prepend=p.rate[:2]))
    for k in range(-3, 4):
        smooth &= np.roll(jerk < 1e-6, k)
    assert smooth.sum() > 1000
    assert np.allclose(force[smooth], 5e4 * acc[smooth], atol=2.0)
    assert np.abs(force).max() > 100.0


def test_ram_inertia_moves_the_rudder_with_a_finite_acceleration(r18_params, r18, can_db):
    """A mass cannot change speed at once: with ram_inertia the rate follows the valve through
    its lag, so the inertia force stays within m v_max / lag (the old plant stepped the rate
    and put m v / dt, tens of bar, into single pressure samples). Without the effect the
    rate still steps as the valve opens (the motion of every other log is unchanged)."""
    lag, mass, prog = 0.1, 6e4, 'hard_over_2,zigzag_10'
    runs = {m: _run(r18_params, can_db, prog, seed=5, noise=False,
                    effects=(sim.parse_effect(f'ram_inertia:mass_kg={m:g},rate_lag_s={lag}'),)).plant
            for m in (0.0, mass)}
    p = runs[mass]
    dt = p.t[1] - p.t[0]
    assert np.abs(np.diff(p.rate)).max() <= 1.001 * np.abs(p.rate).max() * dt / lag
    v_max = 2 * 0.015                                          # ram speed with two pumps [m/s]
    dp = {k: p.pressures[k] - runs[0.0].pressures[k] for k in p.pressures}
    force = r18.ram_area * (dp['pressure_r1_stbd'] - dp['pressure_r1_port'])
    assert 0.3 * mass * v_max / lag < np.abs(force).max() <= 1.01 * mass * v_max / lag
    clean = _run(r18_params, can_db, prog, seed=5, noise=False).plant
    assert np.abs(np.diff(clean.rate)).max() > 0.5 * np.abs(clean.rate).max()   # the valve's steps


@pytest.mark.parametrize('ram, carries', [(1, 0.0), (2, 0.0), (1, 0.6), (2, 1.5)])
def test_ram_bypass_moves_force_from_one_ram_to_the_other_in_its_span_only(r18_params, can_db, ram, carries):
    base = _run(r18_params, can_db, 'zigzag_10', seed=4, noise=False)
    e = sim.parse_effect(f'ram_bypass:ram={ram},carries={carries},start_s=20,end_s=60')
    with_e = _run(r18_params, can_db, 'zigzag_10', seed=4, noise=False, effects=(e,))
    p, q = base.plant, with_e.plant
    assert np.array_equal(p.alpha, q.alpha)

    def dp(plant, r):
        return plant.pressures[f'pressure_r{r}_stbd'] - plant.pressures[f'pressure_r{r}_port']
    span = (p.t >= 20) & (p.t < 60)
    assert np.abs(dp(p, 1)[span]).max() > 20e5
    assert np.allclose(dp(q, ram)[span], carries * dp(p, ram)[span])
    assert np.allclose(dp(q, 3 - ram)[span], (2 - carries) * dp(p, 3 - ram)[span])
    assert np.allclose(dp(q, 1) + dp(q, 2), dp(p, 1) + dp(p, 2))          # the total is the plant's
    for name in p.pressures:                                                   # outside the span: as before
        assert np.array_equal(q.pressures[name][~span], p.pressures[name][~span])
        assert q.pressures[name].min() == pytest.approx(2e5)                   # a chamber at the return line


def test_angle_stuck_sends_the_last_reading_on(r18_params, can_db):
    base = _run(r18_params, can_db, 'zigzag_10', seed=4)
    with_e = _run(r18_params, can_db, 'zigzag_10', seed=4, effects=(sim.parse_effect('angle_stuck:start_s=30'),))
    t = (with_e.sensors.t_ns['rudder'] - with_e.plant.start_ns) / 1e9
    sent, was = with_e.sensors.noisy['rudder_angle'], base.sensors.noisy['rudder_angle']
    before = t < 30
    assert np.array_equal(sent[before], was[before])
    assert np.all(sent[~before] == was[before][-1]) and np.ptp(was[~before]) > 0.1
    assert np.array_equal(with_e.plant.alpha, base.plant.alpha)         # the rudder itself moves on


@pytest.mark.parametrize('effect', [
    'angle_zero:offset_deg=-1.2', 'angle_span:span_pct=5', 'angle_zero:offset_deg=0.6,angle_span:span_pct=-2'])
def test_an_angle_transmitter_reads_with_its_zero_and_span_the_rudder_untouched(r18_params, can_db, effect):
    """The transmitter reads (1 + span) alpha + zero of the rudder's true angle; the order, the
    pressures and the plant are as without it."""
    effects = tuple(sim.parse_effect(e) for e in sim.split_effects(effect))
    base = _run(r18_params, can_db, 'hard_over_2', seed=4, noise=False)
    with_e = _run(r18_params, can_db, 'hard_over_2', seed=4, noise=False, effects=effects)
    by = {e.name: e for e in effects}
    span = float(by['angle_span']['span_pct']) / 100 if 'angle_span' in by else 0.0
    zero = np.radians(float(by['angle_zero']['offset_deg'])) if 'angle_zero' in by else 0.0
    np.testing.assert_allclose(with_e.sensors.exact['rudder_angle'],
                               (1 + span) * base.sensors.exact['rudder_angle'] + zero, rtol=0, atol=1e-12)
    assert np.array_equal(with_e.plant.alpha, base.plant.alpha)
    for name in ('rudder_order', 'pressure_r1_stbd', 'pressure_r2_port'):
        assert np.array_equal(with_e.sensors.exact[name], base.sensors.exact[name]), name


@pytest.mark.parametrize('input_', ['pressure_r1_port', 'pressure_r2_stbd'])
def test_a_transducer_reads_with_its_span_and_lag_the_others_untouched(r18_params, can_db, input_):
    """One transducer's span scales its reading with the pressure (zero at zero gauge), its
    lag reports the pressure tau_s before; every other input reads as without them."""
    base = _run(r18_params, can_db, 'hard_over_2', seed=4, noise=False)
    span = _run(r18_params, can_db, 'hard_over_2', seed=4, noise=False,
                effects=(sim.parse_effect(f'pressure_span:input={input_},span_pct=-6'),))
    np.testing.assert_allclose(span.sensors.exact[input_], 0.94 * base.sensors.exact[input_], rtol=1e-12, atol=0)
    late = _run(r18_params, can_db, 'hard_over_2', seed=4, noise=False,
                effects=(sim.parse_effect(f'pressure_delay:input={input_},tau_s=0.3'),))
    t = (late.sensors.t_ns[input_] - late.plant.start_ns) / 1e9
    expected = np.interp(t - 0.3, base.plant.t, base.plant.pressures[input_])
    np.testing.assert_allclose(late.sensors.exact[input_], expected, rtol=1e-12, atol=0)
    assert np.abs(late.sensors.exact[input_] - base.sensors.exact[input_]).max() > 1e5   # it does move
    for run in (span, late):
        for name in ('rudder_angle', 'pressure_r1_stbd', 'pressure_r2_port'):
            if name != input_:
                assert np.array_equal(run.sensors.exact[name], base.sensors.exact[name]), name


@pytest.mark.parametrize('text,msg', [
    ('nonsense', "unknown effect 'nonsense'"),
    ('pressure_span:input=rudder_angle', 'effect pressure_span: input must be one of'),
    ('pressure_delay:tau_s=9', r'effect pressure_delay: tau_s must lie in 0..5 s, got 9'),
    ('angle_span:span_pct=-60', 'effect angle_span: span_pct must lie between -50 and 100 per cent, got -60'),
    ('angle_zero:offset_deg=12', r'effect angle_zero: offset_deg must lie in -10..10 deg, got 12'),
    ('ram_bypass:ram=3', 'effect ram_bypass: need ram 1 or 2, 0 <= carries <= 2 and start_s < end_s, got ram 3'),
    ('ram_bypass:carries=-0.1', 'effect ram_bypass: need .* got ram 1, carries -0.1'),
    ('ram_bypass:start_s=50,end_s=10', 'effect ram_bypass: need .* start_s 50 and end_s 10'),
    ('viscous:c=1', "effect viscous: unknown parameter 'c'"),
    ('viscous:c_ns_per_m=abc', 'effect viscous: parameter c_ns_per_m must be a number'),
    ('pressure_offset:input=pressure_r9', 'effect pressure_offset: input must be one of'),
    ('band_friction:lo_deg=18,hi_deg=12', 'effect band_friction: need 0 <= lo_deg < hi_deg <= 90'),
    ('ram_inertia:rate_lag_s=-1', 'effect ram_inertia: rate_lag_s must lie in 0..5 s'),
    ('stribeck:v_s_mm_s=0', 'effect stribeck: v_s_mm_s must be more than 0, got 0'),
    ('stribeck:v_s_mm_s=-3', 'effect stribeck: v_s_mm_s must be more than 0, got -3'),
])
def test_bad_effects(text, msg):
    with pytest.raises(ParameterError, match=msg):
        sim.parse_effect(text)


@pytest.mark.parametrize('text,effects', [
    ('viscous', ['viscous']),
    (' viscous , stribeck ', ['viscous', 'stribeck']),
    ('band_friction:lo_deg=4,hi_deg=9', ['band_friction:lo_deg=4,hi_deg=9']),
    ('viscous,band_friction:f_n=6e3,lo_deg=4,hi_deg=9,temp_friction:k_per_k=0.04',
     ['viscous', 'band_friction:f_n=6e3,lo_deg=4,hi_deg=9', 'temp_friction:k_per_k=0.04']),
    ('', []),
])
def test_split_effects(text, effects):
    assert sim.split_effects(text) == effects
    for e in effects:
        sim.parse_effect(e)


def test_split_effects_leaves_a_stray_parameter_for_parse_effect_to_name():
    # a parameter with no effect before it is an item of its own, which parse_effect refuses
    assert sim.split_effects('hi_deg=9,viscous') == ['hi_deg=9', 'viscous']
    with pytest.raises(ParameterError, match="unknown effect 'hi_deg=9'"):
        sim.parse_effect('hi_deg=9')


@pytest.mark.parametrize('text,msg', [
    ('tango', "unknown helm programme 'tango'"),
    ('hold:-3', "helm programme 'hold:-3': the value after \":\" must be a positive number"),
    ('', 'empty helm programme'),
    ('hold_at:40', 'at most 35 deg'),
    ('hold_at:x', 'must be a number'),
    ('speed:45', 'a speed in 0..40 kn'),
    ('pumps:3', '1 or 2 pump'),
    ('zigzag_0', 'positive number'),
    ('zigzag_40', 'at most 35 deg'),
    ('realistic:-5', 'positive number'),
])
def test_bad_programs(text, msg):
    with pytest.raises(ParameterError, match=msg):
        sim.parse_program(text)


@pytest.mark.parametrize('suffix', ['.log', '.blf', '.mcap'])
def test_seed_reproduces_files_byte_for_byte(tmp_path, suffix):
    outs = []
    for k, seed in enumerate((7, 7, 8)):
        path = tmp_path / f'run{k}{suffix}'
        assert simulate_cli.run(None, 'hard_over_2,zigzag_10', path, seed=seed, max_duration_s=60.0,
                                effects=['viscous']) == 0
        outs.append(path.read_bytes())
    assert outs[0] == outs[1]
    assert outs[0] != outs[2]
    truth = json.loads((tmp_path / 'run0.truth.json').read_text())
    assert truth['seed'] == 7 and truth['effects'][0]['name'] == 'viscous'
    assert truth['clearance_2z_mm'] == pytest.approx(0.6)
