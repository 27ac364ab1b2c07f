"""The pipeline's schedule on the data clock: states per 10 ms slot, diagnostics each whole
second, the analyses' findings applied a fixed data time after their job."""

from __future__ import annotations

import math

import pytest

from steer_monitor import sim
from steer_monitor.can import Decoder, Frame, FrameArrays, RejectCounter
from steer_monitor.can.timejump import CONFIRM_FRAMES
from steer_monitor.estimate.finding import Finding
from steer_monitor.estimate.intervals import Interval
from steer_monitor.model import Clearances
from steer_monitor.monitor import DiagnosticsBuilder, DiagnosticsConfig, LiveMonitor
from steer_monitor.monitor.analyst import Analyst, AnalystSettings, Job, Outcome
from steer_monitor.monitor.pipeline import (
    MAX_GAP_SECONDS,
    SECOND_NS,
    SLOT_NS,
    DiagOut,
    Pipeline,
    StateOut,
    apply_delay_ns,
)
from steer_monitor.monitor.runfeed import StateRun
from steer_monitor.params import gear_from_params


@pytest.fixture(scope='module')
def frames(r18_params, can_db):
    db, smap = can_db
    s = sim.run(r18_params, sim.SimConfig(program='hard_over_2', max_duration_s=16.0), db, smap, 4)
    return s.frames.frames()


@pytest.fixture(scope='module')
def long_frames(r18_params, can_db):
    """Longer than a finding's delay (20 s of data time)."""
    db, smap = can_db
    s = sim.run(r18_params, sim.SimConfig(program='hard_over_2', max_duration_s=40.0), db, smap, 4)
    return s.frames.frames()


def _pipeline(r18_params, can_db, analyst=None, jobs=None, defer_share=False):
    db, smap = can_db
    gear = gear_from_params(r18_params)
    rejects = RejectCounter()
    mon = LiveMonitor(gear, Clearances.from_mm(0.6, 0.25), defer_share=defer_share)
    diag = DiagnosticsBuilder(DiagnosticsConfig(hardware_id='test'), smap, gear)
    return Pipeline(Decoder(db, smap, rejects), rejects, mon, diag, analyst, jobs)


def _run(p, frames):
    out = []
    for f in frames:
        out += [(f.t_ns, o) for o in p.feed(f)]
    return out + [(None, o) for o in p.finish()]


def test_one_state_per_slot_and_diagnostics_at_each_whole_second(r18_params, can_db, frames):
    out = _run(_pipeline(r18_params, can_db), frames)
    states = [o.state for _, o in out if isinstance(o, StateOut)]
    diags = [o for _, o in out if isinstance(o, DiagOut)]
    slots = [st.t_ns // SLOT_NS for st in states]
    assert slots == sorted(set(slots))                                 # at most one per slot
    with_frames = {f.t_ns // SLOT_NS for f in frames}
    assert set(slots) <= with_frames and len(slots) >= 0.9 * len(with_frames)
    for fed_at, o in out:                                              # emitted once its slot ended
        if isinstance(o, StateOut) and fed_at is not None:
            assert fed_at // SLOT_NS > o.state.t_ns // SLOT_NS
    secs = [d.t_ns for d in diags]
    assert all(t % SECOND_NS == 0 for t in secs)
    assert secs == list(range(secs[0], secs[-1] + 1, SECOND_NS))       # every second, in order
    assert secs[0] == (frames[0].t_ns // SECOND_NS + 1) * SECOND_NS
    assert secs[-1] == (frames[-1].t_ns // SECOND_NS + 1) * SECOND_NS  # finish: the second after the end
    for fed_at, o in out:
        if isinstance(o, DiagOut) and fed_at is not None:
            assert fed_at >= o.t_ns                                    # after every frame before it


def test_same_frames_same_outputs(r18_params, can_db, frames):
    a = _run(_pipeline(r18_params, can_db), frames)
    b = _run(_pipeline(r18_params, can_db), frames)
    assert repr(a) == repr(b)


def _flat(out):
    """States as (t, angle, rate, torque, 2Z, Z_gb), one by one or from columns; diagnostics as
    they print."""
    flat = []
    for o in out:
        if isinstance(o, StateRun):
            flat += zip(o.t_ns.tolist(), o.alpha.tolist(), o.rate.tolist(), o.torque.tolist(), o.two_z.tolist(),
                        o.z_gb.tolist(), [None] * len(o))
        elif isinstance(o, StateOut):
            s = o.state
            flat.append((s.t_ns, s.alpha, s.rate, s.torque_measured, s.gaps.two_z, s.gaps.z_gb, s.share))
        else:
            flat.append(repr(o))
    return flat


@pytest.mark.parametrize(('batch', 'defer_share'), [(1024, True), (700, True), (1500, False), (37, False)])
def test_runs_taken_at_once_give_what_each_frame_gives(r18_params, can_db, batch, defer_share):
    """Frames fed in parts (feed_frames: a replay's runs, samples laid out and states as
    columns; the node's reads of a few dozen frames, states one by one with their load sharing;
    parts of one frame) against feed() of each frame: the same states, to the bit, and the
    same diagnostics, in the same order (the byte-for-byte tests of whole replays, with
    analyses, are test_replay's)."""
    import numpy as np

    db, smap = can_db
    arrays = sim.run(r18_params, sim.SimConfig(program='zigzag_10,hard_over_1', max_duration_s=45.0), db, smap,
                     6).frames
    one = _pipeline(r18_params, can_db, defer_share=defer_share)
    a = [o for f in arrays.frames() for o in one.feed(f)] + one.finish()
    many = _pipeline(r18_params, can_db, defer_share=defer_share)
    b = []
    for k in range(0, len(arrays), batch):
        b += many.feed_frames(arrays.take(np.arange(k, min(k + batch, len(arrays)))))
    b += many.finish()
    # the run path was taken: the replay's (states as columns) or the node's (states one by one)
    assert any(isinstance(o, StateRun) for o in b) == defer_share
    fa, fb = _flat(a), _flat(b)
    assert len(fa) > 3000 and fa == fb
    assert many.monitor.motion_ns == one.monitor.motion_ns > 0
    assert many.monitor.residuals == one.monitor.residuals


@pytest.mark.parametrize(('part', 'defer_share'), [(512, False), (777, True), (10**6, True)])
def test_runs_over_time_jumps_give_what_each_frame_gives(r18_params, can_db, part, defer_share):
    """The stream's start, a glitched frame an hour ahead, a gap of 30 s (past the jump limit:
    its chain held until confirmed) and a clock set back, inside runs: fed in parts taken as
    runs (the whole stream in one, the last part shorter, a frame at a time) against each
    frame alone, the same outputs."""
    import dataclasses

    import numpy as np
    db, smap = can_db
    frames = list(sim.run(r18_params, sim.SimConfig(program='zigzag_10', max_duration_s=30.0), db, smap,
                          8).frames.frames())
    third = len(frames) // 3
    frames[third // 2] = dataclasses.replace(frames[third // 2], t_ns=frames[third // 2].t_ns + 3600 * 10**9)
    frames = frames[:third] + [dataclasses.replace(f, t_ns=f.t_ns + 30 * 10**9) for f in frames[third:2 * third]] \
        + [dataclasses.replace(f, t_ns=f.t_ns - 20 * 10**9) for f in frames[2 * third:]]
    one = _pipeline(r18_params, can_db, defer_share=defer_share)
    a = [o for f in frames for o in one.feed(f)] + one.finish()
    many = _pipeline(r18_params, can_db, defer_share=defer_share)
    arrays = FrameArrays.from_frames(frames)
    b = []
    for k in range(0, len(arrays), part):
        b += many.feed_frames(arrays.take(np.arange(k, min(k + part, len(arrays)))))
    b += many.finish()
    assert many.rejects.snapshot().counts['time_jump'] >= 1 and many.decoder.jumps.steps_back == 1
    fa, fb = _flat(a), _flat(b)
    assert len(fa) > 1000 and fa == fb
    assert many.rejects.snapshot().counts == one.rejects.snapshot().counts


@pytest.mark.parametrize('gap_s', [5.4, 30.0, 500.2])
def test_a_gap_in_the_data(r18_params, can_db, frames, gap_s):
    cut = len(frames) // 2
    shift = int(gap_s * 1e9)
    later = [Frame(f.t_ns + shift, f.can_id, f.data, f.is_extended) for f in frames[cut:]]
    p = _pipeline(r18_params, can_db)
    for f in frames[:cut]:
        p.feed(f)
    before = p.next_second_ns
    # a gap longer than the time-jump limit (5 s) holds the frames after it until
    # CONFIRM_FRAMES of them confirm the new time; then the seconds of the gap come at once
    n = CONFIRM_FRAMES if gap_s > 5.0 else 1
    out = [o for f in later[:n] for o in p.feed(f)]
    secs = [o.t_ns for o in out if isinstance(o, DiagOut)]
    last = later[n - 1].t_ns // SECOND_NS * SECOND_NS
    assert secs[0] == before and secs[-1] == last
    assert len(secs) == min(MAX_GAP_SECONDS + 1, (last - before) // SECOND_NS + 1)
    assert all(isinstance(o, DiagOut) for o in out[1:])
    # the inputs are silent at the end of a long gap
    if gap_s > 10:
        assert out[-1].statuses[0].level == 3


FINDING = Finding(0, 'loop', Interval(0.3e-3, 0.2e-3, 0.4e-3), Interval(0.1e-3, 0.05e-3, 0.15e-3),
                  Interval(0.4, 0.3, 0.5), (3000.0, 0.1, 0.12), (), 0.0, (), {}, 'declared', 'fits', 0.4, 0.05, 0.35,
                  42.0, 1000)


class EverySecond(Analyst):
    """An analyst that makes a job at every whole second (the real one waits for motion)."""

    def due(self, t_ns, motion_s):
        self.jobs_made += 1
        return Job(self.jobs_made, t_ns, 'loop', self.buffer.signals())


class FakeJobs:
    """Gives a finding for the ``second``-th job; records the jobs' times and their samples."""

    def __init__(self, second: int) -> None:
        self.second = second
        self.submitted: list[Job] = []

    def submit(self, job):
        self.submitted.append(job)
        found = FINDING if len(self.submitted) == self.second else None
        return Outcome(job.seq, job.t_ns, job.kind, found, None if found else 'nothing', ())

    def result(self, handle):
        return handle

    def close(self):
        pass


def test_a_finding_is_applied_a_fixed_data_time_after_its_job(r18_params, can_db, long_frames):
    frames = long_frames
    jobs = FakeJobs(second=2)
    analyst = EverySecond(gear_from_params(r18_params), AnalystSettings())
    p = _pipeline(r18_params, can_db, analyst, jobs)
    out = _run(p, frames)
    diags = [o for _, o in out if isinstance(o, DiagOut)]
    started = diags[1].t_ns                       # the second second's job gives the finding
    for d in diags:
        if d.t_ns < started + apply_delay_ns(analyst.settings, 0.0):
            assert d.source == 'configured' and d.gaps == Clearances.from_mm(0.6, 0.25)
        else:
            assert d.source == 'estimated'
            assert d.gaps == Clearances(0.3e-3, 0.1e-3)
            assert d.interval == {'2z': (0.2e-3, 0.4e-3), 'zgb': (0.05e-3, 0.15e-3)}
            clear = dict(d.statuses[1].values)
            assert clear['k_gl_max_lo'] == '0.300' and clear['estimate_motion_s'] == '42'
    assert any(d.source == 'estimated' for d in diags)
    assert len(jobs.submitted) == len(diags)
    # each job holds the samples before its second, all of them
    for job in jobs.submitted:
        angle = job.signals['rudder_angle']
        assert angle.t_ns.max() < job.t_ns
        assert len(angle) == sum(1 for f in frames if f.t_ns < job.t_ns and (f.can_id >> 8) & 0x3FFFF == 127245)
    # the friction fitted with the gaps comes with them, and the analyst keeps the finding
    assert p.monitor.priors.seal == 3000.0 and analyst.finding == FINDING and analyst.why == 'nothing'


def test_idle_emits_only_after_the_margin(r18_params, can_db, frames):
    p = _pipeline(r18_params, can_db)
    for f in frames[:200]:
        p.feed(f)
    t = frames[199].t_ns
    slot_end = (t // SLOT_NS + 1) * SLOT_NS
    assert p.idle(slot_end + 49_000_000) == []
    out = p.idle(slot_end + 51_000_000)
    assert len(out) == 1 and isinstance(out[0], StateOut)
    assert p.idle(slot_end + 60_000_000) == []         # nothing new
    nxt = (t // SECOND_NS + 1) * SECOND_NS
    out = p.idle(nxt + 2 * SECOND_NS + 50_000_000)
    assert [o.t_ns for o in out] == [nxt, nxt + SECOND_NS, nxt + 2 * SECOND_NS]


def test_nothing_fed_nothing_out(r18_params, can_db):
    p = _pipeline(r18_params, can_db)
    assert p.finish() == [] and p.idle(10**18) == []
    d = p.diagnostics_now(10**18)
    assert d.statuses[0].level == 3 and math.isclose(d.gaps.two_z, 0.6e-3)


def test_a_pipeline_without_analyses_says_why_in_its_model_health(r18_params, can_db):
    """No analyst, and the reason given: the model health says it (not 'not judged yet', which
    waits for an analysis that will never come)."""
    p = _pipeline(r18_params, can_db)
    p.off = 'the analyses are off for a reason'
    [health] = [st for st in p.diagnostics_now(10**18).statuses if st.name.endswith(': model health')]
    assert health.message == 'not judged: the analyses are off for a reason'
    p.off = None
    [health] = [st for st in p.diagnostics_now(10**18).statuses if st.name.endswith(': model health')]
    assert health.message == 'not judged yet: no analysis of the data yet'


@pytest.mark.parametrize('part', [1, 7, 600])
def test_a_part_stops_where_the_time_goes_back_and_the_rest_goes_on_anew(r18_params, can_db, part):
    """The stream's time set back an hour half-way: fed in parts that stop at the frame that
    confirms the step (the node's reads), the rest of the part into a new pipeline, the
    outputs are those of feeding each frame and starting anew right after that frame."""
    import dataclasses
    db, smap = can_db
    frames = list(sim.run(r18_params, sim.SimConfig(program='hold:8'), db, smap, 6).frames.frames())
    half, back = len(frames) // 2, 3600 * 10 ** 9
    frames = [f if i < half else dataclasses.replace(f, t_ns=f.t_ns - back) for i, f in enumerate(frames)]

    def one_by_one():
        p, out = _pipeline(r18_params, can_db), []
        for f in frames:
            out += p.feed(f)
            if p.decoder.jumps.steps_back:
                out += p.finish()
                p = _pipeline(r18_params, can_db)
        return out + p.finish()

    p, out, stopped = _pipeline(r18_params, can_db), [], 0
    for k in range(0, len(frames), part):
        chunk = frames[k:k + part]
        out += p.feed_frames(chunk, until_step_back=True)
        if p.decoder.jumps.steps_back:
            stopped += 1
            assert 0 < p.taken <= len(chunk)
            rest = chunk[p.taken:]
            out += p.finish()
            p = _pipeline(r18_params, can_db)
            out += p.feed_frames(rest)
        else:
            assert p.taken == len(chunk)
    out += p.finish()
    assert stopped == 1
    want = one_by_one()
    assert _flat(out) == _flat(want) and sum(isinstance(o, StateOut) for o in want) > 400
