"""The online estimator's jobs run ahead, in a process of their own, for a replay on a
machine with a second core.

The pipeline applies a job's result ``APPLY_DELAY_NS`` of data time after it submitted the
job (:mod:`steer_monitor.monitor.pipeline`): the node runs the jobs on a thread meanwhile, a
replay ran them at once (:class:`~steer_monitor.monitor.pipeline.SyncEstimatorJobs`), which
made them two fifths of its time. Handing each job's samples to a child as it comes does not
help: ten seconds of data are a few milliseconds of the pipeline's work but up to ten refits
of the estimator's, so the pipeline would wait for every result through the manoeuvres.

So the child makes the jobs itself: ``source`` (run in the child) reads the same logs through
the pipeline's schedule alone (:class:`~steer_monitor.monitor.pipeline.JobSchedule`), which
gives the same jobs, in the same order, as the pipeline's own, and the child runs each on its
copy of the estimator, with the same code, as far ahead as the pipe to the parent holds. The
pipeline's ``submit`` only counts; ``result`` takes the child's answer to that job, after
checking it was made from the same samples (their number and last time: a defect otherwise,
raised, never a silent difference). The replay's file is the same as with the jobs run at
once (tested, byte for byte).

:meth:`ProcessEstimatorJobs.close` brings the estimator's final estimate and motion learned
back to the parent's copy, so a caller reads them there as before.
"""

from __future__ import annotations

import multiprocessing
import os
import signal
import threading
from collections.abc import Callable
from multiprocessing.connection import Connection
from typing import Any

from steer_monitor.can.decoder import Sample
from steer_monitor.errors import SteerMonitorError
from steer_monitor.estimate.online import OnlineEstimator
from steer_monitor.monitor.pipeline import EstimateSnapshot, run_job

__all__ = ['JobSource', 'ProcessEstimatorJobs', 'can_fork_a_worker']

#: run in the child: calls its argument with each job's samples, in order
JobSource = Callable[[Callable[[list[Sample]], None]], None]


def can_fork_a_worker() -> bool:
    """A second core to run on, and this process forkable without surprises (Linux's fork,
    and no other thread alive whose locks the child would inherit held)."""
    try:
        cores = len(os.sched_getaffinity(0))
    except AttributeError:          # not Linux
        return False
    return cores > 1 and threading.active_count() == 1 and 'fork' in multiprocessing.get_all_start_methods()


def _fingerprint(samples: list[Sample]) -> tuple[int, int | None]:
    return len(samples), samples[-1].t_ns if samples else None


def _serve(est: OnlineEstimator, source: JobSource, conn: Connection, parents_end: Connection) -> None:
    """The child: every job of ``source`` in order, each result sent as it is made, then the
    estimator's final state. ``parents_end``, the reading end the fork copied, is closed
    first: held here too, it would keep the pipe open after the parent died (killed, say), and
    the child would wait on a full pipe for ever instead of ending on a broken one."""
    parents_end.close()
    signal.signal(signal.SIGINT, signal.SIG_IGN)      # Ctrl-C is the parent's to handle
    signal.signal(signal.SIGTERM, signal.SIG_DFL)     # the parent's handler is not ours

    def job(samples: list[Sample]) -> None:
        errors: list[str] = []
        snap = run_job(est, samples, lambda e: errors.append(str(e)))
        conn.send(('result', (snap, errors), _fingerprint(samples)))

    try:
        source(job)
        conn.send(('final', (est.estimate, est.motion_s), None))
    except (EOFError, BrokenPipeError):
        pass                                          # the parent is gone
    except Exception as exc:  # noqa: BLE001 - a defect or an unreadable log: the parent raises it
        try:
            conn.send(('crash', f'{type(exc).__name__}: {exc}', None))
        except OSError:
            pass
    finally:
        conn.close()


class ProcessEstimatorJobs:
    """:class:`~steer_monitor.monitor.pipeline.EstimatorJobs` whose jobs a forked child makes
    from ``source`` and runs ahead. ``on_error`` hears an update that failed, when its result
    is taken: later than a job run at once would have. So that a caller can put the error where
    the job ran, ``mark`` (if given) is called as each job is submitted and ``on_error`` hears
    ``(error, mark)``, the mark of the job that failed. Close (idempotent) waits for the child;
    :meth:`abort` ends it at once."""

    def __init__(self, est: OnlineEstimator, source: JobSource,
                 on_error: Callable[..., None] | None = None, *, mark: Callable[[], int] | None = None) -> None:
        ctx = multiprocessing.get_context('fork')
        self.est = est
        self.on_error = on_error
        self._conn, child = ctx.Pipe(duplex=False)
        self._proc: Any = ctx.Process(target=_serve, args=(est, source, child, self._conn),
                                      name='steer_monitor-estimator', daemon=True)
        self._proc.start()
        child.close()
        self._sent: list[tuple[int, int | None]] = []      # each job's fingerprint, by handle
        self.mark = mark
        self._marks: list[int] = []                          # each job's mark, by handle (with mark)
        self._taken = 0
        self._closed = False

    def _take(self) -> tuple[str, Any, Any]:
        try:
            kind, payload, fingerprint = self._conn.recv()
        except (EOFError, OSError) as exc:
            self._proc.join(timeout=1.0)
            msg = f'the estimator process ended unexpectedly (exit code {self._proc.exitcode})'
            raise SteerMonitorError(msg) from exc
        if kind == 'crash':
            msg = f'the estimator process failed: {payload}'
            raise SteerMonitorError(msg)
        return kind, payload, fingerprint

    def submit(self, samples: list[Sample]) -> object:
        self._sent.append(_fingerprint(samples))
        if self.mark is not None:
            self._marks.append(self.mark())
        return len(self._sent) - 1

    def result(self, handle: object) -> EstimateSnapshot | None:
        assert isinstance(handle, int) and handle == self._taken, (handle, self._taken)
        kind, payload, fingerprint = self._take()
        if kind != 'result' or fingerprint != self._sent[handle]:
            msg = (f'the estimator process made job {handle} from other samples than the pipeline '
                   f'({fingerprint} against {self._sent[handle]}): a defect, the replay is stopped')
            raise SteerMonitorError(msg)
        self._taken += 1
        snap, errors = payload
        for text in errors:
            if self.on_error is None:
                continue
            if self.mark is None:
                self.on_error(SteerMonitorError(text))
            else:
                self.on_error(SteerMonitorError(text), self._marks[handle])
        return snap

    def close(self) -> None:
        """Take the results of the jobs submitted and not yet applied, then the estimator's
        final state into the parent's copy; end the child."""
        if self._closed:
            return
        try:
            while self._taken < len(self._sent):
                self.result(self._taken)
            kind, payload, _ = self._take()
            if kind != 'final':
                msg = 'the estimator process made more jobs than the pipeline: a defect, the replay is stopped'
                raise SteerMonitorError(msg)
            self.est.estimate, self.est.motion_s = payload
        finally:
            self.abort()

    def abort(self) -> None:
        """End the child now (idempotent); the parent's estimator keeps what it had."""
        if self._closed:
            return
        self._closed = True
        self._conn.close()
        self._proc.join(timeout=0.5)
        if self._proc.is_alive():
            self._proc.terminate()
            self._proc.join()

    def __enter__(self) -> ProcessEstimatorJobs:
        return self

    def __exit__(self, exc_type: object, *exc: object) -> None:
        if exc_type is None:
            self.close()
        else:
            self.abort()
