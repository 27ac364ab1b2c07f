"""The monitor's pipeline on the data clock: frames in, what the node publishes out. Pure
(no ROS, no CAN bus, no MCAP): the node runs it live, ``steer-monitor replay`` offline, and
because every decision is taken on the frames' own timestamps, both give the same outputs
for the same frames.

Schedule (``t`` is a frame's timestamp, integer ns since the epoch):

* **state**: data time is cut in 10 ms slots. The live model's state after the last frame
  of a slot is emitted when the first frame of a later slot arrives (live, also when the
  bus has been quiet past the slot's end: :meth:`Pipeline.idle`).
* **each whole second** ``k`` (after every frame before it, before any frame at or after
  it): the findings of analyses due by ``k`` are applied to the live model, the
  :class:`~steer_monitor.monitor.analyst.Analyst` is asked whether an analysis of the data
  before ``k`` is due (a job started at ``k``), then the diagnostics are built with
  ``now = k``. Every second of a gap is taken (live, the node goes on emitting them while
  the bus is silent, so inputs show STALE), up to ``MAX_GAP_SECONDS``; a longer jump (the
  next log, a long outage) takes those and its last second only.
* **analyses** are applied :func:`apply_delay_ns` of data time after the job started (20 s
  and 1 % of the motion the window may hold: time for ``analyze`` of an hour of motion on a
  busy node's second core): live, the job runs on the node's worker thread meanwhile and the
  pipeline waits for it only if it is later than that; offline it runs when and where the
  replay likes. Either way the live model takes the finding at the same sample.

Outputs are :class:`StateOut` and :class:`DiagOut` records, in order.
"""

from __future__ import annotations

import threading
import time
from bisect import bisect_left
from collections import deque
from collections.abc import Callable, Iterable, Mapping, Sequence
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from steer_monitor.can.decoder import DecodedRun, Decoder
from steer_monitor.can.frames import Frame, FrameArrays
from steer_monitor.can.rejects import RejectCounter
from steer_monitor.can.timejump import NO_TIME
from steer_monitor.estimate.effects import Effect
from steer_monitor.model.gear import Clearances, GearParams
from steer_monitor.model.inputs import INPUTS, PRESSURE_INPUTS, Sample
from steer_monitor.monitor.analyst import ANALYSED, Analyst, AnalystSettings, Job, JobRunner, Outcome, SyncJobs, run_job
from steer_monitor.monitor.diagnostics import DiagnosticsBuilder, Status
from steer_monitor.monitor.live import LiveMonitor, LiveState
from steer_monitor.monitor.runfeed import ANGLE, RunPlan, StateRun
from steer_monitor.params import min_clearance_2z_from_params, ram_share_warn_from_params
from steer_monitor.runtime import release_freed_memory

__all__ = ['APPLY_DELAY_NS', 'APPLY_PER_MOTION', 'MAX_GAP_SECONDS', 'MIN_RUN', 'SECOND_NS', 'SLOT_NS', 'DiagOut',
           'Pipeline', 'StateOut', 'ThreadedJobs', 'analyst_from_params', 'apply_delay_ns', 'settings_from_params']

SLOT_NS = 10_000_000
SECOND_NS = 1_000_000_000
APPLY_DELAY_NS = 20 * SECOND_NS     # a finding is applied this long after its job started ...
APPLY_PER_MOTION = 0.01             # ... and this share of the motion its window may hold
MAX_GAP_SECONDS = 60
#: frames: a part of fewer goes a frame at a time. A run's decoding and laying out cost some
#: 50-150 us whatever its length, a frame's some 2 us (on a full bus most frames are PGNs the
#: monitor does not use, refused by a dictionary lookup), so below about 500 frames of a full
#: bus (a quarter of a second of it: a replay's blocks are longer, the node's reads shorter)
#: frame by frame is the cheaper (bench/bench_feed.py)
MIN_RUN = 512
#: the inputs whose samples change the live model's state (what a published state reflects)
_STATE_INPUTS = frozenset(('rudder_angle', *PRESSURE_INPUTS))


@dataclass(frozen=True)
class StateOut:
    """The live model's state at the end of a 10 ms slot."""

    state: LiveState


@dataclass(frozen=True)
class DiagOut:
    """Diagnostics at a whole second of data time ``t_ns``, with the clearances then in use."""

    t_ns: int
    statuses: tuple[Status, ...]
    gaps: Clearances
    interval: dict[str, tuple[float, float | None]] | None
    source: str


Output = StateOut | StateRun | DiagOut


def settings_from_params(p: Mapping[str, Any]) -> AnalystSettings:
    """The analyses as the parameters configure them (``estimator.*``)."""
    return AnalystSettings(window_motion_s=p['estimator.window_motion_h'] * 3600.0,
                           loop_every_s=p['estimator.loop_every_motion_s'], every_s=p['estimator.every_motion_s'],
                           first_s=p['estimator.first_motion_s'],
                           min_clearance_2z=min_clearance_2z_from_params(p),
                           ram_share_warn=ram_share_warn_from_params(p))


def analyst_from_params(gear: GearParams, p: Mapping[str, Any]) -> Analyst:
    """A fresh analyst as the parameters configure it."""
    return Analyst(gear, settings_from_params(p))


def apply_delay_ns(settings: AnalystSettings, motion_s: float) -> int:
    """How long after its job starts a finding is applied [ns of data time]: ``APPLY_DELAY_NS``
    and ``APPLY_PER_MOTION`` of the motion the window holds by then (the analysis's work grows
    with it), so that live the node's worker has it ready; the same in a replay."""
    held = min(motion_s, settings.window_motion_s)
    return APPLY_DELAY_NS + int(APPLY_PER_MOTION * held * 1e9)


class ThreadedJobs:
    """Jobs run one after the other on a worker thread (live); each estimate job takes the
    model of the loop before it. ``after`` runs on that thread after each job (the node logs
    its outcome there). Context manager; close waits for the running job and is idempotent."""

    def __init__(self, gear: GearParams, settings: AnalystSettings, model: tuple[Effect, ...] = (),
                 after: Callable[[Outcome], None] | None = None) -> None:
        self.gear, self.settings, self.model = gear, settings, model
        self.after = after
        self._pool: ThreadPoolExecutor | None = ThreadPoolExecutor(1, thread_name_prefix='steer_monitor-analysis')
        self._lock = threading.Lock()
        self.submitted = 0
        #: each job run: (kind, CPU seconds it took on the worker thread)
        self.done: list[tuple[str, float]] = []

    @property
    def pending(self) -> int:
        """Jobs submitted and not yet run to their end."""
        return self.submitted - len(self.done)

    def _run(self, job: Job) -> Outcome:
        c0 = time.thread_time()
        out = run_job(self.gear, self.settings, job, self.model)
        release_freed_memory()      # the analysis's arrays, freed: back to the system, not kept at its peak
        self.done.append((job.kind, time.thread_time() - c0))
        self.model = out.model
        if self.after is not None:
            self.after(out)
        return out

    def submit(self, job: Job) -> object:
        with self._lock:
            if self._pool is None:
                return None
            self.submitted += 1
            return self._pool.submit(self._run, job)

    def result(self, handle: object) -> Outcome | None:   # type: ignore[override]
        return handle.result() if isinstance(handle, Future) else None

    def close(self) -> None:
        with self._lock:
            pool, self._pool = self._pool, None
        if pool is not None:
            pool.shutdown(wait=True, cancel_futures=True)

    def __enter__(self) -> ThreadedJobs:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


class Pipeline:
    """Frames in data-time order in, :class:`StateOut` / :class:`DiagOut` out. Not
    thread-safe: feed it from one thread (the node holds a lock around it)."""

    def __init__(self, decoder: Decoder, rejects: RejectCounter, monitor: LiveMonitor, diag: DiagnosticsBuilder,
                 analyst: Analyst | None = None, jobs: JobRunner | None = None,
                 on_failed: Callable[[str], None] | None = None, off: str | None = None) -> None:
        """``on_failed`` hears an analysis that failed (a defect), when its finding would have
        been applied; ``off``: why there are no analyses (no ``analyst``), which the statuses
        that wait on one say."""
        self.decoder = decoder
        self.off = off
        self.on_failed = on_failed
        self.rejects = rejects
        self.monitor = monitor
        self.diag = diag
        self.analyst = analyst
        self.jobs = jobs if jobs is not None or analyst is None else SyncJobs(analyst.gear, analyst.settings,
                                                                             analyst.model)
        self._slot: int | None = None          # slot of the newest frame
        self._state_pending = False            # samples since the last emitted state
        self._next_second: int | None = None   # the next whole second to act on
        self._pending: deque[tuple[int, object]] = deque()   # (due, job handle)
        if analyst is not None and analyst.finding is not None:
            monitor.set_finding(analyst.finding)
            monitor.last_assessed = dict(analyst.assessed)
        self.frames = 0
        #: after :meth:`feed_frames`: the stamps [ns] of its frames that changed the live model's
        #: state, and how many of its frames it took
        self.changed_stamps: list[int] = []
        self.taken = 0
        self._changed_by_last = False           # the last frame fed (feed) carried a rudder or pressure sample

    @property
    def next_second_ns(self) -> int | None:
        """The next whole second of data the schedule acts on [ns] (None before the first frame)."""
        return self._next_second

    # --- input ---------------------------------------------------------------------------
    def feed_frames(self, part: FrameArrays | Sequence[Frame], see: Callable[[int | None, int], None] | None = None,
                    *, until_step_back: bool = False) -> list[Output]:
        """Take frames in the order received: the one way frames enter the pipeline, for the
        node (what each read of the bus holds, as frames) and for a replay (a log's blocks, as
        columns). A part of :data:`MIN_RUN` frames or more is one run (:meth:`Decoder.decode_run`,
        :meth:`feed_run`), the stream's start and time jumps included; a shorter one goes a
        frame at a time (:meth:`feed`). The outputs do not depend on how the frames are cut into
        parts (tested: one part per frame and parts of any size give the same). Returns what
        became due, in order; :attr:`changed_stamps` then holds the stamps [ns] of the frames
        taken whose samples changed the live model's state (rudder angle, pressures), in order,
        and :attr:`taken` how many of its frames it took. ``see`` hears the stream's time before
        a frame is taken (None before the stream's first) and its stamp: of every frame fed one
        at a time; of a run's first, its first with a time and its last. ``until_step_back``:
        stop after the frame that confirms the stream's time going back (the node starts a new
        monitor there)."""
        if len(part) < MIN_RUN:
            return self._feed_each(part.frames() if isinstance(part, FrameArrays) else part, see, until_step_back)
        fa = part if isinstance(part, FrameArrays) else FrameArrays.from_frames(part)
        if self.decoder.settled or len(fa) < 2 * MIN_RUN:
            return self._feed_run_of(fa, see, until_step_back)
        # the stream's start or a chain held: a run of its first frames alone, so that the rest,
        # its time then settled, is laid out at once (a run deciding across frames goes a row at a time)
        out = self._feed_run_of(fa.take(np.arange(MIN_RUN)), see, until_step_back)
        stamps, taken = self.changed_stamps, self.taken
        if taken == MIN_RUN and not (until_step_back and self.decoder.jumps.steps_back):
            out += self._feed_run_of(fa.take(np.arange(MIN_RUN, len(fa))), see, until_step_back)
            stamps, taken = stamps + self.changed_stamps, taken + self.taken
        self.changed_stamps, self.taken = stamps, taken
        return out

    def _feed_run_of(self, fa: FrameArrays, see: Callable[[int | None, int], None] | None,
                     until_step_back: bool) -> list[Output]:
        """:meth:`feed_frames` of frames taken as one run."""
        run = self.decoder.decode_run(fa, until_step_back)
        n = run.t_ns.shape[0]
        if see is not None:
            jump = self.decoder.jumps.max_jump_ns
            before = run.ref_before
            first_timed = int(np.argmax(before != NO_TIME)) if before[0] == NO_TIME and before[-1] != NO_TIME else 0
            for i in sorted({0, first_timed, n - 1}):
                ti, ref = int(run.t_ns[i]), int(before[i])
                see(None if ref == NO_TIME else ti if abs(ti - ref) <= jump else ref, ti)
        out = self.feed_run(run)
        stamps: list[int] = []
        changing = [name in _STATE_INPUTS for name in run.spec_names]
        if any(changing):
            rows = run.sample_row[np.array(changing)[run.sample_spec]]       # non-decreasing
            if rows.size:
                rows = rows[np.concatenate(([True], rows[1:] != rows[:-1]))]
            stamps = run.t_ns[rows].tolist()
        self.changed_stamps, self.taken = stamps, n
        return out

    def _feed_each(self, frames: Iterable[Frame], see: Callable[[int | None, int], None] | None,
                   until_step_back: bool) -> list[Output]:
        """:meth:`feed_frames` of a short part: a frame at a time."""
        out: list[Output] = []
        stamps: list[int] = []
        taken = 0
        for frame in frames:
            if see is not None:
                see(self.clock(frame.t_ns), frame.t_ns)
            out += self.feed(frame)
            taken += 1
            if self._changed_by_last:
                stamps.append(frame.t_ns)
            if until_step_back and self.decoder.jumps.steps_back:
                break
        self.changed_stamps, self.taken = stamps, taken
        return out

    def feed(self, frame: Frame) -> list[Output]:
        """Take one frame; returns what became due before it (the frame itself is in the
        next output). The path of a part shorter than :data:`MIN_RUN` frames, and the
        reference the run path is tested against."""
        out: list[Output] = []
        self.frames += 1
        samples = self.decoder.decode(frame)
        self._advance(self.clock(frame.t_ns), out)
        if samples:
            self._take(samples)
            self._changed_by_last = any(x.signal in _STATE_INPUTS for x in samples)
        else:
            self._changed_by_last = False
        return out

    def feed_run(self, run: DecodedRun) -> list[Output]:
        """Take a run of frames the decoder has decoded at once (:meth:`Decoder.decode_run`):
        the same outputs, in the same order, as every frame fed alone, with the rejects counted
        as they would have been by each second's diagnostics. Between whole seconds the angle
        and order samples are taken one by one, the others recorded where something reads them
        and the slots' states worked out at once (:mod:`.runfeed`); the states come as
        :class:`~steer_monitor.monitor.runfeed.StateRun` columns. A run where the decoder
        decided across frames (the stream's start, a time jump) goes a frame it visits at a time."""
        t = run.t_ns
        n = t.shape[0]
        out: list[Output] = []
        if n == 0:
            return out
        ref = run.ref_after
        jump = self.decoder.jumps.max_jump_ns
        if run.settled:                                 # every frame after the stream's first time
            clock = np.where(np.abs(t - ref) <= jump, t, ref)
            slot = clock // SLOT_NS
        else:
            timed = ref != NO_TIME
            clock = np.where(timed & (np.abs(t - np.where(timed, ref, t)) <= jump), t, ref)
            slot = np.where(timed, clock // SLOT_NS, np.iinfo(np.int64).min)
        reached = np.maximum.accumulate(slot)
        before = np.empty(n, np.int64)                  # the newest slot before each frame
        before[0] = self._slot if self._slot is not None else np.iinfo(np.int64).min
        before[1:] = np.maximum(reached[:-1], before[0])
        opens = slot > before
        if run.sample_row.size:
            visit = opens.copy()
            visit[run.sample_row] = True
            rows = np.flatnonzero(visit)
        else:
            rows = np.flatnonzero(opens)
        lo = np.searchsorted(run.sample_row, rows, 'left')
        hi = np.searchsorted(run.sample_row, rows, 'right')
        plan = None
        if self._slot is not None and self.monitor.defer_share and run.settled:
            plan = RunPlan(run, self.monitor, lo[opens[rows]])
        if plan is None or not plan.ok:
            names, values, clocks = run.sample_name, run.sample_value.tolist(), clock.tolist()
            stamps = run.sample_t_ns.tolist()
            for i, a, b in zip(rows.tolist(), lo.tolist(), hi.tolist()):
                run.count_rejects(i)
                self._advance(clocks[i], out)
                self._take([Sample(stamps[k], names[k], values[k]) for k in range(a, b)])
        else:
            self._feed_planned(run, plan, rows, lo, hi, opens[rows], clock, slot, out)
        run.count_rejects(n - 1)
        self.frames += n
        return out

    def _feed_planned(self, run: DecodedRun, plan: RunPlan, rows: NDArray[np.intp], lo: NDArray[np.intp],
                      hi: NDArray[np.intp], opens: NDArray[np.bool_], clock: NDArray[np.int64],
                      slot: NDArray[np.int64], out: list[Output]) -> None:
        """:meth:`feed_run` with the run laid out: spans of rows (frames visited) at once between
        whole seconds; at the row where a whole second comes the schedule moves (the state due
        emitted, the second's diagnostics built) and the row's samples go with the span after
        it, or, where the state to emit is then not the one the live model would evaluate, are
        taken one by one, as are the rows after it until it is."""
        mon, analyst = self.monitor, self.analyst
        rows_l, lo_l, hi_l = rows.tolist(), lo.tolist(), hi.tolist()
        clocks, stamps = clock.tolist(), run.t_ns.tolist()
        reached = np.maximum.accumulate(clock[rows]).tolist()
        counting = run.counting_rows(rows).tolist()
        opens_at_a = np.flatnonzero(opens)           # indices into rows
        opens_at = opens_at_a.tolist()
        at_all = lo[opens_at_a]                      # the positions before which each opening slot's state is due
        # whether the live model changed between consecutive openings (the first of a span: worked out there)
        fresh_all = np.empty(at_all.shape[0], bool)
        fresh_all[1:] = plan.changes[at_all[1:]] > plan.changes[at_all[:-1]]
        fresh_before = np.concatenate([[0, 0], np.cumsum(fresh_all[1:])]).tolist()   # of openings 1.. before each
        at_l = at_all.tolist()
        emits: list[tuple[int, NDArray[np.intp], Clearances]] = []   # (place in out, state positions, clearances)
        mon.steady.plan(plan.times[ANGLE], plan.vals[ANGLE])
        c = 0                                        # counting rows passed
        advanced = -1                                # the row whose time the schedule last took
        pos, n_rows = 0, len(rows_l)
        while pos < n_rows:
            if self._state_pending != mon.changed:   # after diagnostics read the state: one by one
                j = pos
            else:
                assert self._next_second is not None
                j = max(pos, bisect_left(reached, self._next_second))
            if j > pos:                              # a span: no whole second in it
                a, b = lo_l[pos], hi_l[j - 1]
                changed = mon.changed
                if not plan.take_rudder(mon, a, b):
                    for s in plan.seq[bisect_left(plan.seq, a):bisect_left(plan.seq, b)]:
                        name = INPUTS[plan.codes[s]]
                        if name == 'rudder_angle':        # an order sample reads nothing recorded
                            plan.before_sequential(mon, s)
                        mon.update(Sample(plan.stamp(s), name, plan.value(s)))
                        plan.rate_after[s] = mon.rate
                plan.sync(mon, analyst, b)
                k0, k1 = bisect_left(opens_at, pos), bisect_left(opens_at, j)
                while c < len(counting) and counting[c] <= rows_l[j - 1]:
                    run.count_rejects(counting[c])
                    c += 1
                state = None
                if k1 > k0:
                    # the openings whose state is due: the live model changed since the last read
                    first = changed or plan.changed_between(a, at_l[k0])
                    if first or fresh_before[k1] > fresh_before[k0 + 1]:
                        fresh = fresh_all[k0:k1]
                        fresh[0] = first
                        due = at_all[k0:k1][fresh]
                        emits.append((len(out), due, mon.gaps))
                        out.append(None)             # type: ignore[arg-type]  # filled below
                        state = plan.state_before(mon, int(due[-1]))
                    changed = plan.changed_between(at_l[k1 - 1], b)
                    self._slot = int(slot[rows_l[opens_at[k1 - 1]]])
                else:
                    changed = changed or plan.changed_between(a, b)
                if state is not None:             # the state last read, as slot_state() would have
                    mon.latest = state
                mon.changed = changed
                self._state_pending = changed
            if j >= n_rows:
                break
            i = rows_l[j]                            # one by one, as feed_run's loop
            if j != advanced:
                plan.sync(mon, analyst, lo_l[j])
                while c < len(counting) and counting[c] <= i:
                    c += 1
                run.count_rejects(i)
                self._advance(clocks[i], out)
                advanced = j
                if self._state_pending == mon.changed:
                    # the state before the row emitted as due: its samples with the span after it
                    pos = j
                    continue
            ti = stamps[i]
            self._take([Sample(ti, INPUTS[plan.codes[k]], plan.value(k)) for k in range(lo_l[j], hi_l[j])])
            plan.skip(hi_l[j])
            for s in plan.seq[bisect_left(plan.seq, lo_l[j]):bisect_left(plan.seq, hi_l[j])]:
                plan.rate_after[s] = mon.rate        # the rate after the row: all a later state reads
            pos = j + 1
        plan.sync(mon, analyst, plan.m)
        mon.steady.plan(None)
        if emits:
            sizes = [at.size for _, at, _ in emits]
            runs = plan.states(mon, np.concatenate([at for _, at, _ in emits]),
                               np.repeat([g.two_z for _, _, g in emits], sizes),
                               np.repeat([g.z_gb for _, _, g in emits], sizes))
            k = 0
            for place, at, _ in emits:
                out[place] = StateRun(*(col[k:k + at.size] for col in (runs.t_ns, runs.alpha, runs.rate, runs.torque,
                                                                        runs.two_z, runs.z_gb)))
                k += at.size

    def clock(self, t_ns: int) -> int | None:
        """The stream's time after a frame stamped ``t_ns``: its own stamp when it lies
        within the time-jump limit of what the decoder has accepted, else that accepted time
        (a glitched stamp does not move the schedule); None before the decoder has accepted
        any time."""
        jumps = self.decoder.jumps
        ref = jumps.ref_ns
        if ref is None:
            return None
        return t_ns if abs(t_ns - ref) <= jumps.max_jump_ns else ref

    def _advance(self, t: int | None, out: list[Output]) -> None:
        """Move the schedule to time ``t``: the state of a slot that ended, whole seconds."""
        if t is None:
            return
        slot = t // SLOT_NS
        if self._slot is None:
            self._slot = slot
            self._next_second = (t // SECOND_NS + 1) * SECOND_NS
        elif slot > self._slot:
            self._emit_state(out)
            self._slot = slot
            self._seconds_until(t, out)

    def _take(self, samples: list[Sample]) -> None:
        if samples:
            mon = self.monitor
            analyst = self.analyst
            for s in samples:
                mon.update(s)
                if analyst is not None and s.signal in ANALYSED:
                    analyst.add(s.signal, s.t_ns, s.value)
            self._state_pending = mon.changed

    def idle(self, now_ns: int, margin_ns: int = 50 * 1_000_000) -> list[Output]:
        """Live only: the bus has been quiet; emit the state of a slot that ended more than
        ``margin_ns`` ago and act on the whole seconds passed by then. A frame stamped
        before that arriving later falls in the next slot/second."""
        out: list[Output] = []
        if self._slot is None:
            return out
        edge = now_ns - margin_ns
        if edge >= (self._slot + 1) * SLOT_NS:
            self._emit_state(out)
            self._slot = edge // SLOT_NS
            self._seconds_until(edge, out)
        return out

    def finish(self) -> list[Output]:
        """End of input (offline): the last slot's state and the whole second after the
        last frame, as the live node emits them once the bus has gone quiet."""
        out: list[Output] = []
        samples = self.decoder.finish()
        if samples:
            self._advance(max(s.t_ns for s in samples), out)
            self._take(samples)
        if self._slot is None:
            return out
        self._emit_state(out)
        assert self._next_second is not None
        self._second(self._next_second, out)
        self._next_second += SECOND_NS
        return out

    def close(self) -> None:
        if self.jobs is not None:
            self.jobs.close()

    # --- schedule ------------------------------------------------------------------------
    def _emit_state(self, out: list[Output]) -> None:
        if self._state_pending:
            self._state_pending = False
            st = self.monitor.slot_state()
            if st is not None:
                out.append(StateOut(st))

    def _seconds_until(self, t: int, out: list[Output]) -> None:
        k = self._next_second
        assert k is not None
        if t < k:
            return
        last = t // SECOND_NS * SECOND_NS
        stop = k + MAX_GAP_SECONDS * SECOND_NS
        while k <= last and k < stop:
            self._second(k, out)
            k += SECOND_NS
        if k <= last:
            self._second(last, out)
        self._next_second = last + SECOND_NS

    def _second(self, k_ns: int, out: list[Output]) -> None:
        mon = self.monitor
        while self._pending and self._pending[0][0] <= k_ns:
            self._apply(self._pending.popleft()[1])
        analyst = self.analyst
        if analyst is not None:
            job = analyst.due(k_ns, mon.motion_s)
            if job is not None:
                assert self.jobs is not None
                due = k_ns + apply_delay_ns(analyst.settings, analyst.motion_base_s + mon.motion_s)
                self._pending.append((due, self.jobs.submit(job)))
        out.append(self.diagnostics_now(k_ns))

    def _apply(self, handle: object) -> None:
        """A job's outcome to the analyst, and its finding, if any, to the live model."""
        assert self.jobs is not None and self.analyst is not None
        outcome = self.jobs.result(handle)
        if outcome is None:          # the runner was closed before it ran
            return
        if outcome.failed and self.on_failed is not None:
            self.on_failed(outcome.why or 'the analysis failed')
        finding = self.analyst.take(outcome)
        if finding is not None:
            self.monitor.set_finding(finding)
            self.monitor.last_assessed = dict(self.analyst.assessed)

    def diagnostics_now(self, now_ns: int) -> DiagOut:
        """Diagnostics at ``now_ns`` with the clearances then in use. Each whole second takes
        them here; live, also at other times while the bus is silent (no second boundary
        comes; STALE shows here). Does not touch the schedule."""
        mon = self.monitor
        statuses = self.diag.build(mon, self.rejects.snapshot(), now_ns,
                                   why=None if self.analyst is None else self.analyst.why, off=self.off)
        interval = dict(mon.gaps_interval) if mon.gaps_interval else None
        return DiagOut(now_ns, tuple(statuses), mon.gaps, interval, mon.gaps_source)
