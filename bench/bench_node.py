"""The node fed at the full NMEA 2000 rate (1,908 frames/s) from the simulator for 60 s.

Simulator and node share one process (python-can's virtual bus lives in one process); the
node runs its executor, reader, estimator and recorder threads as in service. Two ways to
fill the bus, both printed:

* ``bus`` (what a vessel's bus is like): the simulated gear in real time (its ~92 frames/s of
  rudder, pressures, speed and temperature) among other traffic (engine, navigation and
  heading PGNs the monitor does not use) up to 1,908 frames/s. Every frame is received,
  recorded and looked at; the steering ones drive the model.
* ``speedup`` (a stress test): the simulated gear alone, its clock sped up ~21 times so that
  its own frames reach 1,908 frames/s: a rudder that moves 21 times faster, so the model and
  the node's analyses do 21 times the work of any real gear;
* ``voyage``: a realistic voyage (``realistic:S``, manoeuvres, hard-overs, autopilot) in real
  time among the other traffic as in ``bus``, for ``VOYAGE_SECONDS`` (10 minutes), its
  analyses included: the first after ``VOYAGE_FIRST_MOTION_S`` (60 s) of steady motion
  instead of the configured 240 s, so that a 10-minute run holds the loops at 60, 120 and 240 s
  of motion and the estimates between (more analyses per hour than at sea: an upper bound).
  A voyage sped up to fill the bus (as ``speedup``) runs none: its rudder moves 21 times
  faster than any gear's, never steadily. The run waits for the analyses started to finish,
  and the CPU is averaged over all of it.

Measured:
frames dropped, CPU of the node (process CPU minus the simulator thread's, so it includes
the DDS threads; also per 10 s and per thread), p99 latency from the frame's bus timestamp
(when the virtual bus took it; the kernel's receive time on socketcan) to the published
state, so the time a frame waits in the receive queue counts, resident memory at start and
end and every 10 s, and what the frames to play held when they were made (the simulated voyage
and the other traffic, measured before the node starts, in the same process: the node's own
memory is the process's less that).
Targets: 0 dropped, < 25 % of a core, p99 < 20 ms, < 250 MB and no growth.

With ``--parts``, where the reader thread's CPU goes: its calls clocked on the thread's own
CPU clock (``time.thread_time``; a call inside another counted in its own part only; the clocks
cost about a microsecond a call, counted in the parts): reading the bus (python-can's ``recv``
and the frame made of its message), the pause between reads, the pipeline
(``Pipeline.feed_frames``, ``Pipeline.idle``), the messages' CDR (published serialized and
recorded), rclpy's ``publish``, the frames and messages gathered for the recorder and handed
over to its thread, the states' and diagnostics' fields, and the rest of the loop by difference.

With ``--min-run=N``, parts of N frames or more are taken as runs (``Pipeline.feed_frames``;
the package's ``MIN_RUN`` otherwise): ``--min-run=1``, every read of the bus one run.

Run: ``python -m bench.bench_node [bus] [speedup] [voyage] [--seconds=S] [--no-record]
[--batch-ms=B] [--parts] [--min-run=N]`` (part of ``make bench``: bus and speedup for 60 s, the
voyage for ``VOYAGE_SECONDS``).
"""

from __future__ import annotations

import os
import tempfile
import threading
import time
import uuid
from pathlib import Path

import numpy as np

BUS_RATE = 1908.0
SECONDS = 60.0
VOYAGE_SECONDS = 600.0
VOYAGE_FIRST_MOTION_S = 60.0


def _thread_cpu_s() -> dict[str, float]:
    """CPU seconds (user + system) of each thread of this process so far, by the Python
    thread's name where there is one; the rest (DDS, BLAS, ...) by their OS name."""
    names = {t.native_id: t.name for t in threading.enumerate()}
    tick = os.sysconf('SC_CLK_TCK')
    out: dict[str, float] = {}
    for tid in os.listdir('/proc/self/task'):
        try:
            with open(f'/proc/self/task/{tid}/stat') as fh:
                stat = fh.read()
            with open(f'/proc/self/task/{tid}/comm') as fh:
                comm = fh.read().strip()
        except OSError:
            continue                       # the thread ended meanwhile
        fields = stat[stat.rindex(')') + 2:].split()
        name = names.get(int(tid)) or f'{comm} (not Python)'
        out[name] = out.get(name, 0.0) + (int(fields[11]) + int(fields[12])) / tick
    return out


READER = 'steer_monitor-can'


class ReaderParts:
    """The reader thread's CPU by part (see the module): :meth:`install` wraps the entry points,
    :meth:`restore` puts the originals back."""

    def __init__(self) -> None:
        self.spent: dict[str, float] = {}
        self.calls: dict[str, int] = {}
        self._inner: list[float] = []
        self._originals: list[tuple[object, str, object]] = []

    def _wrap(self, owner: object, name: str, part: str, container: bool = False) -> None:
        fn = owner[name] if container else getattr(owner, name)     # type: ignore[index]
        self._originals.append((owner, name, fn))
        spent, calls, inner, clock = self.spent, self.calls, self._inner, time.thread_time

        def wrapper(*a, **k):
            if threading.current_thread().name != READER:
                return fn(*a, **k)
            inner.append(0.0)
            t0 = clock()
            try:
                return fn(*a, **k)
            finally:
                dt = clock() - t0
                spent[part] = spent.get(part, 0.0) + dt - inner.pop()
                calls[part] = calls.get(part, 0) + 1
                if inner:
                    inner[-1] += dt
        if container:
            owner[name] = wrapper                                      # type: ignore[index]
        else:
            setattr(owner, name, wrapper)

    def install(self) -> None:
        from rclpy.publisher import Publisher

        import steer_monitor.node.monitor_node as mn
        from steer_monitor.can.bus import BusReader, ListenOnlyBus
        from steer_monitor.monitor.pipeline import Pipeline
        from steer_monitor.node.recordbatch import RecordBatches
        from steer_monitor.record.recorder import Recorder
        self._wrap(ListenOnlyBus, 'recv', 'reading the bus (recv, the frame)')
        self._wrap(BusReader, '_wait', 'the pause between reads')
        self._wrap(Pipeline, 'feed_frames', 'the pipeline')
        self._wrap(Pipeline, 'idle', 'the pipeline')
        self._wrap(Publisher, 'publish', "rclpy's publish")
        self._wrap(mn, 'state_messages', "states' and diagnostics' fields")
        self._wrap(mn, 'diag_messages', "states' and diagnostics' fields")
        for key in list(mn.FAST_ENCODERS):
            self._wrap(mn.FAST_ENCODERS, key, 'the messages\' CDR', container=True)
        self._wrap(Recorder, 'write', 'to the recorder')
        self._wrap(Recorder, 'write_frames', 'to the recorder')
        self._wrap(Recorder, 'write_messages', 'to the recorder')
        self._wrap(RecordBatches, 'add', 'to the recorder')
        self._wrap(RecordBatches, 'add_message', 'to the recorder')
        self._wrap(RecordBatches, 'hand_over_if_due', 'to the recorder')

    def restore(self) -> None:
        for owner, name, fn in reversed(self._originals):
            if isinstance(owner, dict):
                owner[name] = fn
            else:
                setattr(owner, name, fn)
        self._originals.clear()


def rss_mb() -> float:
    """This process's resident memory [MB] (VmRSS)."""
    with open('/proc/self/status') as fh:
        for line in fh:
            if line.startswith('VmRSS:'):
                return int(line.split()[1]) / 1024.0
    return float('nan')


OTHER_PGNS = (127488, 127489, 129025, 129026, 127250, 127257, 130306, 128267)


def _other_traffic(t0_ns: int, seconds: float, rate: float, seed: int = 0):
    """Frames of PGNs the monitor does not map, evenly spread at ``rate`` frames/s."""
    from steer_monitor.can.frames import FLAG_EXTENDED, FrameArrays, make_id
    rng = np.random.default_rng(seed)
    n = int(rate * seconds)
    t = t0_ns + (np.arange(n) * (1e9 / rate)).astype(np.int64)
    pgn = np.array(OTHER_PGNS)[np.arange(n) % len(OTHER_PGNS)]
    ids = np.array([make_id(3, int(p), 35) for p in pgn], np.uint32)
    data = rng.integers(0, 256, (n, 8), dtype=np.uint8)
    return FrameArrays(t, ids, np.full(n, 8, np.uint8), data, np.full(n, FLAG_EXTENDED, np.uint8))


def main(seconds: float = SECONDS, record: bool = True, mode: str = 'bus', batch_ms: float | None = None,
         parts: bool = False, min_run: int | None = None) -> dict:
    import can
    import rclpy
    from rclpy.executors import SingleThreadedExecutor

    from steer_monitor.monitor import pipeline
    if min_run is not None:       # the shortest part taken as a run (the package's MIN_RUN otherwise)
        pipeline.MIN_RUN = min_run

    from steer_monitor import sim
    from steer_monitor.can.busconfig import can_setup
    from steer_monitor.node.monitor_node import MonitorNode
    from steer_monitor.node.params_ros import overrides_from_file
    from steer_monitor.params import load_params_file
    from steer_monitor.resources import default_config
    from steer_monitor.sim.playback import play

    config = default_config()
    params = load_params_file(config)
    db, smap = can_setup(params, config)
    program = f'realistic:{seconds:.0f}' if mode == 'voyage' else 'voyage'
    rss_before_sim = rss_mb()
    frames = sim.run(params, sim.SimConfig(program=program), db, smap, seed=1).frames
    native_rate = len(frames) / ((int(frames.t_ns[-1]) - int(frames.t_ns[0])) / 1e9)
    if mode == 'speedup':
        frames = frames.take(np.arange(min(int(BUS_RATE * seconds), len(frames))))
        factor = BUS_RATE / native_rate
    else:
        from steer_monitor.can.frames import FrameArrays
        t0 = int(frames.t_ns[0])
        own = frames.take(frames.t_ns < t0 + int(seconds * 1e9))
        other = _other_traffic(t0, seconds, BUS_RATE - len(own) / seconds)
        both = FrameArrays.concat([own, other])
        frames = both.take(np.argsort(both.t_ns, kind='stable'))
        factor = 1.0
    sim_mb = rss_mb() - rss_before_sim     # the simulator's voyage and the other traffic, made before the node
    channel = f'bench-{uuid.uuid4().hex[:6]}'
    clocks = ReaderParts() if parts else None
    if clocks is not None:
        clocks.install()
    with tempfile.TemporaryDirectory() as tmp:
        context = rclpy.Context()
        rclpy.init(context=context)
        node = MonitorNode(parameter_overrides=overrides_from_file(str(config), {
            'can.interface': 'virtual', 'can.channel': channel,
            'recording.directory': tmp, 'recording.enabled': record,
            'estimator.state_file': os.path.join(tmp, 'estimator.npz'),
            **({'estimator.first_motion_s': VOYAGE_FIRST_MOTION_S} if mode == 'voyage' else {}),
            **({} if batch_ms is None else {'can.read_batch_ms': batch_ms})}), context=context)
        executor = SingleThreadedExecutor(context=context)
        executor.add_node(node)
        spinner = threading.Thread(target=executor.spin, daemon=True)
        spinner.start()
        time.sleep(1.0)
        rss_start = rss_mb()
        bus = can.Bus(interface='virtual', channel=channel)
        rss_trace: list[tuple[float, float]] = []
        cpu_trace: list[float] = []
        done = threading.Event()

        def sample_rss() -> None:      # resident memory and process CPU every 10 s: growth or a plateau
            t_start = time.monotonic()
            last = sum(os.times()[:2])
            while not done.wait(10.0):
                rss_trace.append((time.monotonic() - t_start, rss_mb()))
                now = sum(os.times()[:2])
                cpu_trace.append((now - last) / 10.0)
                last = now
        sampler = threading.Thread(target=sample_rss, daemon=True)
        sampler.start()
        threads0 = _thread_cpu_s()
        if clocks is not None:      # from here, as the threads' CPU
            clocks.spent.clear()
            clocks.calls.clear()
        cpu0, main0, wall0 = sum(os.times()[:2]), time.thread_time(), time.monotonic()
        sent = play(frames, bus, factor)
        if mode == 'voyage':      # the analyses started by then run to their end: counted
            settle = time.monotonic() + 120.0
            while time.monotonic() < settle and node.analyses_running():
                time.sleep(0.2)
        wall = time.monotonic() - wall0
        done.set()
        time.sleep(1.0)
        cpu = sum(os.times()[:2]) - cpu0
        sim_cpu = time.thread_time() - main0
        threads1 = _thread_cpu_s()
        rss_end = rss_mb()
        bus.shutdown()
        executor.shutdown()
        received = node.frames_received
        analyses = node.analyses_done()
        lat = np.array(node.latencies_ns) / 1e6
        node.close()
        context.try_shutdown()
        recorded = sum(p.stat().st_size for p in Path(tmp).glob('*.mcap'))
    if clocks is not None:
        clocks.restore()
    node_cpu = (cpu - sim_cpu) / (wall + 1.0)
    dropped = sent - received
    how = (f'the simulated gear sped up {factor:.1f}x' if mode == 'speedup' else
           'a realistic voyage in real time among other traffic, its analyses included' if mode == 'voyage' else
           'the simulated gear in real time among other traffic')
    batch = f'read batch {node.reader.batch * 1e3:g} ms, parts of {pipeline.MIN_RUN} frames or more as runs'
    print(f'node at the full NMEA 2000 rate ({mode}: {how}), recording {"on" if record else "off"}, {batch}: '
          f'{sent:,} frames in {wall:.1f} s ({sent / wall:,.0f} frames/s)')
    print(f'  frames dropped       : {dropped} (received {received:,}; target 0)')
    print(f'  node CPU             : {100 * node_cpu:.1f} % of a core (target < 25 %)')
    worst = int(lat.argmax())       # the states come evenly over the run: where in it the worst one fell
    print(f'  latency frame->state : p50 {np.percentile(lat, 50):.1f} ms, p99 {np.percentile(lat, 99):.1f} ms, '
          f'max {lat.max():.1f} ms (state {worst + 1:,d} of {lat.size:,d}, about '
          f'{wall * worst / max(lat.size - 1, 1):.0f} s into the run; {int((lat > 100).sum())} over 100 ms) '
          f'(target p99 < 20 ms)')
    print(f'  resident memory      : {rss_start:.0f} MB at start, {rss_end:.0f} MB at end '
          f'(process, simulator included); the frames to play (the simulated voyage, the other traffic) held '
          f'{sim_mb:.0f} MB when made, so the node about {rss_start - sim_mb:.0f} MB at start and '
          f'{rss_end - sim_mb:.0f} MB at end (target < 250 MB, no growth)')
    if analyses:
        print('  analyses             : ' + ', '.join(analyses))
    if record:
        print(f'  recording            : {recorded / 1e6:.1f} MB in {wall:.0f} s of bus, '
              f'{recorded / 1e9 * 3600 / wall:.2f} GB an hour, {recorded / 1e9 * 86400 / wall:.1f} GB a day')
    if len(rss_trace) >= 4:
        marks = [rss_trace[int(f * (len(rss_trace) - 1))] for f in (0.0, 0.25, 0.5, 0.75, 1.0)]
        print('  memory over the run  : ' + ', '.join(f'{m:.0f} MB at {t:.0f} s' for t, m in marks))
    if cpu_trace:
        print('  process CPU per 10 s : ' + ', '.join(f'{100 * c:.0f}' for c in cpu_trace) + ' % (simulator included)')
    by_thread = sorted(((v - threads0.get(k, 0.0), k) for k, v in threads1.items()), reverse=True)
    print(
        '  CPU by thread        : '
        + ', '.join(f'{k} {100 * v / (wall + 1.0):.1f} %' for v, k in by_thread if v > 0.005 * wall)
    )
    if clocks is not None:
        reader = threads1.get(READER, 0.0) - threads0.get(READER, 0.0)
        rest = reader - sum(clocks.spent.values())
        print(f'  the reader thread    : {100 * reader / (wall + 1.0):.2f} % of a core, by part (per call):')
        for part, s in sorted(clocks.spent.items(), key=lambda kv: -kv[1]):
            print(f'    {part:34s} {100 * s / (wall + 1.0):5.2f} %  ({1e6 * s / clocks.calls[part]:.1f} us, '
                  f'{clocks.calls[part]:,} calls)')
        print(f'    {"the rest of the loop":34s} {100 * rest / (wall + 1.0):5.2f} %')
    return {'sent': sent, 'dropped': dropped, 'cpu_share': node_cpu, 'p99_ms': float(np.percentile(lat, 99)),
            'rss_start_mb': rss_start, 'rss_end_mb': rss_end, 'recorded_bytes': recorded if record else 0}


if __name__ == '__main__':
    import sys
    modes = [a for a in sys.argv[1:] if a in ('bus', 'speedup', 'voyage')] or ['bus', 'speedup', 'voyage']
    secs = [float(a.split('=', 1)[1]) for a in sys.argv[1:] if a.startswith('--seconds=')]
    batches = [float(a.split('=', 1)[1]) for a in sys.argv[1:] if a.startswith('--batch-ms=')]
    runs = [int(a.split('=', 1)[1]) for a in sys.argv[1:] if a.startswith('--min-run=')]
    for m in modes:
        main(seconds=secs[0] if secs else VOYAGE_SECONDS if m == 'voyage' else SECONDS, mode=m,
             record='--no-record' not in sys.argv,
             batch_ms=batches[0] if batches else None, parts='--parts' in sys.argv,
             min_run=runs[0] if runs else None)
