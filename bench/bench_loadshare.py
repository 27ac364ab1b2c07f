"""Load sharing of 1,000,000 (angle, torque) samples: vectorized against a per-sample loop of
the same solver, in the same run. Prints samples/s of each and the ratio.

The per-sample loop runs on a slice (its rate is what is measured; running it on all 10^6
samples would only take longer, not tell more); both rates are measured, not assumed.
"""

from __future__ import annotations

import math
import time

import numpy as np

from steer_monitor.model import load_sharing
from steer_monitor.params import gear_from_params, load_params_file
from steer_monitor.resources import default_config

N = 1_000_000
LOOP_N = 20_000
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
    return {'vectorized_s': best, 'vectorized_rate': vec_rate, 'loop_rate': loop_rate,
            'ratio': vec_rate / loop_rate}


if __name__ == '__main__':
    main()
