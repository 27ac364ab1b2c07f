"""Logs ashore: the batch path and replay against a plain reader, on a one-hour and a 24-hour
simulated log, candump and MCAP.

The logs: the simulated R-18 gear on the NMEA 2000 signal set of the design (rudder 10 Hz,
four pressures 20 Hz each, speed 1 Hz, oil temperature 0.5 Hz: about 91 frames/s), each hour
a 25-minute voyage (manoeuvres, hard-overs, autopilot) then autopilot, its own seed; the
24-hour log is 24 such hours back to back (7.9 million frames). They are made once and kept
under ``BENCH_DIR`` (default ``/tmp/steer_monitor_bench``).

Measured, each case in a fresh process (so its peak resident memory is its own):

* batch path (:func:`steer_monitor.ashore.reviewlogs.review_logs`): read in blocks of columns,
  decode, model, clearance moments, the estimates with intervals over time; frames/s end to
  end, and the part of the time spent estimating (a fixed cost per log, up to 4 + 1
  profiles, whatever its length). Timed ``BATCH_RUNS`` times, the median shown with every
  run's rate: on this machine (two vCPUs shared with other guests) one run in several is
  up to half again slower than the others;
* ``replay`` (:func:`steer_monitor.ashore.replay.replay`, the node's pipeline: the decoder, live
  model, diagnostics and the node's analyses on its schedule, topics written to MCAP, frames
  left out) and a plain reader of the same file (python-can's ``CanutilsLogReader`` for
  candump; for MCAP, the mcap library's reader with mcap-ros2's decoder, every frame message
  decoded, python-can having no MCAP reader): on the whole one-hour log; on the 24-hour log,
  its first ``PER_FRAME_LIMIT`` frames (a file of its own, made with the logs: replay streams,
  so its rate and memory do not depend on the log's length). That replay writes the file the
  per-frame reference writes is the tests' to hold (``test/ashore/test_replay.py``).

In the same run: on the candump logs, replay's time split (in a process of
its own, :func:`bench.bench_replay_parts.measure_split`: three rounds of python-can's reader then a
replay with its messages and analyses clocked, back to back, the median round's ratio; and one
replay with every part clocked: reading and decoding, the per-sample pipeline, messages,
analyses); every replay made twice, in two processes, and the two files compared byte for byte;
and, with ``--baseline COMMIT``, the whole replay
(``frames=False``, as above) against that commit's (taken from git into ``BENCH_DIR``, its
compiled kernels warmed by one replay first), on the hour log and the first
``PER_FRAME_LIMIT`` frames: a before and after in one run.

Run: ``python -m bench.bench_replay [--baseline COMMIT]`` (part of ``make bench``, without one).
"""

from __future__ import annotations

import hashlib
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
PER_FRAME_LIMIT = 1_000_000     # frames of the 24-hour logs replayed
TARGET_FPS = 1_000_000
BATCH_RUNS = 3          # the batch path is timed this many times (each in a fresh process); the median is shown


def _make_logs() -> dict[str, Path]:
    """The logs (made once): {'1h.log', '1h.mcap', '24h.log', '24h.mcap'} and the first
    ``PER_FRAME_LIMIT`` frames of the last two, '24h-first.log' and '24h-first.mcap'."""
    from steer_monitor import sim
    from steer_monitor.can.busconfig import can_setup
    from steer_monitor.logfiles.logs import write_candump
    from steer_monitor.logfiles.mcapio import McapWriter
    from steer_monitor.params import load_params_file
    from steer_monitor.resources import default_config

    BENCH_DIR.mkdir(parents=True, exist_ok=True)
    paths = {name: BENCH_DIR / name for name in ('1h.log', '1h.mcap', '24h.log', '24h.mcap',
                                                  '24h-first.log', '24h-first.mcap')}
    if all(p.exists() for p in paths.values()):
        return paths
    if all(paths[n].exists() for n in ('1h.log', '1h.mcap', '24h.log', '24h.mcap')):
        _first_frames(paths)
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
            write_candump(log24, fa)
            frames = fa.frames()
            for i in range(0, len(frames), 8192):
                mcap24.write_frames(frames[i:i + 8192])
            if hour == 0:
                with open(paths['1h.log'], 'wb') as fh:
                    write_candump(fh, fa)
                with McapWriter(paths['1h.mcap']) as w:
                    for i in range(0, len(frames), 8192):
                        w.write_frames(frames[i:i + 8192])
            print(f'  made hour {hour + 1}/24 of the bench logs', file=sys.stderr, flush=True)
    _first_frames(paths)
    return paths


def _first_frames(paths: dict[str, Path]) -> None:
    """The first ``PER_FRAME_LIMIT`` frames of the 24-hour logs, as files of their own."""
    from steer_monitor.logfiles.blocks import iter_log
    from steer_monitor.logfiles.logs import LogWriter
    for name in ('24h.log', '24h.mcap'):
        src, dst = paths[name], paths[name.replace('24h', '24h-first')]
        if dst.exists():
            continue
        tmp = dst.with_name('partial-' + dst.name)
        with LogWriter(tmp) as w:
            for i, f in enumerate(iter_log(src)):
                if i >= PER_FRAME_LIMIT:
                    break
                w.write(f)
        tmp.replace(dst)


def _case(kind: str, path: str) -> dict:
    """One measurement, in this (fresh) process, set up as ``steer-monitor`` sets itself up."""
    from steer_monitor.runtime import single_blas_thread
    single_blas_thread()
    t0 = time.perf_counter()
    if kind == 'batch':
        from steer_monitor.ashore.reviewlogs import review_logs
        run = review_logs([path])
        frames, extra = run.frames, {'estimating_s': round(run.review.estimating_s, 2),
                                     'estimates': len(run.review.estimates)}
    elif kind == 'reader':
        if path.endswith('.mcap'):
            from mcap.reader import make_reader
            from mcap_ros2.decoder import DecoderFactory

            from steer_monitor.logfiles.mcapio import FRAME_DATATYPE
            with open(path, 'rb') as fh:
                reader = make_reader(fh, decoder_factories=[DecoderFactory()])
                frames = sum(1 for schema, _, _, _ in reader.iter_decoded_messages(log_time_order=False)
                             if schema is not None and schema.name == FRAME_DATATYPE)
        else:
            import can
            frames = sum(1 for _ in can.CanutilsLogReader(path))
        extra = {}
    elif kind == 'split':
        from bench.bench_replay_parts import measure_split, split_lines
        with tempfile.TemporaryDirectory() as tmp:
            m = measure_split(Path(path), Path(tmp))
        frames = m['frames']
        extra = {'lines': split_lines(m), 'ratio': m['median']['ratio']}
    else:
        from steer_monitor.ashore.replay import replay
        with tempfile.TemporaryDirectory() as tmp:
            summary = replay([path], Path(tmp) / 'out.mcap', frames=False)
            elapsed = time.perf_counter() - t0        # the file's hash not counted
            digest = hashlib.sha256((Path(tmp) / 'out.mcap').read_bytes()).hexdigest()
        frames, extra = summary.frames, {'sha256': digest, 'elapsed': elapsed}
    elapsed = extra.pop('elapsed', time.perf_counter() - t0)
    peak_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    return {'kind': kind, 'log': Path(path).name, 'frames': frames, 'seconds': round(elapsed, 2),
            'frames_per_s': round(frames / elapsed), 'peak_rss_mb': round(peak_mb),
            **extra}


def _child(*args: str, capture: bool = False) -> str:
    """Run this benchmark with ``args`` in a fresh process; its stdout (when ``capture``)."""
    env = dict(os.environ, ROS_AUTOMATIC_DISCOVERY_RANGE='LOCALHOST')
    root = Path(__file__).resolve().parent.parent
    return subprocess.run([sys.executable, '-m', 'bench.bench_replay', *args], env=env, cwd=root,
                          capture_output=capture, text=True, check=True).stdout or ''


def _run_case(kind: str, path: Path) -> dict:
    out = _child('--case', kind, str(path), capture=True)
    return json.loads(out.strip().splitlines()[-1])


_BASELINE_CASE = """
import json, sys, tempfile, time
from pathlib import Path
from steer_monitor.runtime import single_blas_thread
single_blas_thread()
from steer_monitor.ashore.replay import replay
t0 = time.perf_counter()
with tempfile.TemporaryDirectory() as tmp:
    s = replay([sys.argv[1]], Path(tmp) / 'out.mcap', frames=False)
print(json.dumps({'frames': s.frames, 'seconds': round(time.perf_counter() - t0, 2)}))
"""


def _baseline_tree(baseline: str) -> Path | None:
    """The sources at commit ``baseline``, from git, under ``BENCH_DIR`` (made once); None
    where git or the commit is not there."""
    root = Path(__file__).resolve().parent.parent
    tree = BENCH_DIR / f'baseline-{baseline}'
    if (tree / 'steer_monitor').is_dir():
        return tree
    tmp = BENCH_DIR / f'partial-baseline-{baseline}'
    try:
        subprocess.run(['rm', '-rf', str(tmp)], check=True)
        tmp.mkdir(parents=True)
        archive = subprocess.run(['git', '-C', str(root), 'archive', baseline], capture_output=True, check=True).stdout
        subprocess.run(['tar', '-x', '-C', str(tmp)], input=archive, check=True)
    except (OSError, subprocess.CalledProcessError):
        return None
    tmp.replace(tree)
    return tree


def _baseline_replay(tree: Path, path: Path) -> dict:
    """The whole replay (frames=False) of ``path`` by the sources in ``tree``, in a fresh
    process, after one untimed replay there (its compiled kernels cached)."""
    env = dict(os.environ, ROS_AUTOMATIC_DISCOVERY_RANGE='LOCALHOST', PYTHONPATH=str(tree))
    out = ''
    for _ in range(2):
        out = subprocess.run([sys.executable, '-c', _BASELINE_CASE, str(path)], env=env, cwd=tree,
                             capture_output=True, text=True, check=True).stdout
    return json.loads(out.strip().splitlines()[-1])


def main() -> int:
    if len(sys.argv) == 4 and sys.argv[1] == '--case':
        print(json.dumps(_case(sys.argv[2], sys.argv[3])))
        return 0
    if sys.argv[1:] == ['--make-logs']:
        _make_logs()
        return 0
    baseline = sys.argv[2] if len(sys.argv) == 3 and sys.argv[1] == '--baseline' else None
    print('== logs ashore: batch path, replay and a plain reader (simulated R-18 logs, ~91 frames/s) ==')
    # made in a process of their own: Linux keeps a process's peak memory across fork and exec,
    # so the cases, started from here, would report this process's peak as theirs
    _child('--make-logs')
    paths = _make_logs()
    results = []
    fronts: list[tuple[str, float]] = []          # (log, the median round's front end / reader)
    against: list[tuple[str, float, float]] = []  # (log, baseline s, replay s)
    same_bytes: list[tuple[str, bool]] = []        # (log, two runs identical)
    tree = _baseline_tree(baseline) if baseline is not None else None
    for name in ('1h.log', '1h.mcap', '24h.log', '24h.mcap'):
        runs = sorted((_run_case('batch', paths[name]) for _ in range(BATCH_RUNS)), key=lambda r: r['seconds'])
        batch = runs[len(runs) // 2]
        same = paths[name.replace('24h', '24h-first')]        # what replay and the reader read
        reader, fast, again = (_run_case(kind, same) for kind in ('reader', 'replay', 'replay'))
        results.append((name, batch, fast))
        size_mb = paths[name].stat().st_size / 2 ** 20
        print(f'{name:9s} {batch["frames"]:>9,d} frames ({size_mb:,.0f} MB)')
        print(f'  batch     {batch["frames_per_s"]:>10,d} frames/s  {batch["seconds"]:7.2f} s  '
              f'peak {batch["peak_rss_mb"]:5d} MB  (estimating {batch["estimating_s"]:.2f} s, '
              f'{batch["estimates"]} estimates; without it '
              f'{batch["frames"] / max(batch["seconds"] - batch["estimating_s"], 1e-9):,.0f} frames/s)')
        print(f'            median of {len(runs)} runs; all: '
              + ', '.join(f'{r["frames_per_s"]:,d}' for r in runs[::-1]) + ' frames/s')
        scope = '' if fast['frames'] == batch['frames'] else f'  (first {fast["frames"]:,d} frames)'
        for label, r in (('reader', reader), ('replay', fast), ('again', again)):
            print(f'  {label:9s} {r["frames_per_s"]:>10,d} frames/s  {r["seconds"]:7.2f} s  '
                  f'peak {r["peak_rss_mb"]:5d} MB{scope}')
        print(f'  replay: {fast["frames_per_s"] / reader["frames_per_s"]:.3f} x the reader; '
              f'batch {batch["frames_per_s"] / fast["frames_per_s"]:.0f} x replay')
        twice = fast['sha256'] == again['sha256']
        same_bytes.append((name, twice))
        print(f'  the two replays\' files {"identical" if twice else "DIFFER"}')
        if name.endswith('.log'):
            split = _run_case('split', same)
            fronts.append((name, split['ratio']))
            print('  split, in a process of its own:')
            for line in split['lines']:
                print('    ' + line)
            if tree is not None:
                base = _baseline_replay(tree, same)
                against.append((name, base['seconds'], min(fast['seconds'], again['seconds'])))
                print(f'  the baseline ({baseline}): {base["seconds"]:.2f} s for the same frames; this '
                      f'replay {fast["seconds"]:.2f} and {again["seconds"]:.2f} s')
    ok = all(b['frames_per_s'] >= TARGET_FPS for name, b, _ in results if name.startswith('24h'))
    print(f'target: batch path >= {TARGET_FPS:,d} frames/s end to end (median of {BATCH_RUNS} runs): '
          + ('met on the 24-hour logs' if ok else 'NOT met on the 24-hour logs'))
    print('reading, decoding and the per-sample pipeline >= python-can\'s reader (the median of three '
          'rounds): ' + '; '.join(f'{n} {r:.2f} x ({"met" if r >= 1 else "NOT met"})' for n, r in fronts))
    if baseline is not None and tree is None:
        print(f'the whole replay no slower than at {baseline}: not measured (git or the commit not here)')
    elif baseline is not None:
        print(f'the whole replay no slower than at {baseline}: '
              + '; '.join(f'{n} {now:.2f} s against {base:.2f} s ({"met" if now <= base else "NOT met"})'
                          for n, base, now in against))
    print('the same bytes between two runs: '
          + ('yes, on every log' if all(t for _, t in same_bytes) else
             'NO: ' + ', '.join(n for n, t in same_bytes if not t)))
    return 0


if __name__ == '__main__':
    sys.exit(main())
