"""The hard-over time's closed form against the rudder's rate integrated numerically, and
the pumps told from a time."""

from __future__ import annotations

import math

import pytest
from scipy.integrate import solve_ivp

from steer_monitor.model.hardover import hard_over_time, pumps_running


@pytest.mark.parametrize('h, v, n, a1, a2', [(0.6, 15e-3, 1, 34.5, 29.5), (0.6, 15e-3, 2, 35.0, 30.0),
                                             (0.85, 9e-3, 3, 34.5, 29.5), (0.4, 30e-3, 2, 10.0, 5.0)])
def test_closed_form_against_the_integrated_rate(h, v, n, a1, a2):
    """d alpha / dt = n v cos^2(alpha) / H from -a1 until +a2, by an adaptive ODE solver."""
    def rate(_t, y):
        return [n * v * math.cos(y[0]) ** 2 / h]

    def reached(_t, y):
        return y[0] - math.radians(a2)
    reached.terminal = True
    sol = solve_ivp(rate, (0.0, 1e4), [-math.radians(a1)], events=reached, rtol=1e-10, atol=1e-12)
    assert hard_over_time(h, v, n, a1, a2) == pytest.approx(sol.t_events[0][0], rel=1e-7)


@pytest.mark.parametrize('seconds, want', [(50.1, 1), (40.0, 1), (34.0, 1), (32.0, 2), (25.0, 2), (12.0, 2),
                                           (1e9, 1)])
def test_pumps_told_from_the_time(seconds, want):
    assert hard_over_time(0.6, 15e-3) == pytest.approx(50.12, abs=0.01)
    assert pumps_running(seconds, 0.6, 15e-3, 2) == want


@pytest.mark.parametrize('args', [(0.0, 15e-3, 1), (0.6, -1.0, 1), (0.6, 15e-3, 0)])
def test_bad_arguments(args):
    with pytest.raises(ValueError, match='hard-over time needs H > 0, v > 0 and pumps >= 1'):
        hard_over_time(*args)
