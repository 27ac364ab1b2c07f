"""The entry point: SIGTERM ends a command as Ctrl-C does, and leaves nothing behind."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

import pytest

from steer_monitor.cli.main import main
from test.ashore.test_replay_worker import _gone
from test.conftest import PKG


def _children(pid: int) -> list[int]:
    with open(f'/proc/{pid}/task/{pid}/children') as fh:
        return [int(c) for c in fh.read().split()]


@pytest.mark.skipif(not os.path.isfile(f'/proc/{os.getpid()}/task/{os.getpid()}/children'),
                    reason='reads a process\'s children from Linux /proc')
def test_sigterm_ends_a_replay_cleanly(tmp_path):
    """SIGTERM (a service manager stopping a job, a batch system's time limit) killed the
    replay on the spot: its half-made MCAP stayed under its temporary name and its estimator
    process ran on, orphaned. Now: one line, status 143, no file left, the worker ended."""
    log = tmp_path / 'voyage.log'
    assert main(['simulate', '--program', 'autopilot:1200', '--out', str(log)]) == 0
    out = tmp_path / 'out'
    out.mkdir()
    env = dict(os.environ, ROS_AUTOMATIC_DISCOVERY_RANGE='LOCALHOST')
    said = tmp_path / 'stderr.txt'      # a file, not a pipe, which a worker left alive would hold open
    workers: list[int] = []
    with open(said, 'w') as errors:
        proc = subprocess.Popen([sys.executable, '-m', 'steer_monitor.cli.main', 'replay', str(log), '--out',
                                 str(out / 'r.mcap')], env=env, cwd=PKG, stderr=errors)
    try:
        deadline = time.time() + 60
        while not list(out.iterdir()) and time.time() < deadline:    # writing has begun
            time.sleep(0.01)
        assert list(out.iterdir()), 'the replay never started its output'
        workers = _children(proc.pid)
        proc.send_signal(signal.SIGTERM)
        rc = proc.wait(30)
        deadline = time.time() + 10
        while not all(_gone(w) for w in workers) and time.time() < deadline:
            time.sleep(0.05)
        alive = [w for w in workers if not _gone(w)]
    finally:
        if proc.poll() is None:
            proc.kill()
        for w in workers:
            if not _gone(w):
                os.kill(w, signal.SIGKILL)
    err = said.read_text()
    assert rc == 143 and err == 'steer-monitor replay: terminated (SIGTERM)\n', (rc, err)
    assert list(out.iterdir()) == []
    assert not alive, f'the estimator process {alive} outlived the replay'


def test_the_sigterm_handler_is_the_caller_s_again_afterwards(capsys):
    before = signal.getsignal(signal.SIGTERM)
    assert main(['fit', '240 H9/f9']) == 0
    assert signal.getsignal(signal.SIGTERM) is before
