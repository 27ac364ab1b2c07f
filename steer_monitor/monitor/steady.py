"""The rudder's rate and the instants of steady motion, sample by sample or a span at once. Pure.

Per angle sample: the rudder's rate, the least-squares slope of the angle over the last
:data:`SLOPE_WINDOW_NS`, or over the last :data:`MIN_RATE_POINTS` samples where the signal
comes too slowly for that (a gateway forwarding the angle at 2 Hz), as long as they lie within
:data:`MAX_RATE_SPAN_NS` (:func:`rate_window_start`; beyond it, after an outage, the rate is not
known until samples come again). One compiled kernel reads the slopes
(:mod:`~steer_monitor.monitor.slopes`), whether one window is asked for or a replay's run of
them at once (:meth:`SteadyMotion.plan`). The span of the window behind each rate is kept
beside it (:attr:`SteadyMotion.rate_span_ns`): what reads the rate judges its lag by it. Pressure
samples (all four known) are held until the angle is known :data:`HALF_WINDOW_NS` past them
(the analyses' half window for the angle's configured period, where it is slower than 10 Hz)
(and the model's angle delay); then whether the rudder moved steadily through each (the
slopes on both sides of it past :data:`MOVING_RATE`, the same sign) is judged, later and for
many angle samples at once (:mod:`~steer_monitor.monitor.instants`), and each instant of steady
motion goes to the ``sink`` given (the live residual and the rams check), the angle
interpolated to its time. Each steady bracket of angle samples counts its time of motion once
(:attr:`SteadyMotion.motion_ns`: what the node's analyses are scheduled on).

The steadiness constants are the analyses' (:mod:`~steer_monitor.estimate.observe`).
Times are integer ns; values SI.
"""

from __future__ import annotations

import bisect
import math
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass
from itertools import chain

import numpy as np
from numpy.typing import NDArray

from steer_monitor.estimate.observe import DESIGN_ANGLE_PERIOD_NS, HALF_WINDOW_NS, MOVING_RATE, SLOWER, Windows
from steer_monitor.monitor.buffers import HeldSamples
from steer_monitor.monitor.instants import CALL_FIELDS, OUT_FIELDS, take_instants
from steer_monitor.monitor.slopes import NONE, SLOPE, SPECIAL, slope, window_slopes

__all__ = ['CALLS_KEPT', 'HALF_WINDOW_NS', 'MAX_DELAY_NS', 'MAX_HELD', 'MAX_RATE_SPAN_NS', 'MIN_RATE_POINTS',
           'MOTION_STEP_NS', 'MOTION_STEP_PERIODS', 'MOVING_RATE', 'SLOPE_WINDOW_NS', 'InstantSink', 'SteadyMotion',
           'rate_window_start', 'rate_window_starts']

SLOPE_WINDOW_NS = 500_000_000
#: a slope needs this many samples: a signal with fewer in :data:`SLOPE_WINDOW_NS` has its rate
#: read over its last ones
MIN_RATE_POINTS = 3
#: ... when they lie within this span [ns]: three samples of a signal at 0.5 Hz (NMEA 2000's
#: default interval for slow data) with one lost between them, and their jitter; a longer span
#: (an outage) gives no rate
MAX_RATE_SPAN_NS = 8_000_000_000
MAX_DELAY_NS = 1_000_000_000   # the longest angle delay the model in use may read the angle later by
MOTION_STEP_NS = 250_000_000   # a steady bracket of angle samples counts at most this much motion
#: ... or, of an angle slower than the design rate, this many of its periods
MOTION_STEP_PERIODS = 1.5
_HELD = OUT_FIELDS.index('held')     # out's column of the held sample's index
_N_INSTANT = 7                       # the instant's columns (residual.INSTANT_FIELDS)

#: hears the instants of steady motion taken (n, 7: residual.INSTANT_FIELDS), the times of
#: their pressure samples (n,) [ns], the rams' forces (n, 2) [N] and the four pressures (n, 4) [Pa]
InstantSink = Callable[[NDArray[np.float64], NDArray[np.int64], NDArray[np.float64], NDArray[np.float64]], None]


def rate_window_start(times: list[int], t_ns: int) -> int:
    """Where the window of the rate at ``t_ns`` (the newest of ``times`` [ns], in order) begins,
    as an index into ``times``: the samples of the last :data:`SLOPE_WINDOW_NS`, or the last
    :data:`MIN_RATE_POINTS` where those are fewer, but none older than :data:`MAX_RATE_SPAN_NS`
    (then fewer points than a slope needs: no rate). :func:`rate_window_starts`, for one."""
    n = len(times)
    lo_time = bisect.bisect_left(times, t_ns - SLOPE_WINDOW_NS)
    lo_span = bisect.bisect_left(times, t_ns - MAX_RATE_SPAN_NS)
    return min(lo_time, max(n - MIN_RATE_POINTS, lo_span))


def rate_window_starts(t: NDArray[np.int64]) -> NDArray[np.intp]:
    """:func:`rate_window_start` of every sample of ``t`` [ns] (in order) over those before it."""
    idx = np.arange(t.shape[0])
    lo_time = np.searchsorted(t, t - SLOPE_WINDOW_NS, 'left')
    lo_span = np.searchsorted(t, t - MAX_RATE_SPAN_NS, 'left')
    return np.minimum(lo_time, np.maximum(idx + 1 - MIN_RATE_POINTS, lo_span))


@dataclass(frozen=True)
class _AnglePlan:
    """The rates of a run of angle samples (:meth:`SteadyMotion.plan`): ``n`` samples
    from global index ``base`` (counted from the monitor's first angle sample), their times,
    the first global index of each one's rate window, and its status and slope; for a span of
    them taken at once (:meth:`SteadyMotion.take_span`), with the model's angle delay
    ``delay`` [ns] then: the history's front after each, and counts before each (n + 1,) of
    those whose rate the plan does not give (a non-finite angle in the window, or a window
    reaching past the front)."""

    base: int
    n: int
    t: list[int]
    rate_lo: list[int]
    span: list[int]
    status: list[int]
    slope: list[float]
    delay: int
    front: list[int]
    unplanned: list[int]


#: pressure samples held and not yet released at most (51 s of them at 80 a second): with the
#: rudder angle's input dead and the pressures still coming, the oldest are let go unjudged
#: (counted in ``SteadyMotion.held_dropped``), so the node's memory stays bounded; with the
#: angle live they are released within a second or two of being held and never reach it
MAX_HELD = 4096

#: angle samples whose release of held pressure samples is judged later at most
#: (:meth:`SteadyMotion.take`): whatever reads the residual, the rams' share or the
#: motion judges them first; this bounds the log between reads
CALLS_KEPT = 1024


class SteadyMotion:
    """The rudder's rate and the instants of steady motion (see the module). Not thread-safe."""

    def __init__(self, ram_area: float, sink: InstantSink, angle_period_ns: int | None = None) -> None:
        self.ram_area = ram_area
        self._sink = sink
        #: each side of an angle sample its steady-motion slopes are taken over [ns], and the most
        #: motion a steady bracket counts: the analyses' (observe.Windows) for the angle's period
        #: ``angle_period_ns`` (its configured rate; None: the design rate)
        self.half_ns = Windows.of_periods(angle_period_ns, None).half_window_ns
        slow = angle_period_ns is not None and angle_period_ns > SLOWER * DESIGN_ANGLE_PERIOD_NS
        self.motion_step_ns = max(MOTION_STEP_NS, int(MOTION_STEP_PERIODS * angle_period_ns)) if slow and \
            angle_period_ns is not None else MOTION_STEP_NS
        #: the rate after the last angle sample [rad/s] (the last known: a sample that gives
        #: none leaves it)
        self.rate = 0.0
        #: the span of the window the last angle sample's rate was read over [ns]; None where
        #: that sample gave no rate (too few samples within :data:`MAX_RATE_SPAN_NS`)
        self.rate_span_ns: int | None = None
        #: how much later the model in use reads the angle [ns] (take what is held first: :meth:`take`)
        self.delay_ns = 0
        # the last 0.9 s of angles (and the delay), and never fewer than MIN_RATE_POINTS
        self._history: deque[tuple[int, float]] = deque()
        self._hist_base = 0                                  # angle samples dropped from its front
        self._plan: _AnglePlan | None = None                 # a replay's run's slopes (plan)
        # pressure samples held (where all four pressures are known), in the order held, not
        # yet released; how many were ever held
        self._pending = HeldSamples()
        self.held_total = 0
        #: held pressure samples let go unjudged, the angle silent (:data:`MAX_HELD`)
        self.held_dropped = 0
        # per angle sample since the held samples were last judged (take), flat: what it saw
        # (instants.CALL_FIELDS) and the ship's speed and oil temperature then; the angle
        # samples themselves from global index _angles_first on
        self._calls: list[int] = []
        self._call_env: list[float] = []
        self._take_state = np.zeros(6, np.int64)
        self._take_given = np.zeros(6)
        self._angles_t: list[int] = []
        self._angles_a: list[float] = []
        self._angles_first = 0
        # steady motion counted [ns] (brackets of angle samples judged steady once each)
        self._motion_ns = 0
        self._counted_ns: int | None = None

    @property
    def motion_ns(self) -> int:
        """Steady rudder motion counted so far [ns] (what is held judged first)."""
        self.take()
        return self._motion_ns

    @property
    def history(self) -> list[tuple[int, float]]:
        """The angle samples the next rates and judgements reach back to: (t [ns], angle [rad])."""
        return list(self._history)

    @property
    def held(self) -> int:
        """Pressure samples held, not yet judged."""
        return len(self._pending)

    @property
    def log_kept(self) -> tuple[int, int]:
        """(angle samples logged since the held samples were last judged, angle samples kept)."""
        return len(self._calls) // len(CALL_FIELDS), len(self._angles_t)

    # --- pressure samples ----------------------------------------------------------------
    def hold(self, t_ns: int, pressures: list[float]) -> None:
        """One pressure sample's four pressures [Pa] (all known) held at ``t_ns``."""
        self._pending.add_one(t_ns, pressures)
        self.held_total += 1
        if len(self._pending) > MAX_HELD:
            self._bound_held()

    def hold_many(self, times: NDArray[np.int64], pressures: NDArray[np.float64]) -> None:
        """:meth:`hold` of samples at ``times`` (n,) [ns] with ``pressures`` (n, 4) [Pa], in order."""
        if times.shape[0]:
            self._pending.add(times, pressures)
            self.held_total += times.shape[0]
            if len(self._pending) > MAX_HELD:
                self._bound_held()

    # --- angle samples -------------------------------------------------------------------
    def plan(self, times: list[int] | None, values: list[float] | None = None) -> None:
        """A replay's run of angle samples [ns, rad] about to be fed in this order: the rate
        each will need worked out at once by the same kernel, when the history and the run are
        in time order. Each is used only where the window :meth:`angle` takes is the one
        worked out (else it is worked out then). None: forget the plan (the run's end)."""
        self._plan = None
        if not times or values is None:
            return
        t = np.fromiter(chain((p[0] for p in self._history), times), np.int64, len(self._history) + len(times))
        if np.any(np.diff(t) < 0):
            return
        a = np.fromiter(chain((p[1] for p in self._history), values), float, t.shape[0])
        n = t.shape[0]
        lo = rate_window_starts(t)
        status = np.empty(n, np.int8)
        out = np.empty(n)
        window_slopes(t, a, lo, np.arange(1, n + 1), status, out)
        span = t - t[lo]
        base = self._hist_base
        delay = self.delay_ns
        # the history's front after each sample (angle's rule): the first within the time it
        # reaches back, but never fewer than MIN_RATE_POINTS samples, and never back again
        reach = np.searchsorted(t, t - (3 * self.half_ns + delay), 'left')
        front = base + np.maximum(np.minimum(reach, np.arange(n) + 1 - MIN_RATE_POINTS), 0)
        lo += base
        unplanned = np.concatenate([[0], np.cumsum((status == SPECIAL) | (lo < front))])
        self._plan = _AnglePlan(base, n, t.tolist(), lo.tolist(), span.tolist(), status.tolist(), out.tolist(), delay,
                                front.tolist(), unplanned.tolist())

    def angle(self, t_ns: int, alpha: float, speed: float, oil: float) -> float:
        """One angle sample [ns, rad], the ship's speed [m/s] and oil temperature [K] standing
        then (NaN: not known); returns the rate after it [rad/s]."""
        hist = self._history
        hist.append((t_ns, alpha))
        delay = self.delay_ns
        while len(hist) > MIN_RATE_POINTS and hist[0][0] < t_ns - 3 * self.half_ns - delay:
            hist.popleft()
            self._hist_base += 1
        plan, slope, known, span = self._plan, None, False, 0
        if plan is not None:
            k = self._hist_base + len(hist) - 1 - plan.base
            if 0 <= k < plan.n and plan.t[k] == t_ns:
                if plan.rate_lo[k] >= self._hist_base and plan.status[k] != SPECIAL:
                    known, slope, span = True, (plan.slope[k] if plan.status[k] == SLOPE else None), plan.span[k]
            else:
                self._plan = None      # not the samples planned: work each out
        if not known:
            times = [p[0] for p in hist]
            lo = rate_window_start(times, t_ns)
            slope = self.rate_of([hist[i] for i in range(lo, len(hist))])
            span = t_ns - times[lo]
        self.rate_span_ns = None if slope is None else span
        if slope is not None:
            self.rate = slope
        # what this sample releases of the held pressure samples, judged later (take)
        self._angles_t.append(t_ns)
        self._angles_a.append(alpha)
        self._log_angles([t_ns], delay, [self._hist_base], [self._hist_base + len(hist) - 1], [self.held_total])
        self._call_env += (speed, oil)
        if len(self._calls) >= len(CALL_FIELDS) * CALLS_KEPT:
            self.take()
        return self.rate

    def _log_angles(self, t_ns: list[int], delay: int, first: list[int], last: list[int], held: list[int]) -> None:
        """What angle samples at ``t_ns`` saw, into the log judged later (instants.CALL_FIELDS),
        one row each: the time up to which it releases held samples, the delay then [ns], the
        global indices of its history's first and last angle, the pressure samples held so far."""
        cut = self.half_ns + delay
        self._calls += chain.from_iterable(zip([t - cut for t in t_ns], [delay] * len(t_ns), first, last, held))

    def take_span(self, angle_t: list[int], angle_a: list[float], held: list[int], env: list[float],
                  hold_t: NDArray[np.int64], hold_p: NDArray[np.float64]
                  ) -> tuple[list[float], list[int | None]] | None:
        """:meth:`angle` of a replay's span of angle samples at once, where :meth:`plan`
        planned their rates: the times (m,) [ns] and angles (m,) [rad], with what each one logs
        beside it: how many of the pressure samples ``hold_t`` (k,) [ns], ``hold_p`` (k, 4) [Pa]
        (those :meth:`hold` takes before the last angle sample, held here first) came before it
        (``held`` (m,)), and the ship's speed and oil temperature then (``env``, flat (2 m,)).
        The same state as taking them one by one with the pressure samples between them.
        Returns the rate [rad/s] after each angle sample and the span of its window [ns] (None
        where that sample gave no rate: :attr:`rate_span_ns`), or None, having changed nothing,
        where the plan does not give them or the held samples would pass :data:`MAX_HELD` (then
        take them one by one)."""
        m = len(angle_t)
        plan = self._plan
        if plan is None or plan.delay != self.delay_ns or len(self._pending) + hold_t.shape[0] > MAX_HELD:
            return None
        k0 = self._hist_base + len(self._history) - plan.base    # the first one's place in the plan
        k1 = k0 + m
        if k0 < 0 or k1 > plan.n or plan.unplanned[k1] != plan.unplanned[k0] or plan.t[k0:k1] != angle_t \
                or plan.front[k0] < self._hist_base:
            return None
        total = self.held_total
        self.hold_many(hold_t, hold_p)
        rates: list[float] = []
        spans: list[int | None] = []
        rate = self.rate
        for status, value, span in zip(plan.status[k0:k1], plan.slope[k0:k1], plan.span[k0:k1]):
            if status == SLOPE:
                rate = value
            rates.append(rate)
            spans.append(span if status == SLOPE else None)
        front = plan.front[k0:k1]
        hist = self._history
        hist.extend(zip(angle_t, angle_a))
        for _ in range(front[-1] - self._hist_base):
            hist.popleft()
        self._hist_base = front[-1]
        self._angles_t += angle_t
        self._angles_a += angle_a
        delay = self.delay_ns
        first = plan.base + k0
        self._log_angles(angle_t, delay, front, list(range(first, first + m)), [total + h for h in held])
        self._call_env += env
        if len(self._calls) >= len(CALL_FIELDS) * CALLS_KEPT:
            self.take()
        self.rate = rates[-1]
        self.rate_span_ns = spans[-1]
        return rates, spans

    def _bound_held(self) -> None:
        """At most :data:`MAX_HELD` held samples waiting: those released judged first, then
        the oldest of the rest let go."""
        self.take()
        extra = len(self._pending) - MAX_HELD
        if extra <= 0:
            return
        self._pending.release(extra)
        self.held_dropped += extra

    def take(self) -> None:
        """The held pressure samples the angle samples since the last call released, judged
        as each of those angle samples saw them (:func:`~steer_monitor.monitor.instants.take_instants`):
        motion is judged once per pair of angle samples that brackets a held sample (with the
        model's delay: the angle that much later), the angle interpolated to its time (near
        midships the torque curve is steep: an angle 0.1 s old is worth several bar); the
        instants of steady motion to the sink (the residual and the rams' share). Each steady
        bracket counts its time of motion once (:attr:`motion_ns`)."""
        calls = self._calls
        if not calls:
            return
        first = self._angles_first
        pend_t, pend_p = self._pending.view()
        if pend_t.shape[0]:
            angle_t = np.array(self._angles_t, np.int64)
            angle_a = np.array(self._angles_a, float)
            log = np.array(calls, np.int64).reshape(-1, len(CALL_FIELDS))
            env = np.array(self._call_env, float).reshape(-1, 2)
            state, given = self._take_state, self._take_given
            state[:] = (0, 0, self._counted_ns or 0, self._counted_ns is not None, 0, -1)
            given[:2] = -1.0
            out = np.empty((pend_t.shape[0], len(OUT_FIELDS)))
            n = 0
            while True:
                n = take_instants(pend_t, pend_p, self.held_total - pend_t.shape[0], log, env, angle_t, angle_a,
                                  first, self.half_ns, MOVING_RATE, self.motion_step_ns, self.ram_area, state, given,
                                  out, n)
                if state[5] < 0:
                    break
                # a window holding a non-finite angle: its slopes summed by math.fsum (see rate_of)
                k, i = int(state[0]), int(state[5])
                lo, hi = int(log[k, 2]) - first, int(log[k, 3]) - first + 1
                points = list(zip(self._angles_t[lo:hi], self._angles_a[lo:hi]))
                times, t_i = self._angles_t[lo:hi], self._angles_t[i]
                s1 = self.rate_of(points[bisect.bisect_left(times, t_i - self.half_ns):i - lo + 1])
                s2 = self.rate_of(points[i - lo:bisect.bisect_right(times, t_i + self.half_ns)])
                given[:] = (k, i, s1 is not None, math.nan if s1 is None else s1, s2 is not None,
                            math.nan if s2 is None else s2)
            self._pending.release(int(state[1]))
            self._motion_ns += int(state[4])
            self._counted_ns = int(state[2]) if state[3] else None
            if n:
                self._sink(out[:n, :_N_INSTANT], pend_t[out[:n, _HELD].astype(np.int64)], out[:n, 3:5],
                           out[:n, 7:11])
        calls.clear()
        self._call_env.clear()
        drop = self._hist_base - first          # the angles no history reaches back to any more
        del self._angles_t[:drop]
        del self._angles_a[:drop]
        self._angles_first = self._hist_base

    @staticmethod
    def rate_of(points: list[tuple[int, float]] | deque[tuple[int, float]]) -> float | None:
        """Least-squares slope [per s] of (t [ns], value) points, from centred moments, by the
        compiled kernel (:mod:`~steer_monitor.monitor.slopes`): every sum correctly rounded
        (``math.fsum``'s algorithm) and the squares products, so the rate is the same to the
        bit on any Python and C library (the built-in ``sum`` is compensated from Python 3.12
        on, plain before; ``x ** 2`` calls the C library's pow): a replay ashore writes what the
        node on a vessel published. Points holding a non-finite value are summed by
        ``math.fsum`` itself (its special values and errors)."""
        if len(points) < 3:
            return None
        status, value = slope([t for t, _ in points], [a for _, a in points])
        if status == SLOPE:
            return value
        if status == NONE:
            return None
        return SteadyMotion._rate_of_fsum(points)

    @staticmethod
    def _rate_of_fsum(points: list[tuple[int, float]] | deque[tuple[int, float]]) -> float | None:
        """:meth:`rate_of` summed by ``math.fsum`` (points holding a non-finite value)."""
        n = len(points)
        t0 = points[0][0]
        ts = [(t - t0) / 1e9 for t, _ in points]
        mean_t = math.fsum(ts) / n
        mean_a = math.fsum(a for _, a in points) / n
        dt = [t - mean_t for t in ts]
        sxx = math.fsum(d * d for d in dt)
        if sxx <= 0:
            return None
        return math.fsum(d * (a - mean_a) for d, (_, a) in zip(dt, points)) / sxx
