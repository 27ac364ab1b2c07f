"""The monitor's pipeline on the data clock: frames in, what the node publishes out. Pure
(no ROS, no CAN bus, no MCAP): the node runs it live, ``steer-monitor replay`` offline, and
because every decision is taken on the frames' own timestamps, both give the same outputs
for the same frames.

Schedule (``t`` is a frame's timestamp, integer ns since the epoch):

* **state**: data time is cut in 10 ms slots. The live model's state after the last frame
  of a slot is emitted when the first frame of a later slot arrives (live, also when the
  bus has been quiet past the slot's end: :meth:`Pipeline.idle`).
* **each whole second** ``k`` (after every frame before it, before any frame at or after
  it): pending estimator results due by ``k`` are applied to the live model, the samples
  since the last second go to the clearance estimator (a job started at ``k``), then the
  diagnostics are built with ``now = k``. Every second of a gap is taken (live, the node
  goes on emitting them while the bus is silent, so inputs show STALE), up to
  ``MAX_GAP_SECONDS``; a longer jump (the next log, a long outage) takes those and its
  last second only.
* **estimator results** are applied ``APPLY_DELAY_NS`` of data time after the job started:
  live, the job runs on its own thread meanwhile (a full profile takes about a second on
  this machine, up to three with the node busy at a full bus) and the pipeline waits for it
  only if it is later than that; offline it
  runs at once. Either way the live model changes clearances at the same sample.

Outputs are :class:`StateOut` and :class:`DiagOut` records, in order.
"""

from __future__ import annotations

import math
import threading
from collections import deque
from collections.abc import Callable, Mapping
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np

from steer_monitor.can.decoder import DecodedRun, Decoder, Sample
from steer_monitor.can.frames import Frame
from steer_monitor.can.rejects import RejectCounter
from steer_monitor.errors import SteerMonitorError
from steer_monitor.estimate.online import OnlineEstimate, OnlineEstimator
from steer_monitor.model.friction import FrictionParams
from steer_monitor.model.gear import Gaps, GearParams
from steer_monitor.monitor.diagnostics import DiagnosticsBuilder, Status
from steer_monitor.monitor.live import LiveMonitor, LiveState
from steer_monitor.params import min_clearance_2z_from_params, ram_share_warn_from_params

__all__ = ['APPLY_DELAY_NS', 'MAX_GAP_SECONDS', 'SECOND_NS', 'SLOT_NS', 'DiagOut', 'EstimateSnapshot', 'EstimatorJobs',
           'JobSchedule', 'Pipeline', 'StateOut',
           'SyncEstimatorJobs', 'ThreadedEstimatorJobs', 'apply_estimate', 'estimator_from_params', 'plausible',
           'run_job']

SLOT_NS = 10_000_000
SECOND_NS = 1_000_000_000
APPLY_DELAY_NS = 10 * SECOND_NS
MAX_GAP_SECONDS = 60


@dataclass(frozen=True)
class StateOut:
    """The live model's state at the end of a 10 ms slot."""

    state: LiveState


@dataclass(frozen=True)
class DiagOut:
    """Diagnostics at a whole second of data time ``t_ns``, with the clearances then in use."""

    t_ns: int
    statuses: tuple[Status, ...]
    gaps: Gaps
    interval: dict[str, tuple[float, float | None]] | None
    source: str


Output = StateOut | DiagOut


@dataclass(frozen=True)
class EstimateSnapshot:
    """What an estimator job hands back when the estimate changed."""

    estimate: OnlineEstimate
    motion_s: float


class EstimatorJobs(Protocol):
    """Runs the online estimator's jobs in submission order."""

    def submit(self, samples: list[Sample]) -> object: ...

    def result(self, handle: object) -> EstimateSnapshot | None: ...

    def close(self) -> None: ...


def estimator_from_params(gear: GearParams, p: Mapping[str, Any]) -> OnlineEstimator:
    """A fresh online estimator as the parameters configure it (grid from the new fit's 2Z,
    forgetting half-life, the rams' uneven share it does not learn from)."""
    return OnlineEstimator(gear, min_clearance_2z=min_clearance_2z_from_params(p),
                           half_life_s=p['estimator.half_life_h'] * 3600.0,
                           ram_share_warn=ram_share_warn_from_params(p))


def run_job(est: OnlineEstimator, samples: list[Sample],
            on_error: Callable[[SteerMonitorError], None] | None) -> EstimateSnapshot | None:
    """One job: the samples in, an update; the new estimate, or None (no change, or an update
    that failed, which ``on_error`` hears: it guards a defect, the monitoring goes on)."""
    try:
        for s in samples:
            est.add(s)
        if est.update() and est.estimate is not None:
            return EstimateSnapshot(est.estimate, est.motion_s)
    except SteerMonitorError as exc:
        if on_error is not None:
            on_error(exc)
    return None


class SyncEstimatorJobs:
    """Each job runs when submitted (offline). ``on_error`` hears an update that failed."""

    def __init__(self, est: OnlineEstimator, on_error: Callable[[SteerMonitorError], None] | None = None) -> None:
        self.est = est
        self.on_error = on_error

    def submit(self, samples: list[Sample]) -> object:
        return run_job(self.est, samples, self.on_error)

    def result(self, handle: object) -> EstimateSnapshot | None:
        return handle  # type: ignore[return-value]

    def close(self) -> None:
        pass


class ThreadedEstimatorJobs:
    """Jobs run one after the other on a worker thread (live). ``after`` runs on that thread
    after each job (the node saves the estimator state there). Context manager; close waits
    for the running job and is idempotent."""

    def __init__(self, est: OnlineEstimator, on_error: Callable[[SteerMonitorError], None] | None = None,
                 after: Callable[[], None] | None = None) -> None:
        self.est = est
        self.on_error = on_error
        self.after = after
        self._pool: ThreadPoolExecutor | None = ThreadPoolExecutor(1, thread_name_prefix='steer_monitor-estimator')
        self._lock = threading.Lock()

    def _run(self, samples: list[Sample]) -> EstimateSnapshot | None:
        try:
            return run_job(self.est, samples, self.on_error)
        finally:
            if self.after is not None:
                self.after()

    def submit(self, samples: list[Sample]) -> object:
        with self._lock:
            if self._pool is None:
                return None
            return self._pool.submit(self._run, samples)

    def result(self, handle: object) -> EstimateSnapshot | None:
        return handle.result() if isinstance(handle, Future) else None

    def close(self) -> None:
        with self._lock:
            pool, self._pool = self._pool, None
        if pool is not None:
            pool.shutdown(wait=True, cancel_futures=True)

    def __enter__(self) -> ThreadedEstimatorJobs:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


MAX_MU = 0.5            # a friction coefficient beyond this (or below 0) is not a physical fit


def plausible(friction: tuple[float, float, float]) -> bool:
    """F_s >= 0 and both friction coefficients in [0, ``MAX_MU``]: early estimates, on a
    minute of data, can fit the friction with numbers no gear has (mu_g = -9.9 was seen)."""
    f_s, mu_b, mu_g = friction
    return all(map(math.isfinite, friction)) and f_s >= 0.0 and 0.0 <= mu_b <= MAX_MU and 0.0 <= mu_g <= MAX_MU


def apply_estimate(monitor: LiveMonitor, snap: EstimateSnapshot) -> bool:
    """Hand an estimate to the live model: the gaps with their intervals, the friction fitted
    with them, and what the clearance diagnostic adds (K_gl max with its interval). An
    estimate whose friction is not physical (:func:`plausible`) is not used: the live model
    keeps what it has, since its residual would judge the declared model by a fit no gear
    has. Returns whether it was used."""
    e = snap.estimate
    if not plausible(e.friction):
        return False
    interval = {'2z': (e.two_z.lo, e.two_z.hi), 'zgb': (e.z_gb.lo, e.z_gb.hi)}
    fr = FrictionParams(*e.friction)
    # The clearances with the torque and friction fitted at them, as one model: a clearance the
    # data only bound from below keeps the fit's own value (the configured one with the fit's
    # friction was tried: an early fit's mu_b of 0.47 with the configured 2Z put the residual at
    # 17 bar in the demo), and the fit's friction goes with the fit's torque (beside the
    # configured torque it left 3-10 bar on a clean gear). Where that clearance would clamp the
    # model's ram beyond what the fit saw, or beyond the angles it learned, the residual is not
    # judged; the minute of motion the residual covers is judged again under the new model
    # (LiveMonitor).
    monitor.set_gaps(Gaps(e.two_z.value, e.z_gb.value), 'estimated', interval, fr,  # type: ignore[arg-type]
                     e.torque_table(monitor.gear))
    k = e.k_gl_max
    monitor.estimate_info = {'k_gl_max_estimated': f'{k.value:.3f}',
                             'k_gl_max_lo': 'n/a' if k.lo is None else f'{k.lo:.3f}',
                             'k_gl_max_hi': 'n/a' if k.hi is None else f'{k.hi:.3f}',
                             'estimate_rows': str(int(e.rows)),
                             'estimate_motion_s': f'{snap.motion_s:.0f}'}
    return True


class Pipeline:
    """Frames in data-time order in, :class:`StateOut` / :class:`DiagOut` out. Not
    thread-safe: feed it from one thread (the node holds a lock around it)."""

    def __init__(self, decoder: Decoder, rejects: RejectCounter, monitor: LiveMonitor, diag: DiagnosticsBuilder,
                 jobs: EstimatorJobs | None = None) -> None:
        self.decoder = decoder
        self.rejects = rejects
        self.monitor = monitor
        self.diag = diag
        self.jobs = jobs
        self._slot: int | None = None          # slot of the newest frame
        self._state_pending = False            # samples since the last emitted state
        self._next_second: int | None = None   # the next whole second to act on
        self._samples: list[Sample] = []       # for the estimator since the last second
        self._pending: deque[tuple[int, object]] = deque()   # (due, job handle)
        self.frames = 0
        self.last_changed_state = False        # the last frame fed changed the live model's state

    # --- input ---------------------------------------------------------------------------
    def feed(self, frame: Frame) -> list[Output]:
        """Take one frame; returns what became due before it (the frame itself is in the
        next output)."""
        out: list[Output] = []
        self.frames += 1
        samples = self.decoder.decode(frame)
        self._advance(self.clock(frame.t_ns), out)
        self._take(samples)
        return out

    def feed_run(self, run: DecodedRun) -> list[Output]:
        """Take a run of frames the decoder has decoded at once (:meth:`Decoder.decode_run`):
        the same outputs, in the same order, as :meth:`feed` of each frame in turn, with the
        rejects counted as they would have been by each second's diagnostics. Only the frames
        that carry samples or open a new slot are visited; for the others :meth:`feed` does
        nothing but count them."""
        t = run.t_ns
        n = t.shape[0]
        out: list[Output] = []
        if n == 0:
            return out
        ref = run.ref_after
        clock = np.where(np.abs(t - ref) <= self.decoder.jumps.max_jump_ns, t, ref)
        slot = clock // SLOT_NS
        reached = np.maximum.accumulate(slot)
        before = np.empty(n, np.int64)                  # the newest slot before each frame
        before[0] = self._slot if self._slot is not None else np.iinfo(np.int64).min
        before[1:] = np.maximum(reached[:-1], before[0])
        visit = slot > before
        visit[run.sample_row] = True
        visit[-1] = True                                # it sets last_changed_state
        if self._slot is None:
            visit[0] = True
        rows = np.flatnonzero(visit)
        lo = np.searchsorted(run.sample_row, rows, 'left').tolist()
        hi = np.searchsorted(run.sample_row, rows, 'right').tolist()
        names, values, clocks, stamps = run.sample_name, run.sample_value.tolist(), clock.tolist(), t.tolist()
        for i, a, b in zip(rows.tolist(), lo, hi):
            run.count_rejects(i)
            self._advance(clocks[i], out)
            ti = stamps[i]
            self._take([Sample(ti, names[k], values[k]) for k in range(a, b)])
        run.count_rejects(n - 1)
        self.frames += n
        return out

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
        self.last_changed_state = False
        if samples:
            mon = self.monitor
            for s in samples:
                mon.update(s)
            if self.jobs is not None:
                self._samples.extend(samples)
            self._state_pending = mon.changed
            self.last_changed_state = mon.changed

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
            _, handle = self._pending.popleft()
            assert self.jobs is not None
            snap = self.jobs.result(handle)
            if snap is not None:
                apply_estimate(mon, snap)
        if self.jobs is not None:
            samples, self._samples = self._samples, []
            self._pending.append((k_ns + APPLY_DELAY_NS, self.jobs.submit(samples)))
        out.append(self.diagnostics_now(k_ns))

    def diagnostics_now(self, now_ns: int) -> DiagOut:
        """Diagnostics at ``now_ns`` with the clearances then in use. Each whole second takes
        them here; live, also at other times while the bus is silent (no second boundary
        comes; STALE shows here). Does not touch the schedule."""
        mon = self.monitor
        statuses = self.diag.build(mon, self.rejects.snapshot(), now_ns)
        interval = dict(mon.gaps_interval) if mon.gaps_interval else None
        return DiagOut(now_ns, tuple(statuses), mon.gaps, interval, mon.gaps_source)


class JobSchedule(Pipeline):
    """The pipeline's schedule alone: the same frames in give the same estimator jobs (the
    samples since the last whole second, at each whole second, in the same order) as a
    :class:`Pipeline` fed them, handed to ``submit``; no live model, states or diagnostics.
    A replay's worker process runs it over the logs to run the jobs ahead of the pipeline
    (:mod:`~steer_monitor.ashore.replay_worker`)."""

    def __init__(self, decoder: Decoder, submit: Callable[[list[Sample]], None]) -> None:
        super().__init__(decoder, decoder.rejects, None, None, None)  # type: ignore[arg-type]
        self._submit = submit

    def _take(self, samples: list[Sample]) -> None:
        if samples:
            self._samples.extend(samples)

    def _emit_state(self, out: list[Output]) -> None:
        pass

    def _second(self, k_ns: int, out: list[Output]) -> None:
        samples, self._samples = self._samples, []
        self._submit(samples)
