"""The data an analysis looks at: the window of steady motion, and the samples a node keeps."""

from __future__ import annotations

import numpy as np
import pytest

from steer_monitor import sim
from steer_monitor.can import Decoder
from steer_monitor.estimate.observe import GRID_NS, build_observations
from steer_monitor.estimate.window import FAST_MARGIN_NS, WindowBuffer, compact, select
from steer_monitor.model import Clearances
from steer_monitor.model.inputs import INPUTS, Series
from steer_monitor.monitor.analyst import ANALYSED


@pytest.fixture(scope='module')
def voyage(r18_params, can_db):
    """A voyage with long stretches at rest (holds) between the manoeuvres, decoded: the
    samples per input and the frames."""
    db, smap = can_db
    s = sim.run(r18_params, sim.SimConfig(program='hard_over_2,hold:200,zigzag_10,hold:300,autopilot:400',
                                          gaps=Clearances.from_mm(0.4, 0.2)), db, smap, 21)
    dec = Decoder(db, smap)
    t: dict[str, list[int]] = {n: [] for n in INPUTS}
    v: dict[str, list[float]] = {n: [] for n in INPUTS}
    samples = []
    for f in s.frames.frames():
        for x in dec.decode(f):
            t[x.signal].append(x.t_ns)
            v[x.signal].append(x.value)
            samples.append(x)
    signals = {n: Series(np.array(t[n], np.int64), np.array(v[n])) for n in ANALYSED if t[n]}
    return signals, samples


def _moving(signals, ram_area):
    obs = build_observations(signals, ram_area)
    return obs, obs.moving


def test_the_window_holds_the_observations_of_its_motion_to_the_bit(r18, voyage):
    signals, _ = voyage
    win = select(signals, r18.ram_area)
    full, moving = _moving(signals, r18.ram_area)
    kept, kept_moving = _moving(win.signals, r18.ram_area)
    # every instant of steady motion is one of the window's, with the same observations
    t_full, t_kept = full.t_ns[moving], kept.t_ns[kept_moving]
    np.testing.assert_array_equal(t_full, t_kept)
    i = np.searchsorted(full.t_ns, t_full)
    j = np.searchsorted(kept.t_ns, t_kept)
    for name in ('alpha', 'rate', 'direction', 'force', 'pressure', 'speed', 'oil_temp'):
        np.testing.assert_array_equal(getattr(full, name)[i], getattr(kept, name)[j], err_msg=name)
    # and the rest at the holds is gone: far fewer samples than the log's
    assert sum(len(s) for s in win.signals.values()) < 0.75 * sum(len(s) for s in signals.values())
    assert win.motion_s == pytest.approx(t_full.size * GRID_NS / 1e9)
    assert win.start_ns == int(t_full[0]) and win.spans[0, 0] == t_full[0] and win.spans[-1, 1] == t_full[-1]


@pytest.mark.parametrize('motion_s', [20.0, 90.0])
def test_a_bounded_window_keeps_the_last_motion(r18, voyage, motion_s):
    signals, _ = voyage
    whole = select(signals, r18.ram_area)
    win = select(signals, r18.ram_area, motion_s)
    assert win.motion_s == pytest.approx(motion_s, abs=GRID_NS / 1e9)
    assert win.spans[-1, 1] == whole.spans[-1, 1] and win.start_ns > whole.start_ns
    _, moving = _moving(signals, r18.ram_area)
    obs, _ = _moving(signals, r18.ram_area)
    last = obs.t_ns[moving][-int(round(motion_s / 0.05)):]
    kept_obs, kept_moving = _moving(win.signals, r18.ram_area)
    seen = kept_obs.t_ns[kept_moving]
    # the last motion_s of motion, and what the margin before its first instant lets one see
    np.testing.assert_array_equal(seen[seen >= last[0]], last)
    assert seen[0] >= last[0] - FAST_MARGIN_NS


@pytest.mark.parametrize('motion_s', [0.0, 60.0])
def test_what_a_node_keeps_gives_the_window_of_the_whole_log(r18, voyage, motion_s):
    """The node's buffer, compacted every 30 s of data as the samples come: at any second, the
    window of what it holds is the window of the whole log cut there, sample for sample; and
    at the holds it does not grow."""
    signals, samples = voyage
    buf = WindowBuffer(ANALYSED, r18.ram_area, motion_s, compact_every_ns=30 * 10**9)
    t0 = samples[0].t_ns
    checks = {t0 + k * 10**9 for k in (100, 250, 400, 700, 1100)}
    next_second = (t0 // 10**9 + 1) * 10**9
    sizes = []
    for x in samples:
        while x.t_ns >= next_second:
            buf.tick(next_second)
            sizes.append((next_second, len(buf)))
            if next_second in {c // 10**9 * 10**9 for c in checks}:
                cut = {n: Series(s.t_ns[s.t_ns < next_second], s.value[s.t_ns < next_second])
                       for n, s in signals.items()}
                a = select(buf.signals(), r18.ram_area, motion_s)
                b = select(cut, r18.ram_area, motion_s)
                assert set(a.signals) == set(b.signals)
                for n in a.signals:
                    np.testing.assert_array_equal(a.signals[n].t_ns, b.signals[n].t_ns, err_msg=n)
                    np.testing.assert_array_equal(a.signals[n].value, b.signals[n].value, err_msg=n)
                np.testing.assert_array_equal(a.spans, b.spans)
            next_second += 10**9
        if x.signal in ANALYSED:
            buf.add(x.signal, x.t_ns, x.value)
    # during the 300 s hold (from about 400 s on) what the buffer holds stays bounded: a
    # compaction leaves the last half minute's samples and those of the motion before
    hold = [n for t, n in sizes if t0 + 450 * 10**9 <= t <= t0 + 650 * 10**9]
    assert max(hold) < 1.3 * min(hold) + 5000


def test_compact_keeps_what_has_not_settled(r18, voyage):
    signals, _ = voyage
    kept = compact(signals, r18.ram_area)
    end = int(signals['rudder_angle'].t_ns[-1])
    for n, s in signals.items():
        tail = s.t_ns >= end - 2 * 10**9
        np.testing.assert_array_equal(kept[n].t_ns[kept[n].t_ns >= end - 2 * 10**9], s.t_ns[tail])
