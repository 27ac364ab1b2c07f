"""Closed forms of the three beams of the load-sharing model (docs/physics.md).

All per unit load: compliances in m/N, slopes in rad/N, reactions as fractions of the load
(moments in m). ``a`` is the load point's distance from support A (x = 0), ``b = L - a`` its
distance from E (x = L). Arguments are floats or numpy arrays that broadcast. Plain arithmetic
only, so the load-sharing solver compiles these very functions into its kernel
(:mod:`~steer_monitor.model.loadshare`): each formula is written once. Each is checked in
``test/model/test_beams.py`` against an independent finite-element beam solution.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = [
    'clamped_clamped_compliance',
    'clamped_pinned_compliance',
    'clamped_pinned_reactions',
    'euler_force',
    'pinned_pinned_compliance',
    'pinned_pinned_reactions',
    'pinned_pinned_slope_at_a',
]

Array = NDArray[np.float64]


def pinned_pinned_compliance(a: ArrayLike, b: ArrayLike, ei: float) -> Array:
    """Deflection under the load of a simply supported beam, a^2 b^2 / (3 EI L) [m/N]."""
    return a**2 * b**2 / (3.0 * ei * (a + b))


def pinned_pinned_slope_at_a(a: ArrayLike, b: ArrayLike, ei: float) -> Array:
    """Slope at support A of a simply supported beam, b (L^2 - b^2) / (6 EI L) [rad/N]."""
    span = a + b
    return b * (span**2 - b**2) / (6.0 * ei * span)


def pinned_pinned_reactions(a: ArrayLike, b: ArrayLike) -> tuple[Array, Array]:
    """Support reactions per unit load of a simply supported beam: (R_A, R_E) = (b/L, a/L)."""
    span = a + b
    return b / span, a / span


def clamped_pinned_compliance(a: ArrayLike, b: ArrayLike, ei: float) -> Array:
    """Deflection under the load, clamped at A and pinned at E:
    a^3 b^2 (3L + b) / (12 EI L^3) [m/N]."""
    span = a + b
    return a**3 * b**2 * (3.0 * span + b) / (12.0 * ei * span**3)


def clamped_pinned_reactions(a: ArrayLike, b: ArrayLike) -> tuple[Array, Array, Array]:
    """Per unit load, clamped at A and pinned at E: (R_A, R_E, M_A) with
    M_A = a b (L + b) / (2 L^2) [m], R_E = a^2 (3L - a) / (2 L^3), R_A = 1 - R_E."""
    span = a + b
    r_e = a**2 * (3.0 * span - a) / (2.0 * span**3)
    m_a = a * b * (span + b) / (2.0 * span**2)
    return 1.0 - r_e, r_e, m_a


def clamped_clamped_compliance(a: ArrayLike, b: ArrayLike, ei: float) -> Array:
    """Deflection under the load of a beam clamped at both ends, a^3 b^3 / (3 EI L^3) [m/N]."""
    span = a + b
    return a**3 * b**3 / (3.0 * ei * span**3)


def euler_force(ei: float, length: ArrayLike) -> Array:
    """Euler buckling force of a pinned-pinned column, pi^2 EI / length^2 [N]."""
    return math.pi**2 * ei / (length * length)
