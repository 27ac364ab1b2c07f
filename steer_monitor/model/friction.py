"""The declared friction law of the observation model (docs/physics.md, docs/estimation.md).

    F_fr = F_s + mu_b (N_A + N_E) + mu_g |F_gb|
    N_E = |R_E|,  N_A = max(|R_A|, 2 |M_A| / l_s)

A ram clamped in bushing A bears on both ends of the bushing, hence the 2 |M_A| / l_s.
Works on floats and on numpy arrays alike. SI units.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

__all__ = ['FrictionParams', 'friction_force', 'friction_law', 'normal_forces']


@dataclass(frozen=True)
class FrictionParams:
    """Seal friction F_s [N] and the friction coefficients of the ram bushing and guide slipper."""

    seal: float = 9e3
    mu_bushing: float = 0.13
    mu_guide: float = 0.05


def normal_forces(r_a: ArrayLike, r_e: ArrayLike, m_a: ArrayLike, bushing_length: float) -> tuple:
    """(N_A, N_E) [N]: the ram's normal loads on bushings A and E."""
    return np.maximum(np.abs(r_a), 2.0 * np.abs(m_a) / bushing_length), np.abs(r_e)


def friction_law(seal: float, mu_bushing: float, mu_guide: float, n_a: ArrayLike, n_e: ArrayLike,
                 guide_force: ArrayLike) -> ArrayLike:
    """F_fr [N] from the seal friction, the coefficients and the normal loads (numba kernels
    compile this same function)."""
    return seal + mu_bushing * (n_a + n_e) + mu_guide * np.abs(guide_force)


def friction_force(params: FrictionParams, r_a: ArrayLike, r_e: ArrayLike, m_a: ArrayLike,
                   guide_force: ArrayLike, bushing_length: float) -> ArrayLike:
    """F_fr [N] of the declared model from the bushing reactions and the guide force."""
    n_a, n_e = normal_forces(r_a, r_e, m_a, bushing_length)
    return friction_law(params.seal, params.mu_bushing, params.mu_guide, n_a, n_e, guide_force)
