"""The kept twins of docs/architecture.md, each timed against the other form of the same
computation in one run, on the same inputs, with how far apart their answers are.

* the live residual: a minute of instants re-judged in one compiled pass
  (``LiveResidual.rows``) against each instant judged alone (``LiveResidual.pair``);
* the fitted torque table: its compiled lookup over arrays (``TorqueTable.scalars``) against
  its one-sample lookup in a loop (``TorqueTable.scalar``);
* the point fit: the partitioned fit (``PointFitter.fit``) against the whole model fitted at
  each pair (``fit_at``), on a simulated voyage's moments, pairs one call each and a profile's
  grid at once.

Decoding a frame against a run, and frames into the pipeline frame by frame against runs, are
``bench_feed``'s; reading candump and MCAP against python-can's reader and the mcap library,
``bench_decode``'s and ``bench_replay``'s; the load sharing's scalar solver against its arrays,
``bench_loadshare``'s.

Run: ``python -m bench.bench_twins`` (part of ``make bench``).
"""

from __future__ import annotations

import functools
import math
import time
from collections.abc import Callable

import numpy as np


def _best_of(fn: Callable[[], object], rounds: int = 3) -> float:
    """The least wall time [s] of ``rounds`` calls (the machine's speed wanders between them)."""
    best = math.inf
    for _ in range(rounds):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best


def _row(what: str, twin: str, t_twin: float, other: str, t_other: float, n: int, unit: str, apart: str) -> None:
    print(f'  {what}: {twin} {n / t_twin:,.0f} {unit}/s, {other} {n / t_other:,.0f} {unit}/s: '
          f'{t_other / t_twin:,.1f} x; {apart}')


def live_residual(params) -> float:
    from steer_monitor.model.friction import FrictionParams
    from steer_monitor.model.gear import Clearances
    from steer_monitor.model.torque import TorqueTable
    from steer_monitor.monitor.residual import LiveResidual
    from steer_monitor.params import gear_from_params
    gear = gear_from_params(params)
    rng = np.random.default_rng(7)
    n = 600            # the kept minute: one instant every 0.1 s of motion
    instants = np.column_stack([rng.uniform(-0.61, 0.61, n), rng.uniform(2.0, 9.0, n), rng.choice([-1.0, 1.0], n),
                                rng.uniform(-3e5, 3e5, n), rng.uniform(-3e5, 3e5, n), np.full(n, 0.02),
                                np.full(n, 310.0)])
    residual = LiveResidual(gear, Clearances.from_mm(0.6, 0.25), FrictionParams())
    angles = np.radians(np.arange(0.0, 25.01, 0.5))
    residual.use(Clearances.from_mm(0.4, 0.2), None, FrictionParams(9000.0, 0.13, 0.05),
                 TorqueTable(angles, 1.1 * gear.torque(angles), gear.torque.service_speed), new_source=True)
    residual.rows(instants[:2])                                  # compiled before the clock starts
    rows = residual.rows(instants)
    one = [residual.pair(tuple(i)) for i in instants.tolist()]
    judged = rows[:, 2] == 1.0
    apart = max((abs(a - b) for r, p in zip(rows.tolist(), one) if p is not None for a, b in zip(r[:2], p)),
                default=0.0)
    t_rows = _best_of(lambda: residual.rows(instants))
    t_pair = _best_of(lambda: [residual.pair(tuple(i)) for i in instants.tolist()])
    _row('the live residual, a minute of 600 instants', 'rows (compiled)', t_rows, 'pair (one by one)', t_pair,
         n, 'instants', f'{int(judged.sum())} judged, apart at most {apart:.1e} bar')
    return t_pair / t_rows


def torque_table(params) -> float:
    from steer_monitor.model.torque import TorqueTable
    from steer_monitor.params import gear_from_params
    gear = gear_from_params(params)
    angles = np.radians(np.arange(0.0, 35.01, 0.5))
    table = TorqueTable(angles, 1.1 * gear.torque(angles), gear.torque.service_speed)
    rng = np.random.default_rng(1)
    n = 60_000         # a minute of instants re-judged: 100 a second of a full bus's gear
    alpha = rng.uniform(-0.6, 0.6, n)
    speed = rng.uniform(1.0, 9.0, n)
    table.scalars(alpha[:2], speed[:2])
    many = table.scalars(alpha, speed)
    one = np.array([table.scalar(a, s) for a, s in zip(alpha.tolist(), speed.tolist())])
    apart = float(np.max(np.abs(many - one) / np.maximum(np.abs(one), 1.0)))
    t_many = _best_of(lambda: table.scalars(alpha, speed))
    t_one = _best_of(lambda: [table.scalar(a, s) for a, s in zip(alpha.tolist(), speed.tolist())])
    _row('the fitted torque table, 60,000 angles', 'scalars (compiled)', t_many, 'scalar (one by one)', t_one, n,
         'angles', f'apart at most {apart:.1e} of the torque')
    return t_one / t_many


def point_fit(params) -> tuple[float, float]:
    from steer_monitor import sim
    from steer_monitor.can.busconfig import can_setup
    from steer_monitor.can.decoder import Decoder
    from steer_monitor.estimate import fit as F
    from steer_monitor.estimate import pointfit as PF
    from steer_monitor.estimate.batch import make_rows
    from steer_monitor.estimate.observe import build_observations
    from steer_monitor.model.gear import Clearances
    from steer_monitor.params import gear_from_params
    from steer_monitor.resources import default_config
    gear = gear_from_params(params)
    db, smap = can_setup(params, default_config())
    cfg = sim.SimConfig(program='voyage', gaps=Clearances.from_mm(0.6, 0.25), max_duration_s=1800.0)
    s = sim.run(params, cfg, db, smap, 1)
    obs = build_observations(Decoder(db, smap).decode_arrays(s.frames), gear.ram_area)
    mom = make_rows(obs).moments
    basis = F.TorqueBasis(gear.max_rudder)
    extra = F.speed_scale_columns(mom)
    load = F.axial_load(gear, basis, mom, F.torque_prefit(gear, basis, mom))
    rng = np.random.default_rng(3)
    k = 40
    tz = rng.uniform(0.1e-3, 1.2e-3, k)
    zg = rng.uniform(0.05e-3, 0.6e-3, k)
    t_whole = _best_of(lambda: [F.fit_at(gear, basis, mom, a, b, load, extra) for a, b in zip(tz, zg)])
    whole = np.array([F.fit_at(gear, basis, mom, a, b, load, extra).rss for a, b in zip(tz, zg)])
    gz, gg = np.meshgrid(F.GRID_2Z[::3], F.GRID_ZGB[::3], indexing='ij')
    print(f'  the point fit, {len(mom):,} bins of a 30-minute voyage, {k} random pairs one a call and a '
          f'profile\'s grid of {gz.size} pairs at once, against fit_at one pair a call (its pairs/s):')
    ratios = []
    for per_cell, how in ((False, 'friction per bin, as fit_at'),
                          (True, 'friction per cell, as the profile: a cell\'s four bins at their mean angle, load')):
        fitter = PF.PointFitter(gear, basis, mom, load, extra, per_cell=per_cell)
        fitter.fit(tz[:1], zg[:1])
        part = np.concatenate([fitter.fit(tz[i:i + 1], zg[i:i + 1]).rss for i in range(k)])
        apart = float(np.max(np.abs(part - whole) / whole))
        t_build = _best_of(functools.partial(PF.PointFitter, gear, basis, mom, load, extra, per_cell=per_cell))
        t_each = _best_of(functools.partial(_one_a_call, fitter, tz, zg))
        t_grid = _best_of(functools.partial(fitter.fit, gz.ravel(), gg.ravel()))
        print(f'    {how} (set-up {t_build * 1e3:.0f} ms once per moments): one a call {k / t_each:,.0f} pairs/s '
              f'({t_whole / t_each:,.1f} x), the grid {gz.size / t_grid:,.0f} pairs/s '
              f'({t_whole / k * gz.size / t_grid:,.0f} x); RSS apart from fit_at\'s at most {apart:.1e} of itself')
        ratios += [t_whole / t_each, t_whole / k * gz.size / t_grid]
    print(f'    fit_at: {k / t_whole:,.0f} pairs/s')
    return ratios[0], ratios[1]


def _one_a_call(fitter, tz: np.ndarray, zg: np.ndarray) -> list:
    return [fitter.fit(tz[i:i + 1], zg[i:i + 1]) for i in range(len(tz))]


def main() -> dict[str, float]:
    from steer_monitor.params import load_params_file
    from steer_monitor.resources import default_config
    from steer_monitor.runtime import single_blas_thread
    single_blas_thread()
    params = load_params_file(default_config())
    print('kept twins, each against the other form of the same computation (the best of three rounds each):')
    out = {'live_residual': live_residual(params), 'torque_table': torque_table(params)}
    out['point_fit_each'], out['point_fit_grid'] = point_fit(params)
    return out


if __name__ == '__main__':
    main()
