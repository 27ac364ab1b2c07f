"""Where the replay's time goes, on an hour of simulated gear traffic (candump,
about 330,000 frames), with python-can's candump reader on the same file in the same run.

Each part of :func:`steer_monitor.ashore.replay.replay` is timed by wrapping its entry points with
a clock, a timed call made inside another counted in its own part only (the wrappers' own
cost, about a microsecond a call, is counted in the parts):

* decode: ``Decoder.decode_run`` over runs of up to 16,384 frames (``Decoder.decode`` for a
  block's last piece when it is shorter than ``MIN_RUN`` frames);
* live model: ``LiveMonitor.update`` per angle and order sample (rate, the performance
  trackers) where they are taken one by one, ``RunPlan.take_rudder`` where a span of them is
  taken at once (their rates worked out per run, ``SteadyMotion.plan``),
  ``SteadyMotion.take`` (the held pressure samples judged for the residual, where
  they are read), a run's other samples laid out and recorded and the slots' states worked
  out at once (``RunPlan``), ``LiveMonitor.slot_state`` where a slot's state is read one at
  a time (the states' load sharing is left to the packing, below);
* diagnostics: ``DiagnosticsBuilder.build``, once per second of data;
* the analyst: the node's window of samples (``Analyst.add`` per sample, the compaction and
  the schedule in ``Analyst.due`` each second);
* analyses: the jobs (``SyncJobs.submit``: ``analyze`` of the window on the node's schedule),
  run at once when due, as a replay runs them;
* messages: the states' load sharing solved and the states packed into MCAP records, a
  batch of up to 16,384 frames' states at once, diagnostics into message fields, CDR and
  records packed among the states', and writing them (with the frames) to the MCAP;
* reading: the log read into blocks of frames (``iter_log_blocks``, each block's time);
* the schedule (the rest): the pipeline's loop over runs, spans and seconds, by difference.

Reading and decoding are the first two; the per-sample pipeline the live model, the
diagnostics, the analyst and the schedule. :func:`measure_split` is the measurement,
:mod:`bench.bench_replay` runs it on its candump logs.

The machine's speed wanders by a third over tens of seconds, so the front end is compared
with python-can's reader in rounds, the reader's pass and a replay back to back, three of
them, after an untimed replay; each round's ratio is printed and the median taken. In those replays only the messages
and the analyses are clocked (the front end is the rest); the parts above come from one more
replay with every part clocked, whose clocks (about a microsecond a call, some 40,000 calls an
hour in the front end) are counted in the parts.

A second replay of the same log is timed in the same run and the two files checked to be the
same bytes (that they are the bytes of the per-frame reference is the tests' to hold). One
BLAS thread, as the command line sets it.

Run: ``python -m bench.bench_replay_parts`` (part of ``make bench``).
"""

from __future__ import annotations

import functools
import os
import sys
import tempfile
import time
from collections import defaultdict
from pathlib import Path

HOUR_PROGRAM = 'voyage,autopilot:2100'
ROUNDS = 3      # the reader and the timed replay back to back, this many times


def _make_log(path: Path) -> int:
    from steer_monitor import sim
    from steer_monitor.can.busconfig import can_setup
    from steer_monitor.logfiles.logs import write_candump
    from steer_monitor.params import load_params_file
    from steer_monitor.resources import default_config

    config = default_config()
    params = load_params_file(config)
    db, smap = can_setup(params, config)
    fa = sim.run(params, sim.SimConfig(program=HOUR_PROGRAM), db, smap, seed=100).frames
    with open(path, 'wb') as fh:
        write_candump(fh, fa)
    return len(fa)


_inner: list[float] = []     # per timed call under way: the time its timed calls took


def _timed(spent: dict[str, float], part: str, fn):
    """``fn`` with its time added to ``part``, less that of the timed calls it makes (each
    counted in its own part: the diagnostics judge the residual's instants when they read them)."""
    clock = time.perf_counter

    @functools.wraps(fn)
    def wrapper(*a, **k):
        _inner.append(0.0)
        t0 = clock()
        try:
            return fn(*a, **k)
        finally:
            dt = clock() - t0
            spent[part] += dt - _inner.pop()
            if _inner:
                _inner[-1] += dt
    return wrapper


_ORIGINALS: dict[tuple[object, str], object] = {}


def _timed_blocks(spent: dict[str, float], part: str, fn):
    """The generator ``fn`` with the time each of its items takes to come added to ``part``."""
    step = _timed(spent, part, next)       # each item's coming, accounted as a timed call

    @functools.wraps(fn)
    def wrapper(*a, **k):
        it = fn(*a, **k)
        while True:
            try:
                item = step(it)
            except StopIteration:
                return
            yield item
    return wrapper


def _clock(spent: dict[str, float], part: str, owner: object, name: str) -> None:
    """``owner.name`` timed into ``part`` (wrapping the original, however often asked)."""
    fn = _ORIGINALS.setdefault((owner, name), getattr(owner, name))
    setattr(owner, name, _timed(spent, part, fn))


def _instrument(spent: dict[str, float], fine: bool) -> None:
    """Clocks on the messages and the analyses; with ``fine`` on each part of the front end too
    (each clock costs about a microsecond a call, so the front end's total is measured without
    them, its parts with them)."""
    import steer_monitor.ashore.replay as R
    from steer_monitor.can.decoder import Decoder
    from steer_monitor.logfiles.mcapio import McapWriter
    from steer_monitor.monitor.analyst import Analyst, SyncJobs
    from steer_monitor.monitor.diagnostics import DiagnosticsBuilder
    from steer_monitor.monitor.live import LiveMonitor
    from steer_monitor.monitor.runfeed import RunPlan
    from steer_monitor.monitor.steady import SteadyMotion

    _clock(spent, 'analyses', SyncJobs, 'submit')
    for name in ('write_cdr', 'write', 'write_frames', 'write_records'):
        _clock(spent, 'messages', McapWriter, name)
    _clock(spent, 'messages', R, 'write_outputs')     # a batch of outputs packed and written
    if not fine:
        return
    fn = _ORIGINALS.setdefault((R, 'iter_log_blocks'), R.iter_log_blocks)
    R.iter_log_blocks = _timed_blocks(spent, 'reading', fn)
    _clock(spent, 'decode', Decoder, 'decode')
    _clock(spent, 'decode', Decoder, 'decode_run')
    for name in ('update', 'slot_state'):
        _clock(spent, 'live model', LiveMonitor, name)
    for name in ('plan', 'take'):
        _clock(spent, 'live model', SteadyMotion, name)
    for name in ('__init__', 'sync', 'before_sequential', 'take_rudder', 'skip', 'state_before', 'states'):
        _clock(spent, 'live model', RunPlan, name)
    _clock(spent, 'diagnostics', DiagnosticsBuilder, 'build')
    _clock(spent, 'analyst (window, schedule)', Analyst, 'add')
    _clock(spent, 'analyst (window, schedule)', Analyst, 'due')


#: the front end's parts (the fully clocked replay), as reading and decoding and as the per-sample pipeline
READING_AND_DECODING = ('reading', 'decode')
PIPELINE = ('live model', 'diagnostics', 'analyst (window, schedule)', 'schedule (rest)')


def measure_split(log: Path, out_dir: Path, rounds: int = ROUNDS) -> dict:
    """Replay's time on the candump ``log`` split: ``rounds`` rounds of python-can's reader
    then a replay with the messages and the analyses clocked (the front end, reading, decoding
    and the per-sample pipeline, is the rest), and one more replay with every part clocked
    (its parts: ``reading``, ``decode``, ``live model``, ``diagnostics``, ``analyst (window,
    schedule)``, ``messages``, ``analyses`` and the rest, ``schedule (rest)``), all after one
    untimed replay (a fresh process loads its compiled kernels in the first). Replays write
    into ``out_dir``. Returns {'frames', 'rounds': [{'reader_s', 'replay_s', 'front_s',
    'messages_s', 'analyses_s', 'ratio'}], 'median': the round of the median ratio, 'parts',
    'timed_s', 'summary': the last replay's}. Patches the replay's classes with clocks: run
    it in a process of its own, after any unclocked replay."""
    import can

    from steer_monitor.ashore.replay import replay

    replay([log], out_dir / 'warm.mcap')     # untimed: the compiled kernels loaded, the file read once
    spent: dict[str, float] = defaultdict(float)
    _instrument(spent, fine=False)
    rows = []
    n = 0
    for _ in range(rounds):    # each round: the reader, then the replay, back to back
        t0 = time.perf_counter()
        n = sum(1 for _ in can.CanutilsLogReader(str(log)))
        t_reader = time.perf_counter() - t0
        spent.clear()
        t0 = time.perf_counter()
        replay([log], out_dir / 'timed.mcap')
        t_round = time.perf_counter() - t0
        analyses, messages = spent.get('analyses', 0.0), spent.get('messages', 0.0)
        front = t_round - analyses - messages
        rows.append({'reader_s': t_reader, 'replay_s': t_round, 'front_s': front, 'messages_s': messages,
                     'analyses_s': analyses, 'ratio': t_reader / front})
    _instrument(spent, fine=True)
    spent.clear()
    t0 = time.perf_counter()
    summary = replay([log], out_dir / 'timed.mcap')
    t_timed = time.perf_counter() - t0
    parts = dict(spent)
    parts['schedule (rest)'] = t_timed - sum(spent.values())
    return {'frames': n, 'rounds': rows, 'median': sorted(rows, key=lambda r: r['ratio'])[len(rows) // 2],
            'parts': parts, 'timed_s': t_timed, 'summary': summary}


def split_lines(m: dict) -> list[str]:
    """What :func:`measure_split` measured, as lines to print."""
    n, parts, t_timed = m['frames'], m['parts'], m['timed_s']
    lines = [f'replay with every part clocked: {n / t_timed:12,.0f} frames/s ({t_timed:.2f} s)']
    for part, sec in sorted(parts.items(), key=lambda kv: -kv[1]):
        lines.append(f'  {part:28s} {sec:7.2f} s  {100 * sec / t_timed:5.1f} %  ({1e6 * sec / n:6.1f} us per frame)')
    fine_front = t_timed - parts.get('analyses', 0.0) - parts.get('messages', 0.0)
    rd, pl = sum(parts.get(p, 0.0) for p in READING_AND_DECODING), sum(parts.get(p, 0.0) for p in PIPELINE)
    lines.append(f'  the front end {fine_front:.2f} s with its parts clocked, the clocks included: reading and '
                 f'decoding {rd:.2f} s, the per-sample pipeline {pl:.2f} s')
    for k, r in enumerate(m['rounds']):
        lines.append(f"round {k + 1}: python-can's reader {r['reader_s']:.2f} s, then the replay {r['replay_s']:.2f} s "
                     f"(messages {r['messages_s']:.2f} s and analyses {r['analyses_s']:.2f} s clocked): its front end "
                     f"{r['front_s']:.2f} s, {r['ratio']:.2f} x the reader")
    r = m['median']
    s = m['summary']
    lines.append(f"reading, decoding and the per-sample pipeline (the median round): {r['front_s']:.2f} s, "
                 f"{n / r['front_s']:,.0f} frames/s, {r['ratio']:.2f} x python-can's reader (target >= 1: "
                 f"{'met' if r['ratio'] >= 1 else 'NOT met'}); analyses {parts.get('analyses', 0.0):.2f} s of CPU "
                 f'({parts.get("analyses", 0.0) / max(s.analyses, 1):.2f} s each)')
    return lines


def main() -> int:
    os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')
    from steer_monitor.runtime import single_blas_thread
    single_blas_thread()
    import can

    from steer_monitor.ashore.replay import replay

    print('== replay: where the time goes (an hour of simulated gear traffic, candump) ==')
    with tempfile.TemporaryDirectory() as tmp:
        log = Path(tmp) / 'hour.log'
        n = _make_log(log)
        t0 = time.perf_counter()
        k = sum(1 for _ in can.CanutilsLogReader(str(log)))
        t_can = time.perf_counter() - t0
        assert k == n, (k, n)
        t0 = time.perf_counter()
        s = replay([log], Path(tmp) / 'plain.mcap')
        t_plain = time.perf_counter() - t0
        t0 = time.perf_counter()
        replay([log], Path(tmp) / 'again.mcap')
        t_again = time.perf_counter() - t0
        same = (Path(tmp) / 'plain.mcap').read_bytes() == (Path(tmp) / 'again.mcap').read_bytes()
        m = measure_split(log, Path(tmp))
    span_s = (s.last_ns - s.first_ns) / 1e9 if s.first_ns is not None and s.last_ns is not None else 0.0
    print(f'log: {n:,d} frames, {span_s:,.0f} s of data; {s.states:,d} states, {s.diagnostics:,d} diagnostics, '
          f'{s.motion_s:,.0f} s of rudder motion, {s.analyses} analyses')
    print(f'python-can CanutilsLogReader: {n / t_can:12,.0f} frames/s ({t_can:.2f} s)')
    print(f'replay:                       {n / t_plain:12,.0f} frames/s ({t_plain:.2f} s; '
          f'{n / t_plain / (n / t_can):.3f} x python-can)')
    print(f'replay again:                 {n / t_again:12,.0f} frames/s ({t_again:.2f} s; '
          f'{"the same bytes" if same else "FILES DIFFER"})')
    for line in split_lines(m):
        print(line)
    return 0 if same else 1


if __name__ == '__main__':
    sys.exit(main())
