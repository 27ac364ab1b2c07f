"""What the screening of a candidate effect records, an adopted step, and the instants set
aside before screening. Pure."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from steer_monitor.estimate.batch import ClearanceEstimate, lag_moments
from steer_monitor.estimate.effects import Candidate, Effect
from steer_monitor.estimate.intervals import Interval
from steer_monitor.estimate.plausible import refusal

__all__ = ['MIN_BIC_DROP', 'MIN_CV_DEVIANCE', 'OUTLIER_SIGMAS', 'Screening', 'Step', 'best_per_name',
           'outlier_instants', 'screening_record', 'takes_systematic']

MIN_CV_DEVIANCE = 10.0   # held-out deviance on the effective sample size
MIN_BIC_DROP = 15.0      # "very strong" (10) plus 2 ln 10 for the ~10 candidates a round tests
OUTLIER_SIGMAS = 5.0     # instants set aside before screening (see outlier_instants)

@dataclass(frozen=True)
class Screening:
    """One candidate's score: held-out gain (1 - MSE_cv / MSE_cv before) and deviance
    (n_eff ln(MSE_cv before / MSE_cv)), BIC change, in-sample RMS [N], the clearances at its
    optimum [m], its fitted coefficients (SI) and,
    when its coefficients break the physics the effect stands for, why it is refused
    (a refused candidate never passes, however well it fits)."""

    name: str
    fixed: dict[str, float]
    cv_gain: float
    delta_bic: float
    rms: float
    two_z: float
    z_gb: float
    values: dict[str, float] = field(default_factory=dict)
    refused: str | None = None
    cv_deviance: float = 0.0

    @property
    def passes(self) -> bool:
        return self.refused is None and self.cv_deviance >= MIN_CV_DEVIANCE and self.delta_bic <= -MIN_BIC_DROP


@dataclass(frozen=True)
class Step:
    """One adopted effect: its name, parameters (engineers' units, with intervals, from the
    final model), its screening, and the estimates before and after it. In a run under a
    given model (:func:`analyze` with ``model``) an effect is applied, not screened:
    ``screening`` is None and ``before`` is ``after``."""

    name: str
    params: dict[str, Interval | str]
    screening: Screening | None
    before: ClearanceEstimate = field(repr=False)
    after: ClearanceEstimate = field(repr=False)
    candidate: Candidate = field(repr=False)

    @property
    def effect(self) -> Effect:
        """The effect as a later run applies it (:attr:`Analysis.adopted`)."""
        return Effect(self.name, tuple(sorted((self.candidate.fixed or {}).items())), self.candidate.shape)


def screening_record(cand: Candidate, rss: float, n: float, cv: float, tz: float, zg: float, p: int,
               rss0: float, n0: float, cv0: float, p0: int, n_eff: float,
               values: Mapping[str, float] | None = None, scale: tuple[float, float] = (math.inf, math.inf)
               ) -> Screening:
    mse, mse0 = rss / n, rss0 / n0
    d_bic = n_eff * math.log(max(mse, 1e-300) / mse0) + (p - p0) * math.log(max(n_eff, 2.0))
    ok = math.isfinite(cv) and cv > 0 and cv0 > 0
    gain = 1.0 - cv / cv0 if ok else 0.0
    dev = n_eff * math.log(cv0 / cv) if ok else 0.0
    values = dict(values or {})
    return Screening(cand.name, dict(cand.fixed or {}), gain, d_bic, math.sqrt(mse), tz, zg, values,
                     refusal(cand.name, values, *scale), dev)


def best_per_name(scored: list[tuple[Screening, Candidate]]) -> list[tuple[Screening, Candidate]]:
    """Stribeck comes with several v_s: keep each name's best."""
    best: dict[str, tuple[Screening, Candidate]] = {}
    for sc in scored:
        cur = best.get(sc[0].name)
        if cur is None or sc[0].cv_gain > cur[0].cv_gain:
            best[sc[0].name] = sc
    return list(best.values())


def outlier_instants(resid: NDArray[np.float64], direction: NDArray[np.int8]) -> NDArray[np.bool_]:
    """Instants (n,) where either ram's residual (n, 2) [N] lies more than ``OUTLIER_SIGMAS``
    robust standard deviations (1.4826 x the median absolute residual) *against* the
    direction of motion ``direction`` (n,): the pressure held less friction than the model
    puts there.

    They are instants the steadiness test passed while the rudder stood: 10 Hz angle
    samples cannot resolve a pause of a few tens of ms between an autopilot's steps, and
    there the pressure holds no friction (a residual of the whole friction, 2 to 4 bar,
    against 0.35 bar of sensor noise). Left in, a few hundred of them bias the seal
    friction low by more than its interval. Only that side is cut: friction *above* the
    model (a Stribeck rise at low speed) is an effect to find, not an outlier. Gaussian
    noise passes 5 sigma on one side once in 3.5 million rows."""
    r = np.asarray(resid, float) * np.asarray(direction, float)[:, None]
    fin = np.isfinite(r)
    if fin.sum() < 50:
        return np.zeros(r.shape[0], bool)
    scale = 1.4826 * float(np.median(np.abs(r[fin])))
    if not scale > 0:
        return np.zeros(r.shape[0], bool)
    with np.errstate(invalid='ignore'):
        return np.any(fin & (r < -OUTLIER_SIGMAS * scale), axis=1)


#: a residual as :func:`takes_systematic` reads it: per instant and ram (n, 2) [N], the instants
#: [ns], and the rows' spacing [ns]
Residual = tuple[NDArray[np.float64], NDArray[np.int64], int]


def takes_systematic(before: Residual, after: Residual, lag_steps: int, share: float) -> bool:
    """Whether a model change from ``before`` to ``after`` takes something systematic from the
    residual: the positive part of its autocovariance at ``lag_steps`` grid steps falls, by at
    least ``share`` of the fall of its mean square. A systematic misfit is as large at the
    next instant, so its autocovariance there is positive; what a column takes from noise is
    not. Only the positive part counts: a column that makes an autocovariance already nil or
    negative more negative (one that fits the noise's own alternation) takes nothing that was
    there, however much it lowers the mean square (the demo's clean recording once adopted a
    Stribeck rise that way: residual 0.30 -> 0.30 bar, systematic part 0.00 -> 0.00)."""
    m0, c0 = lag_moments(before[0], before[1], lag_steps, before[2])
    m1, c1 = lag_moments(after[0], after[1], lag_steps, after[2])
    if not all(math.isfinite(x) for x in (m0, c0, m1, c1)):
        return False
    d_lag = max(c0, 0.0) - max(c1, 0.0)
    return d_lag > 0 and d_lag >= share * (m0 - m1)
