"""The fleet on Dask: logs per second with 1 and 2 local workers against the single-process
batch path on the same logs, and the peak memory of each worker process.

Thirty-two simulated logs of about four minutes of the gear's traffic each (hard-overs and
zig-zags, ~6,000 frames), written as candump. The single-process figure calls the task
function in a loop (no Dask, no report pages); the Dask figures run ``run_fleet`` without
report pages (the same work) on a fresh LocalCluster
(its start-up and the workers' imports timed apart) with nothing kept from earlier runs. Worker memory is
each worker process's peak RSS (``/proc/<pid>/status`` VmHWM) read through the client at the
end. One BLAS thread in every process, as Dask's workers have. The task function is also
looped inside the one worker (``client.run``: no scheduling, no store), which tells the
worker's process from the fleet's own work. Prints one line per configuration and the
ratios measured in this run (this machine's two vCPUs are shared: the same loop run twice
in a row can differ by a tenth).
"""

from __future__ import annotations

import os
import tempfile
import time
from pathlib import Path

from steer_monitor import sim
from steer_monitor.can.busconfig import load_setup
from steer_monitor.logfiles.logs import write_candump
from steer_monitor.model import Clearances

LOGS = 32
T0_NS = 1_767_225_600_000_000_000


def make_logs(root: Path) -> list[Path]:
    _, params, db, smap = load_setup(None)
    vessel = root / 'bench_vessel'
    vessel.mkdir()
    out = []
    for k in range(LOGS):
        cfg = sim.SimConfig(program='hard_over_2,zigzag_20,zigzag_10', gaps=Clearances.from_mm(0.35, 0.15),
                            start_ns=T0_NS + k * 86_400_000_000_000)
        s = sim.run(params, cfg, db, smap, k)
        path = vessel / f'day_{k:02d}.log'
        with open(path, 'wb') as fh:
            write_candump(fh, s.frames)
        out.append(path)
    return out


def _loop(paths: list[str]) -> float:
    """The task function over ``paths`` in a loop -> seconds (run in a worker by client.run)."""
    from steer_monitor.ashore.store import log_result
    t0 = time.perf_counter()
    for p in paths:
        log_result('bench_vessel', p, None, '', '')
    return time.perf_counter() - t0


def _hwm_kb() -> int:
    with open('/proc/self/status') as fh:
        for line in fh:
            if line.startswith('VmHWM:'):
                return int(line.split()[1])
    return 0


def main() -> dict:
    from steer_monitor.ashore.fleet import make_client, run_fleet
    from steer_monitor.runtime import single_blas_thread

    single_blas_thread()     # as Dask's workers run (OPENBLAS_NUM_THREADS=1): the same work compared

    out = {}
    with tempfile.TemporaryDirectory() as tmp:
        logs = make_logs(Path(tmp))
        single = LOGS / _loop([str(p) for p in logs])
        out['single_process_logs_per_s'] = round(single, 2)
        print(f'single process (no Dask): {single:.2f} logs/s')
        for workers in (1, 2):
            res = Path(tmp) / f'out{workers}'
            res.mkdir()
            t0 = time.perf_counter()
            client, cluster = make_client(workers, None)     # the LocalCluster run_fleet makes
            with cluster, client:
                client.run(lambda: __import__('steer_monitor.ashore.reviewlogs'))     # what a warm worker has
                started = time.perf_counter() - t0
                if workers == 1:     # the worker's process alone: the same loop inside it, no scheduling
                    (inside,) = client.run(_loop, [str(p) for p in logs]).values()
                    out['worker_loop_logs_per_s'] = round(LOGS / inside, 2)
                    print(f'the same loop inside one Dask worker: {LOGS / inside:.2f} logs/s '
                          f'({LOGS / inside / single:.2f} x single process)')
                t1 = time.perf_counter()
                run = run_fleet([logs[0].parent], res, client=client, reports=False)   # the same work as above
                t2 = time.perf_counter()
                hwm = client.run(_hwm_kb)
            rate = LOGS / (t2 - t1)
            peak = max(hwm.values()) / 1024
            assert run.analysed == LOGS and not run.failed
            out[f'dask_{workers}_workers_logs_per_s'] = round(rate, 2)
            out[f'dask_{workers}_workers_startup_s'] = round(started, 1)
            out[f'dask_{workers}_workers_peak_worker_mb'] = round(peak)
            print(f'Dask, {workers} worker(s): {rate:.2f} logs/s ({rate / single:.2f} x single process), after '
                  f'{started:.1f} s of cluster start-up; peak worker RSS {peak:.0f} MB')
    print(f"2 workers / 1 worker: {out['dask_2_workers_logs_per_s'] / out['dask_1_workers_logs_per_s']:.2f}")
    return out


if __name__ == '__main__':
    os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')
    main()
