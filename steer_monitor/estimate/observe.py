"""Decoded streams to aligned observations of the declared model (docs/physics.md, docs/estimation.md).

Real data brings sensors at different rates and phases, gaps, the rudder at rest and
start/stop transients. This module puts everything on one clock and says, per instant,
what the data can tell:

* a uniform grid of ``GRID_NS`` (50 ms, the pressure rate) anchored at multiples of the
  step since the epoch, so a log cut in pieces gives the same grid points as the whole;
* every input interpolated linearly to the grid, valid only where the two bracketing
  samples are close enough (``MAX_GAP_NS`` for fast inputs, a few periods for speed and
  temperature); the angle is shifted by ``angle_shift_s`` on request (the delay candidate);
* the rudder's direction of motion from least-squares slopes of the angle samples over
  ``HALF_WINDOW_NS`` before and after each instant: +1/-1 only when both exceed
  ``MOVING_RATE`` with the same sign (steady motion), 0 otherwise (at rest, starting,
  stopping, reversing). Only steady-motion instants carry friction information.
* and the motion must be steady *through* the instant, not only on average: an autopilot
  on solenoid valves moves the rudder in short steps with pauses, and a window of 0.6 s
  that holds 0.45 s of motion and a 0.15 s pause passes the slope test while the rudder
  stands (no friction) at the instant. So the angle's slope over each of five 100 ms
  segments centred on the instant (``SEGMENT_NS``) must keep the sign and reach
  ``STEADY_FRACTION`` of the window's rate; and the grid points either side must pass too,
  since the 20 Hz pressures interpolated to a point within 50 ms of a stop mix a sample
  with friction and one without.

The constants are made for the angle at 10 Hz and the pressures at 20 Hz (a direct tap).
A gateway may forward them far slower (NMEA 2000's default interval for Actual Pressure is
2 s): each input's own period is measured from its samples (the median interval,
:func:`median_period_ns`) and an input more than ``SLOWER`` times slower than that has its
windows scaled to its period (:class:`Windows`): interpolation across up to 2.5 of its periods,
the slopes over three of the angle's periods each side, the steadiness segments one of its
periods long, steady motion required through every grid point a pressure sample's bracket
reaches, and one row per pressure period (rows between two slow pressure samples are one
interpolation, not more data: :attr:`Observations.step_ns` is the rows' spacing, what the
residual's autocorrelation is read in), and only rows where a timing error of one period
moves the ram forces by at most ``TIMING_PA`` (1 bar; a gateway that holds a value sends it up to a
period stale: :func:`_timing_resolved`). So the slower signal bounds what a transient can show:
at 0.5 Hz only motion steady for a dozen seconds counts. At the design rates nothing changes.

Pure numpy. Times integer ns, values SI.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from steer_monitor.compiled import njit
from steer_monitor.errors import SteerMonitorError
from steer_monitor.estimate.sampling import (
    DESIGN_ANGLE_PERIOD_NS,
    DESIGN_PRESSURE_PERIOD_NS,
    GRID_NS,
    HALF_WINDOW_NS,
    SEGMENT_NS,
    SLOWER,
    SignalTiming,
    Windows,
    median_period_ns,
    missing_steering,
    signal_timing,
)
from steer_monitor.model.inputs import PRESSURE_INPUTS, Series
from steer_monitor.model.ramforce import ram_forces

__all__ = ['DESIGN_ANGLE_PERIOD_NS', 'DESIGN_PRESSURE_PERIOD_NS', 'GRID_NS', 'HALF_WINDOW_NS', 'MOVING_RATE',
           'SEGMENT_NS', 'SLOWER', 'STEADY_FRACTION', 'EstimateError', 'Observations', 'Windows', 'angle_slopes',
           'build_observations', 'data_grid', 'fresh_readings', 'grid_times', 'in_sorted', 'interp_held',
           'median_period_ns', 'sorted_positions', 'SignalTiming', 'signal_timing', 'too_little_motion', 'TIMING_PA',
           'COPIES_FASTER']

MOVING_RATE = 0.2 * math.pi / 180.0   # rad/s
STEADY_FRACTION = 0.5                 # each segment's rate against the window's
SLOW_GAP_NS = 10_000_000_000          # ship speed (1 Hz) and oil temperature (0.5 Hz)
LONG_GAP_NS = 60_000_000_000          # no angle this long: the grid skips the stretch ...
GAP_PAD_NS = 1_000_000_000            # ... keeping this much at each side
#: where an input is slower than the design rate: the most a timing error of one of its periods
#: may move a ram's force, in cylinder pressure [Pa]: about three times the sensor noise of a
#: ram's force (two transducers of 0.25 bar). Chosen on the seeds 74201 and 74401-74405 (at
#: 2 bar the seal friction through a hold gateway at 5 Hz was read 5-9 % high and its interval
#: held on 2 of 5); docs/accuracy-rates.md proves it on others
TIMING_PA = 1e5
#: an angle whose median interval is this much shorter than the design period comes from a
#: gateway resending readings (:func:`fresh_readings`)
COPIES_FASTER = 1.1


class EstimateError(SteerMonitorError, ValueError):
    """The data cannot support an estimate (too little motion, a required input missing)."""


@dataclass(frozen=True)
class Observations:
    """The data on one grid, arrays of shape (n,) unless noted. SI units.

    Attributes:
        t_ns: grid times [ns].
        alpha: rudder angle [rad] (NaN where not valid).
        rate: rudder rate [rad/s] over the centred window (NaN where not valid).
        direction: +1/-1 in steady motion, 0 otherwise (int8).
        force: ram force A_r (p_stbd - p_port) per ram [N], shape (n, 2); NaN where invalid.
        pressure: the four transducers [Pa], shape (n, 4), in ``PRESSURE_INPUTS`` order.
        speed: ship speed [m/s], NaN where not on the bus.
        oil_temp: oil temperature [K], NaN where not on the bus.
        step_ns: the spacing of the rows steady motion may give [ns]: the grid's, or one
            pressure period where the pressures come slower (:class:`Windows`).
        shared_ns: rows closer than this [ns] may be interpolated from one sample of the
            slowest input (:attr:`Windows.shared_ns`): the residual's smooth part is read
            further apart.
    """

    t_ns: NDArray[np.int64]
    alpha: NDArray[np.float64]
    rate: NDArray[np.float64]
    direction: NDArray[np.int8]
    force: NDArray[np.float64]
    pressure: NDArray[np.float64]
    speed: NDArray[np.float64]
    oil_temp: NDArray[np.float64]
    step_ns: int = GRID_NS
    shared_ns: int = GRID_NS

    def __len__(self) -> int:
        return int(self.t_ns.shape[0])

    @functools.cached_property
    def moving(self) -> NDArray[np.bool_]:
        """Steady-motion instants with a valid angle and at least one valid ram force (worked
        out once: an analysis asks a hundred times; read-only, as the arrays are not changed)."""
        ok = np.isfinite(self.alpha) & np.any(np.isfinite(self.force), axis=1)
        out = (self.direction != 0) & ok
        out.flags.writeable = False
        return out

    def select(self, mask: NDArray[np.bool_]) -> Observations:
        return Observations(self.t_ns[mask], self.alpha[mask], self.rate[mask], self.direction[mask],
                            self.force[mask], self.pressure[mask], self.speed[mask], self.oil_temp[mask], self.step_ns,
                            self.shared_ns)


def grid_times(start_ns: int, end_ns: int) -> NDArray[np.int64]:
    """Grid points in [start_ns, end_ns): multiples of ``GRID_NS`` since the epoch."""
    first = -(-int(start_ns) // GRID_NS) * GRID_NS
    if end_ns <= first:
        return np.zeros(0, np.int64)
    return np.arange(first, int(end_ns), GRID_NS, dtype=np.int64)


def data_grid(sample_ns: NDArray[np.int64], start_ns: int, end_ns: int) -> NDArray[np.int64]:
    """:func:`grid_times` over [start_ns, end_ns), less the stretches of more than
    ``LONG_GAP_NS`` without a sample (``sample_ns`` sorted), which keep ``GAP_PAD_NS`` of grid
    at each side (no valid angle there, so no motion). The grid's size is bounded by the data
    present: a log that resumes after a day, or a clock step of years, does not allocate a
    grid point every 50 ms in between."""
    ts = np.asarray(sample_ns, np.int64)
    cut = np.nonzero(np.diff(ts) > LONG_GAP_NS)[0] if ts.size > 1 else np.zeros(0, np.intp)
    if cut.size == 0:
        return grid_times(start_ns, end_ns)
    lo = np.concatenate([[start_ns], ts[cut + 1] - GAP_PAD_NS])
    hi = np.concatenate([ts[cut] + GAP_PAD_NS, [end_ns]])
    parts = [grid_times(max(int(a), start_ns), min(int(b), end_ns)) for a, b in zip(lo, hi) if b > a]
    return np.concatenate(parts) if parts else np.zeros(0, np.int64)


def interp_held(series: Series | None, t: NDArray[np.int64], max_gap: int, shift_ns: int = 0) -> NDArray[np.float64]:
    """Linear interpolation to ``t`` where the bracketing samples are at most ``max_gap``
    apart (and exact hits: the last sample at that time); NaN elsewhere. ``t`` in any order."""
    out = np.full(t.shape, np.nan)
    if series is None or len(series) == 0:
        return out
    ts = series.t_ns - np.int64(shift_ns)
    _interp_into(np.ascontiguousarray(ts), np.ascontiguousarray(series.value, dtype=np.float64),
                 np.ascontiguousarray(t, dtype=np.int64).reshape(-1), np.int64(max_gap), out.reshape(-1))
    return out


def fresh_readings(series: Series, within_ns: int = DESIGN_ANGLE_PERIOD_NS) -> Series:
    """``series`` without the copies a gateway sends of a reading: in a run of samples of one
    value that the signal passes through (the values either side of the run lie on either side
    of it: the rudder moving on through), those less than ``within_ns`` after the run's first
    (the design angle period: no sensor of this bus reads faster). A gateway that holds the last
    value and sends it on a timer faster than the sensor (12 or 15 Hz from a 10 Hz rudder sensor)
    sends some readings twice; its copies, stamped later, make a moving rudder a staircase whose
    flat treads read as standing (a log at 15 Hz kept a twentieth of the steady motion the same
    log kept at 10 Hz). A reading's time is its first sending. A run where the rudder stops
    (turns back, or stands longer than ``within_ns``) keeps its samples: there a repeat is a
    reading, and where the rudder starts to move again is in it. :func:`build_observations`
    applies it only where the angle comes over ``COPIES_FASTER`` times faster than the design
    period, faster than any rudder sensor on this bus reads: from a sensor read directly a
    repeat is a reading (below its resolution, as the rudder slows to a stop, where the
    instants it reads are what the inertia and the stops are judged on)."""
    if len(series) < 2:
        return series
    keep = _fresh(np.ascontiguousarray(series.t_ns), np.ascontiguousarray(series.value, dtype=np.float64),
                  np.int64(within_ns))
    if keep.all():
        return series
    return Series(series.t_ns[keep], series.value[keep])


@njit(cache=True, nogil=True)
def _fresh(t: NDArray[np.int64], v: NDArray[np.float64], within: np.int64
           ) -> NDArray[np.bool_]:   # pragma: no cover - compiled
    """:func:`fresh_readings`' walk: which samples to keep."""
    keep = np.ones(t.size, np.bool_)
    n = t.size
    a = 1
    while a < n:
        if v[a] != v[a - 1]:
            a += 1
            continue
        first = a - 1                   # a run of one value from first to b - 1
        b = a
        while b < n and v[b] == v[first]:
            b += 1
        if first > 0 and b < n and (v[first] - v[first - 1]) * (v[b] - v[first]) > 0:
            for i in range(first + 1, b):
                if t[i] - t[first] < within:
                    keep[i] = False
        a = b
    return keep


@njit(cache=True, nogil=True, inline='always')
def _next_position(ts: NDArray[np.int64], ti: np.int64, j: int, in_order: bool, right: bool
                   ) -> int:   # pragma: no cover - compiled
    """``searchsorted(ts, ti, side='right' if right else 'left')``: walking on from ``j``, the
    position of the point before, when ``in_order`` (the points ascend: the usual case), else a
    binary search."""
    n = ts.size
    if in_order:
        if right:
            while j < n and ts[j] <= ti:
                j += 1
        else:
            while j < n and ts[j] < ti:
                j += 1
        return j
    lo, hi = 0, n
    while lo < hi:
        mid = (lo + hi) >> 1
        if ts[mid] < ti or (right and ts[mid] == ti):
            lo = mid + 1
        else:
            hi = mid
    return lo


@njit(cache=True, nogil=True, error_model='numpy')
def _interp_into(ts: NDArray[np.int64], v: NDArray[np.float64], t: NDArray[np.int64], max_gap: np.int64,
                 out: NDArray[np.float64]) -> None:   # pragma: no cover - compiled
    """:func:`interp_held`'s loop, compiled: per point the first sample after it (walking on from
    the point before when the points are in order, else a binary search), then the value. The
    arithmetic is numpy's (int64 differences divided as float64, ``v0 + (v1 - v0) * w``, no
    fused multiply-add), so the values are the same to the bit as the vectorized form this
    replaced (``test_observe`` compares them). It makes no temporaries: the interpolation took
    a third of a loop's time on an hour's window (0.51 s of 1.43 s), now 0.04 s."""
    n = ts.size
    j = 0
    prev = t[0] if t.size else 0
    for i in range(t.size):
        ti = t[i]
        j = _next_position(ts, ti, j, ti >= prev, True)     # ts[j-1] <= ti < ts[j]
        prev = ti
        if j > 0 and ts[j - 1] == ti:
            out[i] = v[j - 1]
        elif 0 < j < n:
            t0 = ts[j - 1]
            t1 = ts[j]
            if t1 - t0 <= max_gap:
                w = (ti - t0) / (t1 - t0)
                out[i] = v[j - 1] + (v[j] - v[j - 1]) * w


def sorted_positions(ts: NDArray[np.int64], t: NDArray[np.int64], *, right: bool) -> NDArray[np.intp]:
    """``np.searchsorted(ts, t, side='right' if right else 'left')`` for sorted ``ts`` (n,), the
    same positions, found by walking along ``ts`` while ``t`` is in order (a binary search where
    it is not): a tenth of numpy's time on a grid of 200,000 points."""
    out = np.empty(t.shape, np.intp)
    _positions_into(np.ascontiguousarray(ts, dtype=np.int64), np.ascontiguousarray(t, dtype=np.int64).reshape(-1),
                    right, out.reshape(-1))
    return out


@njit(cache=True, nogil=True)
def _positions_into(ts: NDArray[np.int64], t: NDArray[np.int64], right: bool,
                    out: NDArray[np.intp]) -> None:   # pragma: no cover - compiled
    j = 0
    prev = t[0] if t.size else 0
    for i in range(t.size):
        ti = t[i]
        j = _next_position(ts, ti, j, ti >= prev, right)
        prev = ti
        out[i] = j


def in_sorted(a: NDArray[np.int64], b: NDArray[np.int64]) -> NDArray[np.bool_]:
    """``np.isin(a, b)`` for sorted ``b``: whether each of ``a`` is in ``b`` (the same booleans,
    by a search instead of numpy's sort of both)."""
    if b.size == 0:
        return np.zeros(a.shape, bool)
    idx = np.minimum(sorted_positions(b, a, right=False), b.size - 1)
    return b[idx] == a


def _window_sums(ts: NDArray[np.int64], v: NDArray[np.float64], t: NDArray[np.int64], y_ref: NDArray[np.float64],
                 i0: NDArray[np.intp], i1: NDArray[np.intp]) -> NDArray[np.float64]:
    """Sums over the samples ``ts[i0:i1]`` of each grid point: shape (5, n), rows count,
    sum x, sum x^2, sum y, sum x y with x = ts - t [s] and y = v - y_ref. Relative to the
    grid point, so they stay exact to rounding; one pass per sample rank in the window."""
    count = i1 - i0
    out = np.zeros((5, t.size))
    out[0] = count
    last = ts.size - 1
    for k in range(int(count.max()) if count.size else 0):
        use = count > k
        idx = np.minimum(i0 + k, last)
        x = np.where(use, (ts[idx] - t) * 1e-9, 0.0)
        y = np.where(use, v[idx] - y_ref, 0.0)
        out[1] += x
        out[2] += x * x
        out[3] += y
        out[4] += x * y
    return out


def _slope(sums: NDArray[np.float64]) -> NDArray[np.float64]:
    """Least-squares slope [per s] from :func:`_window_sums`; NaN with fewer than 2 distinct
    times (samples under 0.1 us apart count as one time)."""
    n, sx, sxx, sy, sxy = sums
    den = n * sxx - sx * sx
    good = (n >= 2) & (den > 1e-14)
    out = np.full(n.shape, np.nan)
    out[good] = (n * sxy - sx * sy)[good] / den[good]
    return out


def angle_slopes(ts: NDArray[np.int64], v: NDArray[np.float64], t: NDArray[np.int64], half_ns: int = HALF_WINDOW_NS
                  ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Least-squares slopes of the angle samples over ``half_ns`` before each grid
    point, after it, and over both (each window with its ends): shapes (n,). The whole
    window's sums are the halves' less the samples exactly at the grid point, which both
    halves hold (x = 0 there, so only the count and sum y are counted twice)."""
    j = sorted_positions(ts, t, right=False)                 # the first sample at or after t
    k = sorted_positions(ts, t, right=True)                  # the first after t
    y_ref = v[np.minimum(j, ts.size - 1)]
    before = _window_sums(ts, v, t, y_ref, sorted_positions(ts, t - half_ns, right=False), k)
    after = _window_sums(ts, v, t, y_ref, j, sorted_positions(ts, t + half_ns, right=True))
    at = k - j                                               # samples exactly at t
    whole = before + after
    whole[0] -= at
    if at.any():
        hit = np.nonzero(at)[0]
        for r in range(int(at.max())):
            h = hit[at[hit] > r]
            whole[3, h] -= v[j[h] + r] - y_ref[h]
    return _slope(before), _slope(after), _slope(whole)


def _steady_through(angle: Series, t: NDArray[np.int64], shift_ns: int, need: NDArray[np.float64],
                    win: Windows) -> NDArray[np.bool_]:
    """True where the angle's slope over each of the five ``win.segment_ns`` segments centred
    on ``t`` (+-250 ms at the design rate) has the sign of ``need`` [rad/s] and at least its size."""
    seg_ns = win.segment_ns
    offsets = np.array([k * seg_ns // 2 for k in (-5, -3, -1, 1, 3, 5)], np.int64)
    ends = interp_held(angle, (t[None, :] + offsets[:, None]).ravel(), win.angle_gap_ns,
                       shift_ns).reshape(offsets.size, -1)
    ok = np.ones(t.shape, bool)
    with np.errstate(invalid='ignore'):
        for a, b in zip(ends[:-1], ends[1:]):
            seg = (b - a) / (seg_ns / 1e9)
            ok &= np.isfinite(seg) & (seg * np.sign(need) >= np.abs(need))
    return ok


def _eroded(direction: NDArray[np.int8], radius: int = 1) -> NDArray[np.int8]:
    """Steady motion kept only where the ``radius`` grid points either side (one, 50 ms, at
    the design rate) are in the same steady motion. The pressures are sampled at 20 Hz and
    interpolated to the grid, so a grid point within 50 ms of a stop or start mixes a sample
    with friction and one without (the angle's 100 ms segments cannot place the stop closer
    than that); a slower pressure's bracket reaches its period either side."""
    out = direction.copy()
    r = radius
    if out.size < 2 * r + 1:
        out[:] = 0
        return out
    same = np.ones(out.size - 2 * r, bool)
    mid = direction[r:out.size - r]
    for k in range(1, r + 1):
        same &= (mid == direction[r - k:out.size - r - k]) & (mid == direction[r + k:out.size - r + k])
    out[r:out.size - r] = np.where(same, mid, 0)
    out[:r] = 0
    out[out.size - r:] = 0
    return out


def _timing_resolved(force: NDArray[np.float64], win: Windows, ram_area: float) -> NDArray[np.bool_]:
    """Grid points (n,) where neither ram's force changes by more than ``TIMING_PA`` of cylinder
    pressure over one period of the slower input (half a period either side). A gateway that
    holds a value and sends it on its own timer sends it up to one period stale, a lag per
    channel that slides with its crystal; where the force changes fast (near midships the
    torque curve is steep) that is more than the sensor noise, and such rows are not what a
    slow signal can show. Measured on the force itself (its change over the period, not a
    derivative that the 20 Hz noise would swamp)."""
    n = force.shape[0]
    ok = np.zeros(n, bool)
    period = max(win.pressure_period_ns or 0, win.angle_period_ns or 0)
    k = max(1, int(round(period / 2 / GRID_NS)))
    if n <= 2 * k:
        return ok
    with np.errstate(invalid='ignore'):
        change = np.abs(force[2 * k:] - force[:-2 * k])
        worst = np.where(np.isfinite(change), change, np.inf).max(axis=1)
    ok[k:n - k] = worst <= TIMING_PA * ram_area
    return ok


def build_observations(signals: Mapping[str, Series], ram_area: float, *,
                       start_ns: int | None = None, end_ns: int | None = None,
                       angle_shift_s: float = 0.0) -> Observations:
    """Align the decoded streams on the grid (see the module docstring).

    Args:
        signals: per input name, its series (as the decoder
            gives them). ``rudder_angle`` and the four pressures are required.
        ram_area: A_r [m^2].
        start_ns, end_ns: the grid's span (default: the angle's first and last sample).
        angle_shift_s: read the angle ``shift`` seconds later (a sensor that lags by tau is
            undone by shift = tau).
    """
    missing = missing_steering({n: len(v) for n, v in signals.items() if v is not None})
    if missing is not None:
        raise EstimateError(missing)
    angle = signals['rudder_angle']
    period = median_period_ns(angle)
    if period is not None and period * COPIES_FASTER < DESIGN_ANGLE_PERIOD_NS:
        angle = fresh_readings(angle)
    win = Windows.of(signals)
    shift_ns = round(angle_shift_s * 1e9)
    a_t = angle.t_ns - np.int64(shift_ns)
    t0 = int(a_t[0]) if start_ns is None else start_ns
    t1 = int(a_t[-1]) + 1 if end_ns is None else end_ns
    t = data_grid(a_t, t0, t1)
    # the motion is judged on the grid and the points either side of it its erosion reads, so
    # that the erosion at a span's ends does not depend on where a log or a fold is cut
    r = win.erode
    t_ext = np.concatenate([t[0] - GRID_NS * np.arange(r, 0, -1), t, t[-1] + GRID_NS * np.arange(1, r + 1)]) \
        if t.size else t
    alpha_ext = interp_held(angle, t_ext, win.angle_gap_ns, shift_ns)
    before, after, rate = angle_slopes(a_t, angle.value, t_ext, win.half_window_ns)
    with np.errstate(invalid='ignore'):
        steady = (np.abs(before) > MOVING_RATE) & (np.abs(after) > MOVING_RATE) & \
            (np.sign(before) == np.sign(after)) & np.isfinite(alpha_ext)
    steady &= _steady_through(angle, t_ext, shift_ns,
                              np.sign(before) * np.maximum(MOVING_RATE, STEADY_FRACTION * np.abs(rate)), win)
    direction = _eroded(np.where(steady, np.sign(before), 0).astype(np.int8), r)
    inner = slice(r, t_ext.size - r) if t.size else slice(None)
    alpha, rate, direction = alpha_ext[inner], rate[inner], direction[inner]
    if win.row_step > 1:            # one row per slow pressure period: the rows between are interpolation
        direction = np.where(t % win.step_ns == 0, direction, 0).astype(np.int8)
    pressure = np.stack([interp_held(signals.get(n), t, win.pressure_gap_ns) for n in PRESSURE_INPUTS], axis=1)
    force = ram_forces(ram_area, pressure)
    if not win.design:
        direction = np.where(_timing_resolved(force, win, ram_area), direction, 0).astype(np.int8)
    speed = interp_held(signals.get('ship_speed'), t, SLOW_GAP_NS)
    oil = interp_held(signals.get('oil_temperature'), t, SLOW_GAP_NS)
    return Observations(t, alpha, rate, direction, force, pressure, speed, oil, win.step_ns, win.shared_ns)


def too_little_motion(signals: Mapping[str, Series], obs: Observations, rows: int, need: int) -> str:
    """Why ``obs`` (of ``signals``) cannot be estimated from, holding ``rows`` rows of steady
    motion (ram x instant) where ``need`` are needed: at the design rates, the motion missing;
    with a slow input, its period, what the analysis takes from it, and how much steering at
    this log's pace, or which rates, would be enough."""
    msg = f'too little steady rudder motion to estimate the clearances: {rows} rows of steady motion, need {need}'
    win = Windows.of(signals)
    if win.design:
        return msg + ' (about 5 s of moving rudder)'
    pressures = [p for p in (median_period_ns(signals.get(n)) for n in PRESSURE_INPUTS) if p is not None]
    said = [f'the {what} every {p / 1e9:.2f} s ({1e9 / p:.2g} Hz)'
            for what, p in (('rudder angle', median_period_ns(signals.get('rudder_angle'))),
                            ('pressures', max(pressures) if pressures else None))
            if p is not None]
    msg += (f': this log has {" and ".join(said)}, slower than a direct tap (a gateway?), so the analysis takes '
            f'one row per ram every {win.step_ns / 1e9:.2g} s and counts motion only where the rudder moved steadily '
            f'for {2 * win.half_window_ns / 1e9:.2g} s')
    span_min = (int(obs.t_ns[-1]) - int(obs.t_ns[0])) / 60e9 if len(obs) else 0.0
    if rows > 0 and span_min > 0:
        msg += (f'; at this log\'s pace about {math.ceil(span_min * need / rows)} minutes of steering would be '
                f'enough (it holds {span_min:.0f})')
    else:
        msg += '; no stretch of this log held such motion'
    return msg + ('; or raise the rates (the angle at 10 Hz, the pressures at 20 Hz) on the gateway, or through NMEA '
                  "2000's group function (PGN 126208) where the device supports it")
