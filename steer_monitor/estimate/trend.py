"""A clearance's wear trend over a vessel's logs, and the date it reaches its limit.

Each log gives an estimate with its 95 % interval, or a lower bound only. The trend is a
straight line c(t) = a + b (t - t_ref) fitted to them, as a meta-regression with random
effects:

* a two-sided estimate counts with its own standard error s_i = (hi - lo) / (2 x 1.96)
  *and* the scatter tau between logs beyond their own intervals: sigma_i^2 = s_i^2 + tau^2.
  Each log is one helm pattern, one speed and oil temperature: its estimate carries a bias of
  its own that its interval does not (measured: a steady vessel's twelve monthly logs gave a
  rate of 0.015 [0.007, 0.022] mm/year when each log counted with its interval alone). tau^2
  is DerSimonian and Laird's moment estimate for a regression (zero when the logs agree to
  their intervals), made again without the logs more than 3 sigma off the line it gives until they are the same
  logs;
* a lower bound only is a bound, not a value: it costs only when the line passes below it
  (a one-sided residual with the median sigma of the two-sided estimates);
* an outlying log does not carry the line: the loss is Huber's (quadratic to 2 sigma, linear
  beyond), and a log more than 3 sigma from the line is named;
* the rate's interval is Knapp and Hartung's: the covariance scaled by the residuals'
  dispersion when it exceeds one (never down) and Student's t with (logs - 2) degrees of
  freedom, not the normal: a dozen logs do not know their own scatter well.

The limit is reached where the line meets it; its 95 % interval is where the line's 95 % band
does (the band inverted: Fieller's interval), open at the late end when the band never reaches
the limit. The verdict is read from the rate's interval (:attr:`Trend.verdict`): **wear seen**
where it excludes zero (with the date); **no wear seen** only where even its upper end, from the
upper end of the line's band at the last log, reaches no limit within :data:`HORIZON_S` (two and a
half years, the time between dry-dockings, when the gear can be opened); otherwise **cannot
tell yet**, with the earliest the limit could come (:attr:`Trend.earliest_t`) and how many more
months of logs at the same pace would tell (:attr:`Trend.months_to_tell`: a slope's standard
error falls as the span to the power 3/2 when logs keep coming at one pace). Pure: arrays and
records in and out.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from steer_monitor.estimate.intervals import Interval

__all__ = ['CANNOT_TELL', 'HORIZON_S', 'HUBER_SIGMAS', 'NO_WEAR', 'OUTLIER_SIGMAS', 'WEAR_SEEN', 'Trend', 'TrendPoint',
           'band_crossing', 'fit_trend']

Z95 = 1.959963984540054
HUBER_SIGMAS = 2.0
OUTLIER_SIGMAS = 3.0
YEAR_S = 365.25 * 86400.0
CHI2_1_MEDIAN = 0.454936423119572
#: how far ahead a trend's verdict looks [s]: the time between dry-dockings
HORIZON_S = 2.5 * YEAR_S
WEAR_SEEN, NO_WEAR, CANNOT_TELL = 'wear seen', 'no wear seen', 'cannot tell yet'


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
        scale: Knapp and Hartung's factor on the covariance (>= 1).
        between: tau, the scatter between logs beyond their own intervals [SI].
        span_s: the time the two-sided estimates span [s]; dof: the t quantile's degrees of
            freedom.
        last_t: the last two-sided estimate's time [s]; last_hi: the upper end of the line's
            95 % band there [SI].
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
    between: float = 0.0
    span_s: float = 0.0
    dof: int = 1
    last_t: float = 0.0
    last_hi: float = 0.0

    @property
    def wear_seen(self) -> bool:
        """The rate's 95 % interval excludes zero wear (only then is there a limit date)."""
        return self.rate.lo is not None and self.rate.lo > 0

    @property
    def earliest_t(self) -> float | None:
        """The earliest the limit could come [s since 1970]: the upper end of the line's band at
        the last log going on at the upper end of the rate (None: at that rate it never comes;
        the last log's time where the band is past the limit already)."""
        hi = self.rate.hi
        if self.last_hi >= self.limit:
            return self.last_t
        if hi is None or hi <= 0:
            return None
        return self.last_t + (self.limit - self.last_hi) / hi

    @property
    def verdict(self) -> str:
        """:data:`WEAR_SEEN`, :data:`NO_WEAR` or :data:`CANNOT_TELL` (see the module)."""
        if self.wear_seen:
            return WEAR_SEEN
        early = self.earliest_t
        return NO_WEAR if early is None or early - self.last_t > HORIZON_S else CANNOT_TELL

    @property
    def months_to_tell(self) -> float | None:
        """Where the verdict is 'cannot tell yet': how many more months of logs at this pace
        would tell (the rate's interval clear of zero at the rate seen, or its upper end too low
        to reach the limit within the horizon, whichever comes first); None where neither can."""
        if self.verdict != CANNOT_TELL or self.rate.hi is None or self.span_s <= 0:
            return None
        b, half = self.rate.value, self.rate.hi - self.rate.value
        needs = []
        if b > 0:                                  # the interval's low end past zero
            needs.append(half / b)
        room = (self.limit - self.last_hi) / HORIZON_S - b   # how far above b the upper end may stay
        if room > 0:
            needs.append(half / room)
        if not needs:
            return None
        factor = min(needs)                        # the half-width must shrink by this
        return self.span_s * (factor ** (2.0 / 3.0) - 1.0) / (YEAR_S / 12)

    def message(self, unit: float = 1e-3, unit_name: str = 'mm') -> str:
        """One sentence: the verdict with the rate, and the date or what would tell."""
        k = YEAR_S / unit
        rate = f'{self.rate.value * k:.4f} [{self.rate.lo * k:.4f} .. {self.rate.hi * k:.4f}] {unit_name}/year'  # type: ignore[operator]
        months = self.span_s / (YEAR_S / 12)
        over = f'over {months:.0f} months ({self.used} logs; rate {rate})'
        verdict = self.verdict
        if verdict == WEAR_SEEN:
            return f'wearing at {rate} over {months:.0f} months ({self.used} logs)'
        if verdict == NO_WEAR:
            return (f'no wear seen {over}: even at the upper rate the limit is more than '
                    f'{HORIZON_S / YEAR_S:g} years away')
        early = self.earliest_t
        more = self.months_to_tell
        when = ('at the last log the line\'s 95 % band reaches past the limit already'
                if early is not None and early <= self.last_t else
                f'at the upper rate the limit could come in {(early - self.last_t) / (YEAR_S / 12):.0f} months'
                if early is not None else '')
        tell = (f'; about {max(more, 1.0):.0f} more months of logs at this pace would tell' if more is not None
                else '; more logs would tell')
        return f'cannot tell yet {over}: {when}{tell}'

    def at(self, t_s: float) -> float:
        return self.level + self.rate.value * (t_s - self.t_ref)


def fit_trend(points: Sequence[TrendPoint], limit: float) -> Trend | None:
    """The wear trend of ``points`` against ``limit``; None with fewer than three two-sided
    estimates spanning some time (a line through two says nothing of its own error)."""
    from scipy.optimize import least_squares
    from scipy.special import stdtrit

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
    s_own = np.maximum(np.array([(points[i].hi - points[i].lo) / (2 * Z95) for i in two]), 1e-12)  # type: ignore[operator]
    tb = np.array([points[i].t_s for i in one])
    lb = np.array([points[i].lo for i in one], dtype=float)
    x_two = (t - t_ref) / scale_t
    x_one = (tb - t_ref) / scale_t

    def fit(sig: np.ndarray, p0: np.ndarray):     # noqa: ANN202
        sig_b = float(np.median(sig))

        def resid(p: np.ndarray) -> np.ndarray:
            r2 = (p[0] + p[1] * x_two - v) / sig
            r1 = np.maximum(lb - (p[0] + p[1] * x_one), 0.0) / sig_b
            return np.concatenate([r2, r1])
        sol = least_squares(resid, p0, loss='huber', f_scale=HUBER_SIGMAS, method='trf')
        return sol, resid(sol.x)

    w = 1.0 / s_own ** 2
    design = np.stack([np.ones_like(x_two), x_two], axis=1)
    p0 = np.linalg.lstsq(design * np.sqrt(w)[:, None], v * np.sqrt(w), rcond=None)[0]
    # tau^2 from every log, then again from those within 3 sigma of the line it gives (an
    # outlying log would pass for scatter), and the robust fit with it
    inl = np.ones(len(two), bool)
    sol = None
    for first in (True, False, False, False, False):
        # the first pass from the median standardized square (one outlying log would pass for
        # scatter in the sum), then the moment estimate on the logs within 3 sigma
        tau2 = _between_logs(design[inl], v[inl], s_own[inl], robust=first)
        sig = np.sqrt(s_own ** 2 + tau2)
        sol, r = fit(sig, p0 if sol is None else sol.x)
        now = np.abs(r[:len(two)]) <= OUTLIER_SIGMAS
        if np.array_equal(now, inl) or now.sum() < 3:
            break
        inl = now
    p, jac = sol.x, sol.jac
    k = len(two) + int(np.count_nonzero(r[len(two):]))
    dof = max(k - 2, 1)
    # Knapp-Hartung: the residuals' dispersion scales the covariance up (never down)
    q = float(np.sum(r[:len(two)][inl] ** 2) + np.sum(r[len(two):] ** 2)) / max(int(inl.sum()) + len(one) - 2, 1)
    scale = max(1.0, q)
    try:
        cov = np.linalg.inv(jac.T @ jac) * scale
    except np.linalg.LinAlgError:
        return None
    z = float(stdtrit(dof, 0.975))
    a, b = float(p[0]), float(p[1]) / scale_t
    vaa, vbb, vab = float(cov[0, 0]), float(cov[1, 1]) / scale_t ** 2, float(cov[0, 1]) / scale_t
    se_b = math.sqrt(max(vbb, 0.0))
    rate = Interval(b, b - z * se_b, b + z * se_b)
    outliers = tuple(two[k] for k in np.nonzero(np.abs(r[:len(two)]) > OUTLIER_SIGMAS)[0])
    t_last = float(np.max(t))
    d_last = t_last - t_ref
    band_last = z * math.sqrt(max(vaa + d_last * d_last * vbb + 2 * d_last * vab, 0.0))
    limit_t = lo_t = hi_t = None
    if rate.lo is not None and rate.lo > 0:
        tau = (limit - a) / b
        limit_t = t_ref + tau
        lo_t, hi_t = band_crossing(a - limit, b, vaa, vbb, vab, z)
        lo_t = None if lo_t is None else t_ref + lo_t
        hi_t = None if hi_t is None else t_ref + hi_t
    return Trend(rate, a, t_ref, limit, limit_t, lo_t, hi_t, len(two), len(one), outliers, scale,
                 math.sqrt(tau2), float(np.ptp(t)), dof, t_last, a + b * d_last + band_last)


def _between_logs(design: np.ndarray, v: np.ndarray, s: np.ndarray, robust: bool = False) -> float:
    """DerSimonian and Laird's moment estimate of the variance between logs beyond their own
    (tau^2) for a regression of ``v`` (k,) on ``design`` (k, 2) with own standard errors ``s``:
    (Q - (k - 2)) / (tr W - tr((X'WX)^-1 X'W^2X)), at least 0. ``robust``: Q from the median
    of the standardized squares ((k - 2) median / 0.455, the median of chi-square(1)), which
    one outlying log does not move."""
    k = v.size
    if k <= 2:
        return 0.0
    w = 1.0 / s ** 2
    xtwx = design.T @ (design * w[:, None])
    try:
        inv = np.linalg.inv(xtwx)
    except np.linalg.LinAlgError:
        return 0.0
    beta = inv @ (design.T @ (w * v))
    sq = w * (v - design @ beta) ** 2
    q = float((k - 2) * np.median(sq) / CHI2_1_MEDIAN) if robust else float(np.sum(sq))
    den = float(np.sum(w) - np.trace(inv @ (design.T @ (design * (w ** 2)[:, None]))))
    return max(0.0, (q - (k - 2)) / den) if den > 0 else 0.0


def band_crossing(d: float, b: float, vaa: float, vbb: float, vab: float,
                   z: float = Z95) -> tuple[float | None, float | None]:
    """Where the line's 95 % band (``z`` standard errors) meets the limit: the roots tau of
    (d + b tau)^2 = z^2 (vaa + tau^2 vbb + 2 tau vab), d = a - limit. With the rate's
    interval excluding zero (b^2 > z^2 vbb) the set is one interval [tau1, tau2]."""
    z2 = z ** 2
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
