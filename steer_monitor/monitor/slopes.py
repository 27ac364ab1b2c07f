"""Least-squares slopes of the rudder angle over windows of its samples, compiled. Pure.

The live model reads the rudder's rate as the slope of the angle over the last 0.5 s, and
judges steady motion from the slopes over 0.3 s each side of a sample. A replay ashore must
write what the node on a vessel published, to the bit, on any machine: so every sum here is
correctly rounded, by the algorithm of Python's ``math.fsum`` (Shewchuk's exact partials with
its half-even fix-up, ported line by line from CPython's ``math_fsum``). A correctly rounded
sum has one answer whatever computes it, so the slopes equal those of the same formula summed
with ``math.fsum`` (``test_slopes`` checks it on random and cancelling data). The squares are
products and no operation is fused (numba's default, no fast-math).

One kernel serves the node, sample by sample (:func:`slope`), and a replay's run, all of its
windows in one call (:func:`window_slopes`).
"""

from __future__ import annotations

import numpy as np
from numba import njit
from numpy.typing import NDArray

__all__ = ['MAX_PARTIALS', 'NONE', 'SLOPE', 'SPECIAL', 'partials_total', 'push_counting_squares', 'slope',
           'window_slopes']

#: what a window gave: a slope; no slope (fewer than 3 points, or all at one time); a
#: non-finite value among its points (the caller sums those with ``math.fsum`` itself)
SLOPE, NONE, SPECIAL = 0, 1, 2
MAX_PARTIALS = 64       # exact partials of a sum of doubles: at most about 40 are ever needed


@njit(cache=True, nogil=True)
def _add(partials: NDArray[np.float64], n: int, x: float) -> int:
    """Add ``x`` to the exact partials ``partials[:n]``; returns the new count."""
    i = 0
    for j in range(n):
        y = partials[j]
        if abs(x) < abs(y):
            x, y = y, x
        hi = x + y
        yr = hi - x
        lo = y - yr
        if lo != 0.0:
            partials[i] = lo
            i += 1
        x = hi
    n = i
    if x != 0.0:
        partials[n] = x
        n += 1
    return n


@njit(cache=True, nogil=True)
def _total(partials: NDArray[np.float64], n: int) -> float:
    """The correctly rounded value of the partials (``math_fsum``'s last part)."""
    hi = 0.0
    if n > 0:
        n -= 1
        hi = partials[n]
        lo = 0.0
        while n > 0:
            x = hi
            n -= 1
            y = partials[n]
            hi = x + y
            yr = hi - x
            lo = y - yr
            if lo != 0.0:
                break
        if n > 0 and ((lo < 0.0 and partials[n - 1] < 0.0) or (lo > 0.0 and partials[n - 1] > 0.0)):
            y = lo * 2.0
            x = hi + y
            yr = x - hi
            if y == yr:
                hi = x
    return hi


@njit(cache=True, nogil=True)
def _slope_of(t_ns: NDArray[np.int64], a: NDArray[np.float64], lo: int, hi: int, p: NDArray[np.float64],
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
        k = _add(p, k, ts[j])
    mean_t = _total(p, k) / n
    k = 0
    for j in range(lo, hi):
        k = _add(p, k, a[j])
    mean_a = _total(p, k) / n
    if not (np.isfinite(mean_t) and np.isfinite(mean_a)):
        return SPECIAL, 0.0
    k = 0
    for j in range(n):
        d = ts[j] - mean_t
        k = _add(p, k, d * d)
    sxx = _total(p, k)
    if not np.isfinite(sxx):
        return SPECIAL, 0.0
    if sxx <= 0:
        return NONE, 0.0
    k = 0
    for j in range(n):
        d = ts[j] - mean_t
        k = _add(p, k, d * (a[lo + j] - mean_a))
    num = _total(p, k)
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
        s, v = _slope_of(t_ns, a, lo[w], hi[w], p, ts)
        status[w] = s
        out[w] = v


@njit(cache=True, nogil=True, inline='always')
def _add_square(partials: NDArray[np.float64], k: int, x: float, sign: float) -> tuple[int, int]:
    """``sign`` (+1 or -1) times the square of ``x`` added exactly to the exact partials
    ``partials[:k]``: (the new count, 1 where the square is not finite and was left out, else
    0). Adding a square and later taking the same square away leaves the partials' exact sum
    as it was, so a sum kept this way as values come and go is the exact sum of the values
    held, whatever came and went before."""
    sq = x * x
    if not np.isfinite(sq):
        return k, 1
    return _add(partials, k, sign * sq), 0


@njit(cache=True, nogil=True)
def push_counting_squares(data: NDArray[np.float64], nxt: int, kept: int, rows: NDArray[np.float64],
                          partials: NDArray[np.float64], k: int) -> tuple[int, int, int, int, int]:
    """Rows (n, 3) of residual pairs and whether judged (1/0) pushed into a ring ``data``
    (cap, 3) whose next row is ``nxt`` and which holds ``kept`` rows (the live monitor's
    ``RowRing``: the last cap rows stay, where pushing them one by one would put them), the
    squares of the judged pairs of the rows it lets go taken out of the exact partials
    ``partials[:k]`` (oldest first) and those of the rows it takes added, exactly
    (:func:`_add_square`): (next, kept, the partials' count, the change in values
    counted, the change in values whose square was not finite and left out)."""
    cap, total = data.shape[0], rows.shape[0]
    values = bad = 0
    gone = min(kept + total - cap, kept)         # rows let go, oldest first
    oldest = (nxt - kept) % cap
    for g in range(gone):
        r = (oldest + g) % cap
        if data[r, 2] != 0.0:
            for c in range(2):
                k, b = _add_square(partials, k, data[r, c], -1.0)
                values, bad = values - 1, bad - b
    skip = max(total - cap, 0)                   # rows of the push that never enter
    for j in range(skip, total):
        if rows[j, 2] != 0.0:
            for c in range(2):
                k, b = _add_square(partials, k, rows[j, c], 1.0)
                values, bad = values + 1, bad + b
    start = (nxt + skip) % cap
    for j in range(total - skip):
        r = (start + j) % cap
        for c in range(3):
            data[r, c] = rows[skip + j, c]
    return (start + total - skip) % cap, min(kept + total, cap), k, values, bad


@njit(cache=True, nogil=True)
def partials_total(partials: NDArray[np.float64], k: int) -> float:
    """The correctly rounded value of the exact partials ``partials[:k]``."""
    return _total(partials, k)


def slope(t_ns: list[int] | NDArray[np.int64], a: list[float] | NDArray[np.float64]) -> tuple[int, float]:
    """(status, slope [per s]) of one set of points (:func:`window_slopes` of one window)."""
    t = np.asarray(t_ns, np.int64)
    v = np.asarray(a, np.float64)
    status = np.empty(1, np.int8)
    out = np.empty(1)
    window_slopes(t, v, np.zeros(1, np.intp), np.full(1, t.shape[0], np.intp), status, out)
    return int(status[0]), float(out[0])

