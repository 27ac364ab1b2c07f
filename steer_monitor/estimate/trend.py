"""A clearance's wear trend over a vessel's logs, and the date it reaches its limit.

Each log gives an estimate with its 95 % interval, or a lower bound only. The trend is a
straight line c(t) = a + b (t - t_ref) fitted to them:

* a two-sided estimate counts with its own standard error, sigma = (hi - lo) / (2 x 1.96);
* a lower bound only is a bound, not a value: it costs only when the line passes below it
  (a one-sided residual with the median sigma of the two-sided estimates);
* an outlying log does not carry the line: the loss is Huber's (quadratic to 2 sigma, linear
  beyond), and a log more than 3 sigma from the line is named;
* the parameters' covariance is the Gauss-Newton one at the solution, scaled up by the
  residuals' robust dispersion when the logs scatter more than their intervals say (never
  down).

The rate's 95 % interval is b +- 1.96 se(b). The limit is reached where the line meets it;
its 95 % interval is where the line's 95 % band does (the band inverted: Fieller's
interval), open at the late end when the band never reaches the limit. No date is given
when the rate's interval does not exclude zero: wear is then not detected, and a line with
no slope says nothing about a date. Pure: arrays and records in and out.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from steer_monitor.estimate.intervals import Interval

__all__ = ['HUBER_SIGMAS', 'OUTLIER_SIGMAS', 'Trend', 'TrendPoint', 'fit_trend']

Z95 = 1.959963984540054
HUBER_SIGMAS = 2.0
OUTLIER_SIGMAS = 3.0
YEAR_S = 365.25 * 86400.0


@dataclass(frozen=True)
class TrendPoint:
    """One log's estimate: time [s since 1970], value and 95 % interval [SI]; ``hi`` None
    for a lower bound only (then ``value`` is not used)."""

    t_s: float
    value: float
    lo: float | None
    hi: float | None


@dataclass(frozen=True)
class Trend:
    """The fitted line and what it says.

    Attributes:
        rate: wear rate with its 95 % interval [SI per second].
        level: the line's value at ``t_ref`` [SI]; ``t_ref`` [s since 1970].
        limit: the limit [SI]; ``limit_t`` when the line reaches it (None: wear not
            detected), ``limit_t_lo`` / ``limit_t_hi`` its 95 % interval (None: open).
        used, bounds: two-sided estimates and lower bounds the fit used.
        outliers: indices (into the points given) more than 3 sigma from the line.
        scale: factor applied to the covariance (>= 1: the logs scatter beyond their intervals).
    """

    rate: Interval
    level: float
    t_ref: float
    limit: float
    limit_t: float | None
    limit_t_lo: float | None
    limit_t_hi: float | None
    used: int
    bounds: int
    outliers: tuple[int, ...]
    scale: float

    def at(self, t_s: float) -> float:
        return self.level + self.rate.value * (t_s - self.t_ref)


def fit_trend(points: Sequence[TrendPoint], limit: float) -> Trend | None:
    """The wear trend of ``points`` against ``limit``; None with fewer than three two-sided
    estimates spanning some time (a line through two says nothing of its own error)."""
    from scipy.optimize import least_squares

    two = [i for i, p in enumerate(points) if p.lo is not None and p.hi is not None and p.hi > p.lo]
    one = [i for i, p in enumerate(points) if p.hi is None and p.lo is not None]
    if len(two) < 3:
        return None
    t = np.array([points[i].t_s for i in two])
    if np.ptp(t) <= 0:
        return None
    t_ref = float(np.mean(t))
    scale_t = max(float(np.ptp(t)), 1.0)          # fit in units of the span: a well-scaled problem
    v = np.array([points[i].value for i in two])
    sig = np.array([(points[i].hi - points[i].lo) / (2 * Z95) for i in two])  # type: ignore[operator]
    sig = np.maximum(sig, 1e-12)
    tb = np.array([points[i].t_s for i in one])
    lb = np.array([points[i].lo for i in one], dtype=float)
    sig_b = float(np.median(sig))
    x_two = (t - t_ref) / scale_t
    x_one = (tb - t_ref) / scale_t

    def resid(p: np.ndarray) -> np.ndarray:
        r2 = (p[0] + p[1] * x_two - v) / sig
        r1 = np.maximum(lb - (p[0] + p[1] * x_one), 0.0) / sig_b
        return np.concatenate([r2, r1])

    # start from the weighted straight line through the two-sided estimates
    w = 1.0 / sig ** 2
    A = np.stack([np.ones_like(x_two), x_two], axis=1) * np.sqrt(w)[:, None]
    p0 = np.linalg.lstsq(A, v * np.sqrt(w), rcond=None)[0]
    sol = least_squares(resid, p0, loss='huber', f_scale=HUBER_SIGMAS, method='trf')
    p = sol.x
    J = sol.jac
    r = resid(p)
    n_eff = len(two) + int(np.count_nonzero(r[len(two):]))
    # robust dispersion of the two-sided residuals: 1.4826 MAD, never below 1
    mad = 1.4826 * float(np.median(np.abs(r[:len(two)] - np.median(r[:len(two)]))))
    scale = max(1.0, mad ** 2) if n_eff > 2 else 1.0
    try:
        cov = np.linalg.inv(J.T @ J) * scale
    except np.linalg.LinAlgError:
        return None
    a, b = float(p[0]), float(p[1]) / scale_t
    vaa, vbb, vab = float(cov[0, 0]), float(cov[1, 1]) / scale_t ** 2, float(cov[0, 1]) / scale_t
    se_b = math.sqrt(max(vbb, 0.0))
    rate = Interval(b, b - Z95 * se_b, b + Z95 * se_b)
    outliers = tuple(two[k] for k in np.nonzero(np.abs(r[:len(two)]) > OUTLIER_SIGMAS)[0])
    limit_t = lo_t = hi_t = None
    if rate.lo is not None and rate.lo > 0:
        tau = (limit - a) / b
        limit_t = t_ref + tau
        lo_t, hi_t = _band_crossing(a - limit, b, vaa, vbb, vab)
        lo_t = None if lo_t is None else t_ref + lo_t
        hi_t = None if hi_t is None else t_ref + hi_t
    return Trend(rate, a, t_ref, limit, limit_t, lo_t, hi_t, len(two), len(one), outliers, scale)


def _band_crossing(d: float, b: float, vaa: float, vbb: float, vab: float) -> tuple[float | None, float | None]:
    """Where the line's 95 % band meets the limit: the roots tau of
    (d + b tau)^2 = z^2 (vaa + tau^2 vbb + 2 tau vab), d = a - limit. With the rate's
    interval excluding zero (b^2 > z^2 vbb) the set is one interval [tau1, tau2]."""
    z2 = Z95 ** 2
    qa = b * b - z2 * vbb
    qb = 2.0 * (d * b - z2 * vab)
    qc = d * d - z2 * vaa
    if qa <= 0:
        return None, None
    disc = qb * qb - 4 * qa * qc
    if disc < 0:        # the band holds the limit everywhere: cannot happen with qa > 0 and the line crossing
        return None, None
    root = math.sqrt(disc)
    return (-qb - root) / (2 * qa), (-qb + root) / (2 * qa)
