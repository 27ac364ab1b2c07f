"""How much wider than the textbook the intervals must be: a cluster-robust (sandwich) scale
per parameter. Pure.

The profile-likelihood interval of a parameter reads its 95 % set from (RSS(x) - RSS_min) /
sigma^2 against chi-square(1): right when the rows are independent and the model is right.
Neither holds on a real log: the residual is correlated over seconds (a valve's step, the
pumps' pulsation), and what the model lacks is a function of the gear's *state* (the angle,
the load, the direction of motion), the same each time the rudder passes the same angle, so
it does not average out with more data. An interval that narrows as 1/sqrt(n) around an
estimate that a misfit holds off the truth by a fixed amount misses more often the longer
the log (measured: 84 % of the node's intervals held the truth after 150-300 s of motion,
77 % after 600-1200 s).

The sandwich (Huber-White; Liang-Zeger for clusters) measures instead how the estimate would
move if the data's misfits were drawn again, cluster by cluster. With X the model's
derivatives at the estimate (its linear columns, and each clearance's column worked out by
central differences of the friction features), J = X'X and S_g = sum over cluster g of x_i e_i,

    V_model = sigma^2 J^-1,     V_robust = G / (G - 1) J^-1 (sum_g S_g S_g') J^-1,

and a parameter's scale is V_robust / V_model on its diagonal (at least 1: the textbook's
intervals are never narrowed). Its deviance is divided by it; its interval's threshold is the
square of Student's t at the effective number of clusters less one (the clusters that carry a
parameter are few, a handful of angle cells for a clearance's kink, and the variance from few
is itself uncertain: Kish's effective number (sum psi^2)^2 / sum psi^4 of the clusters'
influences psi).

Two clusterings, the larger scale of each parameter taken:

* by **time**, blocks of ``block_s`` chosen from the data: ``BLOCK_DECORRELATIONS`` times
  the lag where the residual's autocorrelation first falls below ``DECORRELATED`` (within
  ``BLOCK_MIN_S`` .. ``BLOCK_MAX_S``): the residual's correlation over seconds, however long
  (a fixed 2 s window needed four times more for a residual correlated over 3 s);
* by **state**, cells of 1 deg of |alpha| (the torque spline's knot step: the spline takes up
  any misfit smoother than that) times side times direction of motion: a misfit that repeats
  at the same angle, which more data do not average away.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy import special

from steer_monitor.estimate import fit as F
from steer_monitor.estimate.moments import Moments
from steer_monitor.model.gear import GearParams

__all__ = ['BLOCK_MAX_S', 'BLOCK_MIN_S', 'CLEARANCES', 'MODEL_ERROR_FLOOR', 'RobustScale', 'block_seconds',
           'robust_scales', 't2_threshold']

BLOCK_MIN_S = 30.0
BLOCK_MAX_S = 300.0
BLOCK_DECORRELATIONS = 10.0      # a block is this many correlation times long
DECORRELATED = 0.05              # autocorrelation below which the residual counts as decorrelated
MAX_LAG_S = 60.0
CELL_DEG = 1.0
CLEARANCES = ('two_z', 'z_gb')
CHUNK = 1 << 15                  # rows per step (a row's derivatives are tens of columns)
STEP_M = 1e-6                    # central-difference step of a clearance [m]
MIN_CLUSTERS = 3.0
#: The clearances' deviance unit is this times the sandwich's: a misfit the whole log shares
#: (neither repeating by angle cell nor varying between time blocks) leaves no trace in the
#: clusters' scatter, yet moves the estimate. Its size was measured against the truth on the
#: simulator's realistic voyages (seeds 20001-20060, manoeuvres 21001-21030): with the
#: sandwich alone 91 % of the Z_gb intervals held the truth there, and the misses needed up to
#: 2.4 times the unit (a ship's speed read at 1 Hz in 0.01 m/s steps moved Z_gb by 0.010 mm on
#: a noise-free log; with the true speed, 0.0003 mm); at 2, 99 %. docs/accuracy.md gives the
#: coverage on seeds used for no choice.
MODEL_ERROR_FLOOR = 2.0


@dataclass(frozen=True)
class RobustScale:
    """A parameter's variance scale (>= 1) and the degrees of freedom its threshold takes
    (the effective number of clusters less one; inf when not measured), with the clustering
    that gave it ('time' or 'state'; '' when the textbook's variance stands)."""

    scale: float
    dof: float
    by: str = ''
    each: tuple[tuple[str, float, float], ...] = ()   # (clustering, scale before the floor of 1, dof) of each tried

    @property
    def threshold_1(self) -> float:
        """The 95 % point of a one-parameter deviance: t(dof)^2 (chi-square(1) at dof = inf)."""
        return t2_threshold(self.dof)


def t2_threshold(dof: float) -> float:
    """The 95 % two-sided point of Student's t at ``dof``, squared (chi-square(1)'s 3.84 as
    dof grows)."""
    if not math.isfinite(dof) or dof > 1e6:
        return float(special.chdtri(1.0, 0.05))
    return float(special.stdtrit(max(dof, MIN_CLUSTERS - 1.0), 0.975) ** 2)


def block_seconds(resid: NDArray[np.float64], t_ns: NDArray[np.int64], step_ns: int) -> float:
    """The time block [s]: ``BLOCK_DECORRELATIONS`` times the first lag at which the
    autocorrelation of the rams' mean residual (at grid times ``t_ns``, steps of ``step_ns``,
    NaN where not fitted) falls below ``DECORRELATED``, within ``BLOCK_MIN_S`` ..
    ``BLOCK_MAX_S``."""
    r = np.asarray(resid, float)
    e = np.nanmean(np.where(np.isfinite(r), r, np.nan), axis=1) if r.ndim == 2 else r
    ok = np.isfinite(e)
    if ok.sum() < 100:
        return BLOCK_MIN_S
    steps = np.round((t_ns[ok] - t_ns[ok][0]) / step_ns).astype(np.int64)
    max_lag_steps = int(MAX_LAG_S * 1e9 / step_ns)
    # gaps longer than the longest lag close up to just past it: no pair across them is counted,
    # and a log whose clock stepped by years is not laid out on a grid of years
    steps = np.concatenate([[0], np.cumsum(np.minimum(np.diff(steps), max_lag_steps + 1))])
    x = e[ok] - float(np.mean(e[ok]))
    size = int(steps[-1]) + 1
    series = np.zeros(size)
    mask = np.zeros(size)
    series[steps], mask[steps] = x, 1.0
    n = 1 << int(math.ceil(math.log2(2 * size)))
    fs, fm = np.fft.rfft(series, n), np.fft.rfft(mask, n)
    max_lag = min(max_lag_steps, size - 1)
    cov = np.fft.irfft(fs * np.conj(fs), n)[:max_lag + 1]
    pairs = np.round(np.fft.irfft(fm * np.conj(fm), n)[:max_lag + 1])
    with np.errstate(invalid='ignore', divide='ignore'):
        acf = (cov / np.maximum(pairs, 1.0)) / (cov[0] / max(pairs[0], 1.0))
    acf = np.where(pairs >= 50, acf, np.nan)
    below = np.nonzero(acf[1:] < DECORRELATED)[0]
    lag = (int(below[0]) + 1) if below.size else max_lag
    return float(np.clip(BLOCK_DECORRELATIONS * lag * step_ns / 1e9, BLOCK_MIN_S, BLOCK_MAX_S))


@dataclass(frozen=True)
class _Derivative:
    """The derivative of the prediction with respect to one clearance, per bin: ``per_bin`` (B,)
    where every column the clearance changes multiplies z = 1 (then a row's derivative is its
    bin's), else ``columns`` (B, p) with their z indices ``zs``, worked out row by row."""

    per_bin: NDArray[np.float64] | None
    columns: NDArray[np.float64] | None = None
    zs: NDArray[np.intp] | None = None

    def rows(self, b: NDArray[np.intp], u: NDArray[np.float64], coef: NDArray[np.float64]) -> NDArray[np.float64]:
        """The derivative at rows of bins ``b`` with per-row ``u`` (r, q)."""
        if self.per_bin is not None:
            return self.per_bin[b]
        assert self.columns is not None and self.zs is not None
        return (self.columns[b] * u[:, self.zs]) @ coef


def _row_design(gear: GearParams, basis: F.TorqueBasis, mom: Moments, coef: NDArray[np.float64], two_z: float,
                z_gb: float, load: NDArray[np.float64], extra: Sequence[F.Column], clearances: Sequence[int]
                ) -> tuple[NDArray[np.float64], NDArray[np.intp], list[str], list[_Derivative]]:
    """(per-bin columns (B, p), the per-row u index each multiplies, names with the clearances'
    appended, the clearances' derivatives): the model's linear columns and, for each clearance
    index in ``clearances`` (0: 2Z, 1: Z_gb), the prediction's derivative with respect to it by
    central differences of ``STEP_M`` (one-sided at 0)."""
    cols, zs, names = F.design_at(gear, basis, mom, two_z, z_gb, load, extra)
    zi = np.asarray(zs, dtype=np.intp)
    derivatives: list[_Derivative] = []
    for axis in clearances:
        at = [two_z, z_gb]
        h = STEP_M if at[axis] >= STEP_M else max(at[axis], 0.0)
        plus, minus = list(at), list(at)
        plus[axis] += STEP_M
        minus[axis] -= h
        cp, _, _ = F.design_at(gear, basis, mom, plus[0], plus[1], load, extra)
        cm, _, _ = F.design_at(gear, basis, mom, minus[0], minus[1], load, extra)
        dcols = (cp - cm) / (STEP_M + h)
        changing = np.any(dcols != 0.0, axis=0)
        if np.any(zi[changing] != 0):       # a clearance-dependent column times a z other than 1 (temp_friction's)
            derivatives.append(_Derivative(None, dcols, zi))
        else:
            derivatives.append(_Derivative(dcols @ coef))
        names = [*names, CLEARANCES[axis]]
    return cols, zi, names, derivatives


def robust_scales(gear: GearParams, basis: F.TorqueBasis, mom: Moments, bin_of_row: NDArray[np.intp],
                  u: NDArray[np.float64], resid: NDArray[np.float64], t_ns: NDArray[np.int64],
                  abs_alpha: NDArray[np.float64], side: NDArray[np.int8], direction: NDArray[np.int8],
                  coef: NDArray[np.float64], names: Sequence[str], two_z: float, z_gb: float,
                  load: NDArray[np.float64], extra: Sequence[F.Column], clearances: Sequence[int],
                  block_s: float) -> dict[str, RobustScale]:
    """Each parameter's :class:`RobustScale` at a fit (see the module docstring): its rows
    (their bins ``bin_of_row`` (r,), per-row ``u`` (r, q) = [1, z.., y] and residual ``resid``
    (r,) [N], time ``t_ns`` (r,), |alpha| [rad], side and direction (r,)), its coefficients
    ``coef`` (named ``names``) at clearances (``two_z``, ``z_gb``) [m] with ``load`` and
    ``extra`` as fitted, the clearances to differentiate (``clearances``: 0 for 2Z, 1 for Z_gb)
    and the time block [s]. Names: ``names`` and 'two_z' / 'z_gb'. A parameter the data do not
    carry (an empty column) gets scale 1 and dof inf."""
    cols, zs, all_names, derivatives = _row_design(gear, basis, mom, coef, two_z, z_gb, load, extra, clearances)
    p, c = cols.shape[1], len(derivatives)
    n = bin_of_row.size
    keys_time = ((t_ns - t_ns.min()) // int(block_s * 1e9)).astype(np.int64) if n else np.zeros(0, np.int64)
    cell = np.floor(abs_alpha / math.radians(CELL_DEG)).astype(np.int64)
    keys_state = (cell * 2 + (side > 0)) * 2 + (direction > 0)
    groups = [np.unique(k, return_inverse=True)[1] for k in (keys_time, keys_state)]
    sizes = [int(g.max(initial=-1)) + 1 for g in groups]
    jmat = np.zeros((p + c, p + c))
    scores = [np.zeros((s, p + c)) for s in sizes]
    rss = 0.0
    for i0 in range(0, n, CHUNK):
        sl = slice(i0, min(i0 + CHUNK, n))
        b = bin_of_row[sl]
        x = np.empty((b.size, p + c))
        x[:, :p] = cols[b] * u[sl][:, zs]
        for k, d in enumerate(derivatives):
            x[:, p + k] = d.rows(b, u[sl], coef)
        e = resid[sl]
        jmat += x.T @ x
        xe = x * e[:, None]
        rss += float(e @ e)
        for g, sc in zip(groups, scores):
            np.add.at(sc, g[sl], xe)
    # the fit's own penalty (the torque curve's smoothing, a relative ridge) keeps J invertible
    jmat[:p, :p] += F.smoothing_penalty(basis.size, p, jmat[:p, :p]) + np.diag(F.RIDGE * np.diag(jmat[:p, :p]))
    live = np.diag(jmat) > 0
    jinv = np.zeros_like(jmat)
    jinv[np.ix_(live, live)] = np.linalg.pinv(jmat[np.ix_(live, live)], hermitian=True)
    sigma2 = rss / max(n - (p + c), 1)
    v_model = sigma2 * np.diag(jinv)
    out: dict[str, RobustScale] = {}
    best = [RobustScale(1.0, math.inf)] * (p + c)
    for by, sc in zip(('time', 'state'), scores):
        g = sc.shape[0]
        if g < MIN_CLUSTERS:
            continue
        psi = sc @ jinv
        sq = psi * psi
        total = sq.sum(axis=0)
        with np.errstate(divide='ignore', invalid='ignore'):
            ratio = g / (g - 1.0) * total / v_model
            g_eff = total ** 2 / np.sum(sq * sq, axis=0)
        for j in range(p + c):
            if not (live[j] and v_model[j] > 0 and math.isfinite(ratio[j]) and math.isfinite(g_eff[j])):
                continue
            dof_j = float(max(g_eff[j] - 1.0, MIN_CLUSTERS - 1.0))
            each = (*best[j].each, (by, float(ratio[j]), dof_j))
            if best[j].by == '' or ratio[j] > best[j].scale:
                best[j] = RobustScale(float(max(ratio[j], 1.0)), dof_j, by, each)
            else:
                best[j] = RobustScale(best[j].scale, best[j].dof, best[j].by, each)
    for j, name in enumerate(all_names):
        out[name] = best[j]
    return out
