"""Fuzzing the decode paths (hypothesis, bounded): frames with time jumps split into blocks
and runs anywhere, and candump lines mangled anywhere read by both log readers. The answers must be
the same samples and the same rejects, and nothing may raise."""

from __future__ import annotations

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from steer_monitor.can import Decoder, Frame, FrameArrays, RejectCounter, collect
from steer_monitor.can.timejump import CONFIRM_FRAMES
from steer_monitor.logfiles.blocks import read_log_fast as read_log_arrays
from steer_monitor.logfiles.candumpcols import iter_candump_blocks
from steer_monitor.logfiles.logs import candump_line
from test.support.canframes import pressure, rudder

T0 = 1_767_225_600_000_000_000
FUZZ = settings(max_examples=120, deadline=None, suppress_health_check=[HealthCheck.too_slow,
                                                                        HealthCheck.function_scoped_fixture])

steps = st.one_of(
    st.integers(0, 20_000_000),                                     # the usual few ms
    st.sampled_from([-10**17, -3600 * 10**9, -6 * 10**9, 6 * 10**9, 3600 * 10**9, 10**17]),   # jumps
)
payloads = st.tuples(st.integers(0, 2), st.integers(-3000, 3000), st.integers(0, 4_000_000))


def _frames(db, step_list, values) -> list[Frame]:
    """Rudder and pressure frames of the R-18 bus at the times the steps give."""
    t = T0
    out = []
    for dt, (kind, angle, bar) in zip(step_list, values):
        t = max(0, min(t + dt, (1 << 62)))
        if kind == 0:
            out.append(rudder(db, t, angle))
        else:
            out.append(pressure(db, t, 0 if kind == 1 else 1, bar))
    return out


def _paths(db, smap, frames, cuts):
    d1 = Decoder(db, smap)
    per_frame = [s for f in frames for s in d1.decode(f)] + d1.finish()
    d2 = Decoder(db, smap)
    fa = FrameArrays.from_frames(frames)
    edges = sorted({0, len(frames), *[c % (len(frames) + 1) for c in cuts]})
    parts = [d2.decode_arrays(fa.take(np.arange(a, b)), final=(b == len(frames)))
             for a, b in zip(edges[:-1], edges[1:])]
    if not parts:
        parts = [d2.decode_arrays(fa, final=True)]
    return collect(per_frame, smap.names), parts, d1.rejects.snapshot(), d2.rejects.snapshot()


def _runs(db, smap, frames, cuts):
    """The samples (in order) and rejects of ``decode_run`` over the frames cut at ``cuts``."""
    d = Decoder(db, smap)
    fa = FrameArrays.from_frames(frames)
    edges = sorted({0, len(frames), *[c % (len(frames) + 1) for c in cuts]})
    samples = []
    for a, b in zip(edges[:-1], edges[1:]):
        run = d.decode_run(fa.take(np.arange(a, b)))
        run.count_rejects(b - a - 1)
        samples += [(t, name, v) for t, name, v in zip(run.sample_t_ns.tolist(), run.sample_name,
                                                       run.sample_value.tolist())]
    samples += [(s.t_ns, s.signal, s.value) for s in d.finish()]
    return samples, d.rejects.snapshot()


@FUZZ
@given(step_list=st.lists(steps, min_size=1, max_size=3 * CONFIRM_FRAMES),
       values=st.lists(payloads, min_size=3 * CONFIRM_FRAMES, max_size=3 * CONFIRM_FRAMES),
       cuts=st.lists(st.integers(0, 10_000), max_size=4))
def test_time_jumps_both_paths_agree(db, smap, step_list, values, cuts):
    frames = _frames(db, step_list, values)
    a, parts, ra, rb = _paths(db, smap, frames, cuts)
    assert ra.counts == rb.counts
    # runs cut at the same places: frame by frame's samples in its order, the same rejects
    d1 = Decoder(db, smap)
    one = [(s.t_ns, s.signal, s.value) for f in frames for s in d1.decode(f)] + \
        [(s.t_ns, s.signal, s.value) for s in d1.finish()]
    runs, rc = _runs(db, smap, frames, cuts)
    assert runs == one and rc.counts == ra.counts
    for name in smap.names:
        t_b = np.concatenate([p[name].t_ns for p in parts])
        v_b = np.concatenate([p[name].value for p in parts])
        np.testing.assert_array_equal(a[name].t_ns, t_b, err_msg=name)
        np.testing.assert_array_equal(a[name].value, v_b, err_msg=name)
        assert np.all(np.diff(a[name].t_ns) >= 0), 'a series went back in time'
    # every frame is a sample source or counted once at frame level
    frame_level = sum(ra.counts.get(k, 0) for k in ('time_jump', 'time_backwards', 'duplicate', 'unmapped',
                                                     'unknown_id', 'wrong_length'))
    assert frame_level <= len(frames)


def _mangle(line: bytes, how: int, where: int, byte: int) -> bytes:
    if how == 0:
        return line
    i = where % (len(line) + 1)
    if how == 1:
        return line[:i] + bytes([byte]) + line[i + 1:]          # one byte changed
    if how == 2:
        return line[:i]                                          # cut
    if how == 3:
        return line[:i] + bytes([byte]) * (where % 50) + line[i:]   # bytes inserted
    if how == 4:
        return bytes([byte]) * (where % 3000)                    # junk, long or empty
    return line.replace(b' ', b'\t', where % 3)                  # other whitespace


@FUZZ
@given(step_list=st.lists(st.integers(0, 20_000_000), min_size=1, max_size=60),
       values=st.lists(payloads, min_size=60, max_size=60),
       mangles=st.lists(st.tuples(st.integers(0, 5), st.integers(0, 10_000), st.integers(0, 255)),
                        min_size=60, max_size=60),
       block=st.sampled_from([97, 1 << 20]))
def test_mangled_lines_both_readers_and_both_paths_agree(tmp_path_factory, db, smap, step_list, values, mangles,
                                                         block):
    frames = _frames(db, step_list, values)
    lines = [_mangle(candump_line(f, 'can0').encode().rstrip(b'\n'), *m) for f, m in zip(frames, mangles)]
    path = tmp_path_factory.mktemp('fuzz') / 'f.log'
    path.write_bytes(b'\n'.join(lines) + b'\n')
    r1, r2 = RejectCounter(), RejectCounter()
    ref = read_log_arrays(path, r1)
    got = FrameArrays.concat(list(iter_candump_blocks(path, r2, block_bytes=block)))
    assert r1.snapshot().counts == r2.snapshot().counts
    for col in ('t_ns', 'can_id', 'dlc', 'data', 'flags'):
        np.testing.assert_array_equal(getattr(ref, col), getattr(got, col), err_msg=col)
    a, parts, ra, rb = _paths(db, smap, ref.frames(), [len(ref) // 2])
    assert ra.counts == rb.counts
    for name in smap.names:
        np.testing.assert_array_equal(a[name].t_ns, np.concatenate([p[name].t_ns for p in parts]))


def test_jump_rule_cases(db, smap):
    """The rule on plain cases: a lone far frame is rejected; a clock step forward is taken
    after CONFIRM_FRAMES frames; the held frames then come out, none lost; a short stream
    (fewer frames than that) is released at its end."""
    def run(times):
        d = Decoder(db, smap)
        out = [s for t in times for s in d.decode(_rudder(db, t))] + d.finish()
        return [s.t_ns for s in out if s.signal == 'rudder_angle'], d.rejects.snapshot().counts

    ms = 10_000_000
    steady = [T0 + k * ms for k in range(100)]
    t, c = run(steady[:50] + [T0 + 10**17] + steady[50:])
    assert t == steady and c == {'time_jump': 1}
    step = [T0 + 3600 * 10**9 + k * ms for k in range(100)]
    t, c = run(steady + step)
    assert t == steady + step and c == {}
    t, c = run(steady[:5])
    assert t == steady[:5] and c == {}
    burst = [T0 + 10**12 + k * ms for k in range(CONFIRM_FRAMES - 1)]
    t, c = run(steady[:50] + burst + steady[50:])
    assert t == steady and c == {'time_jump': CONFIRM_FRAMES - 1}
    t, c = run(steady + [T0 + 10**17])        # at the very end: cannot be confirmed
    assert t == steady and c == {'time_jump': 1}


def _rudder(db, t):
    return rudder(db, t, 100)



def test_a_confirmed_step_back_is_counted_with_its_size_in_both_paths(db, smap):
    """What the live node restarts on: a chain confirmed earlier than the stream's time (a
    host clock set back an hour). Counted once, with the step, frame by frame and block by
    block; forward steps, glitches and a stream's first frames are not steps back."""
    from steer_monitor.can.timejump import JumpFilter
    ms = 10_000_000
    steady = [T0 + k * ms for k in range(100)]
    back = [T0 + 99 * ms - 3600 * 10**9 + k * ms for k in range(100)]
    forward = [T0 + 3600 * 10**9 + k * ms for k in range(100)]
    glitch = steady[:50] + [T0 - 10**12] * 3 + steady[50:]
    for times, n in (
        (steady + back, 1),
        (steady + forward, 0),
        (glitch, 0),
        (back, 0),
        (steady + back + forward + back, 2),
    ):
        one = JumpFilter()
        for t in times:
            one.push(t)
        block = JumpFilter()
        block.decide(np.array(times, np.int64))
        assert one.steps_back == block.steps_back == n, (n, one.steps_back, block.steps_back)
    assert one.step_back_ns == block.step_back_ns > 3600 * 10**9 - 100 * ms
