"""Benchmark of the estimation: ``analyze`` of a one-hour simulated log (target under 60 s),
and what the node's analyses cost per second of data (the node runs ``analyze`` on its
window, on the schedule of ``estimator.*``), measured in one run.

The one-hour log: the voyage programme (about 25 minutes of mixed helm) followed by an hour's
autopilot and zigzags, cut at 3600 s; true gaps 0.6 / 0.25 mm, no undeclared effect.

The node's analyses are timed by replaying that log (:func:`steer_monitor.ashore.replay.replay`
runs the node's pipeline and its jobs, one after the other, as the node's worker thread does):
each job's CPU time, by kind (``loop``: the residual loop on the window; ``estimate``: the
last loop's model refitted), and their sum over the data's span: the share of one core the
node's worker needs at real time; then the steady state, a loop and an estimate on a window
full of motion, and the share of a core they need on a gear that never stops. One BLAS thread, as the node and the
command line set it.

Run: ``python -m bench.bench_estimate`` (part of ``make bench``).
"""

from __future__ import annotations

import functools
import os
import sys
import tempfile
import time
from collections import defaultdict
from pathlib import Path

PROGRAM = 'voyage,autopilot:1200,zigzag_10,autopilot:1200,zigzag_20'


def _mm(x: float | None) -> str:
    return '-' if x is None else f'{x * 1e3:.3f}'


def main() -> int:
    os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')
    from steer_monitor.runtime import single_blas_thread
    single_blas_thread()

    from steer_monitor import sim
    from steer_monitor.ashore.replay import replay
    from steer_monitor.can.busconfig import can_setup
    from steer_monitor.can.decoder import Decoder
    from steer_monitor.estimate.analyze import analyze
    from steer_monitor.logfiles.logs import write_candump
    from steer_monitor.monitor.analyst import SyncJobs
    from steer_monitor.params import gear_from_params, load_params_file
    from steer_monitor.resources import default_config

    cfg_path = default_config()
    params = load_params_file(cfg_path)
    db, smap = can_setup(params, cfg_path)
    gear = gear_from_params(params)
    s = sim.run(params, sim.SimConfig(program=PROGRAM, max_duration_s=3600.0), db, smap, seed=11)
    span = s.plant.duration
    print(f'== estimation: {span:.0f} s simulated log, {len(s.frames):,d} frames ==')
    t0 = time.perf_counter()
    signals = Decoder(db, smap).decode_arrays(s.frames)
    t_decode = time.perf_counter() - t0
    t0 = time.perf_counter()
    a = analyze(gear, signals, min_clearance_2z=0.05e-3)
    t_analyze = time.perf_counter() - t0
    print(f'analyze (batch decode {t_decode:.2f} s + residual loop {t_analyze:.2f} s): {t_analyze + t_decode:.1f} s '
          f'(target < 60 s); verdict {a.verdict}; Z_gb {a.final.z_gb.value * 1e3:.3f} mm')

    jobs: list[tuple[str, float, float]] = []     # kind, CPU s, wall s
    submit = SyncJobs.submit

    @functools.wraps(submit)
    def timed(self, job):
        c0, w0 = time.process_time(), time.perf_counter()
        try:
            return submit(self, job)
        finally:
            jobs.append((job.kind, time.process_time() - c0, time.perf_counter() - w0))

    SyncJobs.submit = timed
    with tempfile.TemporaryDirectory() as tmp:
        log = Path(tmp) / 'hour.log'
        with open(log, 'wb') as fh:
            write_candump(fh, s.frames)
        summary = replay([log], Path(tmp) / 'replay.mcap')
    f = summary.finding
    by_kind: dict[str, list[float]] = defaultdict(list)
    for kind, cpu, _ in jobs:
        by_kind[kind].append(cpu)
    print(f'the node\'s analyses on the same log ({summary.motion_s:.0f} s of steady motion; '
          f'window {params["estimator.window_motion_h"]:.1f} h of motion, a loop every '
          f'{params["estimator.loop_every_motion_s"]:.0f} s and an estimate every '
          f'{params["estimator.every_motion_s"]:.0f} s of motion):')
    for kind, cpus in sorted(by_kind.items()):
        print(f'  {kind:8s} {len(cpus):3d} jobs, CPU {sum(cpus) / len(cpus):5.2f} s each on average, '
              f'{max(cpus):5.2f} s the longest')
    total = sum(c for _, c, _ in jobs)
    print(f'  all jobs: {total:.1f} s of CPU for {span:.0f} s of data: {100 * total / span:.2f} % of one core at '
          f'real time; the longest job {max(w for *_, w in jobs):.2f} s of wall time')
    if f is not None:
        print(f'  last finding: {f.kind} at {f.t_ns / 1e9 - summary.first_ns / 1e9:.0f} s, verdict {f.verdict}, '
              f'Z_gb {_mm(f.z_gb.value)} [{_mm(f.z_gb.lo)}..{_mm(f.z_gb.hi)}] mm')

    # the steady state: a window full of motion (two hours of the seed's realistic operation)
    full = sim.run(params, sim.SimConfig(program='realistic:7200'), db, smap, seed=5)
    sig = Decoder(db, smap).decode_arrays(full.frames)
    window_s = params['estimator.window_motion_h'] * 3600.0
    cost = {}
    for kind in ('loop', 'estimate'):
        c0 = time.process_time()
        fa = analyze(gear, sig, window_motion_s=window_s, model=None if kind == 'loop' else ())
        cost[kind] = time.process_time() - c0
    per = (cost['loop'] + cost['estimate'] * (params['estimator.loop_every_motion_s']
                                              / params['estimator.every_motion_s'] - 1))
    print(f'a full window ({fa.window.motion_s:.0f} s of motion, of {full.plant.duration:.0f} s of realistic '
          f'operation): a loop {cost["loop"]:.2f} s of CPU, an estimate {cost["estimate"]:.2f} s; a gear always '
          f'in motion: {100 * per / params["estimator.loop_every_motion_s"]:.2f} % of one core')
    return 0


if __name__ == '__main__':
    sys.exit(main())
