"""Decoding with rejects counted per reason, frame by frame and in arrays (same answers)."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from steer_monitor.can import Decoder, Frame, FrameArrays, RejectCounter, SignalMap, make_id
from steer_monitor.can.rejects import REASONS
from test.support.canframes import AUTOPILOT, OTHER, T0, assert_same, both, claim, pressure, rudder


def test_good_frames_become_samples(db, smap):
    frames = [rudder(db, T0, 1000, order=1500), pressure(db, T0 + 1000, 0, 1_000_000),
              pressure(db, T0 + 2000, 3, 12_345_678)]
    a, b = both(db, smap, frames)
    assert_same(a, b)
    s, r = a
    assert r.total == 0
    assert s['rudder_angle'].value.tolist() == [pytest.approx(0.1)]
    assert s['rudder_order'].value.tolist() == [pytest.approx(0.15)]
    assert s['pressure_r1_stbd'].value.tolist() == [pytest.approx(1e5)]
    assert s['pressure_r2_port'].value.tolist() == [pytest.approx(1_234_567.8)]
    assert s['pressure_r2_port'].t_ns.tolist() == [T0 + 2000]


@pytest.mark.parametrize('priority,source', [(0, 0), (2, 0x10), (3, 0x7F), (7, 0xFE)])
def test_pgn_matches_whatever_priority_and_source(db, smap, priority, source):
    (s, r), b = both(db, smap, [rudder(db, T0, -500, priority=priority, source=source)])
    assert r.total == 0
    assert s['rudder_angle'].value.tolist() == [pytest.approx(-0.05)]


def _case(db, reason):
    """Frames that produce exactly one reject of ``reason`` (plus good ones around it)."""
    good = rudder(db, T0, 100)
    if reason == 'error_frame':
        return [good, Frame(T0 + 1, 0x1, b'', is_error=True)]
    if reason == 'remote_frame':
        return [good, Frame(T0 + 1, make_id(2, 127245, 0x10), b'', is_remote=True)]
    if reason == 'not_extended':
        return [good, Frame(T0 + 1, 0x123, b'\x01\x02', is_extended=False)]
    if reason == 'unknown_id':
        return [good, Frame(T0 + 1, make_id(3, 129025, 0x05), bytes(8))]
    if reason == 'wrong_length':
        return [good, Frame(T0 + 1, make_id(2, 127245, 0x10), good.data[:6])]
    if reason == 'time_backwards':
        return [good, rudder(db, T0 - 1000, 200)]
    if reason == 'duplicate':
        return [good, good]
    if reason == 'unmapped':
        return [good, pressure(db, T0 + 5, 7, 1000)]
    if reason == 'not_available':
        return [good, rudder(db, T0 + 100, 0x7FFF, order=0)]
    if reason == 'error_value':
        return [good, rudder(db, T0 + 100, 0x7FFE, order=0)]
    if reason == 'out_of_range':
        return [good, rudder(db, T0 + 100, round(math.radians(46) / 1e-4), order=0)]
    raise AssertionError(reason)


FRAME_REASONS = ['error_frame', 'remote_frame', 'not_extended', 'unknown_id', 'wrong_length',
                 'time_backwards', 'duplicate', 'unmapped', 'not_available', 'error_value', 'out_of_range']


@pytest.mark.parametrize('reason', FRAME_REASONS)
def test_each_reject_reason_counted_with_text(db, smap, reason):
    frames = _case(db, reason)
    a, b = both(db, smap, frames)
    assert_same(a, b)
    for _, snap in (a, b):
        assert snap.counts == {reason: 1}
        assert snap.last[reason].startswith(REASONS[reason])
    # The good frame before the bad one is never lost.
    assert a[0]['rudder_angle'].value[0] == pytest.approx(0.01)


def test_reject_text_names_the_frame(db, smap):
    d = Decoder(db, smap)
    d.decode(Frame(T0, make_id(3, 129025, 0x05), bytes(8)))
    d.decode(rudder(db, T0 + 1, round(math.radians(50) / 1e-4)))
    d.finish()     # the stream's first frames wait for its time to be confirmed (timejump)
    last = d.rejects.snapshot().last
    assert last['unknown_id'] == 'unknown identifier: PGN not in the DBC: 0x0DF80105 (PGN 129025)'
    assert (
        'rudder_angle = 0.8727 rad' in last['out_of_range'] and 'possible: -0.785398..0.785398' in last['out_of_range']
    )


@pytest.mark.parametrize('bar,ok', [(-1.5, False), (-0.9, True), (399.0, True), (401.0, False)])
def test_pressure_plausibility(db, smap, bar, ok):
    (s, r), b = both(db, smap, [pressure(db, T0, 1, round(bar * 1e5 / 0.1))])
    assert (len(s['pressure_r1_port']) == 1) == ok
    assert r.counts.get('out_of_range', 0) == (0 if ok else 1)


def test_state_carries_across_calls(db, smap):
    d = Decoder(db, smap)
    first = FrameArrays.from_frames([rudder(db, T0 + 1000, 1)])
    d.decode_arrays(first)
    d.decode_arrays(FrameArrays.from_frames([rudder(db, T0, 2), rudder(db, T0 + 1000, 1)]), final=True)
    assert d.rejects.snapshot().counts == {'time_backwards': 1, 'duplicate': 1}


frame_strategy = st.builds(
    Frame,
    t_ns=st.integers(0, 10_000).map(lambda k: T0 + k * 1000),
    can_id=st.one_of(
        st.integers(0, 0x1FFFFFFF),
        st.tuples(st.integers(0, 7), st.sampled_from([127245, 130314, 128259, 130316, 60928]),
                  st.integers(0, 255)).map(lambda x: make_id(*x))),
    data=st.binary(min_size=0, max_size=12),
    is_extended=st.booleans(),
    is_error=st.booleans().map(lambda b: b and False),
    is_remote=st.just(False),
)


def _fuzzed(frames: list[Frame], errors: list[bool]) -> list[Frame]:
    """The drawn frames with standard identifiers cut to 11 bits, and some made error or
    remote frames or cut to 8 bytes."""
    return [Frame(f.t_ns, f.can_id if f.is_extended else f.can_id & 0x7FF, f.data[:8] if e else f.data,
                  f.is_extended, is_error=(e and i % 7 == 0), is_remote=(e and i % 11 == 0))
            for i, (f, e) in enumerate(zip(frames, errors))]


@settings(max_examples=400, deadline=None)
@given(frames=st.lists(frame_strategy, min_size=1, max_size=40),
       errors=st.lists(st.booleans(), min_size=40, max_size=40))
def test_fuzz_never_raises_and_paths_agree(db, smap, frames, errors):
    frames = _fuzzed(frames, errors)
    a, b = both(db, smap, frames)
    assert_same(a, b)
    samples, snap = a
    frame_level = sum(snap.counts.get(k, 0) for k in ('error_frame', 'remote_frame', 'not_extended',
                                                      'unknown_id', 'wrong_length', 'time_backwards',
                                                      'duplicate', 'unmapped'))
    assert frame_level <= len(frames)
    for s in samples.values():
        assert np.all(np.isfinite(s.value))


def test_counter_rejects_unknown_reason():
    with pytest.raises(KeyError, match="unknown reject reason 'nope'"):
        RejectCounter().add('nope')


def _runs_against_frames(db, smap, frames, cuts=(), lead=True, confirm=None):
    """``decode_run`` of ``frames`` cut into runs at ``cuts`` against ``decode`` of each in turn
    (after an established stream, or, without ``lead``, from the stream's start; a chain after
    a jump confirmed by ``confirm`` frames): per frame, the same samples (their own stamps) in
    the same order and the same reject counts so far; at the end the same frames held."""
    d1, d2 = Decoder(db, smap), Decoder(db, smap)
    if confirm is not None:
        d1.jumps.confirm = d2.jumps.confirm = confirm
    if lead:
        for f in [rudder(db, T0 - 2_000_000_000 + k * 10_000_000, k) for k in range(60)]:   # the stream's time
            d1.decode(f)
            d2.decode(f)
    bounds = [0, *cuts, len(frames)]
    runs = []
    for a, b in zip(bounds[:-1], bounds[1:]):
        part = frames[a:b]
        run = d2.decode_run(FrameArrays.from_frames(part))
        assert run.t_ns.shape[0] == len(part)
        by_frame, counts = [], []
        for f in part:
            by_frame.append([(s.t_ns, s.signal, s.value) for s in d1.decode(f)])
            snap = d1.rejects.snapshot()
            counts.append((snap.counts, snap.by_signal))
        got: list[list] = [[] for _ in part]
        for row, t, name, value in zip(run.sample_row.tolist(), run.sample_t_ns.tolist(), run.sample_name,
                                       run.sample_value.tolist()):
            got[row].append((t, name, value))
        assert got == by_frame
        for i in range(len(part)):
            run.count_rejects(i)
            snap = d2.rejects.snapshot()
            assert (snap.counts, snap.by_signal) == counts[i], i
        assert d2.jumps.ref_ns == d1.jumps.ref_ns and d2.frames_seen == d1.frames_seen
        assert d2.jumps.pending == d1.jumps.pending and d2.jumps.steps_back == d1.jumps.steps_back
        runs.append(run)
    assert [s.t_ns for s in d2.finish()] == [s.t_ns for s in d1.finish()]
    assert d2.rejects.snapshot().counts == d1.rejects.snapshot().counts
    return runs[0] if len(runs) == 1 else runs


def _run_against_frames(db, smap, frames):
    return _runs_against_frames(db, smap, frames)


@pytest.mark.parametrize('reason', FRAME_REASONS)
def test_a_run_decoded_at_once_gives_each_frames_answers(db, smap, reason):
    frames = [Frame(f.t_ns + 100_000, f.can_id, f.data, f.is_extended, f.is_error, f.is_remote)
              for f in _case(db, reason) * 2]
    run = _run_against_frames(db, smap, frames)
    assert run.settled and run.rejects.snapshot().counts.get(reason, 0) >= 1


def test_a_run_over_a_time_jump_gives_the_held_frames_at_the_frame_that_confirms_them(db, smap):
    """A jump an hour on: the chain after it is held until its fifth frame, then its frames'
    samples come there with their own stamps; a glitched frame alone is refused as a time jump
    when the next frame returns; a claim before the jump is read in its turn."""
    hour = 3_600_000_000_000
    frames = [rudder(db, T0, 1), claim(T0 + 1000, 0x10, AUTOPILOT), rudder(db, T0 + 2 * hour, 2),
              rudder(db, T0 + 2000, 3)] + [rudder(db, T0 + hour + k * 1000, 10 + k) for k in range(7)]
    run = _runs_against_frames(db, smap, frames, confirm=5)
    assert not run.settled
    assert run.rejects.snapshot().counts['time_jump'] == 1
    # the chain's first four frames give nothing as they come, then all five at the fifth
    rows, stamps = run.sample_row.tolist(), run.sample_t_ns.tolist()
    assert sorted(set(rows)) == [0, 3, 8, 9, 10]
    assert sorted({t for r, t in zip(rows, stamps) if r == 8}) == [T0 + hour + k * 1000 for k in range(5)]


def test_the_streams_start_and_its_chains_across_runs(db, smap):
    """From the stream's first frame, cut into runs anywhere: the first chain held until
    confirmed across runs, a chain after a jump held across runs and refused where it ends."""
    hour = 3_600_000_000_000
    frames = ([rudder(db, T0 + k * 1000, k) for k in range(6)]
              + [rudder(db, T0 + hour + k * 1000, k) for k in range(3)]       # too short: refused
              + [rudder(db, T0 + 9000 + k * 1000, k) for k in range(4)]
              + [rudder(db, T0 - hour + k * 1000, k) for k in range(5)])      # a step back, confirmed
    for cuts in [(), (1,), (2, 7), (5, 8, 10, 14), tuple(range(1, len(frames)))]:
        _runs_against_frames(db, smap, frames, cuts, lead=False, confirm=4)


def test_a_run_stops_at_the_frame_that_confirms_a_step_back(db, smap):
    hour = 3_600_000_000_000
    frames = ([rudder(db, T0 + k * 1000, k) for k in range(3)]
              + [rudder(db, T0 - hour + k * 1000, k) for k in range(6)])
    d = Decoder(db, smap)
    d.jumps.confirm = 4
    for k in range(60):
        d.decode(rudder(db, T0 - 2_000_000_000 + k * 10_000_000, k))
    run = d.decode_run(FrameArrays.from_frames(frames), until_step_back=True)
    assert run.t_ns.shape[0] == 7 and d.jumps.steps_back == 1       # the fourth frame of the chain
    assert d.decode_run(FrameArrays.from_frames(frames[7:]), until_step_back=True).t_ns.shape[0] == 1


_far = st.sampled_from([0, 0, 0, 0, 0, 0, 3_600_000_000_000, -3_600_000_000_000, 7_000_000_000])


@settings(max_examples=300, deadline=None)
@given(steps=st.lists(st.tuples(st.integers(0, 3_000_000), _far, st.integers(0, 2000), st.sampled_from('1122o')),
                      min_size=1, max_size=40),
       cuts=st.lists(st.integers(1, 39), max_size=6, unique=True), lead=st.booleans())
def test_fuzz_runs_over_time_jumps_agree_with_frame_by_frame(db, smap, steps, cuts, lead):
    """Frames a few ms apart with jumps an hour or seven seconds away and back, some
    duplicates, some of a PGN the monitor does not know, from the stream's start or after it,
    cut into runs anywhere."""
    t, frames = T0, []
    for dt, far, pos, kind in steps:
        t += dt
        f = rudder(db, t + far, pos)
        frames += {'1': [f], '2': [f, f], 'o': [Frame(t + far, make_id(3, 129025, 0x05), bytes(8))]}[kind]
    cuts = sorted(c for c in cuts if c < len(frames))
    _runs_against_frames(db, smap, frames, cuts, lead=lead, confirm=3)


def _bound_to(smap, name):
    """The map with the rudder angle taken from the device ``name`` wherever it is."""
    return SignalMap(tuple(dataclasses.replace(s, device_name=name, address=-1, instance=0)
                           if s.name == 'rudder_angle' else s for s in smap.specs), smap.max_jump_ns)


def test_a_run_with_address_claims_gives_each_frames_answers(db, smap):
    """Claims inside a run are read in order: each frame is its device's as it came, and each
    claim's reject (a short one as a wrong length) is counted when its frame is reached."""
    m = _bound_to(smap, AUTOPILOT)
    short = claim(T0 + 25, 13, OTHER)
    short = Frame(short.t_ns, short.can_id, short.data[:5])
    frames = [rudder(db, T0, 100, source=13),                         # nobody's yet: unmapped
              claim(T0 + 1, 13, AUTOPILOT),
              rudder(db, T0 + 10, 200, source=13),                    # the autopilot's
              claim(T0 + 20, 13, OTHER),                              # OTHER takes 13
              short,
              rudder(db, T0 + 30, 300, source=13),                    # OTHER's: not the rudder
              claim(T0 + 40, 14, AUTOPILOT),
              rudder(db, T0 + 50, 400, source=14)]
    run = _run_against_frames(db, m, frames)
    counts = run.rejects.snapshot().counts
    assert counts['address_claim'] == 3 and counts['wrong_length'] == 1
    got = [v for name, v in zip(run.sample_name, run.sample_value.tolist()) if name == 'rudder_angle']
    assert got == pytest.approx([0.02, 0.04])


@settings(max_examples=200, deadline=None)
@given(events=st.lists(st.tuples(st.booleans(), st.integers(0, 2000), st.sampled_from([13, 14, 20]),
                                 st.sampled_from([AUTOPILOT, OTHER])), min_size=1, max_size=40))
def test_fuzz_a_run_with_claims_agrees_with_frame_by_frame(db, smap, events):
    m = _bound_to(smap, AUTOPILOT)
    frames = [claim(T0 + i * 10**6, a, n) if is_claim else rudder(db, T0 + i * 10**6, t, source=a)
              for i, (is_claim, t, a, n) in enumerate(events)]
    _run_against_frames(db, m, frames)


@settings(max_examples=300, deadline=None)
@given(frames=st.lists(frame_strategy, min_size=1, max_size=40),
       errors=st.lists(st.booleans(), min_size=40, max_size=40))
def test_fuzz_a_run_decoded_at_once_agrees_with_frame_by_frame(db, smap, frames, errors):
    frames = _fuzzed(frames, errors)
    _run_against_frames(db, smap, frames)
