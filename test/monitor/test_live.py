"""The live monitor and its diagnostics, fed by the simulator through the decoder."""

from __future__ import annotations

import math

import numpy as np
import pytest

from steer_monitor import sim
from steer_monitor.can import Decoder, RejectCounter
from steer_monitor.model import Gaps
from steer_monitor.monitor import ERROR, OK, STALE, WARN, DiagnosticsBuilder, DiagnosticsConfig, LiveMonitor
from steer_monitor.params import gear_from_params


def _feed(r18_params, can_db, program, effects=(), seed=2, gaps=None, upto_s=None):
    db, smap = can_db
    cfg = sim.SimConfig(program=program, effects=tuple(sim.parse_effect(e) for e in effects))
    s = sim.run(r18_params, cfg, db, smap, seed)
    decoder = Decoder(db, smap, RejectCounter())
    mon = LiveMonitor(gear_from_params(r18_params), gaps or Gaps.from_mm(0.6, 0.25))
    last = None
    for frame in s.frames.frames():
        if upto_s is not None and frame.t_ns > s.plant.start_ns + upto_s * 1e9:
            break
        for sample in decoder.decode(frame):
            mon.update(sample)
        last = frame.t_ns
    return s, mon, decoder, last


def test_hard_over_time_matches_the_plant(r18_params, can_db):
    s, mon, _, _ = _feed(r18_params, can_db, 'hard_over_2')
    p = s.plant
    a = np.degrees(p.alpha)
    leave = np.nonzero(a >= 34.5)[0][-1]
    arrive = leave + np.argmax(a[leave:] <= -29.5)
    assert arrive > leave
    assert mon.hard_over_s == pytest.approx(p.t[arrive] - p.t[leave], abs=0.25)


def test_live_k_gl_at_rest_matches_truth(r18_params, can_db):
    # Held at 35 deg: at rest the pressure carries only the load, so the live model sees the
    # true lateral force and K_gl.
    s, mon, _, t_last = _feed(r18_params, can_db, 'hard_over_2', upto_s=None)
    p = s.plant
    held = np.nonzero((np.degrees(p.alpha) > 34.5) & (p.rate == 0))[0]
    t_stop = p.t[held[-1]]
    s2, mon2, _, _ = _feed(r18_params, can_db, 'hard_over_2', upto_s=t_stop - 0.2)
    state = mon2.state
    assert not state.moving
    truth = float(np.interp(t_stop - 0.2, p.t, p.k_gl))
    assert state.share.k_gl == pytest.approx(truth, abs=0.02)
    assert state.share.lateral == pytest.approx(float(np.interp(t_stop - 0.2, p.t, p.lateral)), rel=0.02)


def test_residual_small_on_declared_plant_large_with_an_effect(r18_params, can_db):
    _, clean, _, _ = _feed(r18_params, can_db, 'hard_over_2,zigzag_20')
    _, viscous, _, _ = _feed(r18_params, can_db, 'hard_over_2,zigzag_20', effects=['viscous'])
    assert clean.residual_rms_bar() < 1.0   # sensor noise: about sqrt(2) x 0.25 bar
    assert viscous.residual_rms_bar() > 3.0


def test_order_response(r18_params, can_db):
    _, mon, _, _ = _feed(r18_params, can_db, 'hard_over_2')
    r = mon.response
    assert r is not None and r.direction_ok is True
    assert 0 <= r.delay_s < 0.8
    assert r.accuracy is not None and math.degrees(r.accuracy) < 0.6


def _builder(r18_params, can_db, **kw):
    cfg = DiagnosticsConfig.from_params(r18_params)
    if kw:
        from dataclasses import replace
        cfg = replace(cfg, **kw)
    return DiagnosticsBuilder(cfg, can_db[1], gear_from_params(r18_params))


def test_statuses_named_and_levelled(r18_params, can_db):
    _, mon, dec, t_last = _feed(r18_params, can_db, 'hard_over_2')
    statuses = _builder(r18_params, can_db).build(mon, dec.rejects.snapshot(), t_last)
    by = {s.name: s for s in statuses}
    assert list(by) == ['steer_monitor: CAN input', 'steer_monitor: clearances', 'steer_monitor: guide beam',
                        'steer_monitor: steering performance', 'steer_monitor: model health', 'steer_monitor: rams']
    assert all(s.hardware_id == 'R-18 steering gear' for s in statuses)
    assert by['steer_monitor: CAN input'].level == OK
    assert float(by['steer_monitor: CAN input'].value('pressure_r1_stbd_rate_hz')) == pytest.approx(20, abs=0.5)
    # Configured clearances (at the wear limits here) are shown, not assessed: not estimated yet.
    cl = by['steer_monitor: clearances']
    assert cl.level == STALE and cl.value('clearance_zgb_mm') == '0.250'
    assert cl.value('clearance_source') == 'configured'
    assert cl.message.startswith('2Z 0.600 mm configured NOT ASSESSED: not estimated yet')
    assert cl.value('clearance_2z_lo_mm') == 'n/a'
    gb = by['steer_monitor: guide beam']
    assert gb.level == OK and float(gb.value('guide_onset_deg')) == pytest.approx(10.0, abs=0.1)
    assert 'at the configured clearances (judged once they are estimated)' in gb.message
    perf = by['steer_monitor: steering performance']
    assert perf.level == OK and float(perf.value('hard_over_s')) < 28
    assert perf.value('hard_over_pumps') == '2' and 'with 2 pumps (within SOLAS 28 s)' in perf.message
    assert by['steer_monitor: model health'].level == OK


def test_stale_after_silence_and_error_beyond_limits(r18_params, can_db):
    _, mon, dec, t_last = _feed(r18_params, can_db, 'hard_over_2')
    b = _builder(r18_params, can_db)
    later = b.build(mon, dec.rejects.snapshot(), t_last + int(2.5e9))
    can_status = later[0]
    assert can_status.level == STALE and 'rudder_angle' in can_status.message
    mon.set_gaps(Gaps.from_mm(0.65, 0.1), 'test', {'2z': (0.62e-3, 0.68e-3), 'zgb': (0.08e-3, 0.12e-3)})
    cl = b.clearances(mon)
    assert cl.level == ERROR and '2Z 0.650 mm [0.620 .. 0.680] (108% of limit)' in cl.message
    mon.set_gaps(Gaps.from_mm(0.3, 0.1), 'test', {'2z': (0.25e-3, 0.35e-3), 'zgb': (0.08e-3, 0.12e-3)})
    assert b.clearances(mon).level == OK
    assert b.guide_beam(mon).level == OK


def test_one_pump_hard_over_is_reported_not_judged(r18_params, can_db):
    _, mon, dec, t_last = _feed(r18_params, can_db, 'hard_over_1')
    perf = _builder(r18_params, can_db).performance(mon)
    assert perf.level == OK and perf.value('hard_over_pumps') == '1'
    assert 'with 1 pump, as its time says (one pump: 50 s; SOLAS 28 s is judged with 2)' in perf.message


def test_slow_hard_over_with_all_pumps_warns(r18_params, can_db):
    """Two pumps that give 85 % of their speed: the time says two pumps (a slower pair reads
    as one pump, which the message says), over 28 s."""
    _, mon, dec, t_last = _feed(r18_params, can_db, 'hard_over_2')
    b = _builder(r18_params, can_db)
    mon.hard_over_s = 30.0                       # one pump takes 50 s, two 25 s
    perf = b.performance(mon)
    assert perf.level == WARN and perf.value('hard_over_pumps') == '2' and 'OVER SOLAS 28 s' in perf.message


@pytest.mark.parametrize('pumps, speed_mm_s', [(1, 15.0), (2, 15.0), (2, 9.0), (1, 25.0)])
def test_pump_count_from_the_hard_over_time_matches_a_simulation(r18_params, can_db, pumps, speed_mm_s):
    """The closed form H (tan 34.5 + tan 29.5) / (n v) against the simulated gear's own
    hard-over, integrated by its time loop."""
    params = dict(r18_params, **{'hydraulics.ram_speed_per_pump_mm_s': speed_mm_s})
    db, smap = can_db
    gear = gear_from_params(params)
    prog = f'hard_over_{pumps}'
    s = sim.run(params, sim.SimConfig(program=prog), db, smap, 3)
    mon = LiveMonitor(gear, Gaps.from_mm(0.6, 0.25))
    dec = Decoder(db, smap)
    for f in s.frames.frames():
        for sample in dec.decode(f):
            mon.update(sample)
    cfg = DiagnosticsConfig.from_params(params)
    b = DiagnosticsBuilder(cfg, smap, gear)
    assert mon.hard_over_s is not None
    assert b.pumps_running(mon.hard_over_s) == pumps


def test_slow_inputs_not_judged_on_their_first_sample(r18_params, can_db):
    _, mon, dec, t_last = _feed(r18_params, can_db, 'hold:5', upto_s=1.2)
    status = _builder(r18_params, can_db).can_input(mon, dec.rejects.snapshot(), t_last)
    assert status.level == OK, status.message


def _steady_feed(r18_params, smap, seconds: float, skip: dict[str, set[int]] | None = None,
                 slow: dict[str, float] | None = None) -> LiveMonitor:
    """Every input at its configured rate (``slow``: name -> the rate it arrives at instead),
    values at rest; ``skip``: name -> indices of its frames that never came."""
    from steer_monitor.can.decoder import Sample

    values = {'rudder_angle': 0.0, 'rudder_order': 0.0, 'ship_speed': 7.0, 'oil_temperature': 320.0}
    samples = []
    for spec in smap.specs:
        rate = (slow or {}).get(spec.name, spec.rate_hz)
        for i in range(int(seconds * rate)):
            if i not in (skip or {}).get(spec.name, set()):
                samples.append(Sample(int(i * 1e9 / rate), spec.name, values.get(spec.name, 2e5)))
    mon = LiveMonitor(gear_from_params(r18_params), Gaps.from_mm(0.6, 0.25))
    for sample in sorted(samples, key=lambda s: s.t_ns):
        mon.update(sample)
    return mon


@pytest.mark.parametrize('now_s', [19.0, 19.5, 20.0, 20.9])
def test_a_slow_input_with_one_late_frame_is_at_rate(r18_params, can_db, now_s):
    # oil temperature at 0.5 Hz, its frame due at 18 s missing: at 20.9 s it has been silent
    # 4.9 s, under its stale limit of three periods (6 s), and its rate is judged over five
    # periods (10 s), not 5 s, where only the 16 s frame would be left and read as rate 0
    mon = _steady_feed(r18_params, can_db[1], 20.0, skip={'oil_temperature': {9}})
    status = _builder(r18_params, can_db).can_input(mon, RejectCounter().snapshot(), int(now_s * 1e9))
    assert status.level == OK, status.message
    assert 0.25 <= float(status.value('oil_temperature_rate_hz')) <= 0.5


@pytest.mark.parametrize(('name', 'rate'), [('oil_temperature', 0.2), ('pressure_r1_stbd', 8.0),
                                            ('rudder_angle', 2.0)])
def test_an_input_below_half_its_rate_warns(r18_params, can_db, name, rate):
    mon = _steady_feed(r18_params, can_db[1], 30.0, slow={name: rate})
    status = _builder(r18_params, can_db).can_input(mon, RejectCounter().snapshot(), int(29.9e9))
    assert status.level == WARN
    assert status.message == f'below half the expected rate: {name}'
    assert float(status.value(f'{name}_rate_hz')) == pytest.approx(rate, rel=0.05)


def test_a_rate_window_longer_than_the_arrivals_kept_is_refused(r18_params):
    from steer_monitor.monitor.live import ARRIVALS_KEPT_NS

    mon = LiveMonitor(gear_from_params(r18_params), Gaps.from_mm(0.6, 0.25))
    with pytest.raises(ValueError, match='rate window 31 s is longer than the 30 s of arrivals kept'):
        mon.rate_hz('oil_temperature', 0, ARRIVALS_KEPT_NS + 1_000_000_000)


@pytest.mark.parametrize('times_s', [
    [0.0, 0.1, 0.2, 0.5, 1.0, 4.0, 6.5, 7.0],
    [0.0, 5.0, 9.0],
    [1.0, 2.0, 3.0, 2.5, 3.5, 4.0],          # a step back in time: read as it came, not bisected
    [7.0],
    [],
])
@pytest.mark.parametrize('now_s', [0.0, 3.0, 7.0, 9.5, 60.0])
def test_rate_is_the_spacing_of_the_arrivals_in_the_window(r18_params, times_s, now_s):
    from steer_monitor.can.decoder import Sample
    mon = LiveMonitor(gear_from_params(r18_params), Gaps.from_mm(0.6, 0.25))
    for t in times_s:
        mon.update(Sample(int(t * 1e9), 'oil_temperature', 40.0))
    recent = [t for t in times_s if t >= now_s - 5.0]
    want = 0.0 if len(recent) < 2 or recent[-1] == recent[0] else (len(recent) - 1) / (recent[-1] - recent[0])
    assert mon.rate_hz('oil_temperature', int(now_s * 1e9)) == pytest.approx(want, rel=1e-12)


@pytest.mark.parametrize('case', ['configured', 'lower bounds only', 'fitted torque'])
def test_a_minute_rejudged_at_once_is_each_instant_judged_alone(r18_params, case):
    """A new estimate re-judges the kept minute of motion in one vectorized pass; each
    instant's residual pair (or None: a clamp the data never saw, an angle beyond the fitted
    torque) is the one-instant result, to rounding."""
    from steer_monitor.model.friction import FrictionParams
    from steer_monitor.model.torque import TorqueTable
    gear = gear_from_params(r18_params)
    gaps = Gaps.from_mm(0.1, 0.05)
    mon = LiveMonitor(gear, Gaps.from_mm(0.6, 0.25))
    rng = np.random.default_rng(7)
    # (angle, speed (NaN: not known), direction, the rams' forces, rate, oil temperature)
    instants = [(float(a), math.nan if rng.random() < 0.3 else float(rng.uniform(2.0, 9.0)), float(d), float(f1),
                 float(f2), 0.02, 310.0)
                for a, d, f1, f2 in zip(rng.uniform(-0.61, 0.61, 600), rng.choice([-1.0, 1.0], 600),
                                        rng.uniform(-3e5, 3e5, 600), rng.uniform(-3e5, 3e5, 600))]
    angles = np.radians(np.arange(0.0, 25.01, 0.5))
    table = (
        TorqueTable(angles, 1.1 * gear.torque(angles), gear.torque.service_speed) if case == 'fitted torque' else None
    )
    interval = {'2z': (0.05e-3, None), 'zgb': (0.0, None)} if case == 'lower bounds only' else None
    mon.set_gaps(gaps, 'estimated' if case != 'configured' else 'configured', interval,
                 FrictionParams(9000.0, 0.13, 0.05), table)
    rows = mon._residual_rows(np.array(instants))
    many, judged = rows[:, :2], rows[:, 2] == 1.0
    one = [mon._residual_pair(i) for i in instants]
    assert judged.tolist() == [p is not None for p in one]
    assert set(rows[:, 2].tolist()) <= {0.0, 1.0}
    assert np.isnan(many[~judged]).all()
    if case != 'configured':
        assert 0 < sum(p is None for p in one) < len(one)
    for p, ok, q in zip(many.tolist(), judged, one):
        if ok:
            assert p == pytest.approx(q, rel=1e-12, abs=1e-9)



def test_a_monitor_that_defers_the_load_sharing_leaves_it_to_its_caller(r18_params, can_db):
    """With ``defer_share`` the slot's state has no load sharing (its torque is there to solve
    it from); :attr:`state` still gives the whole state; both equal the eager monitor's."""
    db, smap = can_db
    s = sim.run(r18_params, sim.SimConfig(program='hard_over_2'), db, smap, 4)
    gear = gear_from_params(r18_params)
    eager, lazy = (LiveMonitor(gear, Gaps.from_mm(0.6, 0.25), defer_share=d) for d in (False, True))
    decoder = Decoder(db, smap, RejectCounter())
    seen = 0
    for frame in s.frames.frames()[:3000]:
        for sample in decoder.decode(frame):
            eager.update(sample)
            lazy.update(sample)
        if eager.changed:
            want, left = eager.slot_state(), lazy.slot_state()
            assert lazy.changed is False
            if want is None:
                assert left is None
                continue
            assert left.share is None and left.torque_measured == want.torque_measured
            assert lazy.share_of(left) == want.share
            assert lazy.state == want            # the whole state, its load sharing solved
            seen += 1
    assert seen > 1000


def test_the_rate_and_the_residual_rms_are_correctly_rounded_sums():
    """Sums whose plain left-to-right value differs from the exact one in the last bit: the
    monitor gives the correctly rounded one (math.fsum), the same on every Python (the built-in
    sum is compensated from 3.12 on), so a node and a replay on different machines agree."""
    import math

    from steer_monitor.params import gear_from_params, load_params_file
    from steer_monitor.resources import default_config
    # the slope: values whose plain mean loses the 1.0 beside 1e16
    pts = [(0, 1e16), (100_000_000, 1.0), (200_000_000, -1e16), (300_000_000, 3.0)]
    ts = [0.0, 0.1, 0.2, 0.3]
    mean_t, mean_a = math.fsum(ts) / 4, math.fsum(a for _, a in pts) / 4
    assert sum(a for _, a in pts) / 4 != mean_a            # plain summation differs here (3.11)
    want = math.fsum((t - mean_t) * (a - mean_a) for t, (_, a) in zip(ts, pts)) / \
        math.fsum((t - mean_t) * (t - mean_t) for t in ts)
    assert LiveMonitor._slope(pts) == want
    # the residual's RMS over the kept minute
    mon = LiveMonitor(gear_from_params(load_params_file(default_config())), Gaps.from_mm(0.6, 0.25))
    mon._push_residuals(np.array([[1e8, 1.0, 1.0], [1.0, 1.0, 1.0]]))    # two judged pairs
    res = [1e8, 1.0, 1.0, 1.0]
    assert sum(r * r for r in res) != math.fsum(r * r for r in res)
    assert mon.residual_rms_bar() == math.sqrt(math.fsum(r * r for r in res) / 4)


@pytest.mark.parametrize('seed', [1, 2, 3])
def test_the_residual_rms_kept_as_rows_come_and_go_is_the_minutes_fsum(r18_params, seed):
    """The minute's residual RMS, its sum of squares kept exactly as rows enter and leave the
    ring (blocks of any size, one longer than the ring, rows not judged, values from 1e-9 to
    1e6 bar, the ring emptied for a new model, a NaN judged), is math.fsum's over the rows held,
    to the bit, at every step."""
    import math
    rng = np.random.default_rng(seed)
    mon = LiveMonitor(gear_from_params(r18_params), Gaps.from_mm(0.6, 0.25))
    cap = mon._resid.data.shape[0]
    for step in range(80):
        n = int(rng.choice([1, 7, 40, 333, cap + 17]))
        rows = np.column_stack([rng.normal(0, 1, (n, 2)) * 10.0 ** rng.integers(-9, 7, (n, 2)),
                                rng.random(n) < 0.8])
        rows[rows[:, 2] == 0.0, :2] = np.nan
        if step == 50:
            rows[0] = (math.nan, 1.0, 1.0)                 # a judged NaN: the RMS is NaN while it is held
        if step == 30:
            mon._clear_residuals()                         # as set_gaps does
        mon._push_residuals(rows)
        mon._resid_summary = None
        held = mon._resid.rows()
        values = held[held[:, 2] != 0.0, :2].ravel()
        count, skipped, rms = mon._summary()
        assert count == values.size and skipped == held.shape[0] - values.size // 2
        want = math.sqrt(math.fsum(v * v for v in values.tolist()) / values.size)
        assert rms == want or (math.isnan(rms) and math.isnan(want))


@pytest.mark.parametrize('sizes', [[3, 4, 5], [7], [12], [25, 1, 9], [0, 2, 30]])
def test_a_ring_puts_rows_pushed_together_where_one_by_one_would(sizes):
    """The rams' share is summed over the ring's rows in the order they lie: a block of rows,
    even one longer than the ring, lies as the same rows pushed one at a time."""
    from steer_monitor.monitor.live import _Ring
    rng = np.random.default_rng(len(sizes))
    together, alone = _Ring(8, 3), _Ring(8, 3)
    every = np.zeros((0, 3))
    for n in sizes:
        block = rng.normal(size=(n, 3))
        every = np.concatenate([every, block])
        together.push(block)
        for row in block:
            alone.push(row[None, :])
        assert (together.next, together.kept) == (alone.next, alone.kept)
        np.testing.assert_array_equal(together.rows(), alone.rows())
        np.testing.assert_array_equal(together.ordered(), alone.ordered())
        np.testing.assert_array_equal(together.ordered(), every[len(every) - together.kept:])   # oldest first
    assert together.kept == min(sum(sizes), 8)


def _rudder_stream(seed: int, seconds: float, nan_at_s: float | None = None):
    """Samples (t [ns], input, value) of a gear swinging through hard over and back, its orders
    stepping, four pressures and the ship's speed, in time order."""
    from steer_monitor.model.inputs import PRESSURE_INPUTS
    rng = np.random.default_rng(seed)
    t0 = 1_700_000_000_000_000_000
    out = []
    for k in range(int(seconds * 10)):                          # angle and order at 10 Hz
        t = t0 + k * 100_000_000 + int(rng.integers(0, 3_000_000))
        a = math.radians(37.0 * math.sin(2 * math.pi * k / 300.0) + rng.normal(0, 0.05))
        if nan_at_s is not None and abs(k / 10 - nan_at_s) < 1e-9:
            a = math.nan
        out.append((t, 'rudder_angle', a))
        out.append((t + 40_000_000, 'rudder_order', math.radians(35.0 * round(math.sin(2 * math.pi * k / 300.0)))))
    for k in range(int(seconds * 20)):                          # each pressure at 20 Hz
        for j, name in enumerate(PRESSURE_INPUTS):
            out.append((t0 + k * 50_000_000 + 7_000_000 + j, name, 40e5 + 30e5 * (j % 2) + rng.normal(0, 0.3e5)))
    for k in range(int(seconds)):
        out.append((t0 + k * 1_000_000_000 + 3_000_000, 'ship_speed', 6.0 + 0.1 * k))
    out.sort(key=lambda s: s[0])
    return out


def _take_in_spans(mon: LiveMonitor, stream, read: bool, span_s: float = 1.0) -> list[bool]:
    """``stream`` given to ``mon`` a span at a time as a replay's run gives it: the angle samples'
    rates planned, each span's rudder samples taken at once (the pressure samples before its last
    angle sample held with them, what each angle sample logs worked out from the stream), the
    rest one by one; a span the monitor does not take at once, one by one; with ``read`` the
    steady motion read after each span (as the diagnostics read it each second). Whether each
    span was taken at once."""
    from steer_monitor.model.inputs import PRESSURE_INPUTS, Sample
    angles = [(t, v) for t, n, v in stream if n == 'rudder_angle']
    mon.plan_angles([t for t, _ in angles], [v for _, v in angles])
    spans, start = [], stream[0][0]
    while start <= stream[-1][0]:
        spans.append([s for s in stream if start <= s[0] < start + int(span_s * 1e9)])
        start += int(span_s * 1e9)
    taken = []
    pressures = list(mon._pressures)
    speed = mon.signals['ship_speed'].last_value
    for span in spans:
        last = max((i for i, s in enumerate(span) if s[1] == 'rudder_angle'), default=-1)
        kinds, at, aa, held, env, hold_t, hold_p = [], [], [], [], [], [], []
        p, v = list(pressures), speed
        for t, name, value in span[:last + 1]:
            if name in PRESSURE_INPUTS:
                p[PRESSURE_INPUTS.index(name)] = value
                if not math.isnan(sum(p)):
                    hold_t.append(t)
                    hold_p.append(list(p))
            elif name == 'ship_speed':
                v = value
            elif name == 'rudder_angle':
                kinds.append(True)
                at.append(t)
                aa.append(value)
                held.append(len(hold_t))
                env += [v, math.nan]
            else:
                kinds.append(False)
        orders = [(t, value) for t, name, value in span[:last + 1] if name == 'rudder_order']
        rates = mon.take_rudder(kinds, at, aa, held, env, np.array(hold_t, np.int64),
                                np.array(hold_p, float).reshape(-1, 4), [t for t, _ in orders],
                                [o for _, o in orders], True)
        taken.append(rates is not None)
        if rates is not None:
            for t, name, value in span[:last + 1]:             # what the replay records beside them
                if name in PRESSURE_INPUTS:
                    mon.record(name, [t], [value], True)
                elif name == 'ship_speed':
                    mon.record(name, [t], [value], True)
            mon.hold_pressures(np.zeros(0, np.int64), np.zeros((0, 4)), tuple(p))
            rest = span[last + 1:]
        else:
            rest = span
        for t, name, value in rest:
            mon.update(Sample(t, name, value))
        pressures = list(mon._pressures)
        speed = mon.signals['ship_speed'].last_value
        if read:
            assert mon.motion_ns >= 0
    return taken


@pytest.mark.parametrize('nan_at_s, read, refused', [(None, True, []), (20.3, True, [20]), (None, False, [51])])
def test_a_span_of_rudder_samples_taken_at_once_is_each_taken_alone(r18_params, nan_at_s, read, refused):
    """take_rudder (a replay's spans of angle and order samples) leaves the monitor as update()
    of each sample does: the rate, the hard-over time, the response to the order steps, the
    history the residual's instants are judged from, the steady motion counted and the residual.
    A span is refused with nothing changed, and taken one by one, where an angle in its rate
    windows is not a number, or (nothing read for 51 s, so no held pressure sample released)
    where its held samples would pass MAX_HELD."""
    from steer_monitor.model.inputs import Sample
    gear = gear_from_params(r18_params)
    stream = _rudder_stream(3, 65.0, nan_at_s)
    one = LiveMonitor(gear, Gaps.from_mm(0.6, 0.25))
    for t, name, value in stream:
        one.update(Sample(t, name, value))
    spans = LiveMonitor(gear, Gaps.from_mm(0.6, 0.25))
    taken = _take_in_spans(spans, stream, read)
    assert [i for i, ok in enumerate(taken) if not ok] == refused
    assert one.hard_over_s is not None and spans.hard_over_s == one.hard_over_s
    assert one.response is not None and spans.response == one.response
    assert spans.rate == one.rate and list(spans._history) == list(one._history)
    assert spans.motion_ns == one.motion_ns > 0
    assert spans.residuals == one.residuals and len(one.residuals) > 100
    assert spans.signals['rudder_order'].arrivals == one.signals['rudder_order'].arrivals


def test_a_span_is_refused_unchanged_past_the_held_bound_or_under_another_delay(r18_params):
    """Where one by one would judge the held samples as the bound is passed, or the history is
    cut under a delay the plan was not made with, take_rudder takes nothing."""
    from steer_monitor.monitor.live import MAX_HELD
    gear = gear_from_params(r18_params)
    mon = LiveMonitor(gear, Gaps.from_mm(0.6, 0.25))
    mon.plan_angles([10, 20], [0.1, 0.2])
    args = ([True, True], [10, 20], [0.1, 0.2], [0, 0], [math.nan] * 4)
    many = np.arange(MAX_HELD + 1, dtype=np.int64)
    assert mon.take_rudder(*args, many, np.ones((many.size, 4)), [], [], True) is None
    mon._delay_ns = 250_000_000
    assert mon.take_rudder(*args, np.zeros(0, np.int64), np.zeros((0, 4)), [], [], True) is None
    assert mon._held_total == 0 and not mon._history and mon.rate == 0.0
    mon._delay_ns = 0
    assert mon.take_rudder(*args, np.zeros(0, np.int64), np.zeros((0, 4)), [], [], True) == [0.0, 0.0]
    assert [t for t, _ in mon._history] == [10, 20]


@pytest.mark.parametrize('back_at', [None, 700, 5000])
def test_arrivals_kept_are_those_a_deque_popped_from_the_front_keeps(back_at):
    """An input's arrival times kept (the last 30 s, dropped from the front while the first is
    older than the newest's window, as they came; a clock step back makes them unordered) over
    a long stream, one by one and in ordered batches, against a deque doing just that."""
    from collections import deque

    from steer_monitor.monitor.live import ARRIVALS_KEPT_NS, _Signal
    rng = np.random.default_rng(7)
    times = np.cumsum(rng.integers(1, 200_000_000, 8000)).tolist()
    if back_at is not None:
        times = times[:back_at] + [t - 40_000_000_000 for t in times[back_at:]]
    want: deque[int] = deque()
    one, many = _Signal(), _Signal()
    k = 0
    while k < len(times):
        batch = times[k:k + int(rng.integers(1, 40))]
        for t in batch:
            want.append(t)
            while want and want[0] < t - ARRIVALS_KEPT_NS:
                want.popleft()
            one.arrive(t)
        if many.ordered and (not many.kept() or batch[0] >= many.times[-1]) and batch == sorted(batch):
            many.arrive_many(batch)
        else:
            for t in batch:
                many.arrive(t)
        assert one.arrivals == many.arrivals == list(want) and one.kept() == len(want)
        k += len(batch)
    assert len(one.times) < 2 * len(want) + 2048            # cut down as it goes
    assert one.ordered == (back_at is None)


@pytest.mark.parametrize('seed', [4, 5])
def test_held_samples_come_out_as_they_went_in(seed):
    """The held pressure samples' buffer (blocks and single samples added, the oldest
    released, the rest moved down or the buffer grown as it fills) holds what a list would."""
    from steer_monitor.monitor.live import _Held
    rng = np.random.default_rng(seed)
    held, want = _Held(), []
    k = 0
    for _ in range(400):
        what = rng.integers(0, 3)
        if what == 0:                                   # a block, up to past the buffer's size
            n = int(rng.choice([0, 3, 80, 700, 3000]))
            t = np.arange(k, k + n, dtype=np.int64)
            held.add(t, np.column_stack([t, -t, 2 * t, t + 0.5]).astype(float))
            want += [(int(x), (float(x), float(-x), float(2 * x), x + 0.5)) for x in t]
            k += n
        elif what == 1:                                 # single samples
            for _ in range(int(rng.integers(1, 30))):
                held.add_one(k, [float(k), float(-k), float(2 * k), k + 0.5])
                want.append((k, (float(k), float(-k), float(2 * k), k + 0.5)))
                k += 1
        else:
            r = int(rng.integers(0, len(want) + 1))
            held.release(r)
            del want[:r]
        assert len(held) == len(want)
        t, p = held.view()
        assert t.tolist() == [w[0] for w in want] and [tuple(row) for row in p.tolist()] == [w[1] for w in want]
