"""Likelihood-ratio intervals from a profiled residual sum of squares.

For Gaussian errors the profile log-likelihood ratio of a parameter is
(RSS(x) - RSS_min) / sigma^2, chi-square with 1 degree of freedom at the truth. The samples
of a log are not independent (20 Hz samples of a smooth process share model error), so
sigma^2 is inflated by the variance inflation factor of the residual series
(1 + 2 sum of Bartlett-weighted autocorrelations over ``MAX_LAG`` grid steps, times
1 + the correlation between the two rams' residuals). The interval of a clearance is the
set of grid values whose profile stays under the 95 % point; where that set runs to the
end of the grid the data only bound the clearance from one side and the interval says so
(``hi`` None).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

__all__ = [
    'CHI2_1_95',
    'CHI2_2_95',
    'PLATEAU_THRESHOLD',
    'Interval',
    'inflation',
    'plateau_interval',
    'profile_interval',
]

CHI2_1_95 = 3.841458820694124
CHI2_2_95 = 5.991464547107979
MAX_LAG = 40          # grid steps (2 s at 20 Hz)
PLATEAU_TOL = 1e-6    # deviance: grid points beyond any contact give the same model
PLATEAU_THRESHOLD = 9.487729036781154   # chi-square, 4 degrees of freedom, 95 %


@dataclass(frozen=True)
class Interval:
    """A point value and its 95 % interval [lo, hi]; ``hi`` None when unbounded above
    (the data only give a lower bound), ``lo`` None when unbounded below. SI units."""

    value: float
    lo: float | None
    hi: float | None
    edge: str | None = None     # 'low' / 'high': the constrained fit stopped on that end of its physical range

    @property
    def one_sided(self) -> bool:
        return self.lo is None or self.hi is None

    def contains(self, x: float) -> bool:
        return (self.lo is None or x >= self.lo - 1e-12) and (self.hi is None or x <= self.hi + 1e-12)

    def scaled(self, k: float, digits: int = 4) -> dict[str, object]:
        """``{"value", "ci95": [lo, hi], "bounded"}`` in units of 1/k (e.g. k = 1e3 for mm):
        the one JSON shape of an estimate in every command (docs/json.md); ``bounded`` false
        when an end of the interval is open (None), and then ``value`` is None too: a bound is
        no point estimate (the profile's best point on a plateau is any of its points)."""
        def r(v: float | None) -> float | None:
            return None if v is None else round(v * k, digits)
        out: dict[str, object] = {'value': None if self.one_sided else r(self.value), 'ci95': [r(self.lo), r(self.hi)],
                                  'bounded': not self.one_sided}
        if self.edge is not None:
            out['at_range_edge'] = self.edge
        return out


def inflation(resid: NDArray[np.float64], t_ns: NDArray[np.int64], step_ns: int) -> float:
    """Variance inflation factor of residuals ``resid`` of shape (n, 2) (two rams, NaN where
    absent) at grid times ``t_ns`` (n,), steady motion only. >= 1."""
    r = np.asarray(resid, float)
    both = np.all(np.isfinite(r), axis=1)
    if both.sum() > 10:
        a, b = r[both, 0] - r[both, 0].mean(), r[both, 1] - r[both, 1].mean()
        den = math.sqrt(float(a @ a) * float(b @ b))
        rho_rams = float(a @ b) / den if den > 0 else 0.0
    else:
        rho_rams = 0.0
    e = np.nanmean(np.where(np.isfinite(r), r, np.nan), axis=1)
    ok = np.isfinite(e)
    e, t = e[ok] - (np.mean(e[ok]) if ok.any() else 0.0), t_ns[ok]
    if e.size < 3:
        return max(1.0, 1.0 + rho_rams)
    var = float(e @ e) / e.size
    if var <= 0:
        return 1.0
    steps = np.round((t - t[0]) / step_ns).astype(np.int64)
    total = 1.0
    for k in range(1, MAX_LAG + 1):
        idx = np.searchsorted(steps, steps + k)
        idx = np.minimum(idx, steps.size - 1)
        hit = steps[idx] == steps + k
        if not hit.any():
            continue
        rho = float(e[hit] @ e[idx[hit]]) / hit.sum() / var
        total += 2.0 * (1.0 - k / (MAX_LAG + 1)) * rho
    return max(1.0, total) * max(1.0, 1.0 + rho_rams)


def profile_interval(axis: NDArray[np.float64], delta: NDArray[np.float64], threshold: float = CHI2_1_95,
                     open_low: bool = False) -> Interval:
    """Interval from a profile ``delta`` (>= 0, 0 at the best) over grid ``axis``.

    Crossings are interpolated linearly between grid points. Where the accepted set reaches
    the grid's last point the interval is open above (hi None); at the first point it is
    ``axis[0]`` (the physical lower limit of the grid) unless ``open_low``.
    """
    axis = np.asarray(axis, float)
    delta = np.asarray(delta, float)
    best = int(np.argmin(delta))
    inside = np.nonzero(delta <= threshold)[0]
    i0, i1 = int(inside.min()), int(inside.max())

    def cross(i_in: int, i_out: int) -> float:
        d_in, d_out = delta[i_in], delta[i_out]
        if not math.isfinite(d_out) or d_out == d_in:
            return float(axis[i_in])
        w = (threshold - d_in) / (d_out - d_in)
        return float(axis[i_in] + w * (axis[i_out] - axis[i_in]))

    lo: float | None = cross(i0, i0 - 1) if i0 > 0 else (None if open_low else float(axis[0]))
    hi = cross(i1, i1 + 1) if i1 < axis.size - 1 else None
    return Interval(float(axis[best]), lo, hi)


def plateau_interval(axis: NDArray[np.float64], delta: NDArray[np.float64], threshold: float = CHI2_1_95,
                     plateau_threshold: float = PLATEAU_THRESHOLD) -> Interval:
    """:func:`profile_interval` for a clearance whose profile ends in a plateau.

    Beyond the clearance that the largest load seen would close (the guide slipper never
    touches, the ram never clamps) every grid value is the same model, so the profile is flat
    to the grid's end. Comparing that plateau with a contact somewhere inside the data is a
    change-point test: the kink's place *and* its slope change (for Z_gb the guide friction
    mu_g, which has no effect on the plateau) are both free, and the supremum over the kink's
    place adds more (Davies' problem): the 1-degree-of-freedom threshold is far too tight.
    On the 18 course-keeping logs of the accuracy study whose true Z_gb lay on the plateau the
    plateau's deviance averaged 3.9 (0.4 to 9.2), as a chi-square with about 4 degrees of
    freedom would; the plateau is therefore accepted at that distribution's 95 % point
    (``PLATEAU_THRESHOLD``, 9.49). When it is, the interval runs from the usual lower end to
    the open end (``hi`` None): the data cannot tell a slipper that never touched from one
    that did.
    """
    axis = np.asarray(axis, float)
    delta = np.asarray(delta, float)
    iv = profile_interval(axis, delta, threshold)
    if delta.size < 3:
        return iv
    if iv.hi is None:
        return Interval(iv.value, _outward_low(axis, delta, threshold, iv.lo), None)
    flat = np.abs(delta - delta[-1]) <= PLATEAU_TOL
    start = delta.size - 1
    while start > 0 and flat[start - 1]:
        start -= 1
    if start >= delta.size - 1 or delta[-1] > plateau_threshold:
        return iv
    lo = float(axis[start]) if iv.lo is None else min(iv.lo, float(axis[start]))
    return Interval(iv.value, _outward_low(axis, delta, threshold, lo), None)


def _outward_low(axis: NDArray[np.float64], delta: NDArray[np.float64], threshold: float,
                 lo: float | None) -> float | None:
    """A lower bound's end rounded outward to the last value the profile rejects (the axis's
    first where none is). An open profile is not searched between its points (a contact
    placed there would be the noise's choice), so where the deviance crosses the threshold
    between two of them is not known: it is near zero wherever the contact shows in only a few
    rows, and rises steeply only where it shows in many. Interpolated, the crossing read 0.116
    mm for a ram clamping a little at 0.112 mm, a bound above the truth."""
    if lo is None:
        return None
    rejected = np.nonzero((axis < lo) & (delta > threshold))[0]
    return float(axis[rejected.max()]) if rejected.size else float(axis[0])
