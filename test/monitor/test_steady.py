"""The rudder's rate: a correctly rounded slope, over a window that holds enough samples of a
slowly sampled angle and none across an outage."""

from __future__ import annotations

import math

import numpy as np
import pytest

from steer_monitor.monitor.steady import (
    MAX_RATE_SPAN_NS,
    MIN_RATE_POINTS,
    SLOPE_WINDOW_NS,
    SteadyMotion,
    rate_window_start,
    rate_window_starts,
)


def test_the_rate_is_a_correctly_rounded_slope():
    """Sums whose plain left-to-right value differs from the exact one in the last bit: the
    rate is the correctly rounded one (math.fsum), the same on every Python (the built-in sum
    is compensated from 3.12 on), so a node and a replay on different machines agree."""
    # the slope: values whose plain mean loses the 1.0 beside 1e16
    pts = [(0, 1e16), (100_000_000, 1.0), (200_000_000, -1e16), (300_000_000, 3.0)]
    ts = [0.0, 0.1, 0.2, 0.3]
    mean_t, mean_a = math.fsum(ts) / 4, math.fsum(a for _, a in pts) / 4
    assert sum(a for _, a in pts) / 4 != mean_a            # plain summation differs here (3.11)
    want = math.fsum((t - mean_t) * (a - mean_a) for t, (_, a) in zip(ts, pts)) / \
        math.fsum((t - mean_t) * (t - mean_t) for t in ts)
    assert SteadyMotion.rate_of(pts) == want


def _window_oracle(times: list[int], k: int) -> int:
    """Where the rate window of sample ``k`` begins, from its definition: the samples of the
    last half second if they are three or more, else the last three if they lie within 8 s,
    else those within 8 s (too few for a slope)."""
    t = times[k]
    recent = [i for i in range(k + 1) if times[i] >= t - SLOPE_WINDOW_NS]
    if len(recent) >= MIN_RATE_POINTS:
        return recent[0]
    last = list(range(max(0, k + 1 - MIN_RATE_POINTS), k + 1))
    if len(last) == MIN_RATE_POINTS and t - times[last[0]] <= MAX_RATE_SPAN_NS:
        return last[0]
    return min(i for i in range(k + 1) if times[i] >= t - MAX_RATE_SPAN_NS)


@pytest.mark.parametrize('seed', range(4))
def test_the_rate_window_is_its_definition(seed):
    """Samples at rates from 100 Hz down to 0.2 Hz, with gaps: the start of each one's rate
    window, one at a time and all at once, is the definition's."""
    rng = np.random.default_rng(seed)
    steps = np.concatenate([rng.choice([10_000_000, 100_000_000, 500_000_000, 2_000_000_000, 5_000_000_000],
                                       size=400), [20_000_000_000]])
    rng.shuffle(steps)
    times = np.cumsum(steps + rng.integers(0, 20_000_000, steps.size)).astype(np.int64)
    starts = rate_window_starts(times)
    tl = times.tolist()
    for k in range(len(tl)):
        assert rate_window_start(tl[:k + 1], tl[k]) == starts[k] == _window_oracle(tl, k)


@pytest.mark.parametrize('hz, span_s', [(10.0, 0.5), (2.0, 1.0), (1.0, 2.0), (0.5, 4.0)])
def test_a_slowly_sampled_rudder_has_its_rate(hz, span_s):
    """A rudder turning at 2.5 deg/s, its angle sent at ``hz``: from the third sample on, its
    rate exactly (a straight line), read over half a second or, slower, over three samples."""
    steady = SteadyMotion(0.045, lambda *a: None)
    rate = math.radians(2.5)
    period = int(1e9 / hz)
    for k in range(8):
        steady.angle(k * period, rate * k * period / 1e9, math.nan, math.nan)
        if k < 2:
            assert steady.rate_span_ns is None
    assert steady.rate == pytest.approx(rate, rel=1e-9)
    assert steady.rate_span_ns == pytest.approx(span_s * 1e9, abs=period // 10 if hz >= 10 else 0)


def test_after_an_outage_the_rate_waits_for_samples_again():
    """At 2 Hz, 10 s with nothing: the samples just after give no rate (the last three reach
    back past 8 s) until three have come again; the rate then is the new motion's."""
    steady = SteadyMotion(0.045, lambda *a: None)
    for k in range(6):
        steady.angle(k * 500_000_000, 0.01 * k, math.nan, math.nan)
    assert steady.rate == pytest.approx(0.02)
    t = 2_500_000_000 + 10_000_000_000
    spans = []
    for k in range(3):
        steady.angle(t + k * 500_000_000, 0.5 - 0.01 * k, math.nan, math.nan)
        spans.append(steady.rate_span_ns)
    assert spans[:2] == [None, None] and spans[2] == 1_000_000_000
    assert steady.rate == pytest.approx(-0.02)
