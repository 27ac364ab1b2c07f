"""The estimator's jobs run ahead in a forked process: the same results in order, the final
state brought back, and every way the child can fail named (the equality of whole replays
is in test_replay)."""

from __future__ import annotations

import os

import pytest

from steer_monitor.can.decoder import Sample
from steer_monitor.errors import SteerMonitorError
from steer_monitor.ashore.replay_worker import ProcessEstimatorJobs


class _Counting:
    """An estimator's interface (add, update, estimate, motion_s): the estimate is the number
    of samples taken; an update fails on a sample of value -1."""

    def __init__(self) -> None:
        self.estimate: object = None
        self.motion_s = 0.0
        self._n = 0
        self._bad = False

    def add(self, s: Sample) -> None:
        self._n += 1
        self._bad |= s.value == -1.0

    def update(self) -> bool:
        if self._bad:
            self._bad = False
            msg = 'no fit'
            raise SteerMonitorError(msg)
        self.estimate, self.motion_s = ('samples', self._n), float(self._n)
        return True


def _job(k: int) -> list[Sample]:
    return [Sample(1_000_000_000 * k + i, 'rudder_angle', -1.0 if k == 2 else float(i)) for i in range(k % 3)]


def _source(jobs: int, then: str = 'end'):
    def source(submit):
        for k in range(jobs):
            submit([] if then == 'other' and k == 1 else _job(k))
        if then == 'exit':
            os._exit(3)
        if then == 'raise':
            msg = 'boom'
            raise ValueError(msg)
    return source


def test_results_in_order_errors_heard_and_the_final_state_brought_back():
    est, heard = _Counting(), []
    jobs = ProcessEstimatorJobs(est, _source(6), heard.append)   # type: ignore[arg-type]
    handles = [jobs.submit(_job(k)) for k in range(6)]
    got = [jobs.result(h) for h in handles[:4]]
    assert [None if g is None else g.estimate for g in got] == [('samples', 0), ('samples', 1), None, ('samples', 3)]
    assert [str(e) for e in heard] == ['no fit']                   # job 2's update failed
    jobs.close()                                                   # jobs 4 and 5 taken, then the final state
    assert est.estimate == ('samples', 3 + 1 + 2) and est.motion_s == 6.0
    assert not jobs._proc.is_alive()
    jobs.close()
    jobs.abort()                                                   # both idempotent


@pytest.mark.parametrize(('then', 'message'), [
    ('exit', r'the estimator process ended unexpectedly \(exit code 3\)'),
    ('raise', 'the estimator process failed: ValueError: boom'),
    ('other', 'the estimator process made job 1 from other samples than the pipeline'),
])
def test_a_child_that_fails_is_named(then, message):
    jobs = ProcessEstimatorJobs(_Counting(), _source(2, then))     # type: ignore[arg-type]
    handles = [jobs.submit(_job(k)) for k in range(4)]
    with pytest.raises(SteerMonitorError, match=message):
        for h in handles:
            jobs.result(h)
    jobs.abort()
    assert not jobs._proc.is_alive()


def test_more_jobs_in_the_child_than_the_pipeline_made_is_a_defect():
    jobs = ProcessEstimatorJobs(_Counting(), _source(3))           # type: ignore[arg-type]
    jobs.submit(_job(0))
    with pytest.raises(SteerMonitorError, match='made more jobs than the pipeline'):
        jobs.close()
    assert not jobs._proc.is_alive()


def test_leaving_early_ends_the_child_at_once():
    jobs = ProcessEstimatorJobs(_Counting(), _source(10_000))      # type: ignore[arg-type]
    with pytest.raises(RuntimeError), jobs:
        jobs.submit(_job(0))
        msg = 'the replay failed'
        raise RuntimeError(msg)
    assert not jobs._proc.is_alive()


def _gone(pid: int) -> bool:
    """The process has ended (a zombie counts: it runs no more, whoever reaps it)."""
    try:
        with open(f'/proc/{pid}/stat') as fh:
            return fh.read().rsplit(')', 1)[1].split()[0] == 'Z'
    except FileNotFoundError:
        return True


KILLED_PARENT = r'''
import os, signal, sys
sys.path.insert(0, {pkg!r})
from test.ashore.test_replay_worker import _Counting, _job, _source
from steer_monitor.ashore.replay_worker import ProcessEstimatorJobs
jobs = ProcessEstimatorJobs(_Counting(), _source(1_000_000))   # far more results than a pipe holds
print(jobs._proc.pid, flush=True)
os.kill(os.getpid(), signal.SIGKILL)                            # no clean-up of any kind
'''


@pytest.mark.skipif(not os.path.isdir('/proc/self'), reason='reads process states from Linux /proc')
def test_the_child_ends_when_its_parent_is_killed(tmp_path):
    """The fork copied the parent's reading end of the pipe into the child; kept open there,
    a parent killed (SIGKILL, or SIGTERM before the CLI handled it) left the child waiting on a
    full pipe for ever, 160 MB resident. Closed, the pipe breaks and the child ends."""
    import subprocess
    import sys
    import time

    from test.conftest import PKG
    said, err = tmp_path / 'out.txt', tmp_path / 'err.txt'   # files, not pipes: a child left alive holds them
    with open(said, 'w') as out, open(err, 'w') as errors:
        proc = subprocess.run([sys.executable, '-c', KILLED_PARENT.format(pkg=str(PKG))], stdout=out,
                              stderr=errors, timeout=60, cwd=PKG)
    assert proc.returncode == -9, err.read_text()
    child = int(said.read_text().split()[0])
    deadline = time.time() + 10
    while not _gone(child) and time.time() < deadline:
        time.sleep(0.05)
    if not _gone(child):
        os.kill(child, 9)
        pytest.fail('the estimator process outlived its killed parent')
