"""The clearances beside an unexplained misfit, over the places it could sit.

Where the model does not explain the pressures, :func:`~steer_monitor.estimate.locate.locate`
reads where the misfit lives off the residual of the model's fit, and the clearances are
refitted with a free level per piece of that range taken out (a nuisance). But that residual
is what the fit left: where the misfit sits beside the angles a clearance shows at, the fit
has bent the clearance to take part of it, and the residual then shows the rest displaced (an
angle band of friction at 12-18 deg read as less friction at 8.5-12 deg, the guide slipper's
clearance 0.299 [0.270, 0.330] mm for a true 0.118). The nuisance placed there holds the
wrong clearance in place. The same bent fit shows less of the misfit than there is: a band
at 12-18 deg on a voyage reaching 19.9 deg located at 12-17.4 deg, the rest of it read as the
ram clamping early (2Z 0.061 [0.060, 0.066] mm for 0.514).

So the term is first grown a piece at a time at either end while the fit, with the
clearances free, pays for each piece by the locator's own information criterion
(:func:`grown`); then tried where else it could sit: its range moved by ``SHIFTS`` of its
width to either side, each placement fitted on the same rows (those the located range's own
fit keeps: the instants near its ends left out). The placement of least RSS is the answer's;
every placement whose least RSS lies within the clearances' own 95 % threshold of it (in the
same units as their profiles: the residual variance, inflated) fits as well, and each
interval the answer gives spans theirs too: a profile over where the term sits, as each
clearance's interval is a profile over the other parameters. Where every placement but one
fits clearly worse, the intervals are that one's.

Where the term fits best away from where the residual put it, the two ways of placing it
disagree, and the best of a few placements tried is no more than the best of those: with the
band partly covered, the rest of it still bends the clearance (a band at 12-18 deg on a
voyage reaching 19.8 deg, read at 7.5-12 deg off the residual and fitting best at 12-16.4 deg:
Z_gb 0.134 [0.124, 0.175] mm for 0.067). Where it sits is then not known, and the intervals
span those of every placement tried.

Pure: arrays and records in and out.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from steer_monitor.estimate import fit as F
from steer_monitor.estimate.batch import ClearanceEstimate, estimate_clearances, make_rows
from steer_monitor.estimate.effects import z_columns
from steer_monitor.estimate.intervals import Interval
from steer_monitor.estimate.locate import MIN_BIC_DROP, Located
from steer_monitor.estimate.observe import EstimateError, Observations
from steer_monitor.model.gear import GearParams

__all__ = ['SHIFTS', 'Placed', 'grown', 'moved_off', 'placements', 'spanned']

#: the located range moved by these shares of its width (its own place, 0, is always tried)
SHIFTS = (-1.0, -0.5, 0.5, 1.0)

_SPANNED = ('two_z', 'z_gb', 'k_gl_max', 'seal_friction', 'mu_bushing', 'mu_guide')


@dataclass(frozen=True)
class Placed:
    """The nuisance fit of the misfit placed at ``where`` (the located range moved by
    ``shift`` of its width: 0 where the residual put it): ``est`` its clearances, ``fits``
    True when its least RSS lies within the 95 % threshold of the best placement's."""

    where: Located
    est: ClearanceEstimate
    fits: bool = True
    shift: float = 0.0


def _moved(located: Located, share: float) -> Located | None:
    """``located`` with its range moved by ``share`` of its width (None where a magnitude
    would go below 0)."""
    width = located.hi - located.lo
    lo, hi = located.lo + share * width, located.hi + share * width
    if located.either_side and lo < 0:
        return None
    return located.moved(lo, hi)


def _unit(est: ClearanceEstimate) -> float:
    """The variance unit RSS differences are read in: the residual variance times the largest
    of the clearances' own scales (their inflation where none is finite)."""
    scales = [s for s in est.scales if math.isfinite(s)]
    return est.sigma2 * (max(scales) if scales else est.inflation)


def grown(located: Located, est: ClearanceEstimate, fit: Callable[[Located], ClearanceEstimate | None],
           obs: Observations) -> tuple[Located, ClearanceEstimate]:
    """``located`` grown a piece at a time at either end, each end moved by one piece's width
    and the pieces kept as they were, while the fit with the clearances free pays for each
    added piece by the information criterion the locator chooses a term by (on the effective
    sample size, the rows over the residual's variance inflation; a fall of at least
    ``MIN_BIC_DROP``); with its estimate. The residual the locator reads is what the model's
    fit left, and where the fit bent a clearance to take part of the misfit, the residual
    shows less of it than there is: a band of friction at 12-18 deg on a voyage reaching 19.9
    deg located at 12-17.4 deg, its rest read as a ram clamping early (2Z 0.061 [0.060,
    0.066] mm for 0.514)."""
    k = len(located.columns(obs)[1])        # the pieces with rows enough to be fitted
    step = (located.hi - located.lo) / located.cut_into
    located = replace(located, pieces=located.cut_into)
    while True:
        n_eff = max(est.rows / max(est.inflation, 1.0), 2.0)
        best: tuple[float, Located, ClearanceEstimate] | None = None
        for lo, hi in ((located.lo, located.hi + step), (located.lo - step, located.hi)):
            if located.either_side and lo < 0:
                continue
            cand = replace(located.moved(lo, hi), pieces=located.pieces + 1)
            if len(cand.columns(obs)[1]) <= k:      # the new piece has too few rows
                continue
            e = fit(cand)
            if e is None or not e.rss_floor < est.rss_floor:
                continue
            score = n_eff * math.log(e.rss_floor / est.rss_floor) + math.log(n_eff)
            if score < -MIN_BIC_DROP and (best is None or score < best[0]):
                best = (score, cand, e)
        if best is None:
            return located, est
        _, located, est = best
        k += 1


def placements(gear: GearParams, obs: Observations, keep: NDArray[np.bool_], extra: Sequence[F.Column],
               located: Located, grid_2z: NDArray, model_inflation: float,
               shifts: Sequence[float] = SHIFTS, grow: bool = True) -> list[Placed]:
    """The nuisance fit of ``located`` at its own range (grown while the fit pays for it,
    :func:`grown`) and moved by each of ``shifts`` of its width, all on the rows of ``keep``
    less the instants near the located range's ends (so the fit at its own place is the one
    made without the others); best first (least RSS), each marked whether it fits as well as
    the best. Empty when the located place leaves too little motion to fit (the others are
    then no answer of their own)."""
    near = located.near_ends(obs)
    z = z_columns(obs, gear)
    base = keep & ~near

    def fit(w: Located) -> ClearanceEstimate | None:
        zl, cols = w.columns(obs)
        if not cols:
            return None
        rows = make_rows(obs, {**z, **zl}, base)
        try:
            est = estimate_clearances(gear, obs, rows, tuple(extra) + cols, grid_2z=grid_2z,
                                      model_inflation=model_inflation)
        except EstimateError:       # too little motion left outside this placement
            return None
        return est if math.isfinite(est.rss_floor) else None

    at = fit(located)
    if at is None:                  # the located place itself could not be fitted
        return []
    if grow:
        located, at = grown(located, at, fit, obs)
    fitted = [(0.0, located, at)]
    for s in shifts:
        if s and (m := _moved(located, s)) is not None and (e := fit(m)) is not None:
            fitted.append((s, m, e))
    fitted.sort(key=lambda swe: swe[2].rss_floor)
    best = fitted[0][2]
    unit = _unit(best)
    threshold = max(best.thresholds)
    return [Placed(w, e, (e.rss_floor - best.rss_floor) <= threshold * unit, shift) for shift, w, e in fitted]


def _span(ivs: Sequence[Interval]) -> Interval:
    """The first interval's point and edge, its ends reaching to every interval's."""
    first = ivs[0]
    lo = None if any(iv.lo is None for iv in ivs) else min(iv.lo for iv in ivs if iv.lo is not None)
    hi = None if any(iv.hi is None for iv in ivs) else max(iv.hi for iv in ivs if iv.hi is not None)
    return Interval(first.value, lo, hi, first.edge)


def moved_off(placed: Sequence[Placed]) -> bool:
    """True when the term fits best away from where the residual put it (``placed`` best
    first): the two ways of placing it disagree, and where it sits is not known."""
    return bool(placed) and placed[0].shift != 0.0


def spanned(placed: Sequence[Placed]) -> ClearanceEstimate:
    """The best placement's estimate (``placed[0]``) with each interval spanning those of every
    placement that fits as well; of every placement tried when the best is not where the
    residual put the term (:func:`moved_off`). A clearance that any of them bounds only from
    below is a lower bound, saying why where the best's had no reason of its own."""
    best = placed[0].est
    alike = [p.est for p in placed if p.fits or moved_off(placed)]
    if len(alike) == 1:
        return best
    out = {name: _span([getattr(e, name) for e in alike]) for name in _SPANNED}
    why = list(best.bound_why)
    because = ('where the misfit the model lacks sits is not known, and at some of its places the clearance reads '
               'higher' if moved_off(placed) else
               'the misfit the model lacks fits as well elsewhere, where the clearance reads higher')
    for k, name in enumerate(('two_z', 'z_gb')):
        if out[name].hi is None and getattr(best, name).hi is not None and not why[k]:
            why[k] = because
    return replace(best, **out, bound_why=(why[0], why[1]))
