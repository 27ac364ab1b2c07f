"""Every compiled loop of the package run on fixed inputs, for :mod:`test.test_compiled`: once in
the test's process (numba) and once in a process where numba cannot be imported (the same
functions interpreted). ``python -m test.support.compiledprobe OUT.npz`` writes the results
with ``numba`` hidden."""

from __future__ import annotations

import sys
from dataclasses import astuple

import numpy as np

__all__ = ['results']


def results() -> dict[str, np.ndarray]:
    """Name -> array, from fixed inputs (no clock, no random state shared with anything)."""
    from steer_monitor import sim
    from steer_monitor.can import Decoder, RejectCounter
    from steer_monitor.can.busconfig import can_setup
    from steer_monitor.estimate import observe, rams
    from steer_monitor.model import Clearances
    from steer_monitor.model.inputs import Series
    from steer_monitor.model.loadshare import load_sharing
    from steer_monitor.monitor import LiveMonitor, exactsum, slopes
    from steer_monitor.params import gear_from_params, load_params_file
    from steer_monitor.resources import config_dir

    path = config_dir() / 'r18.yaml'
    params = load_params_file(path)
    gear = gear_from_params(params)
    rng = np.random.default_rng(20261207)
    out: dict[str, np.ndarray] = {}

    # the model's element function over angles, torques and clearances (every case of contact)
    alpha = np.radians(np.linspace(-35.0, 35.0, 29))[:, None, None]
    torque = np.linspace(0.0, 1.0, 7)[None, :, None] * 400e3
    two_z = np.array([0.0, 0.3e-3, 0.8e-3])[None, None, :]
    ls = load_sharing(gear, alpha, torque, two_z, 0.2e-3)
    out['loadshare'] = np.stack([ls.lateral, ls.guide_force, ls.k_gl, ls.deflection, ls.case.astype(float)])
    speed = np.where(np.arange(33) % 4 == 0, np.nan, 6.0)
    out['torque'] = gear.torque.scalars(np.radians(np.linspace(-40.0, 40.0, 33)), speed)

    # the estimator's walks over samples
    t = np.cumsum(rng.integers(40_000_000, 160_000_000, 400)).astype(np.int64)
    v = np.round(np.sin(t / 3e9) * 0.4, 3)
    grid = np.arange(t[0], t[-1], 50_000_000, dtype=np.int64)
    series = Series(t, v)
    out['interp_held'] = observe.interp_held(series, grid, 200_000_000)
    kept = observe.fresh_readings(series, 100_000_000)
    out['fresh'] = np.concatenate([kept.t_ns.astype(float), kept.value])
    out['positions'] = observe.sorted_positions(t, grid[::-1].copy(), right=True).astype(float)
    out['angle_slopes'] = np.stack(observe.angle_slopes(t, v, grid))
    force = rng.normal(1e5, 2e4, (300, 2))
    out['share_moments'] = np.array([float(x) for x in astuple(rams.share_moments(force))])

    # the live monitor's exact sums and slopes
    partials = np.zeros(exactsum.MAX_PARTIALS)
    n = 0
    for x in rng.normal(0.0, 1e8, 500):
        n = exactsum.add_exact(partials, n, float(x))
    out['exact_sum'] = np.array([exactsum.total_exact(partials, n)])
    out['slope'] = np.array(slopes.slope(t[:50], v[:50]), dtype=float)

    # the live monitor fed a minute of the simulator's frames through the decoder
    db, smap = can_setup(params, path)
    s = sim.run(params, sim.SimConfig(program='hard_over_2'), db, smap, 5)
    decoder = Decoder(db, smap, RejectCounter())
    mon = LiveMonitor(gear, Clearances.from_mm(0.6, 0.25))
    states = []
    for frame in s.frames.frames():
        for sample in decoder.decode(frame):
            mon.update(sample)
        state = mon.state
        if state is not None and state.share is not None:
            states.append([state.share.lateral, state.share.k_gl, state.share.guide_force])
    out['live'] = np.asarray(states, dtype=float)
    return out


def main(argv: list[str]) -> int:
    sys.modules['numba'] = None      # type: ignore[assignment]   # import numba: ImportError
    from steer_monitor import compiled
    from steer_monitor.model import loadshare
    assert not compiled.COMPILED, 'numba still found'
    assert type(loadshare._solve).__name__ == 'function', type(loadshare._solve)
    np.savez(argv[0], **results())
    return 0


if __name__ == '__main__':
    sys.exit(main(sys.argv[1:]))
