"""The rams' forces of a gear under a sweeping load, for the tests of the share and the check."""

from __future__ import annotations

import numpy as np

__all__ = ['AREA', 'BAR', 'ram_forces']

AREA = 0.045239          # A_r of the R-18 [m^2]
BAR = AREA * 1e5         # one bar of ram pressure as force [N]


def ram_forces(share1: float, n: int = 2000, offset_bar: float = 0.0, noise_bar: float = 0.35, seed: int = 1,
            sweep: float = 12.0):
    """Ram forces (n, 2) [N] for a load sweeping +-40 bar (``sweep`` radians of a sine over the
    n rows), ram 1 carrying ``share1``; each chamber's transducer with its own noise, ram 1's
    stbd one reading ``offset_bar`` high."""
    rng = np.random.default_rng(seed)
    load = 40 * BAR * np.sin(np.linspace(0, sweep, n))       # what each ram carries on an even share
    p = rng.normal(0.0, noise_bar * 1e5, (n, 4))
    f1 = 2 * share1 * load + AREA * (p[:, 0] - p[:, 1] + offset_bar * 1e5)
    f2 = 2 * (1 - share1) * load + AREA * (p[:, 2] - p[:, 3])
    return np.stack([f1, f2], axis=1)
