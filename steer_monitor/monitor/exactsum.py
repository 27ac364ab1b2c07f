"""Correctly rounded sums, compiled: Python's ``math.fsum`` algorithm (Shewchuk's exact
partials with its half-even fix-up, ported line by line from CPython's ``math_fsum``). Pure.

A correctly rounded sum has one answer whatever computes it, so a replay ashore writes what the
node on a vessel published, to the bit, on any machine. The rudder's slopes sum this way
(:mod:`~steer_monitor.monitor.slopes`), and the live residual keeps its minute's sum of squares
exact as residuals come and go (:func:`push_counting_squares`).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from steer_monitor.compiled import njit

__all__ = ['MAX_PARTIALS', 'add_exact', 'partials_total', 'push_counting_squares', 'total_exact']

MAX_PARTIALS = 64       # exact partials of a sum of doubles: at most about 40 are ever needed


@njit(cache=True, nogil=True)
def add_exact(partials: NDArray[np.float64], n: int, x: float) -> int:
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
def total_exact(partials: NDArray[np.float64], n: int) -> float:
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
    return add_exact(partials, k, sign * sq), 0


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
    return total_exact(partials, k)
