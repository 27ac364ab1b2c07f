"""How the inputs came (period, jitter, frames lost, gaps) and the windows a slow input's
observations are judged over."""

from __future__ import annotations

import numpy as np
import pytest

from steer_monitor.estimate.sampling import (
    DESIGN_ANGLE_PERIOD_NS,
    DESIGN_PRESSURE_PERIOD_NS,
    SignalTiming,
    Windows,
    signal_timing,
)


def test_signal_timing_is_its_definition():
    """Samples every 0.5 s with +-10 ms jitter, 3 frames lost at one place and 1 at another, and
    a silence of 6 s: the period, the 95th percentile of the jitter, the frames lost counted
    from the intervals, and the one gap over 2 s."""
    rng = np.random.default_rng(5)
    k = np.arange(400)
    keep = ~np.isin(k, [50, 51, 52, 200]) & ~((k > 300) & (k < 312))
    t = ((k[keep] * 0.5 + rng.uniform(-0.01, 0.01, keep.sum())) * 1e9).astype(np.int64)
    st = signal_timing(t, 2_000_000_000)
    assert st.period_ns == pytest.approx(5e8, abs=2e6)
    d = np.diff(t)
    regular = d < 7.5e8
    assert st.jitter_ns == int(np.percentile(np.abs(d[regular] - st.period_ns), 95))
    assert st.frames_lost == 3 + 1 + 11
    assert len(st.gaps) == 1 and st.gaps[0][1] - st.gaps[0][0] > 5.5e9
    assert signal_timing(t[:2], 10**9) == SignalTiming(None, None, 0, ())


@pytest.mark.parametrize('hz', [2.0, 1.0, 0.5, 5.0])
def test_the_common_rates_sit_between_the_rungs(hz):
    """A gateway's common rates, a little jittered either way, land on one rung: the windows of
    a log and of the node's part of it are the same."""
    p = int(1e9 / hz)
    rungs = {Windows.of_periods(int(p * f), int(p * f)) for f in (0.99, 0.999, 1.0, 1.001, 1.01)}
    assert len(rungs) == 1
    w = rungs.pop()
    assert p <= w.angle_period_ns <= 1.2 * p and p <= w.pressure_period_ns <= 1.2 * p


def test_at_or_near_the_design_rates_the_windows_are_the_design():
    w = Windows.of_periods(DESIGN_ANGLE_PERIOD_NS, DESIGN_PRESSURE_PERIOD_NS)
    assert w.design and w.step_ns == 50_000_000 and w.reach_ns == 600_000_000
    assert Windows.of_periods(None, None).design
    assert Windows.of_periods(int(1.19 * DESIGN_ANGLE_PERIOD_NS), int(1.19 * DESIGN_PRESSURE_PERIOD_NS)).design
    assert not Windows.of_periods(int(1.25 * DESIGN_ANGLE_PERIOD_NS), None).design


@pytest.mark.parametrize('angle_hz, pressure_hz, lags_ms', [
    (10.0, 20.0, (0, 0)),           # a direct tap: stamped as read
    (5.0, 5.0, (-50, 100)),         # a slower gateway: up to a sensor's period stale each
    (2.0, 0.5, (-50, 100)),
    (25.0, 3.0, (-50, 40)),         # the angle sent faster than its sensor: up to a tick stale
    (10.0, 10.0, (-50, 100)),
])
def test_the_lags_a_gateway_s_stamps_allow(angle_hz, pressure_hz, lags_ms):
    """The angle may read later than the pressures by up to the period it was sent at, at most
    its sensor's (the design period), and earlier by up to theirs; nothing at the design rates."""
    w = Windows.of_periods(round(1e9 / angle_hz), round(1e9 / pressure_hz))
    lo, hi = w.lag_span_ns
    assert lo == pytest.approx(lags_ms[0] * 1e6, rel=0.1) and hi == pytest.approx(lags_ms[1] * 1e6, rel=0.1)
