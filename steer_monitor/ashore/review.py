"""A whole log reviewed in blocks of columns, the core of the batch path behind
``steer-monitor report`` (:mod:`~steer_monitor.ashore.reviewlogs` reads the logs into it). Pure
(arrays in, records out).

Blocks of decoded series come in time order (:meth:`Review.add`); each is put on the
estimator's 50 ms grid with the samples carried over from the block before (so a log cut in
blocks gives the grid of the whole), and then, vectorized over the block:

* the model's inputs once per second of data (angle, the four pressures, ram forces, speed),
  for the plots; the load sharing (F_r, F_gb, K_gl) is evaluated on them at the end, at the
  clearances estimated from the whole log;
* the steady-motion rows folded into the binned moments of the clearance estimator, one set
  per time window;
* hard-over times (leaving 35 deg, reaching 30 deg the other side), with the live monitor's
  thresholds and its logic, run over the few samples beyond 29.5 deg only;
* stretches where the rams did not share the force evenly (the one rams check,
  :class:`~steer_monitor.estimate.ramscheck.RamsCheck`, fed the steady-motion rows as they come;
  the rows it may still put into or out of a stretch held until it has settled them), left
  out of the moments and named in the notes, as ``analyze`` leaves them out of its fit.

The clearances are estimated from the moments up to the end of each window (an estimate with
its interval over time: up to ``MAX_WINDOWS`` windows of whole 10 minutes, and the whole log
at the end), under the declared model or, given ``model``, with the effects a model check of
the log adopted (:func:`~steer_monitor.ashore.reviewlogs.refit_windows`: the report's windows
fit the model its clearances rest on). With :meth:`Review.plan` (where the data will end) a
window is estimated as soon as the data pass its end, while the log is still being read; otherwise all at
:meth:`Review.finish`. Each: the coarse profile, the inflation factor of the residuals at its
best point over a sample of the window's own rows, spread over all of them
(:class:`~steer_monitor.ashore.rowsample.RowSample`: a window is told of the residuals it fits,
whenever it is estimated), then the fine profile on the search box of :func:`~steer_monitor.estimate.batch.search_box`.
A window after the first tries the box of the last coarse profile first (the moments have only
grown since) and keeps it when the answer lies inside (the best point and the interval's ends
off its inner edges); the whole log's estimate always profiles the whole grid coarsely.

Times integer ns, values SI.

The logs read into a review (:func:`~steer_monitor.ashore.reviewlogs.review_logs`) are the
next module's; this one takes decoded blocks, whatever reads them.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from steer_monitor.ashore.rowsample import RowSample, concat_observations
from steer_monitor.ashore.windowmodel import Nuisance
from steer_monitor.can.decoder import Series, SignalSet
from steer_monitor.can.signals import PRESSURE_INPUTS
from steer_monitor.estimate import fit as F
from steer_monitor.estimate.batch import (
    MIN_MOTION_SAMPLES,
    ClearanceEstimate,
    Spread,
    box_holds,
    coarse_profile,
    estimate_in_box,
    make_rows,
    residuals_and_inflation,
    sample_spread,
    search_box,
)
from steer_monitor.estimate.effects import Effect, candidate_of, iter_z_columns
from steer_monitor.estimate.locate import piece_columns
from steer_monitor.estimate.moments import SPEED_Z, Moments, rows_from_observations
from steer_monitor.estimate.observe import GRID_NS, EstimateError, Observations, build_observations
from steer_monitor.estimate.rams import opposed_cause, working_against
from steer_monitor.estimate.ramscheck import RamsCheck, UnevenSpan, describe
from steer_monitor.estimate.refine import Refined
from steer_monitor.model.gear import Clearances, GearParams
from steer_monitor.model.kinematics import torque_of_axial
from steer_monitor.model.loadshare import LoadSharing, load_sharing
from steer_monitor.monitor.performance import HardOver, HardOverTracker

__all__ = ['Review', 'ReviewResult', 'WindowEstimate', 'share_at']


SECOND_NS = 1_000_000_000
LAG_NS = SECOND_NS          # the grid is processed up to this far behind the newest angle
KEEP_NS = 3 * SECOND_NS     # samples carried into the next block
MAX_WINDOWS = 4
SLICE_NS = 600 * SECOND_NS
#: a window's note where its rows of motion are too few to measure the residuals
#: (said once for the log, whichever of their spread and correlation found it)
_LITTLE_MOTION = ("too little motion to measure the residuals' spread and correlation: intervals assume "
                  'independent residuals')


@dataclass(frozen=True)
class WindowEstimate:
    """The clearance estimate from the data up to ``t_end_ns``."""

    t_end_ns: int
    estimate: ClearanceEstimate


@dataclass
class ReviewResult:
    """What a review found. Per-second arrays have shape (n,) (pressures (n, 4), forces
    (n, 2)); ``share`` is the load sharing on them at ``gaps``."""

    t_ns: NDArray[np.int64]
    alpha: NDArray[np.float64]
    direction: NDArray[np.int8]
    pressure: NDArray[np.float64]
    force: NDArray[np.float64]
    torque: NDArray[np.float64]
    share: LoadSharing | None
    gaps: Clearances
    gaps_source: str
    hard_overs: list[HardOver]
    estimates: list[WindowEstimate]
    motion_s: float
    samples: int
    notes: list[str] = field(default_factory=list)
    estimating_s: float = 0.0        # wall time of the estimates made at the end (after the reading)
    #: stretches where the rams did not share the force evenly, left out of the estimates
    uneven: list[UnevenSpan] = field(default_factory=list)
    #: why rows were left out for a ram read the wrong way round ('' when none were)
    opposed: str = ''
    #: a window of the rams check said even or uneven
    rams_assessed: bool = False


def _cat(a: Series | None, b: Series | None) -> Series | None:
    if a is None or len(a) == 0:
        return b
    if b is None or len(b) == 0:
        return a
    return Series(np.concatenate([a.t_ns, b.t_ns]), np.concatenate([a.value, b.value]))


def _tail(s: Series, from_ns: int) -> Series:
    i = int(np.searchsorted(s.t_ns, from_ns))
    return Series(s.t_ns[i:], s.value[i:])


class Review:
    """See the module docstring. ``gaps``: the configured clearances (used when the log
    cannot estimate them). ``window_ns``: the estimate's time step (default: the span in up
    to ``MAX_WINDOWS`` steps of whole 10 minutes, decided by :meth:`plan` or at the end).
    ``model``: effects the estimates fit with the declared model (those a model check of the
    log adopted, :attr:`~steer_monitor.estimate.analyze.Analysis.adopted`): a delay read into
    the angle, the others' columns beside the declared model's, as ``analyze`` under that
    model fits them; ``nuisance``: where that check left a residual unexplained, the term it
    located, fitted as it fitted it (the rows near the term's ends left out, the intervals
    counting the misfit) (:func:`~steer_monitor.ashore.windowmodel.window_model`)."""

    def __init__(self, gear: GearParams, gaps: Clearances, *, min_clearance_2z: float = 0.0,
                 window_ns: int | None = None, reuse_boxes: bool = True, ram_share_warn: float = 0.15,
                 model: Sequence[Effect] = (), nuisance: Nuisance | None = None) -> None:
        self.gear = gear
        cands = [candidate_of(e) for e in model]
        self._located = nuisance.located if nuisance is not None and nuisance.pieces else None
        self._pieces = nuisance.pieces if self._located is not None else ()
        self._model_inflation = nuisance.model_inflation if nuisance is not None else 1.0
        self._extra = tuple(col for c in cands for col in c.columns) + piece_columns(self._pieces)
        self._z_names = tuple(dict.fromkeys(col.z for col in self._extra if col.z))
        self._accel = _Accel() if 'accel' in self._z_names else None
        self._shift_s = sum(c.angle_shift_s for c in cands)
        # the grid waits for the angle read later too
        self._lag_ns = LAG_NS + round(self._shift_s * 1e9)
        self._temp_ref: float | None = None     # the oil temperature dtemp is taken from [K]
        self.ram_share_warn = ram_share_warn
        #: stretches where the rams did not share the force evenly, left out of the estimates
        self.uneven: list[UnevenSpan] = []
        self._opposed = ''          # the rams pushed against each other (a ram's pressures swapped): why
        self._held: Observations | None = None     # steady-motion rows not yet settled (see _take)
        self._rams = RamsCheck(ram_share_warn, gear.ram_area)
        self.reuse_boxes = reuse_boxes
        self.gaps = gaps
        self.grid_2z = F.GRID_2Z[F.GRID_2Z >= min_clearance_2z - 1e-12]
        self._buf: SignalSet = {}
        self._done: int | None = None
        self._latest: int | None = None
        self._first: int | None = None
        self._speed_seen = False
        # per 10-minute slice: moments; merged in time order into the running total
        self._slices: dict[int, Moments] = {}
        self._acc = Moments((SPEED_Z, *self._z_names))
        self._merged_below: int | None = None      # slices below this key are in _acc
        self._step: int | None = None if window_ns is None else max(window_ns // SLICE_NS, 1)
        self._windows: list[tuple[int, ClearanceEstimate | None]] = []
        self._windows_tried = 0
        self._box: tuple[NDArray, NDArray] | None = None   # the last coarse profile's search box
        self.boxes_reused = 0
        self.boxes_missed = 0          # search boxes an interval ran past: the whole grid profiled
        self._notes: list[str] = []
        self._sec: list[tuple[NDArray, ...]] = []
        #: the rows folded, as far as a window still to estimate may measure its spread on them
        self._sample = RowSample()
        self._hard = HardOverTracker()
        self.hard_overs: list[HardOver] = []
        self.motion_s = 0.0
        self.samples = 0

    # --- input ---------------------------------------------------------------------------
    def add(self, signals: SignalSet) -> None:
        """One block of decoded series (every series in time order, blocks in time order)."""
        for name, s in signals.items():
            if len(s) == 0:
                continue
            self.samples += len(s)
            self._buf[name] = _cat(self._buf.get(name), s)  # type: ignore[assignment]
            if name == 'ship_speed':
                self._speed_seen = True
        angle = signals.get('rudder_angle')
        if angle is not None and len(angle):
            self._hard_overs(angle)
            self._latest = int(angle.t_ns[-1])
            if self._first is None:
                self._first = int(angle.t_ns[0])
                self._done = -(-self._first // GRID_NS) * GRID_NS
        if self._latest is not None and self._done is not None:
            end = (self._latest - self._lag_ns) // GRID_NS * GRID_NS
            if end > self._done:
                self._process(self._done, end)
                self._done = end
                self._buf = {n: _tail(s, end - KEEP_NS) for n, s in self._buf.items()}
                self._due_windows(self._folded_until(end))

    def plan(self, expected_end_ns: int) -> None:
        """Say where the data are expected to end (e.g. from the file size), so the window
        estimates can be made while the log is still being read; without it they are made at
        :meth:`finish`."""
        if self._step is None and self._first is not None:
            span = max(expected_end_ns - self._first, 1)
            self._step = max(-(-span // (MAX_WINDOWS * SLICE_NS)), 1)
            if self._done is not None:
                self._due_windows(self._folded_until(self._done))
            self._prune_sample()

    def _folded_until(self, end_ns: int) -> int:
        """Up to where every row is folded: ``end_ns``, or the first row held (see :meth:`_take`)."""
        return end_ns if self._held is None else min(end_ns, int(self._held.t_ns[0]))

    def _due_windows(self, complete_ns: int) -> None:
        """Estimate every window whose end the complete data have passed."""
        if self._step is None or self._first is None:
            return
        k0 = self._first // SLICE_NS
        while True:
            end_key = k0 + self._step * (self._windows_tried + 1)
            if end_key * SLICE_NS > complete_ns:
                return
            self._windows_tried += 1
            self._merge_below(end_key)
            end = end_key * SLICE_NS
            self._windows.append((end, self._estimate(self._acc, self._sample.before(end))))
            self._prune_sample()

    def _prune_sample(self) -> None:
        """Drop the rows no window still to estimate may measure its spread on."""
        if self._step is None or self._first is None:       # not planned: windows may end on any slice
            self._sample.prune(boundary_ns=SLICE_NS)
            return
        next_end = (self._first // SLICE_NS + self._step * (self._windows_tried + 1)) * SLICE_NS
        self._sample.prune(next_end_ns=next_end, step_ns=self._step * SLICE_NS)

    def _merge_below(self, key: int) -> None:
        for k in sorted(k for k in self._slices if (self._merged_below is None or k >= self._merged_below) and k < key):
            self._acc = self._acc.merge(self._slices[k])
        self._merged_below = key

    def _estimate(self, mom: Moments, sample: Observations | None, reuse: bool = True) -> ClearanceEstimate | None:
        """The estimate from ``mom``: coarse profile, inflation of the residuals over ``sample``
        (the window's sample of its rows) at its best point, fine profile on the search box. With
        ``reuse``, a window after the first first tries the box the window before found (the
        moments only grew), with the inflation at that box's best fit, and keeps it when
        :func:`box_holds` says it held."""
        if mom.samples < MIN_MOTION_SAMPLES:
            return None
        z = None if sample is None else self._z(sample)     # the effects' columns of the sample, once
        try:
            if reuse and self.reuse_boxes and self._box is not None:
                est = estimate_in_box(self.gear, mom, *self._box, self._spread(sample, z), self._extra)
                if box_holds(est, self.grid_2z, F.GRID_ZGB):
                    self.boxes_reused += 1
                    return est
            coarse = coarse_profile(self.gear, mom, self.grid_2z, F.GRID_ZGB, extra=self._extra)
            pr, g2, gz = coarse
            bi, bj = pr.best
            vif = self._inflation(sample, z, float(g2[bi]), float(gz[bj]), pr.coef)
            self._box = search_box(self.gear, mom, self.grid_2z, F.GRID_ZGB, vif, coarse=coarse)
            est = estimate_in_box(self.gear, mom, *self._box, self._spread(sample, z), self._extra)
            if box_holds(est, self.grid_2z, F.GRID_ZGB):
                return est
            # the box was drawn with the residuals' correlation alone; their cluster-robust spread
            # can widen an interval past it (its end would be the box's edge): the whole grid
            self.boxes_missed += 1
            self._box = (self.grid_2z, F.GRID_ZGB)
            return estimate_in_box(self.gear, mom, self.grid_2z, F.GRID_ZGB, self._spread(sample, z), self._extra)
        except EstimateError as exc:
            self._notes.append(f'an estimate failed: {exc}')
            return None

    def _hard_overs(self, angle: Series) -> None:
        self.hard_overs += self._hard.angles(angle.t_ns.tolist(), angle.value.tolist())

    def _process(self, start: int, end: int) -> None:
        edge = GRID_NS if self._accel is not None else 0
        try:
            obs = build_observations(self._buf, self.gear.ram_area, start_ns=start - edge, end_ns=end + edge,
                                     angle_shift_s=self._shift_s)
        except EstimateError:
            return
        if self._accel is not None:
            # the ram's acceleration reads the rate a grid point either side, as analyze's on the
            # whole grid: worked out here, over the block and a point beyond each end, and kept
            # for the rows folded later (a row kept alone would have no neighbour)
            acc = next(col for name, col in iter_z_columns(obs, self.gear) if name == 'accel')
            inner = (obs.t_ns >= start) & (obs.t_ns < end)
            obs = obs.select(inner)
            self._accel.add(obs.t_ns, acc[inner])
        whole = (obs.t_ns % SECOND_NS) == 0
        self._sec.append((obs.t_ns[whole], obs.alpha[whole], obs.direction[whole], obs.pressure[whole],
                          obs.force[whole]))
        self._rams.feed(obs.t_ns[obs.moving], obs.force[obs.moving])    # as analyze feeds it: speed or not
        keep = obs.moving.copy()
        if self._speed_seen:
            keep &= np.isfinite(obs.speed)
        for arr in self._z(obs).values():           # as make_rows: an effect's column unknown, no row
            keep &= np.all(np.isfinite(arr), axis=1) if arr.ndim == 2 else np.isfinite(arr)
        if self._located is not None:               # as analyze: a row near the term's ends carries a step
            keep &= ~self._located.near_ends(obs)
        if self._accel is not None:     # asked for again only for rows folded: the block's others forgotten
            self._accel.keep_last(keep)
        if keep.any():
            self._take(obs.select(keep))
        if self._accel is not None:     # kept for the rows held or in the sample only (a log at rest adds none)
            firsts = [t for t in (self._sample.first_ns(), None if self._held is None or not len(self._held)
                                  else int(self._held.t_ns[0])) if t is not None]
            self._accel.drop_before(min(firsts, default=end))

    def _take(self, sub: Observations | None, final: bool = False) -> None:
        """Fold steady-motion rows, those of stretches where the rams did not share the force
        evenly left out: rows the rams check may still put into or out of a stretch
        (:meth:`~steer_monitor.estimate.ramscheck.RamsCheck.unsettled_from`) are held until it has
        settled them (or the end)."""
        parts = [p for p in (self._held, sub) if p is not None and len(p)]
        self._held = None
        if final:
            self._rams.finish()
        for sp in self._rams.spans[len(self.uneven):]:
            self.uneven.append(sp)
            self._notes.append(f'{describe(sp)}: left out of the clearance estimates')
        if not parts:
            return
        sub = concat_observations(parts)
        cut = None if final else self._rams.unsettled_from()
        if cut is not None:
            later = sub.t_ns >= cut
            if later.any():
                self._held, sub = sub.select(later), sub.select(~later)
            if not len(sub):
                return
        if self._rams.opposed is not None and not self._opposed:   # the map reverses a ram: nothing here
            self._opposed = opposed_cause(self._rams.opposed, working_against(sub.force, sub.rate), PRESSURE_INPUTS)
            self._notes.append(self._opposed + ': those rows are left out of the clearance estimates')
        if self._opposed:           # a map does not turn round within a log: the rest too
            return
        sub = sub.select(~self._rams.excluded(sub.t_ns))
        if not len(sub):
            return
        self.motion_s += float(len(sub)) * GRID_NS / 1e9
        slice_of = sub.t_ns // SLICE_NS
        for k in np.unique(slice_of).tolist():
            part = sub.select(slice_of == k)
            z = self._z(part)
            keys, aa, v2, u, _, _ = rows_from_observations(part, z)
            if keys.size:
                mom = Moments.from_rows(keys, aa, v2, u, (SPEED_Z, *z))
                self._slices[k] = self._slices[k].merge(mom) if k in self._slices else mom
        self._sample.add(sub)
        self._prune_sample()

    # --- result --------------------------------------------------------------------------
    def finish(self) -> ReviewResult:
        """The result: the window estimates still due and the one from all the data."""
        notes = self._notes
        if self._latest is not None and self._done is not None and self._latest + 1 > self._done:
            self._process(self._done, self._latest + 1)
            self._done = self._latest + 1
        self._take(None, final=True)
        sec = [np.concatenate(c) for c in zip(*self._sec)] if self._sec else [
            np.zeros(0, np.int64), np.zeros(0), np.zeros(0, np.int8), np.zeros((0, 4)), np.zeros((0, 2))]
        t, alpha, direction, pressure, force = sec
        t0 = time.perf_counter()
        estimates = self._final_estimates(notes)
        estimating_s = time.perf_counter() - t0
        gaps, source = self.gaps, 'configured'
        if estimates:
            e = estimates[-1].estimate
            gaps, source = Clearances(e.two_z.value, e.z_gb.value), 'estimated'
        g = self.gear
        fa = 0.5 * (np.abs(force[:, 0]) + np.abs(force[:, 1]))
        with np.errstate(invalid='ignore'):
            torque = torque_of_axial(g, fa, np.cos(alpha))
        share = share_at(g, alpha, torque, gaps)
        return ReviewResult(t, alpha, direction, pressure, force, torque, share, gaps, source, list(self.hard_overs),
                            estimates, self.motion_s, self.samples, list(dict.fromkeys(notes)), estimating_s,
                            list(self.uneven),
                            self._opposed, self._rams.assessed)

    def _final_estimates(self, notes: list[str]) -> list[WindowEstimate]:
        if not self._slices:
            if not self._opposed:
                notes.append('no steady rudder motion in the log: the clearances cannot be estimated')
            return []
        if self._step is None and self._first is not None and self._done is not None:
            self.plan(self._done)              # not planned: the windows of the span, now
        last = max(self._slices) + 1
        if self._merged_below is None or last > self._merged_below:
            self._merge_below(last)
            # the whole log's estimate, the answer: a coarse profile of the whole grid always
            end = int(self._done or 0)
            self._windows.append((end, self._estimate(self._acc, self._sample.before(end), reuse=False)))
        done = [WindowEstimate(t_end, est) for t_end, est in self._windows if est is not None]
        if not done:
            notes.append(f'only {self._acc.samples:.0f} rows of steady motion (at least {MIN_MOTION_SAMPLES} '
                         'needed): the clearances are not estimated')
        return done

    def _spread(self, sample: Observations | None, z: dict[str, NDArray[np.float64]] | None) -> Spread:
        """What a window's estimate is told of its residuals: their spread over ``sample`` (the
        window's sample of its rows, ``z`` its effects' columns) at its best fit
        (:func:`sample_spread`)."""

        def spread(two_z: float, z_gb: float, best: F.FitAt, ref: Refined,
                   extra: Sequence[F.Column]) -> tuple[float, dict | None]:
            if sample is None:
                self._notes.append(_LITTLE_MOTION)
                return 1.0, None
            vif, scales = sample_spread(self.gear, sample, two_z, z_gb, best, ref, extra, z,
                                        self._model_inflation)
            if scales is None:
                self._notes.append(_LITTLE_MOTION)
            return vif, scales
        return spread

    def _inflation(self, sample: Observations | None, z: dict[str, NDArray[np.float64]] | None, two_z: float,
                   z_gb: float, coef: NDArray[np.float64]) -> float:
        """The residuals' variance inflation over ``sample`` (the window's sample of its rows,
        ``z`` its effects' columns), at the fit ``coef`` with the clearances (``two_z``,
        ``z_gb``) [m]."""
        rows = None if sample is None else make_rows(sample, z)
        if sample is None or rows is None or rows.u.shape[0] < MIN_MOTION_SAMPLES:
            self._notes.append(_LITTLE_MOTION)
            return 1.0
        basis = F.TorqueBasis(self.gear.max_rudder)
        load = F.axial_load(self.gear, basis, rows.moments, coef)
        return residuals_and_inflation(self.gear, basis, rows, sample.t_ns, coef, two_z, z_gb, load, self._extra,
                                       sample.step_ns)[1]

    def _z(self, obs: Observations) -> dict[str, NDArray[np.float64]]:
        """The per-observation columns the model's effects read (none for the declared model),
        NaN where unknown. The oil temperature's is taken from the first one read, kept for the
        whole log: any constant gives the same clearances (the declared friction's columns
        absorb a constant times temp_friction's), a window's own mean would not fold."""
        if not self._z_names:
            return {}
        got = {name: arr for name, arr in iter_z_columns(obs, self.gear) if name in self._z_names}
        if self._accel is not None:
            got['accel'] = self._accel.at(obs.t_ns)
        if self._located is not None:
            got.update(self._located.columns(obs, self._pieces)[0])
        if 'dtemp' in self._z_names:
            oil = obs.oil_temp
            if self._temp_ref is None and np.isfinite(oil).any():
                self._temp_ref = float(oil[np.isfinite(oil)][0])
            got['dtemp'] = oil - (self._temp_ref if self._temp_ref is not None else np.nan)
        return {name: got.get(name, np.full(len(obs), np.nan)) for name in self._z_names}


def share_at(gear: GearParams, alpha: NDArray[np.float64], torque: NDArray[np.float64],
             gaps: Clearances) -> LoadSharing | None:
    """The load sharing at ``gaps`` of each second's angle and measured torque (NaN where either
    is unknown); None when none is known."""
    ok = np.isfinite(alpha) & np.isfinite(torque)
    if not ok.any():
        return None
    share = load_sharing(gear, np.where(ok, alpha, 0.0), np.where(ok, torque, 0.0), gaps.two_z, gaps.z_gb)
    return LoadSharing(*(np.where(ok, v, np.nan) if v.dtype.kind == 'f' else v
                         for v in (getattr(share, f) for f in share.__dataclass_fields__)))


class _Accel:
    """The ram acceleration column of the grid rows worked out so far, by time [ns] (kept
    rows are asked for later, after rows around them are gone)."""

    def __init__(self) -> None:
        self._t = np.zeros(0, np.int64)
        self._v = np.zeros(0)

    def add(self, t_ns: NDArray[np.int64], values: NDArray[np.float64]) -> None:
        self._t = np.concatenate([self._t, t_ns])
        self._v = np.concatenate([self._v, values])

    def at(self, t_ns: NDArray[np.int64]) -> NDArray[np.float64]:
        """Each row's value (rows in time order, each one added)."""
        if t_ns.size == 0:
            return np.zeros(0)
        i = np.searchsorted(self._t, t_ns)
        if not (np.all(i < self._t.size) and np.array_equal(self._t[np.minimum(i, self._t.size - 1)], t_ns)):
            msg = 'a row was folded whose ram acceleration was not worked out'
            raise AssertionError(msg)
        return self._v[i]

    def keep_last(self, keep: NDArray[np.bool_]) -> None:
        """Of the rows added last (``keep``'s length of them), only those ``keep`` marks stay."""
        n = keep.shape[0]
        if n and not keep.all():
            cut = self._t.size - n
            self._t = np.concatenate([self._t[:cut], self._t[cut:][keep]])
            self._v = np.concatenate([self._v[:cut], self._v[cut:][keep]])

    def drop_before(self, t_ns: int) -> None:
        k = int(np.searchsorted(self._t, t_ns))
        self._t, self._v = self._t[k:], self._v[k:]
