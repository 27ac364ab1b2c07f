"""Least-squares fit of the declared observation model on binned statistics, with the
clearances profiled on a grid (docs/physics.md, docs/estimation.md).

Per ram, in steady motion (direction d = +-1):

    y = A_r (p_stbd - p_port) = sign(alpha) Fa(alpha, V) + d (F_s + mu_b N_b + mu_g |F_gb|)
    Fa = M(|alpha|) (V / V_s)^2 cos^2(alpha) / (n H)

with the tiller torque M a cubic B-spline in |alpha| through (0, 0) (odd in alpha by the
sign), and N_b = N_A + N_E, F_gb from the load-sharing solver at the clearances
(2Z, Z_gb) and the load Fa. For fixed clearances the model is linear in the torque
coefficients and in (F_s, mu_b, mu_g): :func:`fit_at` solves it by (lightly ridged)
normal equations built from the bins' moment matrices, so its cost does not grow with the
length of the log; the friction coefficients are held to their physical ranges
(:mod:`~steer_monitor.estimate.ranges`, an exact bounded solve: :func:`bounded_quadratic`).
The clearances enter through the kinks of N_b and F_gb (the angle where the guide beam takes
load, the load where the ram clamps in its bushing) and are profiled over a grid
(:mod:`~steer_monitor.estimate.pointfit`: the fit at many pairs at once, and the profile whose
residual sums of squares the likelihood-ratio intervals of
:mod:`~steer_monitor.estimate.intervals` read).

Extra columns (candidate effects, :mod:`steer_monitor.estimate.effects`) are products of a
per-bin feature and one of the per-sample z columns of the moments.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.interpolate import BSpline

from steer_monitor.estimate.moments import SPEED_Z, Moments
from steer_monitor.estimate.ranges import DECLARED
from steer_monitor.model.gear import GearParams
from steer_monitor.model.kinematics import axial_of_torque, torque_of_axial
from steer_monitor.model.loadshare import friction_normals

__all__ = [
    'GRID_2Z',
    'GRID_ZGB',
    'KNOT_STEP_DEG',
    'Column',
    'FitAt',
    'TorqueBasis',
    'axial_load',
    'bounded_quadratic',
    'declared_bounds',
    'design_matrices',
    'inverses',
    'rss_from_weights',
    'smoothing_penalty',
    'z_weights',
    'is_nuisance',
    'speed_scale_columns',
    'torque_z',
    'design_at',
    'design_columns',
    'fit_at',
    'normal_equations',
    'residual_sum_of_squares',
    'solve_normal_equations',
    'friction_features',
    'torque_columns',
    'torque_of_load',
    'torque_prefit',
]

DEG = math.pi / 180.0
GRID_2Z = np.round(np.arange(0.0, 1.5001e-3, 0.02e-3), 9)    # m: 0 .. 1.5 mm
GRID_ZGB = np.round(np.arange(0.0, 0.6001e-3, 0.005e-3), 9)  # m: 0 .. 0.6 mm
RIDGE = 1e-6
KNOT_STEP_DEG = 1.0


@dataclass(frozen=True)
class TorqueBasis:
    """Cubic B-spline basis in |alpha| with M(0) = 0, knots every ``KNOT_STEP_DEG`` up to the
    gear's limit.

    The axial load is large against the friction the clearances change (about 470 kN at
    10 deg against a few kN), so a misfit of the torque *shape* of a tenth of a percent is
    already friction-sized and moves the clearances. Knots every 2.5 deg left the R-18 curve
    (PCHIP through 0, 5, 10, 21, 27.5, 35 deg) misfit by ~0.4 kN m, which pulled Z_gb by up to
    0.06 mm on course-keeping logs and put the truth outside the interval (deviance 8-34 at
    the true clearances on noise-free logs); every 1 deg the deviance at the truth is < 0.1
    there and the cost of the profile is unchanged (accuracy study, docs/accuracy.md)."""

    max_angle: float

    @property
    def knots(self) -> NDArray[np.float64]:
        cached = self.__dict__.get('_knots')
        if cached is None:
            inner = np.radians(np.arange(KNOT_STEP_DEG, 90.0, KNOT_STEP_DEG))
            inner = inner[inner < self.max_angle - 1e-9]
            cached = np.concatenate([[0.0] * 4, inner, [self.max_angle] * 4])
            object.__setattr__(self, '_knots', cached)
        return cached

    @property
    def size(self) -> int:
        return self.knots.size - 4 - 1   # the first function (non-zero at 0) is dropped

    def __call__(self, abs_alpha: NDArray[np.float64]) -> NDArray[np.float64]:
        """Design matrix (n, size) of M at |alpha| per unit coefficient [N m per N m]."""
        x = np.clip(abs_alpha, 0.0, self.max_angle)
        full = BSpline.design_matrix(x, self.knots, 3).toarray()
        return full[:, 1:]

    def torque(self, coef: NDArray[np.float64], abs_alpha: NDArray[np.float64]) -> NDArray[np.float64]:
        return self(abs_alpha) @ coef


@dataclass(frozen=True)
class Column:
    """An extra regressor: per-bin feature (of the bins and the friction features) times the
    per-sample column ``z`` (a name of the moments' z columns, or '' for 1)."""

    name: str
    z: str
    feature: Callable[[Moments, dict[str, NDArray[np.float64]]], NDArray[np.float64]]


@dataclass(frozen=True)
class FitAt:
    """The linear fit at given clearances.

    Attributes:
        coef: torque coefficients [N m] then F_s [N], mu_b, mu_g, then extra columns.
        rss: residual sum of squares [N^2]; n: rows; names: one per coefficient.
        cov_unscaled: (X^T X + ridge)^-1.
    """

    coef: NDArray[np.float64]
    rss: float
    n: float
    names: tuple[str, ...]
    cov_unscaled: NDArray[np.float64]

    def get(self, name: str) -> float:
        return float(self.coef[self.names.index(name)])


def torque_z(mom: Moments) -> int:
    """The z column the torque columns multiply: the per-row speed ratio V^2 / V_c^2 where the
    moments carry it (:data:`~steer_monitor.estimate.moments.SPEED_Z`), else 1 (the bin's
    mean V^2 then stands for every row)."""
    return 1 + mom.z_names.index(SPEED_Z) if SPEED_Z in mom.z_names else 0


def _speed_factor(mom: Moments, service_speed: float) -> NDArray[np.float64]:
    """Per bin, the factor of the torque curve the torque columns carry: (V_c / V_s)^2 of the
    bin's speed class when the rows carry their ratio to it, else the mean (V / V_s)^2; 1
    where the speed is not on the bus."""
    v2 = mom.class_speed_sq if SPEED_Z in mom.z_names else mom.speed_sq
    return np.where(np.isfinite(v2), v2 / service_speed ** 2, 1.0)


def _mean_speed_ratio(mom: Moments) -> NDArray[np.float64]:
    """Per bin, the mean of the z column the torque columns multiply (1 without it)."""
    zt = torque_z(mom)
    if zt == 0:
        return np.ones(len(mom))
    return mom.mean[:, zt]


def torque_columns(gear: GearParams, basis: TorqueBasis, mom: Moments) -> NDArray[np.float64]:
    """(B, k): signed axial force per unit torque coefficient, per bin, for a row of speed
    ratio 1 (the columns multiply the z column :func:`torque_z`) [N per N m]. Cached on the
    moments (which are replaced, not changed, when data are added)."""
    key = (id(gear), basis.max_angle)
    cache = mom.__dict__.setdefault('_torque_columns', {})
    if key not in cache:
        a = mom.abs_alpha
        scale = axial_of_torque(gear, mom.side * _speed_factor(mom, gear.torque.service_speed), np.cos(a))
        cache.clear()
        cache[key] = basis(a) * scale[:, None]
    return cache[key]


def axial_load(gear: GearParams, basis: TorqueBasis, mom: Moments, coef: NDArray[np.float64]) -> NDArray[np.float64]:
    """|Fa| per bin [N] from torque coefficients (at the bin's mean speed ratio)."""
    return np.abs(torque_columns(gear, basis, mom) @ coef[:basis.size]) * _mean_speed_ratio(mom)


SPEED_GROUP_KN = 1.0      # width of a speed group with its own load scale [kn]
MIN_GROUP_ROWS = 100       # rows a speed group needs for a load scale of its own


def _speed_group(mom: Moments) -> NDArray[np.int64]:
    """Per bin, its speed group (``SPEED_GROUP_KN`` wide, from the class centre); -1 where the
    speed is not on the bus."""
    vc = np.sqrt(mom.class_speed_sq) * 3600.0 / 1852.0
    return np.where(np.isfinite(vc), np.floor(np.nan_to_num(vc) / SPEED_GROUP_KN), -1).astype(np.int64)


def speed_scale_columns(mom: Moments) -> tuple[Column, ...]:
    """Nuisance columns that let the load scale depart from V^2 per speed group:
    side x |Fa| x [bin in group g] (times the row's speed ratio), one per group with at least
    ``MIN_GROUP_ROWS`` rows except the largest (the torque curve carries its scale).

    The contract scales the tiller torque with V^2, but a speed log reads through water with
    its own calibration, 0.01 m/s steps (0.25 % of V^2 at 8 kn) and lag, and a real rudder's
    torque does not follow V^2 to the per mille. A load error of 0.2 % is 1 kN at 500 kN, the
    size of the friction that carries the clearances; it is signed with the rudder's side and
    the friction with the direction of motion, so a free scale per speed group takes it
    without taking the friction. Empty when the speed is off the bus or in one group."""
    if SPEED_Z not in mom.z_names or not len(mom):
        return ()
    group = _speed_group(mom)
    groups, inv = np.unique(group, return_inverse=True)
    rows = np.bincount(inv, mom.count, minlength=groups.size)
    ok = (groups >= 0) & (rows >= MIN_GROUP_ROWS)
    if ok.sum() < 2:
        return ()
    ref = int(groups[np.argmax(np.where(ok, rows, -1.0))])
    return tuple(Column(f'load_scale_{int(g * SPEED_GROUP_KN)}kn', SPEED_Z, _group_load(int(g)))
                 for g in groups[ok] if int(g) != ref)


def _group_load(g: int) -> Callable[[Moments, dict[str, NDArray[np.float64]]], NDArray[np.float64]]:
    def feature(mom: Moments, feats: dict[str, NDArray[np.float64]]) -> NDArray[np.float64]:
        per_ratio = feats['load'] / _mean_speed_ratio(mom).reshape((-1,) + (1,) * (np.ndim(feats['load']) - 1))
        inside = (_speed_group(mom) == g).reshape(per_ratio.shape[:1] + (1,) * (per_ratio.ndim - 1))
        return mom.side.reshape(inside.shape) * per_ratio * inside
    feature.nuisance = True  # type: ignore[attr-defined]
    return feature


def is_nuisance(col: Column) -> bool:
    """True for the columns :func:`speed_scale_columns` adds (not an effect's parameter)."""
    return bool(getattr(col.feature, 'nuisance', False))


def friction_features(gear: GearParams, abs_alpha: NDArray[np.float64], torque: NDArray[np.float64],
                      two_z: NDArray[np.float64], z_gb: NDArray[np.float64]) -> tuple[NDArray, NDArray]:
    """(N_A + N_E, |F_gb|) [N] at angles (B,) and torques (B,) for the clearance pairs (G,)
    (or shapes that broadcast to it, such as (1, G)): shapes (B, G)."""
    return friction_normals(gear, abs_alpha, torque, *(np.asarray(x, float).reshape(-1)
                                                       for x in np.broadcast_arrays(two_z, z_gb)))


def smoothing_penalty(k_torque: int, p: int, xtx: NDArray) -> NDArray[np.float64]:
    """Second-difference penalty on the torque coefficients, relative to their own scale: it
    keeps unobserved stretches of the curve smooth and does not bend observed ones."""
    r = np.zeros((p, p))
    if k_torque >= 3:
        d = np.diff(np.eye(k_torque), 2, axis=0)
        r[:k_torque, :k_torque] = (d.T @ d) * RIDGE * float(np.mean(np.diag(xtx)[:k_torque]))
    return r


def _solve(xtx: NDArray, xty: NDArray, smooth: NDArray, names: Sequence[str] = ()) -> tuple[NDArray, NDArray]:
    """(coefficients, (X^T X + penalty)^-1) with the smoothing penalty and a relative ridge per
    column, so an unexcited column stays solvable; the declared friction's coefficients among
    ``names`` held to their physical ranges (:data:`~steer_monitor.estimate.ranges.DECLARED`,
    :func:`bounded_quadratic`). No residual here: see :func:`residual_sum_of_squares`."""
    a = xtx + smooth + np.diag(RIDGE * np.diag(xtx) + 1e-300)
    inv = inverses(a[None])[0]
    coef = inv @ xty
    lo, hi = declared_bounds(names, coef.size)
    if np.any(coef < lo) or np.any(coef > hi):
        coef = bounded_quadratic(a[None], xty[None], lo, hi, coef[None])[0]
    return coef, inv


def declared_bounds(names: Sequence[str], p: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(lower, upper) bounds (p,) of coefficients ``names``: the declared friction's physical
    ranges, infinite for the rest."""
    lo, hi = np.full(p, -np.inf), np.full(p, np.inf)
    for k, name in enumerate(names):
        rng = DECLARED.get(name)
        if rng is not None:
            lo[k], hi[k] = rng.lo, rng.hi
    return lo, hi


def bounded_quadratic(a: NDArray[np.float64], b: NDArray[np.float64], lo: NDArray[np.float64],
                      hi: NDArray[np.float64], start: NDArray[np.float64]) -> NDArray[np.float64]:
    """argmin of x' a x - 2 b' x subject to lo <= x <= hi, for a stack of problems: ``a`` (g, n, n)
    symmetric positive definite, ``b`` (g, n), bounds (n,) (infinite where there is none),
    ``start`` (g, n) the unconstrained minima (kept where already inside).

    Exact, by enumerating the active sets over the bounded coordinates (each free, at its
    lower or at its upper bound; 3^k sets for k bounded coordinates, a handful here): for a
    convex quadratic the constrained minimum is the unconstrained minimum over the free
    coordinates of one of them, and every such point that is feasible is an upper bound of
    it, so the least feasible one is the answer. The all-at-a-bound sets are always feasible."""
    g, n = b.shape
    out = np.array(start, float, copy=True)
    tol = 1e-12 * np.maximum(np.abs(np.where(np.isfinite(lo), lo, 0.0)) + np.abs(np.where(np.isfinite(hi), hi, 0.0)),
                             1e-12)
    bad = np.any((out < lo - tol) | (out > hi + tol), axis=1)
    if not bad.any():
        return out
    rows = np.nonzero(bad)[0]
    a, b = a[rows], b[rows]
    bounded = [k for k in range(n) if np.isfinite(lo[k]) or np.isfinite(hi[k])]
    choices = [[s for s, v in ((0, 0.0), (1, lo[k]), (2, hi[k])) if s == 0 or np.isfinite(v)] for k in bounded]
    best_obj = np.full(rows.size, np.inf)
    best = np.zeros((rows.size, n))
    for states in itertools.product(*choices):
        fixed = [k for k, s in zip(bounded, states) if s]
        value = np.array([lo[k] if s == 1 else hi[k] for k, s in zip(bounded, states) if s])
        free = [k for k in range(n) if k not in fixed]
        x = np.zeros((rows.size, n))
        x[:, fixed] = value
        if free:
            a_ff = a[np.ix_(np.arange(rows.size), free, free)]
            rhs = b[:, free] - (a[np.ix_(np.arange(rows.size), free, fixed)] @ value if fixed else 0.0)
            x[:, free] = (inverses(a_ff) @ rhs[:, :, None])[:, :, 0]
        ok = np.all((x >= lo - tol) & (x <= hi + tol), axis=1)
        obj = np.einsum('gi,gij,gj->g', x, a, x) - 2.0 * np.einsum('gi,gi->g', b, x)
        take = ok & (obj < best_obj)
        best_obj[take], best[take] = obj[take], x[take]
    out[rows] = np.clip(best, lo, hi)
    return out


def z_weights(cols: NDArray, zs: Sequence[int], coef: NDArray, used: Sequence[int] | None = None
               ) -> tuple[list[int], NDArray]:
    """The prediction of a row of bin b as sum_j w[b, j] u[j] over z indices ``used`` (default:
    those ``zs`` names): (those indices, w of shape (B, ..., k)) for ``cols`` (B, p) and
    ``coef`` (p,) or (g, p) (then w is (B, g, k))."""
    zi = np.asarray(zs, dtype=np.intp)
    used = sorted({int(z) for z in zi}) if used is None else list(used)
    coef = np.asarray(coef)
    parts = [cols[:, zi == z] @ coef[..., zi == z].T for z in used]
    return used, np.stack(parts, axis=-1)


def rss_from_weights(mom: Moments, used: Sequence[int], w: NDArray) -> NDArray[np.float64]:
    """Residual sum of squares of predictions sum_j w[b, ..., j] u[used[j]] against y, from
    the centred statistics: per bin v^T S v + n (v . mean)^2 with v = [-w, 1]. Every term is
    non-negative and made of the bin's own deviations, so the sum's relative error is at
    most (bins x machine epsilon), whatever the order of summation; shape w.shape[1:-1]."""
    q = mom.mean.shape[1]
    idx = list(used) + [q - 1]
    scatter = mom.scatter[:, idx][:, :, idx]
    mean = mom.mean[:, idx]
    extra_dims = w.ndim - 2
    v = np.concatenate([-w, np.ones(w.shape[:-1] + (1,))], axis=-1)
    flat = v.reshape(scatter.shape[0], -1, v.shape[-1])               # (B, G, k + 1)
    within = np.einsum('bgj,bgj->bg', flat @ scatter, flat).reshape(v.shape[:-1])
    m_b = mean.reshape((mean.shape[0],) + (1,) * extra_dims + mean.shape[1:])
    off = np.einsum('...i,...i->...', v, m_b)
    n_b = mom.count.reshape((-1,) + (1,) * extra_dims)
    return np.maximum(within, 0.0).sum(axis=0) + (n_b * off * off).sum(axis=0)


def residual_sum_of_squares(mom: Moments, cols: NDArray, zs: Sequence[int], coef: NDArray) -> float:
    """RSS [N^2] of the rows in ``mom`` at coefficients ``coef`` for the bins' columns
    ``cols`` (B, p) multiplying z indices ``zs`` (see :func:`rss_from_weights` for its
    accuracy)."""
    if not len(mom):
        return 0.0
    used, w = z_weights(cols, zs, coef)
    return float(rss_from_weights(mom, used, w))


def design_matrices(fixed: NDArray, fixed_z: Sequence[int], mom: Moments) -> tuple[NDArray, NDArray]:
    """X^T X and X^T y for columns fixed[:, a] * z[fixed_z[a]]: one weighted matrix product per
    pair of distinct z columns (the declared model has only z = 1, the bin counts)."""
    q = mom.m.shape[1]
    zi = np.asarray(fixed_z)
    p = zi.size
    xtx = np.empty((p, p))
    groups = {int(z): np.nonzero(zi == z)[0] for z in np.unique(zi)}
    for za, ia in groups.items():
        for zc, ic in groups.items():
            xtx[np.ix_(ia, ic)] = (fixed[:, ia] * mom.m[:, za, zc][:, None]).T @ fixed[:, ic]
    xty = np.einsum('ba,ba->a', fixed, mom.m[:, zi, q - 1])
    return xtx, xty


def fit_at(gear: GearParams, basis: TorqueBasis, mom: Moments, two_z: float, z_gb: float,
           load: NDArray[np.float64], extra: Sequence[Column] = ()) -> FitAt:
    """The declared model (plus ``extra`` columns) fitted at one pair of clearances.
    ``load``: |Fa| per bin [N] for the friction features."""
    cols, zs, names = design_at(gear, basis, mom, two_z, z_gb, load, extra)
    xtx, xty = design_matrices(cols, zs, mom)
    coef, inv = _solve(xtx, xty, smoothing_penalty(basis.size, len(names), xtx), names)
    return FitAt(coef, residual_sum_of_squares(mom, cols, zs, coef), mom.samples, tuple(names), inv)


def solve_normal_equations(basis: TorqueBasis, xtx: NDArray, xty: NDArray, names: Sequence[str]) -> NDArray:
    """The coefficients from :func:`normal_equations`' X^T X and X^T y."""
    return _solve(xtx, xty, smoothing_penalty(basis.size, len(names), xtx), names)[0]


def normal_equations(gear: GearParams, basis: TorqueBasis, mom: Moments, two_z: float, z_gb: float,
                     load: NDArray[np.float64], extra: Sequence[Column] = ()
                     ) -> tuple[NDArray, NDArray, list[str]]:
    """(X^T X, X^T y, column names) of the model at given clearances."""
    cols, zs, names = design_at(gear, basis, mom, two_z, z_gb, load, extra)
    xtx, xty = design_matrices(cols, zs, mom)
    return xtx, xty, names


def design_at(gear: GearParams, basis: TorqueBasis, mom: Moments, two_z: float, z_gb: float,
              load: NDArray[np.float64], extra: Sequence[Column] = ()) -> tuple[NDArray, list[int], list[str]]:
    """The bins' columns at one pair of clearances: (per-bin features (B, p), the z column each
    multiplies, names); ``load`` is |Fa| per bin [N]."""
    nb, fg = friction_features(gear, mom.abs_alpha, torque_of_load(gear, mom, load), np.array([two_z]),
                               np.array([z_gb]))
    return design_columns(gear, basis, mom, {'n_b': nb[:, 0], 'f_gb': fg[:, 0], 'load': load}, extra)


def torque_of_load(gear: GearParams, mom: Moments, load: NDArray[np.float64]) -> NDArray[np.float64]:
    """Tiller torque [N m] that gives the axial load ``load`` at each bin's angle (load sharing
    takes the torque)."""
    return torque_of_axial(gear, load, np.cos(mom.abs_alpha))


def design_columns(gear: GearParams, basis: TorqueBasis, mom: Moments, feats: dict[str, NDArray],
             extra: Sequence[Column]) -> tuple[NDArray, list[int], list[str]]:
    d = mom.direction
    tor = torque_columns(gear, basis, mom)
    cols = [tor, d[:, None], (d * feats['n_b'])[:, None], (d * feats['f_gb'])[:, None]]
    names = [f'torque_{i}' for i in range(basis.size)] + ['seal_friction_n', 'mu_bushing', 'mu_guide']
    zs = [torque_z(mom)] * basis.size + [0] * 3
    for c in extra:
        cols.append(c.feature(mom, feats)[:, None])
        names.append(c.name)
        zs.append(0 if not c.z else 1 + mom.z_names.index(c.z))
    return np.concatenate(cols, axis=1), zs, names


def torque_prefit(gear: GearParams, basis: TorqueBasis, mom: Moments) -> NDArray[np.float64]:
    """Torque coefficients [N m] with friction left free in shape: d (F_0 + sum g_k |B_k|),
    so the torque (the mean of the two directions) does not depend on the clearances."""
    d = mom.direction
    tor = torque_columns(gear, basis, mom)
    cols = np.concatenate([tor, d[:, None], d[:, None] * np.abs(tor)], axis=1)
    zt = torque_z(mom)
    xtx, xty = design_matrices(cols, [zt] * basis.size + [0] + [zt] * basis.size, mom)
    coef, _ = _solve(xtx, xty, smoothing_penalty(basis.size, cols.shape[1], xtx))
    return coef[:basis.size]


def inverses(a: NDArray[np.float64]) -> NDArray[np.float64]:
    """Inverses of a stack of matrices (g, p, p), the pseudo-inverse where one is singular."""
    try:
        return np.linalg.inv(a)
    except np.linalg.LinAlgError:
        out = np.empty_like(a)
        for k in range(a.shape[0]):
            try:
                out[k] = np.linalg.inv(a[k])
            except np.linalg.LinAlgError:
                out[k] = np.linalg.pinv(a[k])
        return out
