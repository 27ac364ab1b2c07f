"""Frames into the pipeline in parts of a full bus: frame by frame against runs, by part size.

The node takes what each read of the bus holds as one part (``can.read_batch_ms`` of a full
bus), a replay a log's blocks; :meth:`~steer_monitor.monitor.pipeline.Pipeline.feed_frames`
takes a part of fewer than ``MIN_RUN`` frames frame by frame and a longer one as runs. This
times both ways on the same frames, in one run: a minute of the simulated gear (``voyage``)
among other traffic up to the full NMEA 2000 rate (1,908 frames/s, as ``bench_node bus``),
cut into parts of each read period; per part size, the CPU of

* ``frame``: :meth:`Pipeline.feed` of each frame;
* ``run``: :meth:`Decoder.decode_run` of the part, then :meth:`Pipeline.feed_run`;
* ``feed_frames``: what the package does (the one or the other by ``MIN_RUN``),

each as a share of a core over the minute of bus, from the lists of frames the node reads
(the run's columns made from them included). The live model as the node has it (each state's
load sharing solved as it is read), no analyses.

Run: ``python -m bench.bench_feed [--seconds=S]`` (part of ``make bench``).
"""

from __future__ import annotations

import sys
import time

import numpy as np

from bench.bench_node import BUS_RATE, _other_traffic

#: read periods [ms]: the node's (a few ms) up to replay's blocks (16,384 frames: 8.6 s of a full bus)
PERIODS_MS = (2.0, 5.0, 10.0, 20.0, 50.0, 100.0, 250.0, 1000.0, 8590.0)


def _frames(seconds: float):
    from steer_monitor import sim
    from steer_monitor.can.busconfig import can_setup
    from steer_monitor.can.frames import FrameArrays
    from steer_monitor.params import load_params_file
    from steer_monitor.resources import default_config
    config = default_config()
    params = load_params_file(config)
    db, smap = can_setup(params, config)
    frames = sim.run(params, sim.SimConfig(program='voyage'), db, smap, seed=1).frames
    t0 = int(frames.t_ns[0])
    own = frames.take(frames.t_ns < t0 + int(seconds * 1e9))
    other = _other_traffic(t0, seconds, BUS_RATE - len(own) / seconds)
    both = FrameArrays.concat([own, other])
    return params, db, smap, both.take(np.argsort(both.t_ns, kind='stable'))


def _pipeline(params, db, smap):
    from steer_monitor.can.decoder import Decoder
    from steer_monitor.can.rejects import RejectCounter
    from steer_monitor.monitor.diagnostics import DiagnosticsBuilder, DiagnosticsConfig
    from steer_monitor.monitor.live import LiveMonitor
    from steer_monitor.monitor.pipeline import Pipeline
    from steer_monitor.params import (
        friction_from_params,
        gaps_from_params,
        gear_from_params,
        ram_share_warn_from_params,
    )
    gear = gear_from_params(params)
    rejects = RejectCounter()
    mon = LiveMonitor(gear, gaps_from_params(params), 'configured', friction_from_params(params),
                      ram_share_warn=ram_share_warn_from_params(params))
    return Pipeline(Decoder(db, smap, rejects), rejects, mon,
                    DiagnosticsBuilder(DiagnosticsConfig.from_params(params), smap, gear))


def _time(how: str, parts: list, params, db, smap) -> tuple[float, int]:
    """CPU seconds to feed ``parts`` (lists of frames) one way, and the outputs' count."""
    from steer_monitor.can.frames import FrameArrays
    p = _pipeline(params, db, smap)
    n = 0
    start = time.process_time()
    for frames in parts:
        if how == 'frame':
            for f in frames:
                n += len(p.feed(f))
            continue
        if how == 'feed_frames':
            n += len(p.feed_frames(frames))
            continue
        n += len(p.feed_run(p.decoder.decode_run(FrameArrays.from_frames(frames))))
    spent = time.process_time() - start
    n += len(p.finish())
    return spent, n


def main(seconds: float = 60.0) -> dict:
    from steer_monitor.monitor.pipeline import MIN_RUN
    params, db, smap, frames = _frames(seconds)
    t = frames.t_ns
    rate = len(frames) / seconds
    print(f'frames into the pipeline: {len(frames):,} frames in {seconds:.0f} s of bus ({rate:,.0f} frames/s), '
          f'MIN_RUN {MIN_RUN}; CPU as a share of a core over the bus time')
    print(f'  {"read":>8} {"frames/part":>11} {"frame":>8} {"run":>8} {"feed_frames":>11} {"run/frame":>9}')
    rows = {}
    for period in PERIODS_MS:
        cut = np.searchsorted(t, np.arange(int(t[0]), int(t[-1]) + 1, int(period * 1e6)))
        cut = np.unique(np.concatenate([cut, [len(frames)]]))
        parts = [list(frames.take(np.arange(a, b)).frames()) for a, b in zip(cut[:-1], cut[1:]) if b > a]
        spent = {how: _time(how, parts, params, db, smap) for how in ('frame', 'run', 'feed_frames')}
        counts = {n for _, n in spent.values()}
        if len(counts) != 1:
            msg = f'the three ways gave different numbers of outputs at {period:g} ms: {spent}'
            raise SystemExit(msg)
        share = {how: 100 * s / seconds for how, (s, _) in spent.items()}
        rows[period] = share
        print(f'  {period:>6g} ms {len(frames) / len(parts):>11.0f} {share["frame"]:>7.2f}% {share["run"]:>7.2f}% '
              f'{share["feed_frames"]:>10.2f}% {share["run"] / share["frame"]:>9.2f}')
    return rows


if __name__ == '__main__':
    secs = [float(a.split('=', 1)[1]) for a in sys.argv[1:] if a.startswith('--seconds=')]
    main(*(secs[:1]))
