"""The compiled slopes: every sum correctly rounded, so each slope is the one ``math.fsum``
gives for the same formula, to the bit."""

from __future__ import annotations

import math
import zlib

import numpy as np
import pytest

from steer_monitor.monitor.slopes import (
    MAX_PARTIALS,
    NONE,
    SLOPE,
    SPECIAL,
    partials_total,
    push_counting_squares,
    slope,
    window_slopes,
)


def _fsum_slope(t_ns: list[int], a: list[float]) -> float | None:
    """The live model's slope summed by math.fsum (the formula, independently)."""
    n = len(t_ns)
    if n < 3:
        return None
    ts = [(t - t_ns[0]) / 1e9 for t in t_ns]
    mean_t, mean_a = math.fsum(ts) / n, math.fsum(a) / n
    dt = [t - mean_t for t in ts]
    sxx = math.fsum(d * d for d in dt)
    if sxx <= 0:
        return None
    return math.fsum(d * (v - mean_a) for d, v in zip(dt, a)) / sxx


def _values(rng: np.random.Generator, kind: str, n: int) -> np.ndarray:
    if kind == 'wide magnitudes':
        return rng.normal(0.0, 1.0, n) * 10.0 ** rng.integers(-20, 20, n)
    if kind == 'rounded':
        return np.round(rng.normal(0.0, 1.0, n), 2)
    if kind == 'cancelling':
        return 0.1 + 1e-12 * rng.normal(0.0, 1.0, n)
    return rng.normal(0.0, 0.3, n)


@pytest.mark.parametrize('kind', ['rudder', 'wide magnitudes', 'rounded', 'cancelling', 'repeated times'])
def test_each_slope_is_the_fsum_one_to_the_bit(kind):
    rng = np.random.default_rng(zlib.crc32(kind.encode()))
    for _ in range(3000):
        n = int(rng.integers(1, 14))
        step = rng.integers(0, 3, n) * 50_000_000 if kind == 'repeated times' else rng.integers(0, 200_000_000, n)
        t = (np.cumsum(step) + int(rng.integers(0, 2**60))).astype(np.int64)
        a = _values(rng, kind, n)
        want = _fsum_slope(t.tolist(), a.tolist())
        status, got = slope(t, a)
        assert status == (NONE if want is None else SLOPE)
        if want is not None:
            assert got == want


def test_a_sum_plain_addition_gets_wrong_is_right():
    t = [0, 100_000_000, 200_000_000, 300_000_000]
    a = [1e16, 1.0, -1e16, 3.0]
    assert sum(a) / 4 != math.fsum(a) / 4
    assert slope(t, a) == (SLOPE, _fsum_slope(t, a))


@pytest.mark.parametrize('bad', [math.nan, math.inf, -math.inf])
def test_a_window_holding_a_non_finite_value_is_left_to_math_fsum(bad):
    assert slope([0, 1, 2, 3], [0.0, bad, 1.0, 2.0])[0] == SPECIAL


def test_many_windows_at_once_are_each_window_alone():
    rng = np.random.default_rng(3)
    t = np.cumsum(rng.integers(50_000_000, 150_000_000, 400)).astype(np.int64)
    a = np.cumsum(rng.normal(0.0, 0.01, 400))
    lo = rng.integers(0, 390, 200).astype(np.intp)
    hi = (lo + rng.integers(0, 10, 200)).astype(np.intp)
    status, out = np.empty(200, np.int8), np.empty(200)
    window_slopes(t, a, lo, hi, status, out)
    for w in range(200):
        s, v = slope(t[lo[w]:hi[w]], a[lo[w]:hi[w]])
        assert status[w] == s and (s != SLOPE or out[w] == v)


def test_the_kept_sum_of_squares_is_math_fsums_to_the_bit():
    """Values of magnitudes from 1e-8 to 1e8 pushed as judged pairs into a ring that holds
    them all: the partials' total is math.fsum of their squares, to the bit (a sum plain
    addition gets wrong among them); an overflowing square is counted as not finite and left
    out, as is a NaN's."""
    rng = np.random.default_rng(11)
    for _ in range(500):
        x = rng.normal(0.0, 1.0, 2 * int(rng.integers(0, 650))) * 10.0 ** rng.integers(-8, 8)
        rows = np.column_stack([x.reshape(-1, 2), np.ones(x.size // 2)])
        partials = np.empty(MAX_PARTIALS)
        _, kept, k, values, bad = push_counting_squares(np.zeros((700, 3)), 0, 0, rows, partials, 0)
        assert (kept, values, bad) == (x.size // 2, x.size, 0)
        assert partials_total(partials, k) == math.fsum(v * v for v in x.tolist())
    partials = np.empty(MAX_PARTIALS)
    rows = np.array([[1e200, 3.0, 1.0], [math.nan, 4.0, 1.0], [5.0, 6.0, 0.0]])
    _, _, k, values, bad = push_counting_squares(np.zeros((4, 3)), 0, 0, rows, partials, 0)
    assert (values, bad) == (4, 2) and partials_total(partials, k) == 25.0


@pytest.mark.parametrize('sizes', [[1] * 40, [3, 7, 2, 11, 5, 9, 1, 13], [25, 4, 30, 0, 2], [8, 8, 8, 8, 8, 8]])
def test_pushing_rows_keeps_the_last_and_the_exact_sum_of_their_squares(sizes):
    """push_counting_squares against a list that keeps the last cap rows: the ring's rows
    (oldest first from next - kept) are the list's, and after every push the partials' total
    is math.fsum of the squares of the judged pairs held, to the bit; the counts of values and
    of non-finite squares follow the rows held. Pushes larger than the ring included; rows of
    big and tiny magnitudes, a NaN and an overflowing value among them."""
    cap = 10
    rng = np.random.default_rng(len(sizes))
    data = np.zeros((cap, 3))
    partials = np.empty(MAX_PARTIALS)
    nxt = kept = k = values = bad = 0
    held: list[list[float]] = []
    for size in sizes:
        rows = np.column_stack([rng.normal(0, 1, (size, 2)) * 10.0 ** rng.integers(-8, 9, (size, 2)),
                                rng.integers(0, 2, size).astype(float)])
        if size > 3:
            rows[1, 0], rows[2, 1], rows[2, 2], rows[3, 2] = math.nan, 1e200, 1.0, 1.0
        nxt, kept, k, dv, db = push_counting_squares(data, nxt, kept, rows, partials, k)
        values, bad = values + dv, bad + db
        held = (held + rows.tolist())[-cap:]
        assert kept == len(held)
        ring = data[(np.arange(kept) + nxt - kept) % cap]
        assert ring.tolist() == held or np.array_equal(ring, np.array(held), equal_nan=True)
        judged = [v for r in held if r[2] != 0.0 for v in r[:2]]
        squares = [v * v for v in judged]
        assert values == len(judged)
        assert bad == sum(not math.isfinite(q) for q in squares)
        finite = [q for q in squares if math.isfinite(q)]
        assert partials_total(partials, k) == math.fsum(finite)
