"""Load sharing of 1,000,000 (angle, torque) samples: the solver on arrays (one compiled element
function, :mod:`steer_monitor.model.loadshare`) against a per-sample loop of it, in the same
run. Prints samples/s of each and the ratio. Then the live monitor's one-state call
(``load_sharing_scalar``) against arrays of the size a replay solves at once (the same
numbers to the bit), and the rate of a clearance profile's grid (``friction_normals``: every
angle cell of a voyage at every clearance pair).

The per-sample loop runs on a slice (its rate is what is measured; running it on all 10^6
samples would only take longer, not tell more); both rates are measured, not assumed.
"""

from __future__ import annotations

import math
import time

import numpy as np

from steer_monitor.model import load_sharing, load_sharing_scalar
from steer_monitor.model.loadshare import friction_normals
from steer_monitor.params import gear_from_params, load_params_file
from steer_monitor.resources import default_config

N = 1_000_000
LOOP_N = 20_000
SCALARS_BATCH = 4_500       # states in 4,096 frames of gear traffic (about 45 s of data)
TARGET_S = 1.0


def main() -> dict:
    gear = gear_from_params(load_params_file(default_config()))
    rng = np.random.default_rng(0)
    alpha = rng.uniform(-gear.max_rudder, gear.max_rudder, N)
    torque = gear.torque(alpha) * rng.uniform(0.5, 1.5, N)
    two_z, z_gb = 0.6e-3, 0.25e-3

    load_sharing(gear, alpha[:1000], torque[:1000], two_z, z_gb)  # warm up
    best = math.inf
    for _ in range(3):
        t0 = time.perf_counter()
        vec = load_sharing(gear, alpha, torque, two_z, z_gb)
        best = min(best, time.perf_counter() - t0)
    vec_rate = N / best

    t0 = time.perf_counter()
    k_loop = np.empty(LOOP_N)
    for i in range(LOOP_N):
        k_loop[i] = float(load_sharing(gear, alpha[i], torque[i], two_z, z_gb).k_gl)
    loop_s = time.perf_counter() - t0
    loop_rate = LOOP_N / loop_s
    assert np.allclose(k_loop, vec.k_gl[:LOOP_N], rtol=1e-12, atol=1e-15), 'loop and vectorized disagree'

    print(f'load sharing, {N:,} samples (R-18, 2Z = 0.6 mm, Z_gb = 0.25 mm)')
    print(f'  vectorized : {best:8.3f} s for {N:,} samples   {vec_rate:14,.0f} samples/s  '
          f"(target < {TARGET_S:g} s: {'met' if best < TARGET_S else 'NOT met'})")
    print(f'  per-sample : {loop_s:8.3f} s for {LOOP_N:,} samples   {loop_rate:14,.0f} samples/s')
    print(f'  ratio      : vectorized / per-sample = {vec_rate / loop_rate:,.0f}x')

    m = SCALARS_BATCH * 10
    t0 = time.perf_counter()
    one = [load_sharing_scalar(gear, a, t, two_z, z_gb) for a, t in zip(alpha[:m].tolist(), torque[:m].tolist())]
    scalar_rate = m / (time.perf_counter() - t0)
    best_many = math.inf
    for _ in range(3):
        t0 = time.perf_counter()
        many = [load_sharing(gear, alpha[i:i + SCALARS_BATCH], torque[i:i + SCALARS_BATCH], two_z, z_gb)
                for i in range(0, m, SCALARS_BATCH)]
        best_many = min(best_many, time.perf_counter() - t0)
    scalars_rate = m / best_many
    k_many = np.concatenate([x.k_gl for x in many])
    assert k_many.tobytes() == np.array([x.k_gl for x in one]).tobytes(), 'scalar and its array form disagree'
    print(f'live monitor solver, {m:,} states')
    print(f'  load_sharing_scalar, one call per state : {scalar_rate:14,.0f} states/s')
    print(f'  load_sharing, {SCALARS_BATCH:,} at a time        : {scalars_rate:14,.0f} states/s '
          f'({scalars_rate / scalar_rate:.1f}x; the same bits)')
    cells, pairs = 3140, 9196        # a 25-minute voyage's angle-and-speed cells, the clearance grid
    ca = np.abs(alpha[:cells])
    ct = np.abs(torque[:cells])
    tz = np.repeat(np.arange(0.0, 1.5001e-3, 0.02e-3), 121)[:pairs]
    zg = np.tile(np.arange(0.0, 0.6001e-3, 0.005e-3), 76)[:pairs]
    friction_normals(gear, ca[:10], ct[:10], tz[:10], zg[:10])     # compiled before it is timed
    t0 = time.perf_counter()
    for g0 in range(0, pairs, 1000):
        friction_normals(gear, ca, ct, tz[g0:g0 + 1000], zg[g0:g0 + 1000])
    grid_s = time.perf_counter() - t0
    print(f'a profile grid, {cells:,} cells x {pairs:,} clearance pairs')
    print(f'  friction_normals : {grid_s:8.3f} s  {cells * pairs / grid_s:14,.0f} states/s')
    return {'vectorized_s': best, 'vectorized_rate': vec_rate, 'loop_rate': loop_rate,
            'ratio': vec_rate / loop_rate, 'scalar_rate': scalar_rate, 'scalars_rate': scalars_rate,
            'grid_rate': cells * pairs / grid_s}


if __name__ == '__main__':
    main()
