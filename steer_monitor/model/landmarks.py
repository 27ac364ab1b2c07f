"""Summaries of a load-sharing sweep: the landmarks paper 004 reads off its Fig. 7, and the
sensitivity of K_gl to the two clearances (the paper's claim about 2Z)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from steer_monitor.model.gear import Clearances, GearParams
from steer_monitor.model.loadshare import STAGE_CLAMPED, LoadSharing, load_sharing_at

__all__ = ['GapSensitivity', 'Landmarks', 'gap_sensitivity', 'landmarks']


@dataclass(frozen=True)
class Landmarks:
    """Landmarks of a sweep over rudder angle (angles in rad; None where never reached).

    Attributes:
        guide_onset: first angle at which the guide beam carries load: where Fl - F_Z first
            turns positive, interpolated linearly between samples.
        crossover: first angle at which F_gb >= F_r (interpolated the same way).
        k_gl_max: largest K_gl of the sweep, and ``k_gl_max_angle`` where it occurs.
        clamp_onset: first angle at which the ram clamps in bushing A.
    """

    guide_onset: float | None
    crossover: float | None
    k_gl_max: float
    k_gl_max_angle: float
    clamp_onset: float | None


def landmarks(alpha: NDArray[np.float64], res: LoadSharing) -> Landmarks:
    """Landmarks of a sweep; ``alpha`` increasing, shape (k,) [rad]."""
    alpha = np.asarray(alpha, dtype=float)
    slack = res.f_z - res.lateral           # > 0 while the slipper has not touched
    if np.any(res.k_gl[:1] > 0) or (slack.size and slack[0] <= 0):
        onset: float | None = float(alpha[0])      # touching from the first angle (a slipper without clearance)
    else:
        onset = _first_crossing(alpha, slack)
    cross = _first_crossing(alpha, res.ram_force - res.guide_force)
    imax = int(np.argmax(res.k_gl))
    clamps = (res.stages & STAGE_CLAMPED) > 0
    clamp = float(alpha[np.argmax(clamps)]) if np.any(clamps) else None
    return Landmarks(onset, cross, float(res.k_gl[imax]), float(alpha[imax]), clamp)


def _first_crossing(x: NDArray[np.float64], y: NDArray[np.float64]) -> float | None:
    """First x where y goes from > 0 to <= 0, interpolated linearly; None if never."""
    idx = np.nonzero((y[:-1] > 0) & (y[1:] <= 0))[0]
    if not idx.size:
        return None
    i = int(idx[0])
    t = y[i] / (y[i] - y[i + 1])
    return float(x[i] + t * (x[i + 1] - x[i]))


@dataclass(frozen=True)
class GapSensitivity:
    """K_gl against the clearances over a sweep of rudder angle.

    Arrays have shape (len(two_z), len(z_gb)): ``k_gl_max`` the peak K_gl over the sweep,
    ``k_gl_mean_high`` its mean over ``high_from``..max angle, ``clamps`` whether the ram ever
    clamps. ``two_z`` and ``z_gb`` in m, ``high_from`` in rad.
    """

    two_z: NDArray[np.float64]
    z_gb: NDArray[np.float64]
    k_gl_max: NDArray[np.float64]
    k_gl_mean_high: NDArray[np.float64]
    clamps: NDArray[np.bool_]
    high_from: float


def gap_sensitivity(gear: GearParams, two_z: ArrayLike, z_gb: ArrayLike,
                    alpha: ArrayLike, high_from: float) -> GapSensitivity:
    """K_gl over a sweep of ``alpha`` [rad] for every pair of clearances [m]."""
    tz = np.asarray(two_z, dtype=float)
    zg = np.asarray(z_gb, dtype=float)
    alpha = np.asarray(alpha, dtype=float)
    kmax = np.zeros((tz.size, zg.size))
    kmean = np.zeros_like(kmax)
    clamps = np.zeros(kmax.shape, dtype=bool)
    high = alpha >= high_from
    for i, t in enumerate(tz):
        for j, z in enumerate(zg):
            res = load_sharing_at(gear, alpha, Clearances(float(t), float(z)))
            kmax[i, j] = res.k_gl.max()
            kmean[i, j] = res.k_gl[high].mean() if np.any(high) else np.nan
            clamps[i, j] = bool(np.any(res.stages & STAGE_CLAMPED))
    return GapSensitivity(tz, zg, kmax, kmean, clamps, float(high_from))
