"""The gateway model: each forwarding rule checked on the frames it gives, against what a
gateway does (rates per message and instance, hold and decimate, latency, loss in bursts,
outages), and reproducibility."""

from __future__ import annotations

import numpy as np
import pytest

from steer_monitor import sim
from steer_monitor.can import Decoder, RejectCounter
from steer_monitor.can.codec import CanDatabase
from steer_monitor.can.frames import FrameArrays, make_id, pgn_of
from steer_monitor.errors import ParameterError
from steer_monitor.sim.gateway import Gateway, bad_spells, forward, parse_gateway

RUDDER, PRESSURE = 127245, 130314


@pytest.fixture(scope='module')
def voyage(r18_params, can_db):
    db, smap = can_db
    return sim.run(r18_params, sim.SimConfig(program='zigzag_10', max_duration_s=300.0), db, smap, 5)


def _samples(frames: FrameArrays, can_db) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    db, smap = can_db
    dec = Decoder(db, smap, RejectCounter())
    out: dict[str, tuple[list[int], list[float]]] = {}
    for f in frames.frames():
        for s in dec.decode(f):
            t, v = out.setdefault(s.signal, ([], []))
            t.append(s.t_ns)
            v.append(s.value)
    return {k: (np.array(t), np.array(v)) for k, (t, v) in out.items()}


@pytest.mark.parametrize('mode', ['hold', 'decimate'])
@pytest.mark.parametrize('rudder_hz, pressure_hz', [(2.0, 5.0), (0.5, 0.5), (1.0, 20.0)])
def test_each_message_at_its_own_rate(voyage, can_db, mode, rudder_hz, pressure_hz):
    """Each pressure transducer (one instance of PGN 130314 each) and the rudder at the rate
    given, their median interval the period within the jitter; what is not named passes."""
    gw = Gateway({RUDDER: rudder_hz, PRESSURE: pressure_hz}, mode=mode, jitter_s=0.01)
    out = _samples(forward(voyage.frames, gw, can_db[0], 1), can_db)
    full = _samples(voyage.frames, can_db)
    for name, hz in (('rudder_angle', rudder_hz), ('pressure_r1_stbd', pressure_hz), ('pressure_r2_port', pressure_hz)):
        t = out[name][0]
        # decimating a 10 Hz rudder to 2 Hz is every fifth frame: the period the frames allow
        step = np.median(np.diff(t)) / 1e9
        assert step == pytest.approx(1.0 / hz, abs=0.011 + (0.1 if mode == 'decimate' else 0.0))
        assert np.all(np.diff(t) >= 0)
    assert np.array_equal(out['ship_speed'][0], full['ship_speed'][0])


def test_hold_sends_the_last_value_received_and_decimate_the_frame_it_forwards(voyage, can_db):
    """hold: each value sent is the one the sensor sent last before the gateway's tick (its
    latency after it); decimate: a frame the sensor sent, late by the latency and jitter only."""
    full = _samples(voyage.frames, can_db)
    t_in, v_in = full['pressure_r1_stbd']
    gw = Gateway({PRESSURE: 1.0}, mode='hold', latency_s=0.05, jitter_s=0.0)
    t_out, v_out = _samples(forward(voyage.frames, gw, can_db[0], 2), can_db)['pressure_r1_stbd']
    tick = t_out - 50_000_000
    k = np.searchsorted(t_in, tick, 'right') - 1
    assert np.array_equal(v_out, v_in[k])
    gw = Gateway({PRESSURE: 1.0}, mode='decimate', latency_s=0.05, jitter_s=0.02)
    t_out, v_out = _samples(forward(voyage.frames, gw, can_db[0], 2), can_db)['pressure_r1_stbd']
    k = [int(np.flatnonzero(v_in == v)[0]) for v in v_out[:20]]
    late = (t_out[:20] - t_in[k]) / 1e9
    assert np.all((late >= 0.05) & (late <= 0.07 + 1e-9))


def test_a_hold_gateway_sends_nothing_once_its_input_is_older_than_its_timeout(can_db):
    """A sensor silent for 10 s behind a hold gateway at 2 Hz with a 2.5 s timeout: the
    gateway repeats the last value for 2.5 s, then sends nothing until the sensor is back."""
    db = can_db[0]
    layout = db.message(PRESSURE)
    t = np.concatenate([np.arange(0, 5_000_000_000, 50_000_000), np.arange(15_000_000_000, 20_000_000_000, 50_000_000)])
    raw = {'Instance': np.zeros(t.size, np.int64), 'Pressure': np.full(t.size, 10_000, np.int64)}
    data = np.zeros((t.size, 8), np.uint8)
    data[:, :layout.length] = CanDatabase.encode(layout, raw, t.size)
    frames = FrameArrays(t.astype(np.int64), np.full(t.size, make_id(5, PRESSURE, 0x20), np.uint32),
                         np.full(t.size, 8, np.uint8), data, np.ones(t.size, np.uint8))
    out = forward(frames, Gateway({PRESSURE: 2.0}, mode='hold', latency_s=0.0, jitter_s=0.0, hold_timeout_s=2.5), db, 3)
    gap = np.diff(out.t_ns).max() / 1e9
    assert 10.0 - 2.5 - 0.5 <= gap <= 10.0 - 2.5 + 0.5


def test_the_bus_is_bad_its_share_of_the_time_in_spells_of_their_mean_length():
    rng = np.random.default_rng(11)
    spells = bad_spells(0, 100_000_000_000_000, 0.02, 0.2, rng)
    length = (spells[:, 1] - spells[:, 0]) / 1e9
    assert length.sum() / 1e5 == pytest.approx(0.02, rel=0.05)
    assert length.mean() == pytest.approx(0.2, rel=0.05)
    assert np.all(spells[1:, 0] >= spells[:-1, 1])
    assert bad_spells(0, 10**12, 0.0, 0.2, rng).shape == (0, 2)


def test_lost_frames_come_in_bursts_of_a_fast_message_and_alone_of_a_slow_one(voyage, can_db):
    """2 % of the time bad in spells of 0.2 s: of the 20 Hz pressures about 2 % lost, several
    in a row; of a 0.5 Hz rudder about 2 %, one at a time."""
    gw = Gateway({RUDDER: 0.5, PRESSURE: 20.0}, loss=0.02, burst_s=0.2, jitter_s=0.0, latency_s=0.0)
    clean = dict(gw.__dict__, loss=0.0)
    out, full = (_samples(forward(voyage.frames, g, can_db[0], 6), can_db)
                 for g in (gw, Gateway(**clean)))
    for name, hz in (('pressure_r1_stbd', 20.0), ('rudder_angle', 0.5)):
        got, want = out[name][0], full[name][0]
        assert 0.005 < 1 - got.size / want.size < 0.05
        run = np.diff(got) / 1e9 * hz - 1                  # frames missing before each
        if hz == 20.0:
            assert run.max() >= 3
        else:
            assert run.max() <= 1.1


def test_an_outage_forwards_nothing_of_the_named_messages(voyage, can_db):
    gw = Gateway({RUDDER: 10.0, PRESSURE: 20.0}, outages=((100.0, 3.0),), jitter_s=0.0, latency_s=0.0)
    out = forward(voyage.frames, gw, can_db[0], 4)
    t0 = int(voyage.frames.t_ns.min())
    inside = (out.t_ns >= t0 + 100_000_000_000) & (out.t_ns < t0 + 103_000_000_000)
    pgns = set(pgn_of(out.can_id[inside]).tolist())
    assert RUDDER not in pgns and PRESSURE not in pgns and pgns     # the speed log still comes


def test_the_same_seed_gives_the_same_frames(voyage, can_db):
    gw = parse_gateway('rudder=2,pressure=0.5,mode=decimate,loss=0.05,burst=0.4,outage=50+3')
    a, b = (forward(voyage.frames, gw, can_db[0], 9) for _ in range(2))
    c = forward(voyage.frames, gw, can_db[0], 10)
    assert np.array_equal(a.t_ns, b.t_ns) and np.array_equal(a.data, b.data)
    assert not (len(a) == len(c) and np.array_equal(a.t_ns, c.t_ns))


def test_parse_gateway():
    gw = parse_gateway('rudder=2, pressure=0.5, 128259=1, mode=decimate, loss=0.02, burst=0.3, latency=0.1, '
                       'jitter=0.05, timeout=3, outage=600+3, outage=900+2.5')
    assert gw.rates_hz == {RUDDER: 2.0, PRESSURE: 0.5, 128259: 1.0}
    assert (gw.mode, gw.loss, gw.burst_s, gw.latency_s, gw.jitter_s, gw.hold_timeout_s) == ('decimate', 0.02, 0.3,
                                                                                            0.1, 0.05, 3.0)
    assert gw.outages == ((600.0, 3.0), (900.0, 2.5))


@pytest.mark.parametrize('text, message', [
    ('rudder=0', 'gateway rate of PGN 127245: 0.0 Hz, must be above 0'),
    ('rudder=fast', "gateway: cannot read 'rudder=fast' (key=value; outage=start+duration in s)"),
    ('helm=2', "gateway: unknown item 'helm'"),
    ('mode=buffer', "gateway mode 'buffer': one of decimate, hold"),
    ('loss=1.5', 'gateway loss 1.5: must be within 0 .. 0.9'),
    ('outage=5', "gateway: cannot read 'outage=5'"),
])
def test_parse_gateway_refuses_with_the_cause(text, message):
    with pytest.raises(ParameterError) as e:
        parse_gateway(text)
    assert message in str(e.value)
