"""Likelihood-ratio intervals and the variance inflation factor."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.stats import chi2

from steer_monitor.estimate.intervals import (
    CHI2_1_95,
    PLATEAU_THRESHOLD,
    Interval,
    inflation,
    plateau_interval,
    profile_interval,
)


def test_profile_interval_of_a_parabola_matches_the_closed_form():
    x = np.linspace(0, 1, 1001)
    delta = ((x - 0.4) / 0.05) ** 2            # a Gaussian profile with sigma 0.05
    iv = profile_interval(x, delta)
    half = 0.05 * math.sqrt(CHI2_1_95)
    assert iv.value == pytest.approx(0.4)
    assert iv.lo == pytest.approx(0.4 - half, abs=1e-4) and iv.hi == pytest.approx(0.4 + half, abs=1e-4)


def test_flat_tail_gives_a_one_sided_interval():
    x = np.linspace(0.05, 1.5, 74)
    delta = np.where(x < 0.3, ((0.3 - x) / 0.02) ** 2, 0.0)
    iv = profile_interval(x, delta)
    assert iv.hi is None and iv.one_sided
    assert iv.lo == pytest.approx(0.3 - 0.02 * math.sqrt(CHI2_1_95), abs=0.01)
    assert iv.contains(5.0) and not iv.contains(0.1)
    assert iv.scaled(1e3)['ci95'][1] is None


def test_interval_at_the_grid_floor_is_the_floor():
    x = np.linspace(0.05, 1.0, 20)
    iv = profile_interval(x, (x - 0.05) * 100)
    assert iv.lo == pytest.approx(0.05) and iv.value == pytest.approx(0.05)


@pytest.mark.parametrize('rho', [0.0, 0.5, 0.8])
def test_inflation_of_an_ar1_series_matches_theory(rho):
    """Independent check: for AR(1) the long-run variance factor is (1 + rho) / (1 - rho)
    (the Bartlett window over 2 s trims it a little for large rho)."""
    rng = np.random.default_rng(1)
    n = 200_000
    e = np.empty(n)
    e[0] = 0
    w = rng.normal(size=n)
    for i in range(1, n):
        e[i] = rho * e[i - 1] + w[i]
    t = np.arange(n, dtype=np.int64) * 50_000_000
    resid = np.stack([e, rng.normal(size=n) * np.nan], axis=1)
    vif = inflation(resid, t, 50_000_000)
    want = sum((1 - k / 41) * rho ** k for k in range(1, 41)) * 2 + 1
    assert vif == pytest.approx(max(want, 1.0), rel=0.05)


def test_interval_contains_handles_open_ends():
    assert Interval(1.0, None, None).contains(-1e9)
    assert not Interval(1.0, 0.5, 1.5).contains(2.0)


@pytest.mark.parametrize(('plateau', 'expect_open'), [(2.0, True), (9.4, True), (9.6, False), (50.0, False)])
def test_plateau_accepted_at_the_change_point_threshold(plateau, expect_open):
    axis = np.linspace(0.0, 0.6e-3, 121)
    # a parabola around 0.1 mm that flattens onto a plateau from 0.3 mm on (no contact beyond)
    delta = np.minimum(((axis - 0.1e-3) / 0.01e-3) ** 2, plateau)
    delta[axis >= 0.3e-3] = plateau
    iv = plateau_interval(axis, delta)
    plain = profile_interval(axis, delta)
    assert iv.value == pytest.approx(0.1e-3)
    if expect_open:
        # a bound's end rounded outward to the last value the profile rejects
        rejected = axis[(axis < plain.lo) & (delta > 3.841458820694124)]
        low = rejected.max() if rejected.size else axis[0]
        assert iv.hi is None and iv.lo == pytest.approx(low) and plain.lo - iv.lo < axis[1] - axis[0] + 1e-15
    else:
        assert iv == plain and iv.hi is not None
    assert PLATEAU_THRESHOLD == pytest.approx(chi2.ppf(0.95, 4))


def test_no_plateau_is_the_plain_interval():
    axis = np.linspace(0.0, 0.6e-3, 121)
    delta = ((axis - 0.2e-3) / 0.02e-3) ** 2
    assert plateau_interval(axis, delta) == profile_interval(axis, delta)


def test_a_lower_bound_is_rounded_outward_not_interpolated():
    """A ram that clamps in a few rows at 0.112 mm: the deviance is near zero from there to the
    plateau and steep only below; on a 0.02 mm grid the interpolated crossing put the bound at
    0.116 mm, above the truth. Rounded outward it is the last rejected grid value, 0.10 mm."""
    axis = np.round(np.arange(0.06e-3, 1.5e-3, 0.02e-3), 9)
    true = 0.112e-3
    delta = np.where(axis < true, 300.0 * (true - axis) / 0.02e-3, 0.0)    # what the grid sees
    iv = plateau_interval(axis, delta)
    assert iv.hi is None and iv.lo == pytest.approx(0.10e-3) and iv.lo <= true
    assert profile_interval(axis, delta).lo > true                          # interpolated: above the truth
