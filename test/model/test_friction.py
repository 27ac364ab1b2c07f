"""The declared friction law, for floats and arrays, both branches of N_A."""

from __future__ import annotations

import numpy as np
import pytest

from steer_monitor.model import FrictionParams, friction_force, normal_forces


def test_pinned_ram_uses_its_reactions():
    p = FrictionParams(9e3, 0.13, 0.05)
    # pinned: M_A = 0, N_A = |R_A|
    assert float(friction_force(p, -40e3, 60e3, 0.0, 100e3, 0.25)) == pytest.approx(9e3 + 0.13 * 100e3 + 0.05 * 100e3)


def test_clamped_ram_bears_on_both_ends_of_the_bushing():
    n_a, n_e = normal_forces(10e3, 5e3, 4e3, 0.25)   # 2 |M_A| / l_s = 32 kN > |R_A|
    assert (float(n_a), float(n_e)) == (pytest.approx(32e3), pytest.approx(5e3))


def test_arrays_broadcast():
    p = FrictionParams()
    f = friction_force(p, np.array([1e3, 2e3]), np.array([1e3, 1e3]), np.array([0.0, 1e3]), 0.0, 0.25)
    assert f.shape == (2,) and f[1] == pytest.approx(9e3 + 0.13 * (8e3 + 1e3))
