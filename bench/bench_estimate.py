"""Benchmark of the estimator (issue 5): ``analyze`` of a one-hour simulated log (target under
60 s) and the online update cost per second of data (target under 5 ms), measured in one run.

The one-hour log: the voyage programme (about 25 minutes of mixed helm) followed by an hour's
autopilot and zigzags, cut at 3600 s; true gaps 0.6 / 0.25 mm, no undeclared effect.
"""

from __future__ import annotations

import os
import time

os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')

from steer_monitor import sim  # noqa: E402
from steer_monitor.can.decoder import Decoder  # noqa: E402
from steer_monitor.can.setup import can_setup  # noqa: E402
from steer_monitor.estimate.analyze import analyze  # noqa: E402
from steer_monitor.estimate.online import OnlineEstimator  # noqa: E402
from steer_monitor.params import gear_from_params, load_params_file  # noqa: E402
from steer_monitor.resources import default_config  # noqa: E402

PROGRAM = 'voyage,autopilot:1200,zigzag_10,autopilot:1200,zigzag_20'


def main() -> int:
    cfg_path = default_config()
    params = load_params_file(cfg_path)
    db, smap = can_setup(params, cfg_path)
    gear = gear_from_params(params)
    s = sim.run(params, sim.SimConfig(program=PROGRAM, max_duration_s=3600.0), db, smap, seed=11)
    span = s.plant.duration
    print(f'estimator benchmark: {span:.0f} s simulated log, {len(s.frames)} frames')
    dec = Decoder(db, smap)
    t0 = time.perf_counter()
    signals = dec.decode_arrays(s.frames)
    t_decode = time.perf_counter() - t0
    t0 = time.perf_counter()
    a = analyze(gear, signals, min_clearance_2z=0.05e-3)
    t_analyze = time.perf_counter() - t0
    print(f'  analyze (batch decode {t_decode:.2f} s + fit, screening, refit): {t_analyze + t_decode:.1f} s '
          f'(target < 60 s); verdict {a.verdict}; Z_gb {a.final.z_gb.value * 1e3:.3f} mm')
    live = Decoder(db, smap)   # a fresh decoder: the batch one has seen every frame already
    samples = [live.decode(s.frames.frame(i)) for i in range(len(s.frames))]
    est = OnlineEstimator(gear, min_clearance_2z=0.05e-3)
    t_add = t_update = 0.0
    for k, batch in enumerate(samples):
        t0 = time.process_time()
        for smp in batch:
            est.add(smp)
        t1 = time.process_time()
        t_add += t1 - t0
        if k % 100 == 0:
            est.update()
            t_update += time.process_time() - t1
    per_s = (t_add + t_update) / span * 1e3
    print(f'  online: {per_s:.2f} ms CPU per second of data (target < 5 ms): add {t_add / span * 1e3:.2f}, '
          f'update {t_update / span * 1e3:.2f}; {est.motion_s:.0f} s of motion; '
          f'final Z_gb {est.estimate.z_gb.value * 1e3:.3f} mm')
    return 0


if __name__ == '__main__':
    raise SystemExit(main())
