"""The declared model's fit at many clearance pairs at once, and the profile over the grid.

:func:`fit_points` solves the linear fit of :mod:`~steer_monitor.estimate.fit` at every pair of
clearances asked, the clearance-independent part built once per set of moments
(:class:`PointFitter`, kept with the moments), the friction features of every cell at every
pair evaluated in chunks; :func:`profile` is that over a grid, its residual sums of squares
what the likelihood-ratio intervals of :mod:`~steer_monitor.estimate.intervals` read.
"""

from __future__ import annotations

import weakref
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from steer_monitor.estimate.fit import (
    GRID_2Z,
    GRID_ZGB,
    RIDGE,
    Column,
    FitAt,
    TorqueBasis,
    bounded_quadratic,
    declared_bounds,
    design_columns,
    design_matrices,
    inverses,
    rss_from_weights,
    smoothing_penalty,
    torque_of_load,
    z_weights,
)
from steer_monitor.estimate.moments import Moments
from steer_monitor.model.gear import GearParams
from steer_monitor.model.loadshare import friction_normals, load_sharing

__all__ = ['BEYOND', 'FEATURE_CHUNK', 'FITTERS_KEPT', 'POINT_CHUNK', 'PointFits', 'PointFitter', 'Profile',
           'closing_clearances', 'fit_points', 'profile']


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
    comes from the bins' centred statistics (:func:`rss_from_weights`); the terms subtracted
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
        xtx0, xty0 = design_matrices(self.base_cols, self.zs, mom)
        smooth = smoothing_penalty(basis.size, p, xtx0)
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
        self.inv11 = inverses((a11 + self.p1)[None])[0]
        self.beta1 = self.inv11 @ xty0[fixed]
        self.p1_beta1 = self.p1 @ self.beta1             # X1' r0
        _, w0 = z_weights(self.base_cols[:, fixed], self.fixed_z, self.beta1, self.used)
        self.rss0 = float(rss_from_weights(mom, self.used, w0))

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
            s_inv = inverses(s_mat)
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
