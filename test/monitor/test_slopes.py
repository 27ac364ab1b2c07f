"""The compiled slopes: every sum correctly rounded, so each slope is the one ``math.fsum``
gives for the same formula, to the bit."""

from __future__ import annotations

import math
import zlib

import numpy as np
import pytest

from steer_monitor.monitor.slopes import NONE, SLOPE, SPECIAL, slope, window_slopes


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
