"""Logs ashore: the batch path against the per-frame path, on a one-hour and a 24-hour
simulated log, candump and MCAP.

The logs: the simulated R-18 gear on the NMEA 2000 signal set of the design (rudder 10 Hz,
four pressures 20 Hz each, speed 1 Hz, oil temperature 0.5 Hz: about 91 frames/s), each hour
a 25-minute voyage (manoeuvres, hard-overs, autopilot) then autopilot, its own seed; the
24-hour log is 24 such hours back to back (7.9 million frames). They are made once and kept
under ``BENCH_DIR`` (default ``/tmp/steer_monitor_bench``).

Measured, each case in a fresh process (so its peak resident memory is its own):

* batch path (:func:`steer_monitor.batchpath.review_logs`): read in blocks of columns,
  decode, model, clearance moments, the estimates with intervals over time; frames/s end to
  end, and the part of the time spent estimating (a fixed cost per log, up to 4 + 1
  profiles, whatever its length). Timed ``BATCH_RUNS`` times, the median shown with every
  run's rate: on this machine (two vCPUs shared with other guests) one run in several is
  up to half again slower than the others;
* per-frame path (:func:`steer_monitor.replay.replay`, the node's pipeline: every frame
  through the decoder, live model, online estimator and diagnostics, topics written to
  MCAP): on the whole one-hour log; on the 24-hour log, its first ``PER_FRAME_LIMIT`` frames
  (the per-frame path streams, so its rate and memory do not depend on the log's length; at
  its rate the whole day would take most of an hour).

Run: ``python -m bench.bench_replay`` (part of ``make bench``).
"""

from __future__ import annotations

import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

BENCH_DIR = Path(os.environ.get('BENCH_DIR', '/tmp/steer_monitor_bench'))
HOUR_PROGRAM = 'voyage,autopilot:2100'
PER_FRAME_LIMIT = 1_000_000
TARGET_FPS = 1_000_000
BATCH_RUNS = 3          # the batch path is timed this many times (each in a fresh process); the median is shown


def _make_logs() -> dict[str, Path]:
    """The four logs (made once): {'1h.log', '1h.mcap', '24h.log', '24h.mcap'}."""
    from steer_monitor import sim
    from steer_monitor.can.fastlogs import write_candump_arrays
    from steer_monitor.can.mcapio import McapWriter
    from steer_monitor.can.setup import can_setup
    from steer_monitor.params import load_params_file
    from steer_monitor.resources import default_config

    BENCH_DIR.mkdir(parents=True, exist_ok=True)
    paths = {name: BENCH_DIR / name for name in ('1h.log', '1h.mcap', '24h.log', '24h.mcap')}
    if all(p.exists() for p in paths.values()):
        return paths
    config = default_config()
    params = load_params_file(config)
    db, smap = can_setup(params, config)
    start = 1_767_225_600_000_000_000
    with open(paths['24h.log'], 'wb') as log24, McapWriter(paths['24h.mcap']) as mcap24:
        for hour in range(24):
            cfg = sim.SimConfig(program=HOUR_PROGRAM, max_duration_s=3600.0, start_ns=start + hour * 3_600_000_000_000)
            fa = sim.run(params, cfg, db, smap, seed=100 + hour).frames
            fa = fa.take(fa.t_ns < start + (hour + 1) * 3_600_000_000_000)
            write_candump_arrays(log24, fa)
            frames = fa.frames()
            for i in range(0, len(frames), 8192):
                mcap24.write_frames(frames[i:i + 8192])
            if hour == 0:
                with open(paths['1h.log'], 'wb') as fh:
                    write_candump_arrays(fh, fa)
                with McapWriter(paths['1h.mcap']) as w:
                    for i in range(0, len(frames), 8192):
                        w.write_frames(frames[i:i + 8192])
            print(f'  made hour {hour + 1}/24 of the bench logs', file=sys.stderr, flush=True)
    return paths


def _case(kind: str, path: str) -> dict:
    """One measurement, in this (fresh) process, set up as ``steer-monitor`` sets itself up."""
    from steer_monitor.threads import single_blas_thread
    single_blas_thread()
    t0 = time.perf_counter()
    if kind == 'batch':
        from steer_monitor.batchpath import review_logs
        run = review_logs([path])
        frames, extra = run.frames, {'estimating_s': round(run.review.estimating_s, 2),
                                     'estimates': len(run.review.estimates)}
    else:
        from steer_monitor.can.logs import iter_log
        from steer_monitor.replay import replay
        src = Path(path)
        limited = None
        with tempfile.TemporaryDirectory() as tmp:
            if PER_FRAME_LIMIT and kind == 'per-frame-limited':
                from steer_monitor.can.logs import LogWriter
                limited = Path(tmp) / f'first{src.suffix}'
                with LogWriter(limited) as w:
                    for i, f in enumerate(iter_log(src)):
                        if i >= PER_FRAME_LIMIT:
                            break
                        w.write(f)
                t0 = time.perf_counter()
            summary = replay([limited or src], Path(tmp) / 'out.mcap', frames=False)
        frames, extra = summary.frames, {}
    elapsed = time.perf_counter() - t0
    peak_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    return {'kind': kind, 'log': Path(path).name, 'frames': frames, 'seconds': round(elapsed, 2),
            'frames_per_s': round(frames / elapsed), 'peak_rss_mb': round(peak_mb), **extra}


def _child(*args: str, capture: bool = False) -> str:
    """Run this benchmark with ``args`` in a fresh process; its stdout (when ``capture``)."""
    env = dict(os.environ, ROS_AUTOMATIC_DISCOVERY_RANGE='LOCALHOST')
    root = Path(__file__).resolve().parent.parent
    env['PYTHONPATH'] = os.pathsep.join([str(root / 'steer_monitor'), str(root)]) + os.pathsep + env.get('PYTHONPATH', '')
    return subprocess.run([sys.executable, '-m', 'bench.bench_replay', *args], env=env, cwd=root,
                          capture_output=capture, text=True, check=True).stdout or ''


def _run_case(kind: str, path: Path) -> dict:
    out = _child('--case', kind, str(path), capture=True)
    return json.loads(out.strip().splitlines()[-1])


def main() -> int:
    if len(sys.argv) == 4 and sys.argv[1] == '--case':
        print(json.dumps(_case(sys.argv[2], sys.argv[3])))
        return 0
    if sys.argv[1:] == ['--make-logs']:
        _make_logs()
        return 0
    print('== replay: batch path vs per-frame path (simulated R-18 logs, ~91 frames/s) ==')
    # made in a process of their own: Linux keeps a process's peak memory across fork and exec,
    # so the cases, started from here, would report this process's peak as theirs
    _child('--make-logs')
    paths = _make_logs()
    results = []
    for name in ('1h.log', '1h.mcap', '24h.log', '24h.mcap'):
        runs = sorted((_run_case('batch', paths[name]) for _ in range(BATCH_RUNS)), key=lambda r: r['seconds'])
        batch = runs[len(runs) // 2]
        per_frame = _run_case('per-frame' if name.startswith('1h') else 'per-frame-limited', paths[name])
        ratio = batch['frames_per_s'] / per_frame['frames_per_s']
        results.append((name, batch, per_frame, ratio))
        size_mb = paths[name].stat().st_size / 2 ** 20
        print(f'{name:9s} {batch["frames"]:>9,d} frames ({size_mb:,.0f} MB)')
        print(f'  batch     {batch["frames_per_s"]:>10,d} frames/s  {batch["seconds"]:7.2f} s  '
              f'peak {batch["peak_rss_mb"]:5d} MB  (estimating {batch["estimating_s"]:.2f} s, '
              f'{batch["estimates"]} estimates; without it '
              f'{batch["frames"] / max(batch["seconds"] - batch["estimating_s"], 1e-9):,.0f} frames/s)')
        print(f'            median of {len(runs)} runs; all: '
              + ', '.join(f'{r["frames_per_s"]:,d}' for r in runs[::-1]) + ' frames/s')
        scope = '' if per_frame['frames'] == batch['frames'] else f' (first {per_frame["frames"]:,d} frames)'
        print(f'  per-frame {per_frame["frames_per_s"]:>10,d} frames/s  {per_frame["seconds"]:7.2f} s  '
              f'peak {per_frame["peak_rss_mb"]:5d} MB{scope}')
        print(f'  ratio     {ratio:10.0f} x')
    ok = all(b['frames_per_s'] >= TARGET_FPS for name, b, _, _ in results if name.startswith('24h'))
    print(f'target: batch path >= {TARGET_FPS:,d} frames/s end to end (median of {BATCH_RUNS} runs): '
          + ('met on the 24-hour logs' if ok else 'NOT met on the 24-hour logs'))
    return 0


if __name__ == '__main__':
    sys.exit(main())
