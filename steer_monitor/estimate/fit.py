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
load, the load where the ram clamps in its bushing) and are
profiled over a grid; :func:`profile` keeps the residual sum of squares at every grid
point for the likelihood-ratio intervals of :mod:`steer_monitor.estimate.intervals`.

Extra columns (candidate effects, :mod:`steer_monitor.estimate.effects`) are products of a
per-bin feature and one of the per-sample z columns of the moments.
"""

from __future__ import annotations

import itertools
import math
import weakref
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.interpolate import BSpline

from steer_monitor.estimate.moments import SPEED_Z, Moments
from steer_monitor.estimate.ranges import DECLARED
from steer_monitor.model.gear import GearParams
from steer_monitor.model.loadshare import friction_normals, load_sharing

__all__ = [
    'GRID_2Z',
    'GRID_ZGB',
    'KNOT_STEP_DEG',
    'Column',
    'FitAt',
    'Profile',
    'TorqueBasis',
    'axial_load',
    'bounded_quadratic',
    'declared_bounds',
    'is_nuisance',
    'speed_scale_columns',
    'torque_z',
    'design_at',
    'design_columns',
    'fit_at',
    'normal_equations',
    'residual_sum_of_squares',
    'solve_normal_equations',
    'closing_clearances',
    'friction_features',
    'PointFits',
    'PointFitter',
    'fit_points',
    'profile',
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
        scale = (
            mom.side * _speed_factor(mom, gear.torque.service_speed) * np.cos(a) ** 2 / (gear.rams * gear.stock_to_ram)
        )
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


def _smoothing(k_torque: int, p: int, xtx: NDArray) -> NDArray[np.float64]:
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
    inv = _inverses(a[None])[0]
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
            x[:, free] = (_inverses(a_ff) @ rhs[:, :, None])[:, :, 0]
        ok = np.all((x >= lo - tol) & (x <= hi + tol), axis=1)
        obj = np.einsum('gi,gij,gj->g', x, a, x) - 2.0 * np.einsum('gi,gi->g', b, x)
        take = ok & (obj < best_obj)
        best_obj[take], best[take] = obj[take], x[take]
    out[rows] = np.clip(best, lo, hi)
    return out


def _z_weights(cols: NDArray, zs: Sequence[int], coef: NDArray, used: Sequence[int] | None = None
               ) -> tuple[list[int], NDArray]:
    """The prediction of a row of bin b as sum_j w[b, j] u[j] over z indices ``used`` (default:
    those ``zs`` names): (those indices, w of shape (B, ..., k)) for ``cols`` (B, p) and
    ``coef`` (p,) or (g, p) (then w is (B, g, k))."""
    zi = np.asarray(zs, dtype=np.intp)
    used = sorted({int(z) for z in zi}) if used is None else list(used)
    coef = np.asarray(coef)
    parts = [cols[:, zi == z] @ coef[..., zi == z].T for z in used]
    return used, np.stack(parts, axis=-1)


def _rss_from_weights(mom: Moments, used: Sequence[int], w: NDArray) -> NDArray[np.float64]:
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
    ``cols`` (B, p) multiplying z indices ``zs`` (see :func:`_rss_from_weights` for its
    accuracy)."""
    if not len(mom):
        return 0.0
    used, w = _z_weights(cols, zs, coef)
    return float(_rss_from_weights(mom, used, w))


def _design(fixed: NDArray, fixed_z: Sequence[int], mom: Moments) -> tuple[NDArray, NDArray]:
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
    xtx, xty = _design(cols, zs, mom)
    coef, inv = _solve(xtx, xty, _smoothing(basis.size, len(names), xtx), names)
    return FitAt(coef, residual_sum_of_squares(mom, cols, zs, coef), mom.samples, tuple(names), inv)


def solve_normal_equations(basis: TorqueBasis, xtx: NDArray, xty: NDArray, names: Sequence[str]) -> NDArray:
    """The coefficients from :func:`normal_equations`' X^T X and X^T y."""
    return _solve(xtx, xty, _smoothing(basis.size, len(names), xtx), names)[0]


def normal_equations(gear: GearParams, basis: TorqueBasis, mom: Moments, two_z: float, z_gb: float,
                     load: NDArray[np.float64], extra: Sequence[Column] = ()
                     ) -> tuple[NDArray, NDArray, list[str]]:
    """(X^T X, X^T y, column names) of the model at given clearances."""
    cols, zs, names = design_at(gear, basis, mom, two_z, z_gb, load, extra)
    xtx, xty = _design(cols, zs, mom)
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
    return load * gear.rams * gear.stock_to_ram / np.cos(mom.abs_alpha) ** 2


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
    xtx, xty = _design(cols, [zt] * basis.size + [0] + [zt] * basis.size, mom)
    coef, _ = _solve(xtx, xty, _smoothing(basis.size, cols.shape[1], xtx))
    return coef[:basis.size]


@dataclass(frozen=True)
class Profile:
    """Residual sum of squares over the clearance grid.

    Attributes:
        two_z, z_gb: grid axes [m], shapes (I,), (J,).
        rss: shape (I, J) [N^2]; n: rows; best: (i, j) of the minimum.
    """

    two_z: NDArray[np.float64]
    z_gb: NDArray[np.float64]
    rss: NDArray[np.float64]
    n: float
    p: int
    coef: NDArray[np.float64] | None = None   # the linear coefficients at the best grid point

    @property
    def best(self) -> tuple[int, int]:
        i, j = np.unravel_index(int(np.argmin(self.rss)), self.rss.shape)
        return int(i), int(j)


def profile(gear: GearParams, basis: TorqueBasis, mom: Moments, load: NDArray[np.float64],
            extra: Sequence[Column] = (), grid_2z: NDArray = GRID_2Z, grid_zgb: NDArray = GRID_ZGB) -> Profile:
    """RSS of the linear fit at every grid point (:func:`fit_points` over the grid, friction
    features per angle cell)."""
    fits = fit_points(gear, basis, mom, load, np.repeat(grid_2z, grid_zgb.size), np.tile(grid_zgb, grid_2z.size),
                      extra)
    rss = fits.rss.reshape(grid_2z.size, grid_zgb.size)
    best = int(np.argmin(fits.rss))
    return Profile(grid_2z, grid_zgb, rss, mom.samples, len(fits.names), fits.coef[best].copy())


@dataclass(frozen=True)
class PointFits:
    """The linear fit at each of G clearance pairs.

    Attributes:
        rss: (G,) [N^2]; coef: (G, p) as :attr:`FitAt.coef`; names: (p,).
        cov_unscaled: (G, p, p) as :attr:`FitAt.cov_unscaled`, or None when not asked for.
    """

    rss: NDArray[np.float64]
    coef: NDArray[np.float64]
    names: tuple[str, ...]
    cov_unscaled: NDArray[np.float64] | None

    def at(self, g: int, n: float) -> FitAt:
        """The fit at pair ``g`` (``n`` rows) as :func:`fit_at` gives it."""
        if self.cov_unscaled is None:
            msg = 'these fits were made without their covariance (fit_points(..., covariance=True))'
            raise ValueError(msg)
        return FitAt(self.coef[g], float(self.rss[g]), n, self.names, self.cov_unscaled[g])


POINT_CHUNK = 1 << 20      # pairs solved at once: bins x pairs per array (8 MB)


def fit_points(gear: GearParams, basis: TorqueBasis, mom: Moments, load: NDArray[np.float64],
               two_z: NDArray[np.float64], z_gb: NDArray[np.float64], extra: Sequence[Column] = (), *,
               per_cell: bool = True, covariance: bool = False, dedupe: bool = True) -> PointFits:
    """The declared model fitted at each clearance pair (``two_z[g]``, ``z_gb[g]``), shapes
    (G,) [m]; ``load`` is |Fa| per bin [N]. The clearance-independent blocks of X^T X are
    built once; per pair only the friction columns (and extras built from them) change, and
    the pairs go through the load-sharing solver and the solves together, a chunk at a time.

    ``per_cell``: friction features once per (angle bin, speed class) cell at the cell's
    mean angle and torque (the profile; ~1e-4 of the RSS from the per-bin features), else
    per bin, as :func:`fit_at` (which this then equals to rounding). ``covariance``: also
    the (X^T X + ridge)^-1 of every pair. ``dedupe``: pairs whose features are equal to the
    bit (beyond any contact) are solved once; a saving only, the residual sums of squares
    being order-independent to (bins x epsilon) either way. The clearance-independent part
    (:class:`PointFitter`) is built once per moments, load and columns and kept with the
    moments (:meth:`PointFitter.of`): the profiles, refinements and interval fits of one model
    share it."""
    return PointFitter.of(gear, basis, mom, load, extra, per_cell=per_cell).fit(two_z, z_gb, covariance=covariance,
                                                                                dedupe=dedupe)


FITTERS_KEPT = 6          # PointFitters kept with one set of moments (a few MB each)


class PointFitter:
    """:func:`fit_points` on one set of moments, load and extra columns, its
    clearance-independent part built once: the same numbers as :func:`fit_points` call for
    call, without its ~30 ms of set-up on a long log.

    The columns split into those the clearances do not change (X1: the torque curve, the seal
    friction, most extra columns) and the few they do (X2: the bushing's and the slipper's
    friction, and extra columns made from them). The penalized fit of X1 alone (its
    coefficients beta1, its residual r0 and the inverse of its normal matrix) is made once;
    per pair only X2 is new, and the fit of both is its partitioned form (Frisch-Waugh-Lovell,
    with the ridge and smoothing penalty of :func:`fit_at` on each block):

        K = (A11 + P1)^-1 A12,   S = A22 + P2 - A21 K,   b2 = S^-1 (c2 - A21 beta1),
        b1 = beta1 - K b2,       RSS = r0'r0 - 2 b2' R2'r0 + b2' R2'R2 b2,

    with R2 = X2 - X1 K (R2'r0 = c2 - A21 beta1 - K' P1 beta1, R2'R2 = A22 - A21 K - K' P1 K).
    So a pair costs the cross products of its two or three columns with the others and a
    2 x 2 or 3 x 3 solve, not a solve of the whole model and a pass over every bin. r0'r0
    comes from the bins' centred statistics (:func:`_rss_from_weights`); the terms subtracted
    from it are the friction the clearances explain, a hundredth of it or more, so the RSS
    keeps its relative accuracy to within that factor of rounding (``test_fit`` compares it
    with :func:`fit_at`, which works it out bin by bin, to 1e-10)."""

    def __init__(self, gear: GearParams, basis: TorqueBasis, mom: Moments, load: NDArray[np.float64],
                 extra: Sequence[Column] = (), *, per_cell: bool = True) -> None:
        self.gear, self.basis, self.load, self.extra = gear, basis, load.copy(), tuple(extra)
        self._mom: Moments | weakref.ref[Moments] = mom
        self.per_cell = per_cell
        torque = torque_of_load(gear, mom, load)
        zero = {'n_b': np.zeros(len(mom)), 'f_gb': np.zeros(len(mom)), 'load': load}
        self.base_cols, self.zs, self.names = design_columns(gear, basis, mom, zero, extra)
        p = len(self.names)
        self.dep = _dependent_columns(basis, extra)
        self.dep_lo, self.dep_hi = declared_bounds([self.names[a] for a in self.dep], len(self.dep))
        xtx0, xty0 = _design(self.base_cols, self.zs, mom)
        smooth = _smoothing(basis.size, p, xtx0)
        q = mom.m.shape[1]
        self.myz = mom.m[:, q - 1, :]                    # (B, q): y with each z
        if per_cell:
            self.cell_alpha, self.cell_torque, self.cell_of_bin = _cells(mom, torque)
        else:
            self.cell_alpha, self.cell_torque, self.cell_of_bin = mom.abs_alpha, torque, np.arange(len(mom))
        fixed = np.array([c for c in range(p) if c not in self.dep], np.intp)
        self.fixed_cols = fixed
        self.used = sorted({int(z) for z in self.zs})
        self.slot = {z: k for k, z in enumerate(self.used)}
        self.fixed_z = [self.zs[c] for c in fixed]
        self.cross = {a: self.base_cols[:, fixed] * mom.m[:, self.zs[a], np.asarray(self.fixed_z)]
                      for a in self.dep}                 # (B, n_fixed)
        # The friction columns are d x (a cell's feature): their products with anything sum
        # over a cell's bins first (the features are the cell's), so a pair costs cells, not bins.
        ncell = int(self.cell_of_bin.max(initial=-1)) + 1
        self.friction = [a for a in self.dep if a in (basis.size + 1, basis.size + 2)]
        self.others = [a for a in self.dep if a not in self.friction]
        d = mom.direction

        def per_cell(x: NDArray[np.float64]) -> NDArray[np.float64]:
            out = np.zeros((ncell,) + x.shape[1:])
            np.add.at(out, self.cell_of_bin, x)
            return out

        self.cell_cross = {a: per_cell(d[:, None] * self.cross[a]) for a in self.friction}      # (C, n_fixed)
        self.cell_y = {a: per_cell(d * self.myz[:, self.zs[a]]) for a in self.friction}         # (C,)
        self.cell_m = {(a, b): per_cell(mom.m[:, self.zs[a], self.zs[b]]) for a in self.friction
                       for b in self.friction}                                                 # (C,): d^2 = 1
        a11 = xtx0[np.ix_(fixed, fixed)]
        self.p1 = smooth[np.ix_(fixed, fixed)] + np.diag(RIDGE * np.diag(a11) + 1e-300)
        self.inv11 = _inverses((a11 + self.p1)[None])[0]
        self.beta1 = self.inv11 @ xty0[fixed]
        self.p1_beta1 = self.p1 @ self.beta1             # X1' r0
        _, w0 = _z_weights(self.base_cols[:, fixed], self.fixed_z, self.beta1, self.used)
        self.rss0 = float(_rss_from_weights(mom, self.used, w0))

    def _closing(self) -> tuple[float, float]:
        """(2Z, Z_gb) [m] past which no cell's load closes the clearance (:func:`closing_clearances`)."""
        if self.__dict__.get('_closes') is None:
            self._closes = closing_clearances(self.gear, self.cell_alpha, self.cell_torque)
        return self._closes

    @property
    def mom(self) -> Moments:
        """The moments fitted (held weakly by a fitter kept with them, :meth:`of`)."""
        m = self._mom
        if isinstance(m, weakref.ref):
            held = m()
            if held is None:
                msg = 'the moments of this fitter are gone: keep them while the fitter is used'
                raise RuntimeError(msg)
            return held
        return m

    @classmethod
    def of(cls, gear: GearParams, basis: TorqueBasis, mom: Moments, load: NDArray[np.float64],
           extra: Sequence[Column] = (), *, per_cell: bool = True) -> PointFitter:
        """The fitter of this problem, built once and kept with the moments (which are replaced,
        not changed, when data are added), the last ``FITTERS_KEPT`` of them: the same object
        for the same gear, load (by value) and columns (by identity)."""
        extra = tuple(extra)
        kept: list[PointFitter] = mom.__dict__.setdefault('_point_fitters', [])
        for f in kept:
            if (f.gear is gear and f.basis == basis and f.per_cell == per_cell and len(f.extra) == len(extra)
                    and all(a is b for a, b in zip(f.extra, extra)) and np.array_equal(f.load, load)):
                return f
        f = cls(gear, basis, mom, load, extra, per_cell=per_cell)
        # kept on the moments, it refers to them weakly: a cycle (moments -> fitter -> moments)
        # outlived each analysis until Python's cycle collector happened to run, holding the
        # fitters' arrays (the node's worker kept 300-560 MB after a loop instead of 200 MB)
        f._mom = weakref.ref(mom)
        kept.append(f)
        del kept[:-FITTERS_KEPT]
        return f

    def fit(self, two_z: NDArray[np.float64], z_gb: NDArray[np.float64], *, covariance: bool = False,
            dedupe: bool = True) -> PointFits:
        """The fits at the pairs, as :func:`fit_points`."""
        gear, basis, mom, load, extra = self.gear, self.basis, self.mom, self.load, self.extra
        zs, dep, fixed = self.zs, self.dep, self.fixed_cols
        two_z, z_gb = np.broadcast_arrays(np.asarray(two_z, float).ravel(), np.asarray(z_gb, float).ravel())
        d = mom.direction
        p, nd = len(self.names), len(dep)
        nb_all, fg_all, first, inverse = _point_features(gear, self.cell_alpha, self.cell_torque, two_z, z_gb,
                                                         dedupe, self._closing())
        u_all = first.size
        rss = np.empty(u_all)
        coef_all = np.empty((u_all, p))
        cov = np.empty((u_all, p, p)) if covariance else None
        step = max(POINT_CHUNK // max(len(mom), 1), 1)
        cell_feature = {basis.size + 1: nb_all, basis.size + 2: fg_all}
        for g0 in range(0, u_all, step):
            sl = slice(g0, min(g0 + step, u_all))
            g = sl.stop - sl.start
            fcell = {a: cell_feature[a][:, sl] for a in self.friction}                  # (C, g): d x this per bin
            vals = {}
            if self.others:
                feats = {'n_b': nb_all[self.cell_of_bin, sl], 'f_gb': fg_all[self.cell_of_bin, sl],
                         'load': load[:, None]}
                vals = {a: _dep_value(a, basis, d[:, None], feats, mom, extra) for a in self.others}  # (B, g)
                for a in self.friction:
                    vals[a] = d[:, None] * fcell[a][self.cell_of_bin]
            a12 = np.empty((g, fixed.size, nd))
            a22 = np.empty((g, nd, nd))
            c2 = np.empty((g, nd))
            for i, a in enumerate(dep):
                if a in self.friction:
                    a12[:, :, i] = fcell[a].T @ self.cell_cross[a]
                    c2[:, i] = fcell[a].T @ self.cell_y[a]
                else:
                    a12[:, :, i] = vals[a].T @ self.cross[a]
                    c2[:, i] = vals[a].T @ self.myz[:, zs[a]]
                for j in range(i, nd):
                    b = dep[j]
                    if a in self.friction and b in self.friction:
                        a22[:, i, j] = (fcell[a] * fcell[b]).T @ self.cell_m[(a, b)]
                    else:
                        a22[:, i, j] = (vals[a] * vals[b]).T @ mom.m[:, zs[a], zs[b]]
                    a22[:, j, i] = a22[:, i, j]
            a21 = a12.transpose(0, 2, 1)                                                  # (g, nd, p1)
            kt = a21 @ self.inv11                                                         # K' (g, nd, p1)
            a21k = kt @ a12                                                               # A21 K = K' A12
            s_mat = a22 - a21k
            s_mat[:, np.arange(nd), np.arange(nd)] += RIDGE * np.diagonal(a22, axis1=1, axis2=2) + 1e-300
            rhs = c2 - a21 @ self.beta1                                                   # X2' r0
            s_inv = _inverses(s_mat)
            b2 = (s_inv @ rhs[:, :, None])[:, :, 0]
            # the bushing's and the slipper's friction held to their physical ranges: with b1
            # profiled out the penalized objective is b2' S b2 - 2 b2' rhs, and b1 and the RSS
            # below follow from any b2
            b2 = bounded_quadratic(s_mat, rhs, self.dep_lo, self.dep_hi, b2)
            b1 = self.beta1[None, :] - (b2[:, None, :] @ kt)[:, 0, :]
            r2_r0 = rhs - kt @ self.p1_beta1
            r2_r2 = a22 - a21k - (kt @ self.p1) @ kt.transpose(0, 2, 1)
            rss[sl] = (self.rss0 - 2.0 * np.einsum('gd,gd->g', b2, r2_r0)
                       + np.einsum('gd,gd->g', b2, (r2_r2 @ b2[:, :, None])[:, :, 0]))
            coef = np.empty((g, p))
            coef[:, fixed] = b1
            coef[:, dep] = b2
            coef_all[sl] = coef
            if cov is not None:
                ks = kt.transpose(0, 2, 1) @ s_inv                                        # K S^-1
                full = np.empty((g, p, p))
                full[np.ix_(np.arange(g), fixed, fixed)] = self.inv11[None] + ks @ kt
                full[np.ix_(np.arange(g), fixed, dep)] = -ks
                full[np.ix_(np.arange(g), dep, fixed)] = -ks.transpose(0, 2, 1)
                full[np.ix_(np.arange(g), dep, dep)] = s_inv
                cov[sl] = full
        return PointFits(np.maximum(rss, 0.0)[inverse], coef_all[inverse], tuple(self.names),
                         None if cov is None else cov[inverse])


FEATURE_CHUNK = 1 << 21    # friction features evaluated per call: cells x pairs (16 MB a array)
BEYOND = 1.0 + 1e-6       # a clearance this far past the largest any cell closes is past them all


def closing_clearances(gear: GearParams, alpha: NDArray[np.float64], torque: NDArray[np.float64]
                       ) -> tuple[float, float]:
    """(2Z, Z_gb) [m] past which no cell (angles and torques (C,)) closes the clearance: ``BEYOND``
    times the largest 2Z whose F_theta a cell's lateral force reaches, and likewise for F_Z."""
    unit = load_sharing(gear, alpha, torque, 1.0, 1.0)           # F_theta, F_Z at a clearance of 1 m
    with np.errstate(divide='ignore', invalid='ignore'):
        closes_2z = unit.lateral / unit.f_theta
        closes_zgb = unit.lateral / unit.f_z
    return (float(np.nanmax(closes_2z, initial=0.0)) * BEYOND, float(np.nanmax(closes_zgb, initial=0.0)) * BEYOND)


def _point_features(gear: GearParams, alpha: NDArray[np.float64], torque: NDArray[np.float64],
                    two_z: NDArray[np.float64], z_gb: NDArray[np.float64], dedupe: bool = True,
                    closing: tuple[float, float] | None = None
                    ) -> tuple[NDArray, NDArray, NDArray[np.intp], NDArray[np.intp]]:
    """:func:`friction_features` at angles and torques (C,) for clearance pairs (G,), kept
    once per distinct column: (N_b (C, U), |F_gb| (C, U), the first pair of each distinct
    column (U,), each pair's distinct column (G,)).

    Pairs beyond any contact are one model, solved once when ``dedupe``: on a log whose ram
    never clamps, most of the grid's 2Z axis is one plateau. A 2Z past the one that lets the
    most loaded cell's ram clamp (F_theta >= Fl in every cell, with a margin of ``BEYOND``
    over rounding) leaves every cell's loading as it is whatever its value (the clamp is
    never reached, and after the guide touches the ram's force stays below F_theta), and so
    does a Z_gb past the one the most loaded cell's ram deflects to: such pairs have the same
    features to the bit (``test_fit`` checks it), and each such class is evaluated once.
    ``closing``: :func:`closing_clearances` of the cells, when known."""
    if dedupe and two_z.size > 1:
        top_2z, top_zgb = closing or closing_clearances(gear, alpha, torque)
        key = np.where(two_z >= top_2z, top_2z, two_z) + 1j * np.where(z_gb >= top_zgb, top_zgb, z_gb)
        _, first, inverse = np.unique(key, return_index=True, return_inverse=True)
        order = np.argsort(first)                                     # the classes in order of their first pair
        rank = np.empty_like(order)
        rank[order] = np.arange(order.size)
        first, inverse = first[order], rank[inverse.reshape(-1)]
    else:
        first, inverse = np.arange(two_z.size), np.arange(two_z.size)
    step = max(FEATURE_CHUNK // max(alpha.size, 1), 1)
    if first.size <= step:
        nb_all, fg_all = friction_normals(gear, alpha, torque, two_z[first], z_gb[first])
        return nb_all, fg_all, first.astype(np.intp), inverse.astype(np.intp)
    # chunk by chunk into the whole (a list of the chunks joined at the end held both at once:
    # twice the features, 270 MB of the analysis's peak on a 25-minute voyage)
    nb_all, fg_all = np.empty((alpha.size, first.size)), np.empty((alpha.size, first.size))
    for g0 in range(0, first.size, step):
        cols = first[g0:g0 + step]
        nb_all[:, g0:g0 + cols.size], fg_all[:, g0:g0 + cols.size] = friction_normals(gear, alpha, torque,
                                                                                     two_z[cols], z_gb[cols])
    return nb_all, fg_all, first.astype(np.intp), inverse.astype(np.intp)


def _inverses(a: NDArray[np.float64]) -> NDArray[np.float64]:
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


def _cells(mom: Moments, torque: NDArray[np.float64]) -> tuple[NDArray, NDArray, NDArray]:
    """The friction features depend on |alpha| and the load only, not on the side or the
    direction: evaluate them once per (angle bin, speed class) cell, at the cell's mean angle
    and torque (count-weighted), and map back to the bins."""
    cell_key = mom.keys >> 2
    uk, inv = np.unique(cell_key, return_inverse=True)
    w = np.bincount(inv, mom.count, minlength=uk.size)
    a = np.bincount(inv, mom.sum_abs_alpha, minlength=uk.size) / w
    t = np.bincount(inv, torque * mom.count, minlength=uk.size) / w
    return a, t, inv


def _dependent_columns(basis: TorqueBasis, extra: Sequence[Column]) -> list[int]:
    k = basis.size
    dep = [k + 1, k + 2]
    dep += [k + 3 + i for i, c in enumerate(extra) if getattr(c.feature, 'uses_clearances', False)]
    return dep


def _dep_value(a: int, basis: TorqueBasis, d: NDArray, feats: dict,
               mom: Moments, extra: Sequence[Column]) -> NDArray:
    k = basis.size
    if a == k + 1:
        return d * feats['n_b']
    if a == k + 2:
        return d * feats['f_gb']
    return extra[a - k - 3].feature(mom, feats)
