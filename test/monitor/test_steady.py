"""The rudder's rate: a correctly rounded slope."""

from __future__ import annotations

import math

from steer_monitor.monitor.steady import SteadyMotion


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
