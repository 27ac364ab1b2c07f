"""Peak memory of ``inspect`` and ``analyze`` on a log of 1.5 M frames (a day of a busy bus's steering streams).

The log is an hour of simulated voyage and autopilot (about 330,000 frames) written five
times over, each copy an hour and a bit later, into one candump file (about 75 MB, 1.6 M
frames). Each command runs in its own process; its peak resident set size is what the kernel
reports for that child (``wait4``'s ``ru_maxrss``), so the interpreter and the libraries
count too. Prints one line per command: frames, seconds, peak MB.
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

PROGRAM = 'voyage,voyage,autopilot:610'  # about one hour
COPIES = 5


def make_log(path: Path) -> int:
    """Write the 1.5 M-frame log; returns its number of frames. (Imports here: the process
    that starts the measured commands stays small, its peak being handed on to them.)"""
    import numpy as np

    from steer_monitor import sim
    from steer_monitor.can.busconfig import can_setup
    from steer_monitor.can.frames import FrameArrays
    from steer_monitor.logfiles.logs import write_candump
    from steer_monitor.params import load_params_file
    from steer_monitor.resources import default_config

    config = default_config()
    params = load_params_file(config)
    db, smap = can_setup(params, config)
    fa = sim.run(params, sim.SimConfig(program=PROGRAM), db, smap, seed=1).frames
    span = int(fa.t_ns[-1] - fa.t_ns[0]) + 60_000_000_000
    with open(path, 'wb') as fh:
        for k in range(COPIES):
            shifted = FrameArrays(fa.t_ns + np.int64(k * span), fa.can_id, fa.dlc, fa.data, fa.flags)
            write_candump(fh, shifted)
    return COPIES * len(fa)


def peak(argv: list[str]) -> tuple[int, float, float]:
    """(exit status, seconds, peak RSS [MB]) of a command run as a child process."""
    env = dict(os.environ, ROS_AUTOMATIC_DISCOVERY_RANGE='LOCALHOST')
    t0 = time.perf_counter()
    proc = subprocess.Popen(argv, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env)
    _, status, usage = os.wait4(proc.pid, 0)
    return os.waitstatus_to_exitcode(status), time.perf_counter() - t0, usage.ru_maxrss / 1024.0


def main() -> dict:
    exe = [sys.executable, '-m', 'steer_monitor.cli.main']
    out = {}
    with tempfile.TemporaryDirectory() as tmp:
        log = Path(tmp) / 'long.log'
        # made in a process of its own: Linux hands a process's peak memory on to the children it
        # starts (fork copies it, exec keeps it), so a log simulated here would set the commands'
        # peaks below
        env = dict(os.environ, ROS_AUTOMATIC_DISCOVERY_RANGE='LOCALHOST')
        made = subprocess.run([sys.executable, '-m', 'bench.bench_memory', '--make-log', str(log)], env=env,
                              check=True, capture_output=True, text=True)
        n = int(made.stdout.strip().splitlines()[-1])
        size_mb = log.stat().st_size / 1e6
        print(f'log: {n:,d} frames, {size_mb:.0f} MB')
        for name, argv in (('inspect', [*exe, 'inspect', str(log), '--json', '-']),
                           ('analyze', [*exe, 'analyze', str(log), '--json', str(Path(tmp) / 'a.json')])):
            rc, seconds, mb = peak(argv)
            print(f'{name:8s} exit {rc}  {seconds:7.1f} s  peak {mb:6.0f} MB')
            out[name] = {'exit': rc, 'seconds': round(seconds, 1), 'peak_mb': round(mb)}
    out['frames'] = n
    return out


if __name__ == '__main__':
    if len(sys.argv) == 3 and sys.argv[1] == '--make-log':
        print(make_log(Path(sys.argv[2])))
    else:
        main()
