"""The live monitor and its diagnostics, fed by the simulator through the decoder."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from steer_monitor import sim
from steer_monitor.can import Decoder, RejectCounter
from steer_monitor.model import Clearances
from steer_monitor.monitor import ERROR, OK, STALE, WARN, DiagnosticsBuilder, DiagnosticsConfig, LiveMonitor
from steer_monitor.params import gear_from_params


def _feed(r18_params, can_db, program, effects=(), seed=2, gaps=None, upto_s=None):
    db, smap = can_db
    cfg = sim.SimConfig(program=program, effects=tuple(sim.parse_effect(e) for e in effects))
    s = sim.run(r18_params, cfg, db, smap, seed)
    decoder = Decoder(db, smap, RejectCounter())
    mon = LiveMonitor(gear_from_params(r18_params), gaps or Clearances.from_mm(0.6, 0.25))
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
    assert (cl.level, cl.label) == (OK, 'NOT ASSESSED')
    assert cl.value('clearance_zgb_mm') == '0.250'
    assert cl.value('clearance_source') == 'configured'
    assert cl.message.startswith('2Z 0.600 mm configured NOT ASSESSED: not estimated yet')
    assert cl.value('clearance_2z_lo_mm') == 'n/a'
    gb = by['steer_monitor: guide beam']
    assert (gb.level, gb.label) == (OK, 'NOT ASSESSED')
    assert float(gb.value('guide_onset_deg')) == pytest.approx(10.0, abs=0.1)
    assert gb.message.startswith('NOT ASSESSED: the clearances are not estimated yet; at the configured ones')
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
    mon.set_gaps(Clearances.from_mm(0.65, 0.1), 'test', {'2z': (0.62e-3, 0.68e-3), 'zgb': (0.08e-3, 0.12e-3)})
    cl = b.clearances(mon)
    assert cl.level == ERROR and '2Z 0.650 mm [0.620 .. 0.680] (108% of limit)' in cl.message
    mon.set_gaps(Clearances.from_mm(0.3, 0.1), 'test', {'2z': (0.25e-3, 0.35e-3), 'zgb': (0.08e-3, 0.12e-3)})
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
    last = mon.hard_over
    mon.performance.hard_over.last = replace(last, seconds=30.0, seconds_min=29.9)   # one pump takes 50 s, two 25 s
    perf = b.performance(mon)
    assert perf.level == WARN and perf.value('hard_over_pumps') == '2' and 'OVER SOLAS 28 s' in perf.message
    # an angle sampled every 2 s: 27.0-30.0 s can be either side of 28 s, and is not judged
    mon.performance.hard_over.last = replace(last, seconds=30.0, seconds_min=27.0)
    perf = b.performance(mon)
    assert perf.level == OK and perf.value('hard_over_min_s') == '27.0'
    assert ('hard-over 35 deg to 30 deg the other side in 27.0-30.0 s with 2 pumps (SOLAS 28 s not judged: the '
            "angle's samples leave the time either side of it)") in perf.message


@pytest.mark.parametrize('pumps, speed_mm_s', [(1, 15.0), (2, 15.0), (2, 9.0), (1, 25.0)])
def test_pump_count_from_the_hard_over_time_matches_a_simulation(r18_params, can_db, pumps, speed_mm_s):
    """The closed form H (tan 34.5 + tan 29.5) / (n v) against the simulated gear's own
    hard-over, integrated by its time loop."""
    params = dict(r18_params, **{'hydraulics.ram_speed_per_pump_mm_s': speed_mm_s})
    db, smap = can_db
    gear = gear_from_params(params)
    prog = f'hard_over_{pumps}'
    s = sim.run(params, sim.SimConfig(program=prog), db, smap, 3)
    mon = LiveMonitor(gear, Clearances.from_mm(0.6, 0.25))
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
    mon = LiveMonitor(gear_from_params(r18_params), Clearances.from_mm(0.6, 0.25))
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


@pytest.mark.parametrize(('name', 'rate'), [('oil_temperature', 0.2), ('pressure_r1_stbd', 0.5),
                                            ('rudder_angle', 2.0)])
def test_an_input_steadily_slower_than_configured_is_judged_at_its_own_rate(r18_params, can_db, name, rate):
    """A gateway forwarding an input at its own rate, slower than the parameters say: at rate,
    the rate said, OK; silent only after five of its own periods."""
    # it stops at 60 s, the others go on to 90 s
    mon = _steady_feed(r18_params, can_db[1], 90.0, slow={name: rate}, skip={name: set(range(int(60 * rate), 999))})
    b = _builder(r18_params, can_db)
    configured = next(s.rate_hz for s in can_db[1].specs if s.name == name)
    last = (int(60.0 * rate) - 1) / rate
    status = b.can_input(mon, RejectCounter().snapshot(), int((last + 4.9 / rate) * 1e9))
    assert status.level == OK, status.message
    assert f'slower than the parameters say, judged at their own rates: {name} {rate:.2g} Hz ' \
        f'({configured:g} configured)' in status.message
    assert float(status.value(f'{name}_interval_s')) == pytest.approx(1.0 / rate, rel=1e-6)
    assert status.value(f'{name}_expected_hz') == f'{configured:g}'
    status = b.can_input(mon, RejectCounter().snapshot(), int((last + 5.1 / rate) * 1e9))
    assert status.level in (STALE, WARN) and status.message == f'silent: {name}'


def test_an_input_that_loses_most_of_its_frames_warns(r18_params, can_db):
    """A pressure transducer at 20 Hz heard 1.5 s in every 4 (a loose connector): between its
    silences, WARN for frames lost, its own period still 50 ms."""
    skip = {'pressure_r1_stbd': {i for i in range(1200) if (i % 80) >= 30}}
    mon = _steady_feed(r18_params, can_db[1], 60.0, skip=skip)
    status = _builder(r18_params, can_db).can_input(mon, RejectCounter().snapshot(), int(57.6e9))
    assert status.level == WARN
    assert status.message == 'below half its own rate (frames lost): pressure_r1_stbd'
    assert status.value('pressure_r1_stbd_interval_s') == '0.050'


def test_a_monitor_that_defers_the_load_sharing_leaves_it_to_its_caller(r18_params, can_db):
    """With ``defer_share`` the slot's state has no load sharing (its torque is there to solve
    it from); :attr:`state` still gives the whole state; both equal the eager monitor's."""
    db, smap = can_db
    s = sim.run(r18_params, sim.SimConfig(program='hard_over_2'), db, smap, 4)
    gear = gear_from_params(r18_params)
    eager, lazy = (LiveMonitor(gear, Clearances.from_mm(0.6, 0.25), defer_share=d) for d in (False, True))
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



def test_lost_frames_and_gaps_are_counted_with_their_time(r18_params, can_db):
    """The rudder angle at 10 Hz with frames 100-102 lost (0.4 s) and 300-329 (3.1 s, a gap):
    counted once each however often the status is built, the gap's UTC time and length said."""
    from steer_monitor.utc import utc_json
    mon = _steady_feed(r18_params, can_db[1], 40.0, skip={'rudder_angle': {100, 101, 102, *range(300, 330)}})
    b = _builder(r18_params, can_db)
    for now in (25.0, 35.0, 39.9):
        status = b.can_input(mon, RejectCounter().snapshot(), int(now * 1e9))
    assert status.value('rudder_angle_frames_lost') == str(3 + 30)
    assert status.value('rudder_angle_gaps') == '1'
    assert status.value('rudder_angle_last_gap_utc') == utc_json(int(29.9e9))
    assert status.value('rudder_angle_last_gap_s') == '3.1'
    assert status.value('pressure_r1_stbd_frames_lost') == '0' and status.value('pressure_r1_stbd_gaps') == '0'
