"""Where an unexplained residual lives: the observed variable, the range of it, the ram and
the direction of motion that carry the misfit no effect in the library explains.

The residual (per instant and ram, after the model and any adopted effects) is regressed on
piecewise-constant functions of each observed variable: binned means, one free level per bin
of ``N_BINS`` equal bins over the variable's observed span (bins with fewer than
``MIN_BIN_ROWS`` rows carry none). Each variable is tried with each *shape* the rows allow:

- on both rams or one, in both directions of motion or one;
- in both directions either *odd* (the term changes sign with the direction of motion, as a
  friction does) or *even* (it does not, as a pressure error or a load does).

The variable and shape are chosen by the Bayesian information criterion on the effective
sample size (rows / variance inflation, the same count :mod:`~steer_monitor.estimate.analyze`
screens with), so a finer structure has to pay for its levels. The rudder angle is tried
signed and as its magnitude (a term at the same angle on either side needs half the levels).
The range is the run of bins around the largest contribution whose levels are significant
(|level| over ``SIGNIFICANT`` standard errors, the residual's variance inflated for its
autocorrelation) with the same sign, bridging a single bin that is not.

A located term can be put back into the fit as nuisance columns, one per bin of its range
(:meth:`Located.columns`), so that the clearances are profiled with the misfit taken out
rather than leaning on it.

Pure: arrays in, records out. Units: per-row values SI; ``lo``/``hi`` and the bins in the
variable's unit (the name says which).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import NDArray

from steer_monitor.estimate.batch import residual_parts
from steer_monitor.estimate.fit import Column
from steer_monitor.estimate.moments import Moments
from steer_monitor.estimate.observe import Observations

__all__ = [
    'EDGE_MARGIN',
    'MIN_BIN_ROWS',
    'MIN_BIC_DROP',
    'N_BINS',
    'SIGNIFICANT',
    'VARIABLES',
    'Located',
    'Shape',
    'locate',
    'piece_columns',
    'variable_values',
]

VARIABLES = ('alpha_deg', 'rate_deg_s', 'speed_kn', 'pressure_bar', 'oil_temp_c', 'time_s')
UNITS = {'alpha_deg': 'deg', 'rate_deg_s': 'deg/s', 'speed_kn': 'kn', 'pressure_bar': 'bar',
         'oil_temp_c': 'C', 'time_s': 's'}
WHAT = {'alpha_deg': 'rudder angle', 'rate_deg_s': 'rudder rate', 'speed_kn': 'ship speed',
        'pressure_bar': 'driving pressure', 'oil_temp_c': 'oil temperature', 'time_s': 'time into the log'}
N_BINS = 30
MIN_BIN_ROWS = 30
SIGNIFICANT = 3.0
EDGE_MARGIN = 0.25
MIN_BIC_DROP = 10.0
KNOT = 1852.0 / 3600.0


@dataclass(frozen=True)
class Shape:
    """Which rows a term touches and how it is signed.

    ram: 0 or 1 (one ram) or None (both, one shared level per bin); direction: +1 (rudder
    moving to starboard), -1 (to port) or 0 (both); odd: in both directions, the term
    changes sign with the direction of motion (a friction)."""

    ram: int | None
    direction: int
    odd: bool

    def rows(self, ram: NDArray[np.intp], direction: NDArray[np.int8]) -> NDArray[np.bool_]:
        sel = np.ones(ram.shape, bool)
        if self.ram is not None:
            sel &= ram == self.ram
        if self.direction:
            sel &= direction == self.direction
        return sel

    def sign(self, direction: NDArray) -> NDArray[np.float64]:
        return direction.astype(float) if (self.odd and not self.direction) else np.ones(direction.shape)

    @property
    def ram_name(self) -> str:
        return 'both' if self.ram is None else f'ram{self.ram + 1}'

    @property
    def direction_name(self) -> str:
        return {0: 'both', 1: 'to_starboard', -1: 'to_port'}[self.direction]


SHAPES = tuple(Shape(r, d, odd) for r in (None, 0, 1) for d, odd in ((0, True), (0, False), (1, False), (-1, False)))


@dataclass(frozen=True)
class Located:
    """The term that carries the unexplained residual.

    Attributes:
        variable: one of ``VARIABLES``; either_side: for the rudder angle, the term sits at
            the same |alpha| on both sides (``lo``, ``hi`` are then magnitudes).
        lo, hi: its range in the variable's unit.
        level: the term's RMS over the rows in its range [N] (signed by its mean: positive
            is more force against the motion for an odd term, a higher starboard-minus-port
            reading for an even one).
        share: the fraction of the residual's systematic (smooth) variance the term carries.
        shape: the rows it touches.
        edges: bin edges (bins + 1,) in the variable's unit; means: level per bin [N]
            (0 where a bin has too few rows); se: its standard error [N]; counts: rows per bin.
        run: (first, last) bin of the range.
        x, target: per-row variable value and the residual signed by the shape [N], for plots.
        pieces: how many pieces :meth:`columns` cuts the range into (0: about one bin each).
    """

    variable: str
    either_side: bool
    lo: float
    hi: float
    level: float
    share: float
    shape: Shape
    edges: NDArray[np.float64] = field(repr=False)
    means: NDArray[np.float64] = field(repr=False)
    se: NDArray[np.float64] = field(repr=False)
    counts: NDArray[np.float64] = field(repr=False)
    run: tuple[int, int] = (0, 0)
    x: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0), repr=False)
    target: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0), repr=False)
    pieces: int = 0

    def message(self, ram_area: float) -> str:
        """One sentence for the user (pressures in bar over the ram area [m^2])."""
        bar = ram_area * 1e5
        unit = UNITS[self.variable]
        if self.shape.odd and not self.shape.direction:
            kind = ('more friction than the model' if self.level > 0 else 'less friction than the model')
        else:
            kind = ('a higher starboard-minus-port pressure than the model' if self.level > 0
                    else 'a lower starboard-minus-port pressure than the model')
        rams = 'both rams' if self.shape.ram is None else f'ram {self.shape.ram + 1}'
        moving = {0: '', 1: ', moving to starboard', -1: ', moving to port'}[self.shape.direction]
        side = ' on either side' if self.either_side else ''
        return (f'the unexplained residual lives at {WHAT[self.variable]} {self.lo:.3g} to {self.hi:.3g} {unit}{side} '
                f'on {rams}{moving}: {abs(self.level) / bar:.2f} bar of {kind}, '
                f'{100 * self.share:.0f} % of the systematic part')

    def moved(self, lo: float, hi: float) -> Located:
        """The same term over [``lo``, ``hi``): its level and share over the bins whose centres
        lie there (the residual's own, as :func:`locate` measured them; level 0 and share 0
        where none does)."""
        centres = 0.5 * (self.edges[:-1] + self.edges[1:])
        inside = np.nonzero((centres >= lo) & (centres < hi) & (self.counts >= MIN_BIN_ROWS))[0]
        a, b = self.run
        c_old, m_old = self.counts[a:b + 1], self.means[a:b + 1]
        old = float(np.sum(c_old * m_old ** 2))
        c, m = self.counts[inside], self.means[inside]
        new = float(np.sum(c * m ** 2))
        level = math.copysign(math.sqrt(new / float(c.sum())), float(np.sum(c * m))) if inside.size else 0.0
        share = min(self.share * new / old, 1.0) if old > 0 else 0.0
        run = (int(inside[0]), int(inside[-1])) if inside.size else self.run
        return replace(self, lo=lo, hi=hi, level=level, share=share, run=run)

    @property
    def cut_into(self) -> int:
        """How many pieces :meth:`columns` cuts the range into: ``pieces``, or about one bin each."""
        w = float(self.edges[1] - self.edges[0])
        return self.pieces or max(int(round((self.hi - self.lo) / w)), 1)

    def values(self, obs: Observations) -> NDArray[np.float64]:
        """The located variable per observation and ram, (n, 2), in its unit."""
        v = variable_values(obs, self.variable)
        return np.abs(v) if self.either_side else v

    def columns(self, obs: Observations, names: Sequence[str] | None = None
                ) -> tuple[dict[str, NDArray[np.float64]], tuple[Column, ...]]:
        """Nuisance z columns (n, 2) and their columns: the range [lo, hi) cut into pieces of
        about one bin, one free level each (the term's shape inside it is not assumed), the
        outer edges at the refined ends (a step there is then taken whole). A piece with too
        few rows of ``obs`` is left out; given ``names`` (those a fit on other data kept),
        exactly those pieces, in that order."""
        v = self.values(obs)
        pieces = self.cut_into
        cuts = np.linspace(self.lo, self.hi, pieces + 1)
        sel = np.ones(v.shape, bool)
        if self.shape.ram is not None:
            sel[:, 1 - self.shape.ram] = False
        if self.shape.direction:
            sel &= (obs.direction == self.shape.direction)[:, None]
        sel &= obs.moving[:, None]
        sign = np.broadcast_to(self.shape.sign(obs.direction)[:, None], v.shape)
        z: dict[str, NDArray[np.float64]] = {}
        for k in range(pieces):
            name = f'located_{k}'
            inside = sel & (v >= cuts[k]) & (v < cuts[k + 1])
            if (names is None and inside.sum() < MIN_BIN_ROWS) or (names is not None and name not in names):
                continue
            z[name] = np.where(inside, sign, 0.0)
        if names is not None:
            missing = [n for n in names if n not in z]
            if missing:
                msg = f'the located term has no piece {", ".join(missing)}'
                raise ValueError(msg)
            z = {n: z[n] for n in names}
        return z, piece_columns(tuple(z))


    def near_ends(self, obs: Observations) -> NDArray[np.bool_]:
        """Instants (n,) whose value lies within ``EDGE_MARGIN`` bins of either end of the
        range: the ends are known to a tenth of a bin, and a row on the wrong side of a step
        carries the whole step into the fit, so the fit leaves these out."""
        v = self.values(obs)
        m = EDGE_MARGIN * float(self.edges[1] - self.edges[0])
        near = (np.abs(v - self.lo) < m) | (np.abs(v - self.hi) < m)
        return np.any(near, axis=1)


def _nuisance_ones(mom: Moments, feats: dict) -> NDArray[np.float64]:
    return np.ones(len(mom))


def piece_columns(names: Sequence[str]) -> tuple[Column, ...]:
    """The fit's columns of a located term's pieces ``names`` (:meth:`Located.columns`): a free
    level each, a nuisance (not reported)."""
    return tuple(Column(name, name, _nuisance_ones) for name in names)


_nuisance_ones.nuisance = True  # type: ignore[attr-defined]


def variable_values(obs: Observations, name: str) -> NDArray[np.float64]:
    """Variable ``name`` per observation and ram, shape (n, 2), in its unit (NaN where not
    observed). The driving pressure is each ram's higher chamber."""
    n = len(obs)
    if name == 'alpha_deg':
        v = np.degrees(obs.alpha)
    elif name == 'rate_deg_s':
        v = np.degrees(np.abs(obs.rate))
    elif name == 'speed_kn':
        v = obs.speed / KNOT
    elif name == 'oil_temp_c':
        v = obs.oil_temp - 273.15
    elif name == 'time_s':
        v = (obs.t_ns - (obs.t_ns[0] if n else 0)) / 1e9
    elif name == 'pressure_bar':
        p = obs.pressure.reshape(n, 2, 2)
        return np.max(p, axis=2) / 1e5
    else:
        msg = f'unknown variable {name!r} (choose from: {", ".join(VARIABLES)})'
        raise ValueError(msg)
    return np.repeat(np.asarray(v, float)[:, None], 2, axis=1)


def _bin_of(v: NDArray[np.float64], edges: NDArray[np.float64]) -> NDArray[np.intp]:
    """Bin index per value (values beyond the span fall in the end bins; NaN -> -1)."""
    b = np.clip(np.searchsorted(edges, v, side='right') - 1, 0, edges.size - 2)
    return np.where(np.isfinite(v), b, -1)


def _run(means: NDArray[np.float64], z: NDArray[np.float64], counts: NDArray[np.float64]) -> tuple[int, int] | None:
    """The bins around the largest contribution that are significant with its sign, with
    at most one bin in a row that is not."""
    contrib = counts * means ** 2
    sig = np.abs(z) >= SIGNIFICANT
    if not sig.any():
        return None
    peak = int(np.argmax(np.where(sig, contrib, -1.0)))
    sign = np.sign(means[peak])

    def good(b: int) -> bool:
        return 0 <= b < means.size and bool(sig[b]) and np.sign(means[b]) == sign

    lo = hi = peak
    while good(lo - 1) or good(lo - 2):
        lo -= 1 if good(lo - 1) else 2
    while good(hi + 1) or good(hi + 2):
        hi += 1 if good(hi + 1) else 2
    return lo, hi


def locate(obs: Observations, resid: NDArray[np.float64], vif: float) -> Located | None:
    """The variable, range and shape that carry most of the residual ``resid`` (n, 2) [N]
    (NaN where not fitted), or None when no binned term passes the information criterion.
    ``vif``: the residual's variance inflation (its autocorrelation)."""
    idx, ram = np.nonzero(np.isfinite(resid))
    if idx.size < 10 * MIN_BIN_ROWS:
        return None
    r = resid[idx, ram]
    d = obs.direction[idx]
    n = r.size
    rss0 = float(np.sum(r * r))
    if not rss0 > 0:
        return None
    n_eff = n / max(vif, 1.0)
    sigma2 = rss0 / n
    smooth_var = _smooth_variance(resid, obs.t_ns)
    best: tuple[float, str, bool, Shape, NDArray, NDArray, NDArray, NDArray, NDArray] | None = None
    for name in VARIABLES:
        values = variable_values(obs, name)[idx, ram]
        width = math.nan
        for either_side in ((False, True) if name == 'alpha_deg' else (False,)):
            x = np.abs(values) if either_side else values
            fin = np.isfinite(x)
            if fin.sum() < 10 * MIN_BIN_ROWS:
                continue
            lo, hi = float(np.min(x[fin])), float(np.max(x[fin]))
            if not hi - lo > 1e-9 * max(abs(lo), abs(hi), 1.0):
                continue
            if either_side and math.isfinite(width):
                # the signed angle's bin width: the same resolution with half the levels
                edges = lo + width * np.arange(max(int(math.ceil((hi - lo) / width)), 1) + 1)
            else:
                edges = np.linspace(lo, hi, N_BINS + 1)
                width = float(edges[1] - edges[0])
            b = _bin_of(x, edges)
            for shape in SHAPES:
                sel = shape.rows(ram, d) & fin
                if sel.sum() < MIN_BIN_ROWS:
                    continue
                t = r * shape.sign(d)
                counts = np.bincount(b[sel], minlength=edges.size - 1).astype(float)
                sums = np.bincount(b[sel], t[sel], minlength=edges.size - 1)
                used = counts >= MIN_BIN_ROWS
                means = np.where(used, sums / np.maximum(counts, 1.0), 0.0)
                drop = float(np.sum(counts * means ** 2))
                k = int(used.sum())
                if k == 0 or drop >= rss0:
                    continue
                score = n_eff * math.log((rss0 - drop) / rss0) + k * math.log(n_eff)
                if best is None or score < best[0]:
                    best = (score, name, either_side, shape, edges, means, counts, x, np.where(sel, t, np.nan))
    if best is None or best[0] > -MIN_BIC_DROP:
        return None
    _, name, either_side, shape, edges, means, counts, x, target = best
    se = np.sqrt(sigma2 * max(vif, 1.0) / np.maximum(counts, 1.0))
    run = _run(means, np.where(counts >= MIN_BIN_ROWS, means / se, 0.0), counts)
    if run is None:
        return None
    a, b = run
    lo_x, hi_x = _refine_edges(x, target, edges, run)
    c = counts[a:b + 1]
    level = math.sqrt(float(np.sum(c * means[a:b + 1] ** 2)) / max(float(c.sum()), 1.0))
    level = math.copysign(level, float(np.sum(c * means[a:b + 1])))
    share = min(float(np.sum(c * means[a:b + 1] ** 2)) / n / smooth_var, 1.0) if smooth_var > 0 else 1.0
    return Located(name, either_side, lo_x, hi_x, level, share, shape, edges, means, se, counts, run, x, target)


def _refine_edges(x: NDArray[np.float64], target: NDArray[np.float64], edges: NDArray[np.float64],
                  run: tuple[int, int]) -> tuple[float, float]:
    """The range's ends to a tenth of a bin: the boxcar level g 1[lo <= x < hi] that takes
    most of the signed residual ``target`` (NaN off the shape's rows), with ``lo`` within a
    bin of the run's first edge and ``hi`` of its last (a step in the residual rarely falls
    on a bin edge; where it does not, a level per bin leaves half a step in the end bins)."""
    ok = np.isfinite(target) & np.isfinite(x)
    xs, ts = x[ok], target[ok]
    order = np.argsort(xs, kind='stable')
    xs, ts = xs[order], ts[order]
    cs = np.concatenate([[0.0], np.cumsum(ts)])
    a, b = run
    w = float(edges[1] - edges[0])
    lo_c = np.linspace(edges[a] - w, edges[a] + w, 21)
    hi_c = np.linspace(edges[b + 1] - w, edges[b + 1] + w, 21)
    i = np.searchsorted(xs, lo_c, side='left')
    j = np.searchsorted(xs, hi_c, side='left')
    n = j[None, :] - i[:, None]
    s = cs[j][None, :] - cs[i][:, None]
    with np.errstate(divide='ignore', invalid='ignore'):
        gain = np.where((n >= MIN_BIN_ROWS) & (hi_c[None, :] > lo_c[:, None]), s * s / n, -1.0)
    k, m = np.unravel_index(int(np.argmax(gain)), gain.shape)
    return float(lo_c[k]), float(hi_c[m])


def _smooth_variance(resid: NDArray[np.float64], t_ns: NDArray[np.int64]) -> float:
    _, smooth = residual_parts(resid, t_ns)
    return smooth ** 2 if math.isfinite(smooth) else 0.0
