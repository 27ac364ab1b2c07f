"""Held-out scoring of a model on a log. Pure.

The log is cut into alternate blocks of time (a minute; on a short log the longest of
``SHORT_BLOCKS_S`` that gives ``MIN_BLOCKS`` of them), a model fitted on one half is scored on
the other, within the angles the fitting half covers, both ways (:func:`cv_mse`); a candidate
effect is scored at its best clearances on the grid, refined between grid points
(:func:`candidate_score`).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from steer_monitor.estimate import fit as F
from steer_monitor.estimate import pointfit as PF
from steer_monitor.estimate.moments import Moments
from steer_monitor.estimate.observe import Observations
from steer_monitor.estimate.refine import refine_profile
from steer_monitor.model.gear import GearParams

__all__ = ['BLOCK_NS', 'MIN_BLOCKS', 'MIN_SEGMENT_SAMPLES', 'SHORT_BLOCKS_S', 'block_ns', 'candidate_score', 'covered',
           'cv_mse', 'halves']

BLOCK_NS = 60_000_000_000
MIN_BLOCKS = 8           # cross-validation blocks a log is cut into at least (see block_ns)
SHORT_BLOCKS_S = (30, 15, 10, 5)
MIN_SEGMENT_SAMPLES = 20


def block_ns(t_ns: NDArray[np.int64]) -> int:
    """The cross-validation block for data at times ``t_ns``: a minute, or on a log shorter
    than ``MIN_BLOCKS`` minutes the longest of ``SHORT_BLOCKS_S`` that cuts it into at least
    that many (on a 71 s log, minutes made halves of 60 s and 11 s: a fit on 11 s scored on
    60 s put a column worth 1 % in-sample at 58 % held-out)."""
    span = int(t_ns[-1] - t_ns[0]) if t_ns.size else 0
    for block in (BLOCK_NS, *(s * 1_000_000_000 for s in SHORT_BLOCKS_S)):
        if span >= MIN_BLOCKS * block:
            return block
    return SHORT_BLOCKS_S[-1] * 1_000_000_000


def halves(obs: Observations) -> tuple[NDArray[np.bool_], NDArray[np.bool_]]:
    block = (obs.t_ns // block_ns(obs.t_ns)) % 2 == 0
    return block, ~block


def covered(train: Moments, score: Moments, basis: F.TorqueBasis) -> NDArray[np.bool_]:
    """Bins of ``score`` whose torque-spline segment the training half has data in (at least
    ``MIN_SEGMENT_SAMPLES``): held-out rows elsewhere would score the spline's extrapolation
    (a hard-over sits in one minute, so in one half only), not the friction model."""
    step = math.radians(F.KNOT_STEP_DEG)
    seg_train = np.floor(train.abs_alpha / step).astype(np.int64)
    counts = np.bincount(seg_train, train.count, minlength=int(seg_train.max(initial=0)) + 1)
    seg = np.floor(score.abs_alpha / step).astype(np.int64)
    ok = seg < counts.size
    ok[ok] = counts[seg[ok]] >= MIN_SEGMENT_SAMPLES
    return ok


def cv_mse(gear: GearParams, basis: F.TorqueBasis, parts: tuple[Moments, Moments], coef_torque: NDArray,
            two_z: float, z_gb: float, extra: tuple[F.Column, ...]) -> float:
    """Held-out mean square: fit on each half at the given clearances, score on the other
    (the bins of the other half inside the angles the fitting half covers)."""
    if min(part.samples for part in parts) < 50:
        return math.nan
    total, n = 0.0, 0.0
    for fit_on, score_on in ((0, 1), (1, 0)):
        fmom = parts[fit_on]
        xtx, xty, names = F.normal_equations(gear, basis, fmom, two_z, z_gb,
                                             F.axial_load(gear, basis, fmom, coef_torque), extra)
        coef = F.solve_normal_equations(basis, xtx, xty, names)
        mom = parts[score_on]
        keep = covered(fmom, mom, basis)
        if not keep.any():          # the scoring half lies wholly outside the fitting half's angles
            continue
        if not keep.all():
            mom = mom.subset(keep)
        cols, zs, _ = F.design_at(gear, basis, mom, two_z, z_gb, F.axial_load(gear, basis, mom, coef_torque), extra)
        total += F.residual_sum_of_squares(mom, cols, zs, coef)
        n += mom.samples
    return total / n if n > 0 else math.nan


def candidate_score(gear: GearParams, basis: F.TorqueBasis, mom: Moments, parts: tuple[Moments, Moments],
                    coef_torque: NDArray, extra: tuple[F.Column, ...], grid_2z: NDArray,
                    declared_at: tuple[float, float]) -> tuple[float, float, float, float, float, int,
                                                                NDArray[np.float64]]:
    """(in-sample RSS, rows, held-out MSE, 2Z, Z_gb, parameters) at the candidate's optimum:
    a coarse pass over the grid, then the full resolution around its best point and around
    the declared model's estimate ``declared_at`` (2Z, Z_gb) [m] (a ram that clamps makes the
    profile in 2Z narrower than the coarse step, so the coarse pass alone can miss it). ``mom``:
    the rows' moments; ``parts``: those of the two halves."""
    load = F.axial_load(gear, basis, mom, coef_torque)
    pr = PF.profile(gear, basis, mom, load, extra, grid_2z[::3], F.GRID_ZGB[::3])
    best: tuple[float, float, float, int, NDArray[np.float64]] = (math.inf, 0.0, 0.0, 0, np.zeros(0))
    centres = dict.fromkeys((int(np.argmin(np.abs(grid_2z - tz0))), int(np.argmin(np.abs(F.GRID_ZGB - zg0))))
                            for tz0, zg0 in ((float(pr.two_z[pr.best[0]]), float(pr.z_gb[pr.best[1]])), declared_at))
    window: PF.Profile | None = None
    for i0, j0 in centres:      # in order; one fine search when both centres are the same point
        fine = PF.profile(gear, basis, mom, load, extra, grid_2z[max(i0 - 3, 0):i0 + 4],
                         F.GRID_ZGB[max(j0 - 3, 0):j0 + 4])
        i, j = fine.best
        if fine.rss[i, j] < best[0]:
            best = (float(fine.rss[i, j]), float(fine.two_z[i]), float(fine.z_gb[j]), fine.p, fine.coef)
            window = fine
    if window is not None:
        # between grid points where the grid cannot resolve the optimum, as the estimate
        # does: a model scored at a grid point its clearances miss would carry that misfit
        ref = refine_profile(gear, basis, mom, load, extra, window)
        if float(ref.rss.min()) < best[0]:
            tz, zg = ref.best
            at = PF.fit_points(gear, basis, mom, load, np.array([tz]), np.array([zg]), extra)
            best = (float(at.rss[0]), tz, zg, best[3], at.coef[0].copy())
    rss, tz, zg, p, coef = best
    cv = cv_mse(gear, basis, parts, coef_torque, tz, zg, extra)
    return rss, mom.samples, cv, tz, zg, p, coef
