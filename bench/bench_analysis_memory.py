"""The node's resident memory after each of its analyses, on its worker thread.

A 25-minute realistic voyage (seed 21) decoded once; the node's own jobs (``run_job``, a loop
then an estimate under the loop's model) on windows of 20, 30, 45, 60, 80 and 100 % of it,
then four loops on the whole, each on one worker thread as the node runs them, followed by
what the node does after each (``release_freed_memory``: the cycle collector, then
``malloc_trim``). Prints the process's resident memory after each job and the number of
signatures numba has compiled for the load-sharing solver (a growing count would be
compilation on new array types). Target: flat once the first loops are in (the node's memory
must not grow with its window's analyses).

Run: ``python -m bench.bench_analysis_memory`` (part of ``make bench``).
"""

from __future__ import annotations

import os
import sys
from concurrent.futures import ThreadPoolExecutor

from bench.bench_node import rss_mb

VOYAGE_S = 1500.0
FRACTIONS = (0.2, 0.3, 0.45, 0.6, 0.8, 1.0)
REPEATS = 4


def _signatures() -> int:
    import numba

    from steer_monitor.model import loadshare
    return sum(len(v.signatures) for v in vars(loadshare).values() if isinstance(v, numba.core.registry.CPUDispatcher))


def main() -> int:
    os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')
    from steer_monitor import sim
    from steer_monitor.can.busconfig import load_setup
    from steer_monitor.can.decoder import Decoder
    from steer_monitor.model.inputs import Series
    from steer_monitor.monitor.analyst import ANALYSED, AnalystSettings, Job, run_job
    from steer_monitor.params import gear_from_params
    from steer_monitor.runtime import release_freed_memory

    _, params, db, smap = load_setup(None)
    gear = gear_from_params(params)
    frames = sim.run(params, sim.SimConfig(program='realistic', max_duration_s=VOYAGE_S), db, smap, 21).frames
    signals = {k: v for k, v in Decoder(db, smap).decode_arrays(frames, final=True).items() if k in ANALYSED}
    del frames
    release_freed_memory()
    t0 = min(int(s.t_ns[0]) for s in signals.values() if len(s))
    t1 = max(int(s.t_ns[-1]) for s in signals.values() if len(s))
    print(f'== the node\'s analyses on a worker thread: resident memory after each ({VOYAGE_S / 60:.0f}-minute '
          f'realistic voyage) ==\nbefore the first: {rss_mb():.0f} MB')
    settings = AnalystSettings()
    model: tuple = ()
    after: list[float] = []
    with ThreadPoolExecutor(1, thread_name_prefix='steer_monitor-analysis') as pool:
        def job(t: int, kind: str, seq: int) -> None:
            nonlocal model
            cut = {k: Series(v.t_ns[v.t_ns < t], v.value[v.t_ns < t]) for k, v in signals.items()}

            def work():
                out = run_job(gear, settings, Job(seq, t, kind, cut), model)
                release_freed_memory()
                return out
            outcome = pool.submit(work).result()
            if kind == 'loop':
                model = outcome.model
            after.append(rss_mb())
            print(f'{kind:8s} of {(t - t0) / 1e9:5.0f} s of data: {after[-1]:6.1f} MB, numba signatures '
                  f'{_signatures()}, {"a finding" if outcome.finding else outcome.why}', flush=True)

        seq = 0
        for fraction in FRACTIONS:
            for kind in ('loop', 'estimate'):
                seq += 1
                job(t0 + int((t1 - t0) * fraction), kind, seq)
        for _ in range(REPEATS):
            seq += 1
            job(t1, 'loop', seq)
    late = after[len(after) // 2:]
    print(f'after each job: {min(after):.0f}-{max(after):.0f} MB; the second half of the jobs '
          f'{min(late):.0f}-{max(late):.0f} MB (target: flat)')
    return 0


if __name__ == '__main__':
    sys.exit(main())
