"""The clearance profile between grid points, where the grid cannot resolve it. Pure.

The clearances are profiled on a grid (:data:`~steer_monitor.estimate.fit.GRID_2Z`, 0.02 mm
steps; :data:`~steer_monitor.estimate.fit.GRID_ZGB`, 0.005 mm). Where the data pin a clearance
to less than a few steps (a ram that clamps pins 2Z to a few micrometres on a long voyage)
the grid's best point is the grid's, not the data's: a true 2Z of 0.1916 mm was estimated
at 0.2000 mm with the interval [0.1974, 0.2001], and the misfit of the wrong 2Z moved Z_gb
by three of its steps (0.325 mm for a true 0.311, interval 0.0003 mm wide), K_gl and the
friction with it. Every clearance of the accuracy study lay on the grid, so its coverage
could not show this; real clearances lie anywhere.

Here each clearance whose 95 % set on the grid spans fewer than ``SHARP_STEPS`` grid steps
is profiled again on a finer axis: at each of its values the other clearance is searched
for the least RSS (the two are correlated: the profile is a tilted ridge, so a box of fine
points around the grid's best would miss its minimum), first on the other axis's grid
steps, moving on while the least lies at the edge of the points tried, then on a quarter, a
sixteenth and a sixty-fourth of them, last at the vertex of a parabola through the best and
its neighbours. The finer axis runs over the grid's 95 % set and a step either side,
widened while the set still reaches its ends, and made finer again, around its own 95 %
set, while that holds fewer than ``MIN_POINTS`` points. A clearance the data bound from one
side only (its set runs to the grid's end) is searched on its grid values alone, as the
profiled axis and as the other one: between them a search would place a contact at the
highest loads wherever the noise liked it best and narrow the other clearance's interval
for nothing. The result is each clearance's marginal profile (least RSS over the other
clearance) on the merged axis, and every pair evaluated, from which the estimate takes its
best point, intervals and joint region.

Before that, a valley the grid steps over (:func:`_deeper_valley`): a clamp can pin a
clearance in a valley narrower than the grid's step away from the grid's best, its bottom
below the best though the grid's points on its flanks stand high. Each clearance's lowest
local minima the grid does not resolve are profiled between their grid neighbours; one that
goes below the grid's best becomes the best the refinement goes on from.

RSS here is the profile's (friction features per angle cell, :func:`~steer_monitor.estimate.pointfit.fit_points`),
so refined and grid points compare on the same footing.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from steer_monitor.estimate import fit as F
from steer_monitor.estimate import pointfit as PF
from steer_monitor.estimate.intervals import CHI2_1_95
from steer_monitor.estimate.moments import Moments
from steer_monitor.model.gear import GearParams

__all__ = ['MIN_POINTS', 'SHARP_STEPS', 'VALLEYS', 'Marginal', 'Refined', 'marginal_of', 'refine_profile', 'widen_to']

SHARP_STEPS = 4          # a 95 % set narrower than this many grid steps is profiled between them
POINTS = 11              # values of the finer axis per pass
MIN_POINTS = 4           # a finer pass whose 95 % set holds fewer values is made finer again
LEVELS = 3               # finer passes at most
WIDEN = 4                # times a finer axis may be widened on a side its 95 % set still reaches
SEARCH = 2               # the other clearance is tried at +-SEARCH of its step around its guess
MOVES = 8                # ... moving on at most this many times while the least is at an edge
ZOOMS = 3                # ... then +-2 quarters of that step around the best, three times (to 1/64),
                         # and last at the vertex of the parabola through the best and its neighbours
DECIMALS = 12            # m: values rounded to a picometre, so a grid value is found as itself
VALLEYS = 2              # a clearance's lowest local minima on the grid looked into between grid points
VALLEY_POINTS = 9        # values across a valley, its two grid neighbours included
VALLEY_ZOOMS = 2         # ... then +-2 quarters of that spacing around the least, twice


@dataclass(frozen=True)
class Marginal:
    """A clearance's profile: at each value of ``axis`` [m] (sorted, shape (K,)) the least
    RSS over the other clearance, ``rss`` (K,) [N^2], found at ``other`` (K,) [m]."""

    axis: NDArray[np.float64]
    rss: NDArray[np.float64]
    other: NDArray[np.float64]


@dataclass(frozen=True)
class Refined:
    """The profile with its sharp parts refined.

    Attributes:
        two_z, z_gb: the marginal profile of each clearance (the grid's values and the
            finer ones merged).
        pairs: (P, 2) every clearance pair evaluated [m] (the grid's and the finer ones);
            rss: (P,) their RSS [N^2].
        steps: (2Z, Z_gb) [m]: the spacing of the finest axis each clearance was profiled
            on (the grid's step where it was not refined).
        refined: (2Z, Z_gb) whether each was profiled between grid points.
    """

    two_z: Marginal
    z_gb: Marginal
    pairs: NDArray[np.float64]
    rss: NDArray[np.float64]
    steps: tuple[float, float]
    refined: tuple[bool, bool]
    #: each clearance profiled between grid points, as :func:`widen_to` goes on with it (None: not)
    axes: tuple[_Axis | None, _Axis | None] = field(default=(None, None), repr=False, compare=False)
    #: how many of the evaluator's calls ``pairs`` holds (the rest came after it was made)
    evaluated: int = field(default=0, repr=False, compare=False)

    @property
    def best(self) -> tuple[float, float]:
        """The pair of least RSS [m]."""
        k = int(np.argmin(self.rss))
        return float(self.pairs[k, 0]), float(self.pairs[k, 1])


def marginal_of(pr: PF.Profile, axis: int) -> Marginal:
    """The grid profile's marginal along ``axis`` (0: 2Z, 1: Z_gb)."""
    values, others = (pr.two_z, pr.z_gb) if axis == 0 else (pr.z_gb, pr.two_z)
    rss = pr.rss if axis == 0 else pr.rss.T
    k = np.argmin(rss, axis=1)
    return Marginal(np.asarray(values, float), rss[np.arange(rss.shape[0]), k], np.asarray(others, float)[k])


class _Evaluator:
    """RSS at clearance pairs, every pair kept."""

    def __init__(self, gear: GearParams, basis: F.TorqueBasis, mom: Moments, load: NDArray[np.float64],
                 extra: Sequence[F.Column]) -> None:
        self.problem = (gear, basis, mom, load, tuple(extra))
        self.fitter: PF.PointFitter | None = None     # built at the first pair: most profiles need none
        self.pairs: list[NDArray[np.float64]] = []
        self.rss: list[NDArray[np.float64]] = []
        self.least = np.inf     # the least RSS evaluated so far [N^2] ...
        self.best = (np.nan, np.nan)   # ... and where (2Z, Z_gb) [m]

    def __call__(self, two_z: NDArray[np.float64], z_gb: NDArray[np.float64]) -> NDArray[np.float64]:
        shape = two_z.shape
        tz, zg = two_z.ravel(), z_gb.ravel()
        if self.fitter is None:
            self.fitter = PF.PointFitter.of(*self.problem)
        rss = self.fitter.fit(tz, zg).rss
        self.pairs.append(np.stack([tz, zg], axis=1))
        self.rss.append(rss)
        if rss.size and float(rss.min()) < self.least:
            k = int(np.argmin(rss))
            self.least, self.best = float(rss[k]), (float(tz[k]), float(zg[k]))
        return rss.reshape(shape)


def _conditional(evaluate: _Evaluator, axis: int, xs: NDArray[np.float64], guess: NDArray[np.float64],
                 step: float, lo: float, hi: float, on_grid: bool = False
                 ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """For each ``xs`` (values of clearance ``axis``) the least RSS over the other clearance
    and where: tried at +-``SEARCH`` of its ``step`` around ``guess``, moving on while the least
    is at an edge that is not the grid's (``lo``, ``hi``), then at finer steps -> (rss, other).
    ``on_grid``: the other clearance is tried at its grid values only (see :func:`refine_profile`)."""
    centre = np.clip(guess, lo, hi)
    if on_grid and step > 0:
        centre = np.round(lo + np.round((centre - lo) / step) * step, DECIMALS)
    best_rss = np.full(xs.size, np.inf)
    best_at = centre.copy()

    def attempt(rows: NDArray[np.intp], h: float, offsets: NDArray[np.float64]) -> NDArray[np.bool_]:
        ys = np.round(np.clip(centre[rows, None] + h * offsets[None, :], lo, hi), DECIMALS)
        x = np.broadcast_to(xs[rows, None], ys.shape)
        rss = evaluate(x, ys) if axis == 0 else evaluate(ys, x)
        k = np.argmin(rss, axis=1)
        got = rss[np.arange(rows.size), k]
        better = got < best_rss[rows]
        best_rss[rows[better]] = got[better]
        best_at[rows[better]] = ys[better, k[better]]
        centre[rows] = best_at[rows]
        return ((k == 0) & (ys[:, 0] > lo)) | ((k == offsets.size - 1) & (ys[:, -1] < hi))

    rows = np.arange(xs.size)
    wide = np.arange(-SEARCH, SEARCH + 1, dtype=float)
    for _ in range(MOVES + 1):
        edge = attempt(rows, step, wide)
        rows = rows[edge]
        if rows.size == 0:
            break
    if on_grid:
        return best_rss, best_at
    near = np.array([-2.0, -1.0, 1.0, 2.0])    # the least lies within half a step of the best
    h = step
    everyone = np.arange(xs.size)
    for _ in range(ZOOMS):
        h /= 4
        attempt(everyone, h, near)
    # the vertex of the parabola through the best and the points a quarter-step either side
    ys = np.round(np.clip(best_at[:, None] + h * np.array([-1.0, 1.0])[None, :], lo, hi), DECIMALS)
    x = np.broadcast_to(xs[:, None], ys.shape)
    side = evaluate(x, ys) if axis == 0 else evaluate(ys, x)
    curve = side[:, 0] + side[:, 1] - 2.0 * best_rss
    with np.errstate(divide='ignore', invalid='ignore'):
        shift = np.where(curve > 0, 0.5 * h * (side[:, 0] - side[:, 1]) / curve, 0.0)
    vertex = np.round(np.clip(best_at + np.clip(shift, -h, h), lo, hi), DECIMALS)
    at_vertex = evaluate(xs, vertex) if axis == 0 else evaluate(vertex, xs)
    for r, y in zip((side[:, 0], side[:, 1], at_vertex), (ys[:, 0], ys[:, 1], vertex)):
        better = r < best_rss
        best_rss[better], best_at[better] = r[better], y[better]
    return best_rss, best_at


def _accepted(rss: NDArray[np.float64], floor: float, scale: float) -> NDArray[np.intp]:
    return np.nonzero((rss - floor) / scale <= CHI2_1_95)[0]


def _merged(x: NDArray[np.float64], rss: NDArray[np.float64], other: NDArray[np.float64]) -> Marginal:
    """One value per clearance, the least RSS where a value was profiled more than once."""
    x = np.round(np.asarray(x, float), DECIMALS)
    rss, other = np.asarray(rss, float), np.asarray(other, float)
    order = np.lexsort((rss, x))
    x, rss, other = x[order], rss[order], other[order]
    first = np.ones(x.size, dtype=bool)
    first[1:] = x[1:] != x[:-1]
    return Marginal(x[first], rss[first], other[first])


class _Axis:
    """The conditional minima found so far along one clearance."""

    def __init__(self, evaluate: _Evaluator, axis: int, other_grid: NDArray[np.float64], coarse: Marginal,
                 other_open: bool = False) -> None:
        self.evaluate, self.axis, self.other_open = evaluate, axis, other_open
        self.o_step = float(other_grid[1] - other_grid[0]) if other_grid.size > 1 else 0.0
        self.o_lo, self.o_hi = float(other_grid[0]), float(other_grid[-1])
        self.coarse = coarse
        self.fine: dict[float, tuple[float, float]] = {}
        self.spans: list[tuple[float, float]] = []   # ranges profiled between grid points

    def run(self, xs: NDArray[np.float64], start: float | None = None) -> None:
        """The conditional minima at ``xs`` not profiled yet, the other clearance's search
        started where the marginal so far has it (or at ``start`` [m])."""
        xs = np.array([x for x in np.round(np.asarray(xs, float), DECIMALS).tolist() if x not in self.fine])
        if xs.size == 0:
            return
        if start is None:
            m = self.marginal()
            guess = np.interp(xs, m.axis, m.other)
        else:
            guess = np.full(xs.size, start)
        rss, other = _conditional(self.evaluate, self.axis, xs, guess, self.o_step, self.o_lo, self.o_hi,
                                  self.other_open)
        for x, r, o in zip(xs.tolist(), rss.tolist(), other.tolist()):
            self.fine[x] = (r, o)

    def within(self, lo: float, hi: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        xs = np.array(sorted(x for x in self.fine if lo - 1e-15 <= x <= hi + 1e-15))
        return xs, np.array([self.fine[x][0] for x in xs.tolist()])

    def marginal(self) -> Marginal:
        """The conditional minima found, and the grid's marginal outside the ranges profiled
        between grid points (inside them it reads high: its other clearance was the grid's)."""
        fx = np.array(list(self.fine), float)
        fr = np.array([v[0] for v in self.fine.values()], float)
        fo = np.array([v[1] for v in self.fine.values()], float)
        c = self.coarse
        keep = np.ones(c.axis.size, dtype=bool)
        for lo, hi in self.spans:
            keep &= ~((c.axis > lo + 1e-15) & (c.axis < hi - 1e-15))
        return _merged(np.concatenate([fx, c.axis[keep]]), np.concatenate([fr, c.rss[keep]]),
                       np.concatenate([fo, c.other[keep]]))


def _refine_axis(ax: _Axis, grid: NDArray[np.float64], scale: float) -> float:
    """Clearance ``ax.axis`` profiled between its grid points, over its 95 % set; returns the
    finest spacing used [m]."""
    evaluate = ax.evaluate
    spacing = float(grid[1] - grid[0])
    # the grid's view of the 95 % set, and the least pair found so far (the other
    # clearance's refinement may have moved it off that set: the profile is a tilted ridge)
    inside = _accepted(ax.coarse.rss, float(ax.coarse.rss.min()), scale)
    best = evaluate.best[ax.axis]
    ax.fine.setdefault(float(np.round(best, DECIMALS)), (evaluate.least, evaluate.best[1 - ax.axis]))
    lo = min(float(grid[max(int(inside.min()) - 1, 0)]), max(best - spacing, float(grid[0])))
    hi = max(float(grid[min(int(inside.max()) + 1, grid.size - 1)]), min(best + spacing, float(grid[-1])))
    for level in range(LEVELS):
        if hi <= lo:
            break
        spacing = (hi - lo) / (POINTS - 1)
        ax.run(np.linspace(lo, hi, POINTS))
        ax.spans.append((lo, hi))
        lo, hi, _ = _widen(ax, grid, lo, hi, spacing, CHI2_1_95 * scale)
        xs, rss = ax.within(lo, hi)
        inside = _accepted(rss, evaluate.least, scale)
        if level == LEVELS - 1 or inside.size >= MIN_POINTS:
            break
        if inside.size == 0:
            inside = np.array([int(np.argmin(rss))])
        lo = float(xs[max(int(inside.min()) - 1, 0)])
        hi = float(xs[min(int(inside.max()) + 1, xs.size - 1)])
    return spacing


def _widen(ax: _Axis, grid: NDArray[np.float64], lo: float, hi: float, spacing: float, limit: float
           ) -> tuple[float, float, bool]:
    """Clearance ``ax.axis`` profiled beyond ``lo`` .. ``hi`` [m] at ``spacing`` while the set
    within ``limit`` [N^2] of the least RSS still reaches an end (by half the width, up to
    :data:`WIDEN` times, within the grid) -> (lo, hi, whether it grew)."""
    grew = False
    for _ in range(WIDEN):
        xs, rss = ax.within(lo, hi)
        inside = np.nonzero(rss - ax.evaluate.least <= limit)[0]
        grow_lo = bool(inside.size) and int(inside.min()) == 0 and lo > grid[0]
        grow_hi = bool(inside.size) and int(inside.max()) == xs.size - 1 and hi < grid[-1]
        if not (grow_lo or grow_hi):
            break
        width, new = hi - lo, []
        if grow_lo:
            lo_new = max(lo - width / 2, float(grid[0]))
            new.append(np.arange(lo - spacing, lo_new - spacing / 2, -spacing))
            lo = lo_new
        if grow_hi:
            hi_new = min(hi + width / 2, float(grid[-1]))
            new.append(np.arange(hi + spacing, hi_new + spacing / 2, spacing))
            hi = hi_new
        ax.run(np.clip(np.concatenate(new), float(grid[0]), float(grid[-1])))
        ax.spans.append((lo, hi))
        grew = True
    return lo, hi, grew


def widen_to(ref: Refined, limits: tuple[float, float]) -> Refined:
    """``ref`` with each clearance it profiled between grid points profiled further where its
    95 % set read against ``limits`` (2Z, Z_gb: RSS above the least [N^2], the intervals' own,
    their scale and threshold known only once the refinement's best is fitted) reaches past
    the values profiled. Beyond them the marginal is the grid's, whose other clearance on its
    grid reads high, so an interval would end at the first grid value there, too soon (a
    window read Z_gb 0.3147 [0.2980, 0.3192] mm for 0.3213: the grid's 0.320 stood 21 of the
    interval's units above the least where the other clearance searched between grid points
    put it below 4). The set's ends are then located between the values profiled at a tenth of
    their spacing. Unchanged when no set reaches that far."""
    marginals = [ref.two_z, ref.z_gb]
    grew_any = False
    for axis, ax in enumerate(ref.axes):
        if ax is None or not ax.spans:
            continue
        grid = ax.coarse.axis
        lo, hi = min(a for a, _ in ax.spans), max(b for _, b in ax.spans)
        first = ax.spans[0]
        spacing = (first[1] - first[0]) / (POINTS - 1)
        lo, hi, grew = _widen(ax, grid, lo, hi, spacing, limits[axis])
        if not grew:
            continue
        grew_any = True
        xs, rss = ax.within(lo, hi)
        inside = np.nonzero(rss - ax.evaluate.least <= limits[axis])[0]
        if inside.size:                      # each end of the set between the values either side
            new = []
            for a, b in ((int(inside.min()) - 1, int(inside.min())), (int(inside.max()), int(inside.max()) + 1)):
                if 0 <= a and b < xs.size:
                    new.append(np.linspace(xs[a], xs[b], POINTS)[1:-1])
            if new:
                ax.run(np.concatenate(new))
        marginals[axis] = ax.marginal()
    if not grew_any:
        return ref
    evaluate = next(a for a in ref.axes if a is not None).evaluate
    pairs = np.concatenate([ref.pairs, *evaluate.pairs[ref.evaluated:]])
    rss = np.concatenate([ref.rss, *evaluate.rss[ref.evaluated:]])
    return _assembled(marginals, pairs, rss, ref.steps, ref.refined, ref.axes, len(evaluate.pairs))


def _assembled(marginals: list[Marginal], pairs: NDArray[np.float64], rss: NDArray[np.float64],
               steps: tuple[float, float], refined: tuple[bool, bool],
               axes: tuple[_Axis | None, _Axis | None], evaluated: int) -> Refined:
    """The refined profile: the least pair evaluated, wherever its search found it, stands in
    both marginals, so each reaches the profile's minimum (any pair bounds the least RSS at
    its values)."""
    k = int(np.argmin(rss))
    for axis in (0, 1):
        m = marginals[axis]
        marginals[axis] = _merged(np.append(m.axis, pairs[k, axis]), np.append(m.rss, rss[k]),
                                  np.append(m.other, pairs[k, 1 - axis]))
    return Refined(marginals[0], marginals[1], pairs, rss, steps, refined, axes, evaluated)


def _open_axis(ax: _Axis, scale: float) -> None:
    """A clearance whose 95 % set runs to the grid's end (the data bound it from one side):
    its grid values profiled again with the other clearance searched between grid points,
    from a step below the set to where the plateau starts (beyond it every value is the
    same model: the plateau's rest takes the last value found)."""
    coarse = ax.coarse
    inside = _accepted(coarse.rss, float(coarse.rss.min()), scale)
    first = max(int(inside.min()) - 1, 0)
    last = coarse.rss.size - 1
    flat = np.abs(coarse.rss - coarse.rss[-1]) <= 1e-12 * max(abs(float(coarse.rss[-1])), 1.0)
    start = last
    while start > first and flat[start - 1]:
        start -= 1
    stop = min(start + 1, last)
    ax.run(coarse.axis[first:stop + 1])
    if stop < last:
        r, o = ax.fine[float(np.round(coarse.axis[stop], DECIMALS))]
        for x in np.round(coarse.axis[stop + 1:], DECIMALS).tolist():
            ax.fine[x] = (r, o)


def _valleys(m: Marginal, scale: float, best: int) -> list[int]:
    """The grid marginal's interior local minima, the grid's best (index ``best``) aside, that
    the grid does not resolve (each neighbour more than the 95 % deviance above it, RSS unit
    ``scale``), the :data:`VALLEYS` lowest."""
    r = m.rss
    if r.size < 3:
        return []
    rise = CHI2_1_95 * scale
    k = np.nonzero((r[:-2] - r[1:-1] > rise) & (r[2:] - r[1:-1] > rise))[0] + 1
    k = k[k != best]
    return k[np.argsort(r[k], kind='stable')][:VALLEYS].tolist()


def _look_into(ax: _Axis, lo: float, hi: float) -> None:
    """Clearance ``ax.axis`` profiled between ``lo`` and ``hi`` [m]: :data:`VALLEY_POINTS`
    values, then twice around the least at a quarter of the spacing."""
    ax.run(np.linspace(lo, hi, VALLEY_POINTS)[1:-1])
    h = (hi - lo) / (VALLEY_POINTS - 1)
    for _ in range(VALLEY_ZOOMS):
        xs, rss = ax.within(lo, hi)
        h /= 4
        ax.run(np.clip(xs[int(np.argmin(rss))] + h * np.array([-2.0, -1.0, 1.0, 2.0]), lo, hi))


def _deeper_valley(evaluate: _Evaluator, marginals: Sequence[Marginal], grids: Sequence[NDArray[np.float64]],
                   opened: Sequence[bool], best: tuple[int, int], scale: float) -> list[Marginal] | None:
    """A valley of the profile between grid points deeper than the grid's best, or None.

    A clamp can pin a clearance in a valley narrower than the grid's step, away from the grid's
    best, whose bottom the grid's points on its flanks miss by hundreds of the deviance's units.
    Each clearance's lowest local minima the grid does not resolve (:func:`_valleys`) are
    profiled between their grid neighbours (:func:`_look_into`; the other clearance searched
    as everywhere here), and so is the grid's best between its neighbours, so that a valley
    wins on its bottom and not on a finer search. When a valley's bottom is the least of all,
    the marginals the refinement goes on from: the valley's bottom stands at its grid point,
    and the other clearance's grid values are profiled again with the search started at the
    valley's bottom (its marginal the least over both branches). Otherwise nothing found is
    kept (``evaluate`` as it was): the grid's answer stands."""
    floor, kept, mark = evaluate.least, evaluate.best, len(evaluate.pairs)
    probed = []
    for axis in (0, 1):
        coarse = marginals[axis]
        valleys = _valleys(coarse, scale, best[axis])
        if not valleys:
            continue
        ax = _Axis(evaluate, axis, grids[1 - axis], coarse, opened[1 - axis])
        b, last = best[axis], coarse.axis.size - 1
        _look_into(ax, float(coarse.axis[max(b - 1, 0)]), float(coarse.axis[min(b + 1, last)]))
        spans = [(k, float(coarse.axis[k - 1]), float(coarse.axis[k + 1])) for k in valleys]
        for _, lo, hi in spans:
            _look_into(ax, lo, hi)
        probed.append((axis, ax, spans))
    for axis, ax, spans in probed:
        x = float(np.round(evaluate.best[axis], DECIMALS))
        for k, lo, hi in spans:
            if evaluate.least < floor and lo < x < hi and x in ax.fine and ax.fine[x][0] == evaluate.least:
                coarse = marginals[axis]
                rss, other = coarse.rss.copy(), coarse.other.copy()
                rss[k], other[k] = evaluate.least, evaluate.best[1 - axis]
                across = _Axis(evaluate, 1 - axis, grids[axis], marginals[1 - axis], opened[axis])
                across.run(grids[1 - axis], start=evaluate.best[axis])
                out = [Marginal(coarse.axis, rss, other), across.marginal()]
                return out if axis == 0 else out[::-1]
    del evaluate.pairs[mark:], evaluate.rss[mark:]
    evaluate.least, evaluate.best = floor, kept
    return None


def refine_profile(gear: GearParams, basis: F.TorqueBasis, mom: Moments, load: NDArray[np.float64],
                   extra: Sequence[F.Column], pr: PF.Profile) -> Refined:
    """The profile ``pr`` (on a part of the clearance grid) with each clearance the grid
    cannot resolve profiled between its points (see the module docstring); ``load`` and
    ``extra`` as the profile was made with. Sharpness is judged without the residuals'
    inflation (which only widens), so a clearance is refined whenever it may need it."""
    marginals = [marginal_of(pr, 0), marginal_of(pr, 1)]
    floor = float(pr.rss.min())
    scale = floor / max(pr.n - pr.p, 1.0)
    grids = (np.asarray(pr.two_z, float), np.asarray(pr.z_gb, float))
    steps = [float(g[1] - g[0]) if g.size > 1 else 0.0 for g in grids]
    inside = [_accepted(m.rss, floor, scale) for m in marginals]     # each clearance's 95 % set on the grid
    evaluate = _Evaluator(gear, basis, mom, load, extra)
    i, j = pr.best
    evaluate.least, evaluate.best = floor, (float(pr.two_z[i]), float(pr.z_gb[j]))
    # A clearance the data bound from one side only (its 95 % set runs to the grid's end: no
    # contact at the loads seen) is searched on its grid values alone: between them a search
    # would place a contact at the highest loads wherever the noise likes it best (a change
    # point's place is a free parameter), lowering the least RSS, and with it narrowing the
    # other clearance's interval, for no real evidence.
    opened = [bool(k.size) and int(k.max()) == g.size - 1 for g, k in zip(grids, inside)]
    deeper = _deeper_valley(evaluate, marginals, grids, opened, (i, j), scale) if scale > 0 else None
    if deeper is not None:
        marginals, floor = deeper, evaluate.least
        inside = [_accepted(m.rss, floor, scale) for m in marginals]
        opened = [bool(k.size) and int(k.max()) == g.size - 1 for g, k in zip(grids, inside)]
    sharp = [g.size > 2 and k.size > 0 and int(k.max() - k.min()) < SHARP_STEPS and scale > 0
             for g, k in zip(grids, inside)]
    refined = [False, False]
    kept: list[_Axis | None] = [None, None]
    if any(sharp):
        # Both are profiled again: the other clearance's marginal, taken over the grid alone,
        # would read high against a minimum found between grid points.
        axes = [_Axis(evaluate, axis, grids[1 - axis], marginals[axis], opened[1 - axis]) for axis in (0, 1)]
        for axis in (0, 1):
            if grids[axis].size <= 2 or not inside[axis].size:
                continue
            if opened[axis]:
                _open_axis(axes[axis], scale)
            else:
                steps[axis] = _refine_axis(axes[axis], grids[axis], scale)
                refined[axis] = True
                kept[axis] = axes[axis]
        marginals = [a.marginal() for a in axes]
    grid_pairs = np.stack([np.repeat(grids[0], grids[1].size), np.tile(grids[1], grids[0].size)], axis=1)
    pairs = np.concatenate([grid_pairs, *evaluate.pairs]) if evaluate.pairs else grid_pairs
    rss = np.concatenate([pr.rss.ravel(), *evaluate.rss]) if evaluate.rss else pr.rss.ravel()
    return _assembled(list(marginals), pairs, rss, (steps[0], steps[1]), (refined[0], refined[1]),
                      (kept[0], kept[1]), len(evaluate.pairs))
