"""Least-squares slopes of the rudder angle over windows of its samples, compiled. Pure.

The live model reads the rudder's rate as the slope of the angle over the last 0.5 s, and
judges steady motion from the slopes over 0.3 s each side of a sample. A replay ashore must
write what the node on a vessel published, to the bit, on any machine: so every sum here is
correctly rounded, by the algorithm of Python's ``math.fsum``
(:mod:`~steer_monitor.monitor.exactsum`). A correctly rounded
sum has one answer whatever computes it, so the slopes equal those of the same formula summed
with ``math.fsum`` (``test_slopes`` checks it on random and cancelling data). The squares are
products and no operation is fused (numba's default, no fast-math).

One kernel serves the node, sample by sample (:func:`slope`), and a replay's run, all of its
windows in one call (:func:`window_slopes`).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from steer_monitor.compiled import njit
from steer_monitor.monitor.exactsum import MAX_PARTIALS, add_exact, total_exact

__all__ = ['NONE', 'SLOPE', 'SPECIAL', 'slope', 'slope_of', 'window_slopes']

#: what a window gave: a slope; no slope (fewer than 3 points, or all at one time); a
#: non-finite value among its points (the caller sums those with ``math.fsum`` itself)
SLOPE, NONE, SPECIAL = 0, 1, 2


@njit(cache=True, nogil=True)
def slope_of(t_ns: NDArray[np.int64], a: NDArray[np.float64], lo: int, hi: int, p: NDArray[np.float64],
              ts: NDArray[np.float64]) -> tuple[int, float]:
    """(status, slope [per s]) of the points ``lo:hi``: centred moments, every sum correctly
    rounded (``SteadyMotion.rate_of``'s formula)."""
    n = hi - lo
    if n < 3:
        return NONE, 0.0
    t0 = t_ns[lo]
    k = 0
    for j in range(lo, hi):
        if not np.isfinite(a[j]):
            return SPECIAL, 0.0
        ts[j - lo] = (t_ns[j] - t0) / 1e9
    for j in range(n):
        k = add_exact(p, k, ts[j])
    mean_t = total_exact(p, k) / n
    k = 0
    for j in range(lo, hi):
        k = add_exact(p, k, a[j])
    mean_a = total_exact(p, k) / n
    if not (np.isfinite(mean_t) and np.isfinite(mean_a)):
        return SPECIAL, 0.0
    k = 0
    for j in range(n):
        d = ts[j] - mean_t
        k = add_exact(p, k, d * d)
    sxx = total_exact(p, k)
    if not np.isfinite(sxx):
        return SPECIAL, 0.0
    if sxx <= 0:
        return NONE, 0.0
    k = 0
    for j in range(n):
        d = ts[j] - mean_t
        k = add_exact(p, k, d * (a[lo + j] - mean_a))
    num = total_exact(p, k)
    if not np.isfinite(num):
        return SPECIAL, 0.0
    return SLOPE, num / sxx


@njit(cache=True, nogil=True)
def window_slopes(t_ns: NDArray[np.int64], a: NDArray[np.float64], lo: NDArray[np.intp], hi: NDArray[np.intp],
                  status: NDArray[np.int8], out: NDArray[np.float64]) -> None:
    """The slope [per s] of each window ``lo[w]:hi[w]`` of points (``t_ns`` [ns], ``a``) into
    ``out[w]``, with ``status[w]`` (:data:`SLOPE`, :data:`NONE`, :data:`SPECIAL`)."""
    p = np.empty(MAX_PARTIALS)
    width = 0
    for w in range(lo.shape[0]):
        width = max(width, hi[w] - lo[w])
    ts = np.empty(max(width, 1))
    for w in range(lo.shape[0]):
        s, v = slope_of(t_ns, a, lo[w], hi[w], p, ts)
        status[w] = s
        out[w] = v


def slope(t_ns: list[int] | NDArray[np.int64], a: list[float] | NDArray[np.float64]) -> tuple[int, float]:
    """(status, slope [per s]) of one set of points (:func:`window_slopes` of one window)."""
    t = np.asarray(t_ns, np.int64)
    v = np.asarray(a, np.float64)
    status = np.empty(1, np.int8)
    out = np.empty(1)
    window_slopes(t, v, np.zeros(1, np.intp), np.full(1, t.shape[0], np.intp), status, out)
    return int(status[0]), float(out[0])

