"""How much of a ram-inertia force can any linear filter of the rudder angle recover?

An oracle for the target "residual at least halved" with ``ram_inertia``: simulate a voyage
with a mass and its twin without (same seed: same helm, noise and lagging rate, so the
difference of the plants' noise-free ram forces is the inertia force m a alone), take the
instants the declared fit uses, and fit that true force by least squares on the angle
samples around each instant: the samples within +-K periods of it, relative to the last one
before it, and the same multiplied by the instant's phase between samples and its square
(so the filter's weights may depend on where the instant falls). Fitted on one half of the
log and scored on the other, both ways. The share of the force's variance it explains (R2)
bounds what any column linear in the angle can take out; halving the effect's misfit (its
RMS) needs R2 >= 0.75. R2 does not depend on the mass (the trajectory is the twin's).

``ANGLE`` chooses what the filter sees: ``bus`` (the decoded 10 Hz angle as the monitor
reads it: 1e-4 rad steps, 1.5e-4 rad noise), ``10hz_clean`` (the plant's angle at the same
instants without noise or quantisation), ``100hz`` (the plant's angle every 10 ms with the
bus's noise); ``K`` the samples either side (10).

Run from the repository: ``.venv/bin/python docs/studies/inertia_bound.py realistic:1500 5037,5038``
(programme, seeds, mass in kg: 12000 by default). Figures in docs/residual-loop.md.
"""

from __future__ import annotations

import math
import os
import sys
from dataclasses import replace

os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')


def main(argv: list[str]) -> int:
    from steer_monitor.runtime import single_blas_thread
    single_blas_thread()
    import numpy as np

    from steer_monitor import sim
    from steer_monitor.can.busconfig import can_setup
    from steer_monitor.can.decoder import Decoder
    from steer_monitor.estimate.analyze import declared_fit
    from steer_monitor.params import gear_from_params, load_params_file
    from steer_monitor.resources import default_config
    from steer_monitor.studies.accuracy import true_forces

    prog, seeds = argv[0], [int(s) for s in argv[1].split(',')]
    mass = float(argv[2]) if len(argv) > 2 else 12e3
    mode, k = os.environ.get('ANGLE', 'bus'), int(os.environ.get('K', '10'))
    config = default_config()
    params = load_params_file(config)
    db, smap = can_setup(params, config)
    gear = gear_from_params(params)
    bar = gear.ram_area * 1e5
    for seed in seeds:
        cfg = sim.SimConfig(program=prog, effects=(sim.parse_effect(f'ram_inertia:mass_kg={mass}'),))
        twin_cfg = replace(cfg, effects=(sim.parse_effect('ram_inertia:mass_kg=0'),))
        s, twin = sim.run(params, cfg, db, smap, seed), sim.run(params, twin_cfg, db, smap, seed)
        signals = Decoder(db, smap).decode_arrays(s.frames, final=True)
        obs, est = declared_fit(gear, signals)
        t = obs.t_ns[np.isfinite(est.residual).any(axis=1)]
        force = (true_forces(s.plant, cfg, t, gear.ram_area)
                 - true_forces(twin.plant, twin_cfg, t, gear.ram_area)).mean(axis=1)
        if mode == 'bus':
            at, av = signals['rudder_angle'].t_ns, signals['rudder_angle'].value
        else:
            step = {'100hz': 1, '10hz_clean': 10}[mode]
            at = (s.plant.start_ns + np.round(s.plant.t[::step] * 1e9)).astype(np.int64)
            av = s.plant.alpha[::step]
            if mode == '100hz':
                av = av + np.random.default_rng(seed).normal(0.0, 1.5e-4, av.size)
        j = np.searchsorted(at, t, side='right') - 1
        ok = (j - k >= 0) & (j + k + 1 < at.size)
        t, force, j = t[ok], force[ok], j[ok]
        phase = ((t - at[j]) / np.median(np.diff(at)))[:, None]
        near = av[j[:, None] + np.arange(-k, k + 2)[None, :]] - av[j][:, None]
        x = np.concatenate([near, near * phase, near * phase ** 2, np.ones((t.size, 1))], axis=1)
        first = t < np.median(t)
        r2 = []
        for fit, score in ((first, ~first), (~first, first)):
            coef, *_ = np.linalg.lstsq(x[fit], force[fit], rcond=None)
            r2.append(1.0 - np.var(force[score] - x[score] @ coef) / np.var(force[score]))
        print(f'[{mode}] {prog} seed {seed}, {mass / 1e3:g} t: {t.size} instants, inertia force '
              f'{math.sqrt(np.mean(force ** 2)) / bar:.4f} bar RMS; best linear filter of the angle '
              f'({x.shape[1]} columns) explains {r2[0]:.3f} / {r2[1]:.3f} of it held out: '
              f'{math.sqrt(max(1.0 - float(np.mean(r2)), 0.0)):.2f} of its RMS left (halving: 0.50)')
    return 0


if __name__ == '__main__':
    sys.exit(main(sys.argv[1:]))
