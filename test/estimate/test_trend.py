"""The wear trend: rate and limit date with honest intervals, bounds used as bounds, an
outlying log resisted, no date without detected wear."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import brentq

from steer_monitor.estimate.trend import (
    CANNOT_TELL,
    HORIZON_S,
    NO_WEAR,
    WEAR_SEEN,
    YEAR_S,
    Z95,
    TrendPoint,
    band_crossing,
    fit_trend,
)

T0 = 1_767_225_600.0          # 2026-01-01
MM = 1e-3


def monthly(rate_mm_year, c0_mm, sigma_mm, rng, months=12, bound_every=0, outlier=None):
    """A year of monthly estimates of a clearance growing at ``rate_mm_year``."""
    pts = []
    for k in range(months):
        t = T0 + k * YEAR_S / 12
        true = (c0_mm + rate_mm_year * k / 12) * MM
        s = sigma_mm[k % len(sigma_mm)] * MM if isinstance(sigma_mm, list) else sigma_mm * MM
        v = true + rng.normal(0, s)
        if outlier is not None and k == outlier:
            v += 12 * s
        if bound_every and k % bound_every == 1:
            pts.append(TrendPoint(t, v, true - abs(rng.normal(0, s)) - 2 * s, None))   # a bound below the truth
        else:
            pts.append(TrendPoint(t, v, v - Z95 * s, v + Z95 * s))
    return pts


def true_date(rate_mm_year, c0_mm, limit_mm):
    return T0 + (limit_mm - c0_mm) / rate_mm_year * YEAR_S


def test_band_crossing_against_a_root_finder():
    rng = np.random.default_rng(1)
    for _ in range(50):
        d, b = -abs(rng.normal(0.1, 0.05)), abs(rng.normal(0.01, 0.002))
        vaa, vbb = rng.uniform(1e-5, 1e-4), rng.uniform(1e-7, 1e-6)
        vab = rng.uniform(-0.5, 0.5) * math.sqrt(vaa * vbb)
        if b * b <= Z95 ** 2 * vbb:
            continue
        lo, hi = band_crossing(d, b, vaa, vbb, vab)

        def g(tau, d=d, b=b, vaa=vaa, vbb=vbb, vab=vab):
            return (d + b * tau) ** 2 - Z95 ** 2 * (vaa + tau * tau * vbb + 2 * tau * vab)
        centre = -d / b
        assert g(centre) < 0
        assert lo == pytest.approx(brentq(g, centre - 1e6, centre), rel=1e-9, abs=1e-9)
        assert hi == pytest.approx(brentq(g, centre, centre + 1e6), rel=1e-9, abs=1e-9)


@pytest.mark.parametrize('rate, c0, sigma', [(0.10, 0.12, 0.01), (0.05, 0.15, 0.01), (0.20, 0.05, [0.01, 0.03])])
def test_rate_and_date_intervals_cover_the_truth(rate, c0, sigma):
    """Coverage over 200 simulated vessels: the 95 % intervals hold the truth about 95 % of
    the time (a binomial 95 % band for 200 trials reaches down to 0.91)."""
    rng = np.random.default_rng(7)
    hit_rate = hit_date = dated = 0
    n = 200
    for _ in range(n):
        tr = fit_trend(monthly(rate, c0, sigma, rng), 0.25 * MM)
        assert tr is not None
        hit_rate += tr.rate.lo * YEAR_S / MM <= rate <= tr.rate.hi * YEAR_S / MM     # in mm/year
        if tr.limit_t is not None:
            dated += 1
            hit_date += tr.limit_t_lo <= true_date(rate, c0, 0.25) <= tr.limit_t_hi
    assert hit_rate / n >= 0.91
    assert dated / n >= 0.9 and hit_date / dated >= 0.91


def test_no_wear_gives_no_date():
    rng = np.random.default_rng(3)
    dates = [fit_trend(monthly(0.0, 0.12, 0.01, rng), 0.25 * MM).limit_t for _ in range(200)]
    assert sum(d is None for d in dates) >= 0.93 * 200        # the rate's interval holds zero


def test_an_outlying_log_does_not_carry_the_line():
    rng = np.random.default_rng(5)
    pts = monthly(0.10, 0.12, 0.005, rng, outlier=11)          # the last month 12 sigma high
    tr = fit_trend(pts, 0.25 * MM)
    assert tr.outliers == (11,)
    assert tr.rate.value * YEAR_S / MM == pytest.approx(0.10, abs=0.02)
    plain = np.polyfit([p.t_s for p in pts], [p.value for p in pts], 1)[0] * YEAR_S / MM
    assert plain > 0.13                                        # least squares is pulled up


def test_lower_bounds_are_bounds():
    """Bounds below the truth change nothing; a bound above the line pulls it up."""
    rng = np.random.default_rng(9)
    pts = monthly(0.10, 0.12, 0.01, rng, bound_every=3)
    with_bounds = fit_trend(pts, 0.25 * MM)
    two_sided = fit_trend([p for p in pts if p.hi is not None], 0.25 * MM)
    assert with_bounds.bounds == 4 and with_bounds.used == 8
    assert with_bounds.rate.value == pytest.approx(two_sided.rate.value, rel=1e-6)
    high = pts + [TrendPoint(T0 + YEAR_S, 0.0, 0.30 * MM, None)]          # at least 0.30 mm at the end
    assert fit_trend(high, 0.25 * MM).at(T0 + YEAR_S) > two_sided.at(T0 + YEAR_S)


@pytest.mark.parametrize('pts', [
    [],
    [TrendPoint(T0, 1e-4, 0.9e-4, 1.1e-4), TrendPoint(T0 + 1e6, 1e-4, 0.9e-4, 1.1e-4)],
    [TrendPoint(T0, 1e-4, 0.9e-4, 1.1e-4)] * 3,                                   # no time span
    [TrendPoint(T0 + k, 1e-4, 1e-4, None) for k in range(5)],                    # bounds only
])
def test_too_little_to_fit(pts):
    assert fit_trend(pts, 0.25 * MM) is None


def biased_monthly(rate_mm_year, c0_mm, sigma_mm, tau_mm, rng, months=12):
    """Monthly estimates whose own intervals are honest for the noise (sigma) but each log also
    carries a bias of its own (tau: its helm pattern, speed, oil), as real logs do."""
    pts = []
    for k in range(months):
        t = T0 + k * YEAR_S / 12
        v = (c0_mm + rate_mm_year * k / 12 + rng.normal(0, tau_mm) + rng.normal(0, sigma_mm)) * MM
        pts.append(TrendPoint(t, v, v - Z95 * sigma_mm * MM, v + Z95 * sigma_mm * MM))
    return pts


def test_a_steady_vessel_whose_logs_scatter_beyond_their_intervals_gets_no_date():
    """Each log biased by twice its own standard error: with the scatter between logs as a random
    effect, a year of logs of a gear that does not wear gets a date 2-3 % of the time (each log
    counted with its interval and a dispersion factor, 5 %)."""
    rng = np.random.default_rng(11)
    trends = [fit_trend(biased_monthly(0.0, 0.12, 0.004, 0.008, rng), 0.25 * MM) for _ in range(300)]
    dated = sum(tr.limit_t is not None for tr in trends)
    assert dated <= 0.04 * 300
    undated = [tr for tr in trends if tr.limit_t is None]
    assert all(not tr.wear_seen and tr.message().startswith(('no wear seen over 11 months',
                                                            'cannot tell yet over 11 months')) for tr in undated)
    assert sum(tr.verdict == NO_WEAR for tr in undated) >= 0.5 * len(undated)
    assert np.median([tr.between for tr in trends]) / MM == pytest.approx(0.008, rel=0.3)


def test_a_wearing_vessel_whose_logs_scatter_gets_its_date_within_its_interval():
    """The rate's and the date's intervals hold the truth at their rate (each log counted with its
    interval and a dispersion factor: 89-90 %)."""
    rng = np.random.default_rng(12)
    n, hit_rate, hit_date, dated = 300, 0, 0, 0
    for _ in range(n):
        tr = fit_trend(biased_monthly(0.10, 0.12, 0.004, 0.008, rng), 0.25 * MM)
        hit_rate += tr.rate.lo * YEAR_S / MM <= 0.10 <= tr.rate.hi * YEAR_S / MM
        if tr.limit_t is not None:
            dated += 1
            hit_date += (tr.limit_t_lo is not None and tr.limit_t_lo <= true_date(0.10, 0.12, 0.25)
                         and (tr.limit_t_hi is None or true_date(0.10, 0.12, 0.25) <= tr.limit_t_hi))
    assert hit_rate / n >= 0.93
    assert dated / n >= 0.9 and hit_date / dated >= 0.93


def test_a_trend_that_cannot_tell_says_so_with_the_earliest_date_and_what_would_tell():
    """Three logs over six months, Z_gb 0.10, 0.14, 0.18 mm (the first and last intervals do not
    overlap): the rate's interval holds zero, but at its upper end the 0.25 mm limit is months
    away: 'cannot tell yet', the earliest the limit could come, and how many more months of logs
    would tell; never 'no wear seen'."""
    pts = [TrendPoint(T0, 0.10 * MM, 0.085 * MM, 0.115 * MM),
           TrendPoint(T0 + YEAR_S / 4, 0.14 * MM, 0.08 * MM, 0.20 * MM),
           TrendPoint(T0 + YEAR_S / 2, 0.18 * MM, 0.165 * MM, 0.195 * MM)]
    tr = fit_trend(pts, 0.25 * MM)
    assert tr is not None
    if tr.wear_seen:                     # the three are steep enough to say so: then a date
        assert tr.verdict == WEAR_SEEN and tr.limit_t is not None
        return
    assert tr.verdict == CANNOT_TELL
    early = tr.earliest_t
    assert early is not None and tr.last_t <= early < tr.last_t + HORIZON_S
    assert tr.months_to_tell is not None and tr.months_to_tell > 0
    msg = tr.message()
    assert msg.startswith('cannot tell yet over 6 months (3 logs; rate ')
    assert ('at the upper rate the limit could come in ' in msg
            or "at the last log the line's 95 % band reaches past the limit already" in msg)
    assert 'more months of logs at this pace would tell' in msg


def test_no_wear_is_said_only_where_even_the_upper_rate_reaches_no_limit_within_the_horizon():
    """A steady slipper at 0.10 mm, a year of tight logs: no wear seen, the upper rate far from
    the limit; the same logs at 0.24 mm, just under the 0.25 mm limit: the upper rate reaches it
    within the horizon, so it cannot tell."""
    def logs(level):
        return [TrendPoint(T0 + k * YEAR_S / 12, level * MM, (level - 0.004) * MM, (level + 0.004) * MM)
                for k in range(12)]
    far, near = fit_trend(logs(0.10), 0.25 * MM), fit_trend(logs(0.24), 0.25 * MM)
    assert far.verdict == NO_WEAR and far.earliest_t is None or far.earliest_t - far.last_t > HORIZON_S
    assert near.verdict == CANNOT_TELL and near.earliest_t - near.last_t <= HORIZON_S
