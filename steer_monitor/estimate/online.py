"""The clearance estimator online: samples in, an updated estimate at least every second of
rudder motion, bounded memory, state on disk. Pure (no ROS, no CAN).

It keeps the raw samples of the last few seconds only, turns each second of data into
observations exactly as the batch path does (same epoch-anchored grid, same windows; the
second is processed once the data are ``LAG_NS`` beyond it, so every window is complete),
and folds the steady-motion rows into the binned moments of
:mod:`~steer_monitor.estimate.moments`. Memory is bounded by the bin layout, whatever the
length of the voyage. On the same data the moments equal the batch ones, so the estimates
converge to the batch estimate.

* After each second of data with motion in it: a local step of the clearance search (the 3 x 3
  points around the current best, a step apart: the grid's step, or the finer one the last full
  profile used where the grid could not resolve the clearance, :mod:`~steer_monitor.estimate.refine`),
  and a refit of the linear parameters there.
* The full profile with its intervals and the residuals' inflation factor at the first
  estimate and whenever the motion learned has doubled since the last one, then every
  ``FULL_EVERY_S`` of motion: early estimates rest on little data and the profile can have
  several minima, which a local step alone could stay in.
* No motion, no update: nothing is folded while the rudder rests, so nothing winds up.
* Nothing is folded either while the rams do not share the force evenly
  (:mod:`~steer_monitor.estimate.rams`, judged over the last ``WINDOW_INSTANTS`` instants of
  steady motion, the second's own included): the declared model has each ram carry half,
  and with a ram's chambers joined the friction the fit would read is another gear's.
* Forgetting (optional): the moments decay with a half-life counted in seconds of motion.
* :meth:`save` / :meth:`load`: the moments and the last estimate in one ``.npz``, written
  atomically; a restart picks up what was learned.
"""

from __future__ import annotations

import bisect
import json
import math
from collections import deque
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from steer_monitor.atomic import atomic_write
from steer_monitor.can.decoder import Sample, Series
from steer_monitor.can.signals import PRESSURE_INPUTS
from steer_monitor.estimate import fit as F
from steer_monitor.estimate.batch import (MIN_MOTION_SAMPLES, ClearanceEstimate, Rows, estimate_from_moments,
                                          predict_rows, search_box)
from steer_monitor.estimate.intervals import Interval, inflation
from steer_monitor.estimate.moments import SPEED_Z, Moments, rows_from_observations, speed_ratio
from steer_monitor.estimate.observe import (GRID_NS, HALF_WINDOW_NS, MOVING_RATE, EstimateError, build_observations)
from steer_monitor.estimate.rams import IDLE, OPPOSED, UNEVEN, WINDOW_INSTANTS, judge, ram_share
from steer_monitor.model.gear import GearParams
from steer_monitor.model.torque import TorqueTable

__all__ = ['FULL_EVERY_S', 'LAG_NS', 'OnlineEstimate', 'OnlineEstimator']

LAG_NS = 1_000_000_000          # a second is processed once the data are this far beyond it
KEEP_NS = 3_000_000_000         # raw samples kept behind the processed edge
CHUNK_NS = 1_000_000_000
SKIP_NS = 60_000_000_000        # a stretch this long without angle samples is skipped, not walked
FULL_EVERY_S = 300.0            # seconds of motion between full profiles
LOCAL = 1                       # local search: +-1 grid step on each axis (a hill climb)
REPROFILE_EVERY_S = 30.0        # at most one extra full profile per this much motion when a local
                                # step leaves the interval (between them the step is not taken)
RESID_KEEP = 8000               # recent rows (ram x instant) kept for the inflation factor
STATE_VERSION = 3               # 3: the best point as clearances and local steps (2: grid indices)
READS = (2, 3)                  # versions load() takes: a node upgraded keeps what it learned
_INPUTS = ('rudder_angle',) + PRESSURE_INPUTS + ('ship_speed',)


@dataclass(frozen=True)
class OnlineEstimate:
    """The latest estimate: clearances [m] and K_gl max with intervals (from the last full
    profile; the clearances' moved with the point), rows used, data time [ns] and whether it
    came from a full profile."""

    two_z: Interval
    z_gb: Interval
    k_gl_max: Interval
    rows: float
    t_ns: int
    full: bool
    friction: tuple[float, float, float] = (math.nan, math.nan, math.nan)   # F_s [N], mu_b, mu_g at the point
    #: the torque fitted with that friction: B-spline coefficients of ``F.TorqueBasis`` at
    #: service speed [N m] (empty when not known), and the largest |alpha| learned [rad]
    torque_coef: tuple[float, ...] = ()
    max_angle: float = 0.0

    def torque_table(self, gear: GearParams, step: float = math.radians(0.05)) -> TorqueTable | None:
        """The fitted torque as a table up to :attr:`max_angle` (None when not known)."""
        if not self.torque_coef or not self.max_angle > step:
            return None
        basis = F.TorqueBasis(gear.max_rudder)
        top = min(self.max_angle, gear.max_rudder)
        angles = np.append(np.arange(0.0, top, step), top)
        return TorqueTable(angles, basis.torque(np.asarray(self.torque_coef), angles), gear.torque.service_speed)


def _gear_signature(gear: GearParams) -> list[float]:
    return [gear.stock_to_ram, gear.bushing_span, gear.ram_outer_diameter, gear.ram_inner_diameter,
            gear.youngs_modulus, gear.guide_beam_inertia, gear.guide_beam_span, gear.bushing_length,
            float(gear.rams), gear.max_rudder]


class OnlineEstimator:
    """See the module docstring. Not thread-safe: the node serializes calls."""

    def __init__(self, gear: GearParams, *, min_clearance_2z: float = 0.0, half_life_s: float = 0.0,
                 ram_share_warn: float = 0.15) -> None:
        self.gear = gear
        self.ram_share_warn = ram_share_warn
        self._ram_forces: deque[NDArray[np.float64]] = deque()   # the rams' forces of recent seconds, (k, 2) each
        #: seconds of steady motion not folded because the rams did not share the force evenly
        self.uneven_s = 0.0
        self.basis = F.TorqueBasis(gear.max_rudder)
        self.grid_2z = F.GRID_2Z[F.GRID_2Z >= min_clearance_2z - 1e-12]
        self.grid_zgb = F.GRID_ZGB
        self.half_life_s = half_life_s
        self.moments = Moments()
        self._buf: dict[str, deque[tuple[int, float]]] = {n: deque() for n in _INPUTS}
        self._done_ns: int | None = None       # grid processed up to here (exclusive)
        self._latest_ns: int | None = None
        self._speed_seen = False
        self._motion_since_full = 0.0
        self._new_motion = 0.0
        self._point: tuple[float, float] | None = None    # the current best (2Z, Z_gb) [m] ...
        self._grid_steps = (float(self.grid_2z[1] - self.grid_2z[0]), float(self.grid_zgb[1] - self.grid_zgb[0]))
        self._steps: tuple[float, float] = self._grid_steps                # ... and the local step
        self._coef: np.ndarray | None = None
        self._delta_profile: tuple[np.ndarray, np.ndarray] | None = None
        self._recent: deque[tuple] = deque(maxlen=RESID_KEEP)   # recent rows, for the inflation
        self._vif = 1.0
        self.estimate: OnlineEstimate | None = None
        self.motion_s = 0.0
        self.last_full: ClearanceEstimate | None = None

    # --- input ---------------------------------------------------------------------------
    def add(self, sample: Sample) -> None:
        """Take one decoded sample (any input; those the estimator does not use are ignored)."""
        buf = self._buf.get(sample.signal)
        if buf is None:
            return
        if buf and sample.t_ns <= buf[-1][0]:
            return                                # the decoder already refused out-of-order frames
        buf.append((sample.t_ns, sample.value))
        if sample.signal == 'ship_speed':
            self._speed_seen = True
        if sample.signal == 'rudder_angle':
            if self._done_ns is None:
                self._done_ns = -(-sample.t_ns // GRID_NS) * GRID_NS
            self._latest_ns = sample.t_ns

    def update(self) -> bool:
        """Process every complete second of data; refit when there was motion. True when the
        estimate changed."""
        if self._done_ns is None or self._latest_ns is None:
            return False
        changed = False
        while self._latest_ns - self._done_ns >= CHUNK_NS + LAG_NS:
            if self._latest_ns - self._done_ns > SKIP_NS:
                self._skip_gap()
                if self._latest_ns - self._done_ns < CHUNK_NS + LAG_NS:
                    break
            end = self._done_ns + CHUNK_NS
            self._fold(self._done_ns, end)
            self._done_ns = end
            self._trim(end - KEEP_NS)
        if self._new_motion > 0 and self.moments.samples >= MIN_MOTION_SAMPLES:
            changed = self.refit()
        return changed

    def _skip_gap(self) -> None:
        """Over a stretch without angle samples (a pause in the log, a clock step) go straight
        to the whole second before the next sample's window, so the work is bounded by the
        data present, not by the time between them."""
        assert self._done_ns is not None
        buf = self._buf['rudder_angle']
        i = bisect.bisect_left(buf, self._done_ns - HALF_WINDOW_NS, key=lambda tv: tv[0])
        if i >= len(buf):
            return
        ahead = buf[i][0] - HALF_WINDOW_NS - self._done_ns
        if ahead > SKIP_NS:
            self._done_ns += ahead // CHUNK_NS * CHUNK_NS
            self._trim(self._done_ns - KEEP_NS)

    def _series(self) -> dict[str, Series]:
        out = {}
        for name, buf in self._buf.items():
            if buf:
                t, v = zip(*buf)
                out[name] = Series(np.fromiter(t, np.int64, len(t)), np.fromiter(v, float, len(v)))
        return out

    def _trim(self, before_ns: int) -> None:
        for buf in self._buf.values():
            while len(buf) > 2 and buf[1][0] < before_ns:
                buf.popleft()

    def _at_rest(self, start: int, end: int) -> bool:
        """No steady motion is possible in [start, end): the angle moved less over the chunk
        and its windows than the motion threshold allows in one window."""
        lo, hi = start - HALF_WINDOW_NS, end + HALF_WINDOW_NS
        a = [v for t, v in self._buf['rudder_angle'] if lo <= t <= hi]
        return len(a) < 2 or (max(a) - min(a)) < MOVING_RATE * HALF_WINDOW_NS / 1e9

    def _fold(self, start: int, end: int) -> None:
        if self._at_rest(start, end):
            return
        signals = self._series()
        try:
            obs = build_observations(signals, self.gear.ram_area, start_ns=start, end_ns=end)
        except EstimateError:
            return
        keep = obs.moving
        if self._speed_seen:
            keep &= np.isfinite(obs.speed)
        if not keep.any():
            return
        sub = obs.select(keep)
        keys, aa, v2, u, idx, ram = rows_from_observations(sub)
        if keys.size == 0:
            return
        if not self._rams_even(sub.force):
            self.uneven_s += float(np.count_nonzero(keep)) * GRID_NS / 1e9
            return
        self._recent.extend(zip(sub.t_ns[idx].tolist(), ram.tolist(), keys.tolist(), aa.tolist(),
                                v2.tolist(), u[:, -1].tolist()))
        motion = float(np.count_nonzero(keep)) * GRID_NS / 1e9
        if self.half_life_s > 0 and len(self.moments):
            self.moments = self.moments.scaled(0.5 ** (motion / self.half_life_s))
        self.moments = self.moments.merge(Moments.from_rows(keys, aa, v2, u, (SPEED_Z,)))
        self.motion_s += motion
        self._motion_since_full += motion
        self._new_motion += motion

    def _rams_even(self, force: NDArray[np.float64]) -> bool:
        """Take a second's ram forces (k, 2) [N] into the window of the last
        ``WINDOW_INSTANTS`` instants with both, and say whether the rams share evenly there
        (or it cannot be judged)."""
        both = force[np.isfinite(force).all(axis=1)]
        if both.shape[0]:
            self._ram_forces.append(both)
            while sum(a.shape[0] for a in self._ram_forces) - self._ram_forces[0].shape[0] >= WINDOW_INSTANTS:
                self._ram_forces.popleft()
        if not self._ram_forces:
            return True
        window = np.concatenate(list(self._ram_forces))[-WINDOW_INSTANTS:]
        return judge(ram_share(window), self.ram_share_warn, self.gear.ram_area) not in (UNEVEN, IDLE, OPPOSED)

    def _residuals(self) -> None:
        """Residuals of the recent rows at the current fit -> the inflation factor. Run with
        the full profile only: per second the rows are just kept (bounded)."""
        if self._coef is None or self._point is None or len(self._recent) < 100:
            return
        arr = np.array(self._recent)                  # (r, 6): t, ram, |alpha| key parts ...
        t, ram, keys = arr[:, 0].astype(np.int64), arr[:, 1].astype(np.intp), arr[:, 2].astype(np.int64)
        aa, v2, y = arr[:, 3], arr[:, 4], arr[:, 5]
        u = np.stack([np.ones_like(y), speed_ratio(keys, v2), y], axis=1)
        one = Moments.from_rows(keys, aa, v2, u, (SPEED_Z,))
        rows = Rows(one, np.searchsorted(one.keys, keys), u, np.arange(y.size), ram)
        tz, zg = self._point
        load = F.axial_load(self.gear, self.basis, one, self._coef)
        res = y - predict_rows(self.gear, self.basis, rows, self._coef, tz, zg, load)
        times, inv = np.unique(t, return_inverse=True)
        resid = np.full((times.size, 2), np.nan)
        resid[inv, ram] = res
        self._vif = inflation(resid, times, GRID_NS)

    # --- fitting -------------------------------------------------------------------------
    def refit(self, full: bool | None = None) -> bool:
        """A local step, or the full profile when due (or asked)."""
        mom = self.moments
        due = min(FULL_EVERY_S, max(self.motion_s - self._motion_since_full, 1.0))
        full = full if full is not None else (self._point is None or self._motion_since_full >= due)
        self._new_motion = 0.0
        if full:
            return self._full()
        assert self._point is not None
        near = np.arange(-LOCAL, LOCAL + 1, dtype=float)
        axes = [np.unique(np.round(np.clip(c + h * near, g[0], g[-1]), 12))
                for c, h, g in zip(self._point, self._steps, (self.grid_2z, self.grid_zgb))]
        load = F.axial_load(self.gear, self.basis, mom, self._coef)
        pr = F.profile(self.gear, self.basis, mom, load, (), axes[0], axes[1])
        bi, bj = pr.best
        tz, zg = float(pr.two_z[bi]), float(pr.z_gb[bj])
        prev = self.estimate
        if prev is not None and not (prev.two_z.contains(tz) and prev.z_gb.contains(zg)):
            # the local step left the last full profile's interval: the profile has moved
            # (or the step is in a local minimum); a point outside its own interval is not
            # an answer: profile again, or, if one was made within the last
            # REPROFILE_EVERY_S of motion, keep the estimate as it is until then
            if self._motion_since_full >= REPROFILE_EVERY_S:
                return self._full()
            return False
        self._point = (tz, zg)
        self._coef = pr.coef
        self.estimate = OnlineEstimate(_moved(prev.two_z, tz) if prev else Interval(tz, None, None),
                                       _moved(prev.z_gb, zg) if prev else Interval(zg, None, None),
                                       prev.k_gl_max if prev else Interval(math.nan, None, None), mom.samples,
                                       self._latest_ns or 0, False, *self._fitted(self._coef))
        return True

    def _fitted(self, coef: NDArray[np.float64]) -> tuple[tuple[float, float, float], tuple[float, ...], float]:
        """The estimate's model beside its clearances: friction, torque coefficients and the
        largest |alpha| the moments hold (the mean of the outermost angle bin) [rad]."""
        mom = self.moments
        top = float(mom.abs_alpha[mom.count > 0].max()) if len(mom) else 0.0
        return self._friction(coef), tuple(float(c) for c in coef[:self.basis.size]), top

    def _friction(self, coef: NDArray[np.float64] | None) -> tuple[float, float, float]:
        """(F_s, mu_b, mu_g) of a fit's coefficients (they follow the torque coefficients)."""
        if coef is None:
            return (math.nan, math.nan, math.nan)
        k = self.basis.size
        return (float(coef[k]), float(coef[k + 1]), float(coef[k + 2]))

    def _full(self) -> bool:
        """The batch estimator on the moments (the same code, so the same numbers)."""
        try:
            g2, gz = self._search_box()
            est = estimate_from_moments(self.gear, self.moments, self._inflation(), g2, gz)
        except EstimateError:
            return False
        self._point = (float(est.two_z.value), float(est.z_gb.value))
        self._steps = tuple(h if h > 0 else g for h, g in zip(est.steps, self._grid_steps))   # type: ignore[assignment]
        self._coef = est.fit.coef
        self._motion_since_full = 0.0
        self.estimate = OnlineEstimate(est.two_z, est.z_gb, est.k_gl_max, self.moments.samples,
                                       self._latest_ns or 0, True, *self._fitted(self._coef))
        self.last_full = est
        return True

    def _search_box(self) -> tuple[np.ndarray, np.ndarray]:
        """:func:`~steer_monitor.estimate.batch.search_box` at the current fit."""
        return search_box(self.gear, self.moments, self.grid_2z, self.grid_zgb, self._vif, self._coef)

    def _inflation(self) -> float:
        """From the recent rows' residuals at the current fit; 1 before the first fit."""
        self._residuals()
        return self._vif

    def restart_stream(self) -> None:
        """Forget the samples not yet folded and the stream's time, keeping all that was
        learned (moments, fit, estimate): for a data time that went back (a host clock set
        back), the state a restart from :meth:`save` would start from."""
        for buf in self._buf.values():
            buf.clear()
        self._ram_forces.clear()
        self._done_ns = self._latest_ns = None

    # --- persistence ---------------------------------------------------------------------
    def save(self, path: str | Path) -> Path:
        """Write the learned state atomically (an ``.npz``, through a temporary name removed
        if the write fails). Raises :class:`~steer_monitor.errors.OutputError` naming the path
        and the system's reason (no directory, disk full, ...)."""
        path = Path(path)
        meta = {'version': STATE_VERSION, 'gear': _gear_signature(self.gear),
                'grid_2z_min': float(self.grid_2z[0]), 'motion_s': self.motion_s, 'vif': self._vif,
                'point': list(self._point) if self._point else None, 'steps': list(self._steps),
                'motion_since_full': self._motion_since_full,
                'estimate': _estimate_to_json(self.estimate) if self.estimate is not None else None}
        arrays = self.moments.to_arrays()
        if self._coef is not None:
            arrays['coef'] = self._coef
        with atomic_write(path, 'wb') as fh:
            np.savez(fh, meta=np.array(json.dumps(meta)), **arrays)
        return path

    def load(self, path: str | Path) -> None:
        """Take the state of :meth:`save`. Raises :class:`EstimateError` naming what does
        not fit (another gear, a newer format, a broken file); the current state is kept."""
        path = Path(path)
        try:
            with np.load(path, allow_pickle=False) as d:
                meta = json.loads(str(d['meta']))
                arrays = {k: d[k] for k in d.files if k != 'meta'}
        except Exception as exc:   # noqa: BLE001 - numpy's and zipfile's own errors (BadZipFile, a header
            # numpy cannot parse, ...) on a damaged file: all mean the same to the caller
            msg = f'estimator state {path}: cannot read it ({type(exc).__name__}: {exc})'
            raise EstimateError(msg) from exc
        if not isinstance(meta, dict) or meta.get('version') not in READS:
            version = meta.get('version') if isinstance(meta, dict) else None
            msg = f'estimator state {path}: format version {version}, this build reads {" or ".join(map(str, READS))}'
            raise EstimateError(msg)
        try:
            same_gear = bool(np.allclose(meta.get('gear', []), _gear_signature(self.gear)))
            state = self._state_of(meta, arrays) if same_gear else None
        except (ValueError, TypeError, KeyError) as exc:
            msg = f'estimator state {path}: damaged ({exc}); not used'
            raise EstimateError(msg) from exc
        if state is None:
            msg = f'estimator state {path}: learned on another gear geometry; not used'
            raise EstimateError(msg)
        self.moments, self.motion_s, self._vif, self._point, self._steps, self._coef, self._motion_since_full = state
        if meta.get('estimate') is not None and self._point is not None:
            # the estimate as it was (a fresh full profile could land elsewhere on a flat
            # profile than the local steps had; the next full profile comes on schedule)
            self.estimate = _estimate_from_json(meta['estimate'])
        elif self.moments.samples >= MIN_MOTION_SAMPLES:
            self._full()

    def _state_of(self, meta: dict, arrays: dict[str, NDArray]) -> tuple:
        """The learned state a saved file holds, checked to fit this estimator (ValueError,
        TypeError or KeyError naming what does not): a file that was damaged yet still
        parses must be refused here, not fail at the next refit."""
        moments = Moments.from_arrays(arrays)
        if moments.z_names != (SPEED_Z,):
            msg = f'moments of columns {list(moments.z_names)}, expected {[SPEED_Z]}'
            raise ValueError(msg)
        grid_steps = self._grid_steps
        point: tuple[float, float] | None = None
        steps = grid_steps
        if meta.get('version') == 2:        # the best as grid indices, the grid's steps
            best = tuple(int(i) for i in meta['best']) if meta.get('best') else None
            if best is not None and not (len(best) == 2 and 0 <= best[0] < self.grid_2z.size
                                         and 0 <= best[1] < self.grid_zgb.size):
                msg = f'best grid point {best} outside the grid ({self.grid_2z.size} x {self.grid_zgb.size})'
                raise ValueError(msg)
            if best is not None:
                point = (float(self.grid_2z[best[0]]), float(self.grid_zgb[best[1]]))
        else:
            if meta.get('point'):
                tz, zg = (float(x) for x in meta['point'])
                if not (self.grid_2z[0] - 1e-12 <= tz <= self.grid_2z[-1] + 1e-12
                        and self.grid_zgb[0] - 1e-12 <= zg <= self.grid_zgb[-1] + 1e-12):
                    msg = (f'best point 2Z {tz * 1e3:g} mm, Z_gb {zg * 1e3:g} mm outside the grid '
                           f'({self.grid_2z[0] * 1e3:g}..{self.grid_2z[-1] * 1e3:g} mm, '
                           f'0..{self.grid_zgb[-1] * 1e3:g} mm)')
                    raise ValueError(msg)
                point = (tz, zg)
            h2, hz = (float(x) for x in meta['steps'])
            if not all(math.isfinite(h) and 0 < h <= g + 1e-15 for h, g in zip((h2, hz), grid_steps)):
                msg = f'local steps {[h2, hz]} m must be positive and at most the grid steps {list(grid_steps)}'
                raise ValueError(msg)
            steps = (h2, hz)
        coef = arrays.get('coef')
        if coef is not None:
            coef = np.asarray(coef, float)
            if coef.ndim != 1 or coef.size < self.basis.size + 3 or not np.all(np.isfinite(coef)):
                msg = f'fitted coefficients of shape {coef.shape}, expected ({self.basis.size + 3},) or more, finite'
                raise ValueError(msg)
        numbers = [float(meta.get(k, d)) for k, d in (('motion_s', 0.0), ('vif', 1.0), ('motion_since_full', 0.0))]
        if not all(math.isfinite(x) and x >= 0 for x in numbers):
            msg = f'motion and inflation {numbers} must be finite and not negative'
            raise ValueError(msg)
        motion_s, vif, since_full = numbers
        if meta.get('estimate') is not None:
            _estimate_from_json(meta['estimate'])          # parses, or raises
        return moments, motion_s, vif, point, steps, coef, since_full


def _iv_json(iv: Interval) -> list[float | None]:
    return [iv.value, iv.lo, iv.hi]


def _estimate_to_json(e: OnlineEstimate) -> dict[str, object]:
    return {'two_z': _iv_json(e.two_z), 'z_gb': _iv_json(e.z_gb), 'k_gl_max': _iv_json(e.k_gl_max),
            'rows': e.rows, 't_ns': e.t_ns, 'full': e.full, 'friction': list(e.friction),
            'torque_coef': list(e.torque_coef), 'max_angle': e.max_angle}


def _estimate_from_json(d: dict) -> OnlineEstimate:
    return OnlineEstimate(Interval(*d['two_z']), Interval(*d['z_gb']), Interval(*d['k_gl_max']), float(d['rows']),
                          int(d['t_ns']), bool(d['full']), tuple(float(x) for x in d['friction']),  # type: ignore[arg-type]
                          tuple(float(x) for x in d.get('torque_coef', ())), float(d.get('max_angle', 0.0)))


def _moved(iv: Interval, value: float) -> Interval:
    """The interval of the last full profile, kept around a point that moved within it."""
    return Interval(value, iv.lo, iv.hi)
