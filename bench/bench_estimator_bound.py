"""What the node's online estimator asks of a replay, against issue 19's target.

A replay gives the node's exact answers only if it runs the node's estimator jobs: a fold
of each second of data, a local step of the clearance profile (the 3 x 3 grid points around
the best, each profiled over every angle-and-speed cell of the moments) after each second
of motion, and the full profiles. Each job starts from the last one's point, so they run in
sequence. This benchmark replays an hour of simulated gear traffic (the ``bench_replay``
hour, seed 100) with the jobs in-process and counts, per kind of job, the calls, their time
and the load-sharing states they solve (every call of the solver the fits use is counted).
It then times that solver alone on a local step's states (the moments' cells x 9 pairs, in
one call) and prints what the load sharing alone costs for the hour, in the same run, beside
the time a replay at 1,000,000 frames/s would have for the whole hour.

Run: ``python -m bench.bench_estimator_bound`` (part of ``make bench``).
"""

from __future__ import annotations

import functools
import os
import sys
import tempfile
import time
from collections import defaultdict
from pathlib import Path

TARGET_FPS = 1_000_000


def main() -> int:
    os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')
    from steer_monitor.threads import single_blas_thread
    single_blas_thread()
    import numpy as np

    from bench.bench_replay_parts import _make_log
    from steer_monitor.ashore.replay import replay
    from steer_monitor.estimate import fit as F
    from steer_monitor.estimate import online as O
    from steer_monitor.params import gear_from_params, load_params_file
    from steer_monitor.resources import default_config

    spent: dict[str, float] = defaultdict(float)
    calls: dict[str, int] = defaultdict(int)
    states: dict[str, int] = defaultdict(int)
    cells: list[int] = []
    current = ['other']
    solver = F.load_sharing

    @functools.wraps(solver)
    def counted(gear, abs_alpha, torque, two_z, z_gb, *a, **k):
        states[current[0]] += int(np.broadcast(abs_alpha, torque, two_z, z_gb).size)
        return solver(gear, abs_alpha, torque, two_z, z_gb, *a, **k)

    def timed(kind_of, fn):
        @functools.wraps(fn)
        def wrapper(self, *a, **k):
            kind = kind_of(self)
            outer, current[0] = current[0], kind
            t0 = time.perf_counter()
            try:
                return fn(self, *a, **k)
            finally:
                spent[kind] += time.perf_counter() - t0
                calls[kind] += 1
                current[0] = outer
                if kind == 'local step':
                    cells.append(len(self.moments))
        return wrapper

    F.load_sharing = counted
    full = O.OnlineEstimator._full
    O.OnlineEstimator._fold = timed(lambda self: 'fold', O.OnlineEstimator._fold)
    O.OnlineEstimator._full = timed(lambda self: 'full profile', full)
    O.OnlineEstimator.refit = timed(lambda self: 'local step', O.OnlineEstimator.refit)

    print('== the online estimator on the node\'s schedule, against 1,000,000 frames/s (an hour, candump) ==')
    with tempfile.TemporaryDirectory() as tmp:
        log = Path(tmp) / 'hour.log'
        n = _make_log(log)
        t0 = time.perf_counter()
        s = replay([log], Path(tmp) / 'out.mcap', worker=False)
        t_replay = time.perf_counter() - t0
    # a refit that turned into a full profile was timed as both: its profile counts as a profile
    # (the solver's states are counted under the innermost job already)
    spent['local step'] -= spent['full profile']
    budget = n / TARGET_FPS
    print(f'log: {n:,d} frames, {s.motion_s:,.0f} s of rudder motion learned; replay with the jobs in-process '
          f'{t_replay:.2f} s; at {TARGET_FPS:,d} frames/s the whole hour has {budget:.3f} s')
    for kind in ('fold', 'local step', 'full profile'):
        k = calls[kind] - (calls['full profile'] if kind == 'local step' else 0)
        print(f'  {kind:13s} {k:6,d} calls {spent[kind]:7.3f} s ({1e3 * spent[kind] / max(k, 1):7.3f} ms each), '
              f'{states[kind]:12,d} load-sharing states')
    total_states = sum(states.values())
    jobs = spent['fold'] + spent['local step'] + spent['full profile']
    print(f'  the jobs: {jobs:.2f} s in sequence = {jobs / budget:.1f} x the whole hour\'s time at the target; '
          f'{total_states:,d} load-sharing states')

    gear = gear_from_params(load_params_file(default_config()))
    m = int(np.median(cells)) if cells else 1
    rng = np.random.default_rng(1)
    abs_alpha = rng.uniform(0.01, 0.6, m)[:, None]
    torque = rng.uniform(1e5, 1e6, m)[:, None]
    two_z, z_gb = (g.ravel()[None, :] for g in np.meshgrid(F.GRID_2Z[10:13], F.GRID_ZGB[10:13]))
    best = float('inf')
    for _ in range(5):
        t0 = time.perf_counter()
        for _ in range(50):
            solver(gear, abs_alpha, torque, two_z, z_gb)
        best = min(best, (time.perf_counter() - t0) / 50)
    rate = m * 9 / best
    print(f'the solver alone: {m:,d} cells x 9 pairs in {1e3 * best:.2f} ms ({rate / 1e6:.2f} M states/s, best of 5); '
          f'the hour\'s {total_states:,d} states at that rate: {total_states / rate:.2f} s = '
          f'{total_states / rate / budget:.1f} x the time the target gives the whole replay')
    return 0


if __name__ == '__main__':
    sys.exit(main())
