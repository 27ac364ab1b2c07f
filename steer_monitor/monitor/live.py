"""The live monitor: what the node knows at each moment, updated sample by sample. Pure.

Per sample it keeps the latest value and arrival times of every input, and on each rudder or
pressure sample it evaluates:

* the rudder rate: least-squares slope of the angle over the last 0.5 s;
* the load sharing from the *measured* pressures: the axial ram force
  Fa = A_r |p_stbd - p_port| (mean of the two rams), the tiller torque it implies,
  M = Fa n H / cos^2(alpha), and the scalar load-sharing solver with the current clearances.
  While the rudder moves Fa includes friction (the estimator of the clearances separates it);
* the residual of the model in use (docs/physics.md, docs/estimation.md): the declared model with the
  configured torque and friction until an analysis gives its clearances with the torque,
  friction and effects fitted with them (:meth:`LiveMonitor.set_finding`; then the last
  minute of motion is judged again under that model):
  A_r (p_stbd - p_port) against sign(alpha) Fa_model + sign(dalpha/dt) F_fr + the effects'
  terms (a delay reads the angle later), only where the rudder moves steadily (at rest the
  pressure only bounds friction). Each pressure sample is held 0.3 s (and the delay) and
  counted only when the angle's slope on both sides of it is above the motion threshold with
  the same sign, so starts and stops do not pollute it; the time of those steady stretches
  is counted (:attr:`LiveMonitor.motion_s`: what the node's analyses are scheduled on);
* the steering performance: hard-over time from leaving 35 deg to reaching 30 deg the other
  side, and the response to order steps (direction, delay, settled accuracy);
* how the two rams share the driving force: the instants of steady motion go to the one rams
  check (:class:`~steer_monitor.estimate.ramscheck.RamsCheck`, windows of half a minute of steady
  motion judged as ``analyze`` judges a log's, from the pressures alone: whatever model is
  in use).

Times are integer ns; values SI.

Why one module of some 1,000 lines: :class:`LiveMonitor` is updated sample by sample (the node)
and run by run (replay's pipeline, :mod:`~steer_monitor.monitor.runfeed`), and both paths read
and write the same state at every sample: the inputs' last values and arrival times, the
rudder's history and rate, the held pressure samples, the ring of the last minute's instants
and residuals and the hard-over and order-response tracking. Its compiled kernels live apart
(:mod:`~steer_monitor.monitor.instants`, :mod:`~steer_monitor.monitor.slopes`); splitting the
state into parts with interfaces of their own goes with one live path (the node feeding runs,
as replay does), so that each part has one caller.
"""

from __future__ import annotations

import bisect
import math
from collections import deque
from dataclasses import dataclass, field, replace
from itertools import chain
from typing import Any

import numpy as np
from numpy.typing import NDArray

from steer_monitor.estimate.effects import Effect, live_term
from steer_monitor.estimate.finding import Finding
from steer_monitor.estimate.ramscheck import RamsCheck
from steer_monitor.model.friction import FrictionParams, friction_force
from steer_monitor.model.gear import Gaps, GearParams
from steer_monitor.model.hardover import HARD_OVER_FROM_DEG, HARD_OVER_TO_DEG
from steer_monitor.model.inputs import INPUTS, Sample
from steer_monitor.model.loadshare import ShareScalar, declared_residuals, load_sharing_scalar
from steer_monitor.model.torque import TorqueTable
from steer_monitor.monitor.instants import CALL_FIELDS, OUT_FIELDS, take_instants
from steer_monitor.monitor.slopes import (
    MAX_PARTIALS,
    NONE,
    SLOPE,
    SPECIAL,
    partials_total,
    push_counting_squares,
    slope,
    window_slopes,
)
from steer_monitor.utc import utc_json

__all__ = ['ARRIVALS_KEPT_NS', 'NO_RESPONSE_ERR', 'NO_RESPONSE_NS', 'RATE_WINDOW_NS', 'LiveMonitor', 'LiveState',
           'Response', 'states_at']

DEG = math.pi / 180.0
RATE_WINDOW_NS = 5_000_000_000      # the shortest window a rate is judged over
ARRIVALS_KEPT_NS = 30_000_000_000   # arrivals kept per input: five periods down to 0.17 Hz
SLOPE_WINDOW_NS = 500_000_000
HALF_WINDOW_NS = 300_000_000   # each side of a pressure sample, for the residual
MAX_DELAY_NS = 1_000_000_000   # the longest angle delay the model in use may read the angle later by
MOTION_STEP_NS = 250_000_000   # a steady bracket of angle samples counts at most this much motion
MOVING_RATE = 0.2 * DEG        # rad/s: below this the rudder is at rest
RESIDUAL_SAMPLES = 1200        # about a minute of motion at 20 Hz
#: an instant of steady motion's columns: angle [rad], ship speed [m/s] (NaN: not known),
#: direction +-1, the rams' forces [N], rate [rad/s], oil temperature [K]
_INSTANT = OUT_FIELDS[:7]
_HELD = OUT_FIELDS.index('held')     # out's column of the held sample's index
HARD_OVER_DEG = HARD_OVER_FROM_DEG   # "at 35 deg", allowing for sensor noise and the valve dead band
OTHER_SIDE_DEG = HARD_OVER_TO_DEG    # "at 30 deg" likewise: the valve stops within its dead band
ORDER_STEP = 1.0 * DEG
#: after an order step, how long the rudder may still move the old way: the rate read here
#: is a slope over SLOPE_WINDOW_NS, so a turn shows half a window late, and the pump's valve
#: takes a moment to reverse the flow (the simulated gear stops in one 10 ms step)
REVERSAL_NS = SLOPE_WINDOW_NS + 500_000_000
#: a rudder that has not moved this long after an order step, the order still this far from
#: it, did not respond (the simulated gear starts in 0.1 s, a real one within a second or two;
#: one pump or cold oil make it slower to move, not slower to start)
NO_RESPONSE_NS = 5_000_000_000
NO_RESPONSE_ERR = 1.0 * DEG
_PRESSURE_INDEX = {'pressure_r1_stbd': 0, 'pressure_r1_port': 1, 'pressure_r2_stbd': 2, 'pressure_r2_port': 3}


def _carried(alpha: Any, rate: Any, t_ns: Any, alpha_t_ns: Any) -> Any:
    """The angle [rad] read at ``alpha_t_ns`` carried to ``t_ns`` [ns] at ``rate`` [rad/s]:
    floats or arrays, the same operations in the same order."""
    return alpha + rate * (t_ns - alpha_t_ns) / 1e9


def _torque(gear: GearParams, cos_a: Any, p0: Any, p1: Any, p2: Any, p3: Any) -> Any:
    """The tiller torque [N m] the measured pressures [Pa] imply where cos(alpha) is ``cos_a``:
    Fa = A_r |p_stbd - p_port| (mean of the two rams), M = Fa n H / cos^2(alpha); floats or
    arrays, the same operations in the same order."""
    area = gear.ram_area
    fa = 0.5 * (abs(area * (p0 - p1)) + abs(area * (p2 - p3)))
    return fa * gear.rams * gear.stock_to_ram / (cos_a * cos_a)


def states_at(gear: GearParams, t_ns: NDArray[np.int64], alpha: NDArray[np.float64], alpha_t_ns: NDArray[np.int64],
              rate: NDArray[np.float64], p: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The live model's numbers of states (n,) at ``t_ns`` from the angle ``alpha`` [rad] read
    at ``alpha_t_ns``, the rate [rad/s] and the four pressures ``p`` (n, 4) [Pa] standing then:
    (the angle carried to ``t_ns`` at the rate, the measured torque [N m]). Element by element,
    by the formulas :meth:`LiveMonitor.state_at` applies to one state (the cosine by
    ``math.cos``): the same numbers to the bit."""
    a = np.where(t_ns > alpha_t_ns, _carried(alpha, rate, t_ns, alpha_t_ns), alpha)
    cos_a = np.fromiter(map(math.cos, a.tolist()), float, a.shape[0])
    return a, _torque(gear, cos_a, p[:, 0], p[:, 1], p[:, 2], p[:, 3])


@dataclass
class Response:
    """Order-to-response of the last order step: direction right, delay [s], settled error
    [rad]; ``stalled_s`` [s] and ``stalled_at`` [rad]: how long the rudder has stood since the
    step while the order was more than ``NO_RESPONSE_ERR`` away, and where (None while it has
    not stood ``NO_RESPONSE_NS``, and again once it moves)."""

    order: float
    t_step_ns: int
    direction_ok: bool | None = None
    delay_s: float | None = None
    accuracy: float | None = None
    stalled_s: float | None = None
    stalled_at: float | None = None


@dataclass(frozen=True)
class LiveState:
    """One evaluation of the live model (SI). ``share`` is None until angle and all four
    pressures have been seen, or (``torque_measured`` set) when it was left to the caller
    (:meth:`LiveMonitor.slot_state`)."""

    t_ns: int
    alpha: float
    rate: float
    moving: bool
    torque_measured: float | None
    share: ShareScalar | None
    gaps: Gaps


@dataclass
class _Signal:
    """An input's newest sample and its arrival times: those of the last
    :data:`ARRIVALS_KEPT_NS` kept, in the order they came (``times`` from ``start`` on; the
    list is cut down as it grows, so dropping the oldest costs no per-sample work)."""

    last_t_ns: int | None = None
    last_value: float = math.nan
    times: list[int] = field(default_factory=list)
    start: int = 0
    ordered: bool = True        # arrivals in time order (a clock step back can break it)

    @property
    def arrivals(self) -> list[int]:
        """The arrival times kept [ns], as they came (a copy)."""
        return self.times[self.start:]

    def kept(self) -> int:
        """How many arrival times are kept."""
        return len(self.times) - self.start

    def arrive(self, t_ns: int) -> None:
        """One arrival at ``t_ns``: kept, those older than :data:`ARRIVALS_KEPT_NS` dropped."""
        times = self.times
        if len(times) > self.start and t_ns < times[-1]:
            self.ordered = False
        times.append(t_ns)
        self._drop(t_ns - ARRIVALS_KEPT_NS)

    def arrive_many(self, t_ns: list[int]) -> None:
        """Arrivals in time order, none before the last kept, :meth:`arrive` of each at once."""
        self.times += t_ns
        self._drop(t_ns[-1] - ARRIVALS_KEPT_NS)

    def silent_for(self, now_ns: int) -> float | None:
        """Seconds since the input was last heard at ``now_ns`` (None: never)."""
        t = self.last_t_ns
        return None if t is None else (now_ns - t) / 1e9

    def rate_hz(self, now_ns: int, window_ns: int) -> float:
        """:meth:`LiveMonitor.rate_hz` of this input (``window_ns`` at most the time kept)."""
        if self.ordered:
            times = self.times
            i = bisect.bisect_left(times, now_ns - window_ns, self.start)
            n = len(times) - i
            first, last = (times[i], times[-1]) if n else (0, 0)
        else:
            recent = [t for t in self.arrivals if t >= now_ns - window_ns]
            n, first, last = len(recent), recent[0] if recent else 0, recent[-1] if recent else 0
        if n < 2 or last == first:
            return 0.0
        return (n - 1) / ((last - first) / 1e9)

    def _drop(self, cut: int) -> None:
        """The oldest dropped while the first kept is before ``cut`` [ns]."""
        times, i = self.times, self.start
        if self.ordered:
            i = bisect.bisect_left(times, cut, i)
        else:
            n = len(times)
            while i < n and times[i] < cut:
                i += 1
        if i > 1024 and 2 * i > len(times):
            del times[:i]
            i = 0
        self.start = i


class _Ring:
    """The last ``cap`` rows of a stream of rows of ``width`` floats, in one numpy array
    written in place (numpy reads it as it is, where a deque of tuples took 0.4 ms a second
    to convert): the next row at ``next``, ``kept`` rows held. Rows pushed together lie
    where pushing them one by one would put them."""

    def __init__(self, cap: int, width: int) -> None:
        self.data = np.zeros((cap, width))
        self.next = 0
        self.kept = 0

    def push(self, block: NDArray[np.float64]) -> None:
        """Rows (n, width) after those held."""
        cap, total = self.data.shape[0], block.shape[0]
        block = block[-cap:]
        k = block.shape[0]
        start = (self.next + total - k) % cap
        head = min(k, cap - start)
        self.data[start:start + head] = block[:head]
        self.data[:k - head] = block[head:]
        self.next = (start + k) % cap
        self.kept = min(self.kept + total, cap)

    def clear(self) -> None:
        self.next = self.kept = 0

    def rows(self) -> NDArray[np.float64]:
        """The rows held (kept, width), in the order they lie (a view)."""
        return self.data[:self.kept]

    def ordered(self) -> NDArray[np.float64]:
        """The rows held (kept, width), oldest first (a copy)."""
        return self.data[(np.arange(self.kept) + (self.next - self.kept)) % self.data.shape[0]]


class _Held:
    """Pressure samples held for the residual and not yet released, in the order held: their
    times (n,) [ns] and four pressures (n, 4) [Pa] in one buffer (released from the front, the
    rest moved down when the buffer is full, the buffer grown when that is not room enough),
    those held one by one kept in lists until read."""

    def __init__(self) -> None:
        self.t = np.zeros(1024, np.int64)
        self.p = np.zeros((1024, 4))
        self.lo = self.hi = 0
        self._one_t: list[int] = []
        self._one_p: list[float] = []

    def __len__(self) -> int:
        return self.hi - self.lo + len(self._one_t)

    def add_one(self, t_ns: int, pressures: list[float]) -> None:
        """One sample held (four pressures [Pa])."""
        self._one_t.append(t_ns)
        self._one_p.extend(pressures)

    def add(self, times: NDArray[np.int64], pressures: NDArray[np.float64]) -> None:
        """Samples held after those held so far (times (n,), pressures (n, 4))."""
        self._loose()
        n = times.shape[0]
        if self.hi + n > self.t.shape[0]:
            live = self.hi - self.lo
            cap = self.t.shape[0]
            if live + n > cap:
                cap = max(2 * cap, live + n)
                t, p = np.zeros(cap, np.int64), np.zeros((cap, 4))
            else:
                t, p = self.t, self.p
            t[:live] = self.t[self.lo:self.hi]
            p[:live] = self.p[self.lo:self.hi]
            self.t, self.p, self.lo, self.hi = t, p, 0, live
        self.t[self.hi:self.hi + n] = times
        self.p[self.hi:self.hi + n] = pressures
        self.hi += n

    def _loose(self) -> None:
        if self._one_t:
            t, p = np.array(self._one_t, np.int64), np.array(self._one_p, float).reshape(-1, 4)
            self._one_t.clear()
            self._one_p.clear()
            self.add(t, p)

    def view(self) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
        """The samples held (times (n,), pressures (n, 4)), views valid until the next change."""
        self._loose()
        return self.t[self.lo:self.hi], self.p[self.lo:self.hi]

    def release(self, k: int) -> None:
        """The oldest ``k`` samples let go."""
        self._loose()
        self.lo += k
        if self.lo >= self.hi:
            self.lo = self.hi = 0


@dataclass(frozen=True)
class _AnglePlan:
    """The rates of a run of angle samples (:meth:`LiveMonitor.plan_angles`): ``n`` samples
    from global index ``base`` (counted from the monitor's first angle sample), their times,
    the first global index of each one's rate window, and its status and slope; for a span of
    them taken at once (:meth:`LiveMonitor.take_rudder`), with the model's angle delay
    ``delay`` [ns] then: the history's front after each, and counts before each (n + 1,) of
    those whose rate the plan does not give (a non-finite angle in the window, or a window
    reaching past the front) and of those the hard-over tracker must see (past the smaller of
    its angles)."""

    base: int
    n: int
    t: list[int]
    rate_lo: list[int]
    status: list[int]
    slope: list[float]
    delay: int
    front: list[int]
    unplanned: list[int]
    past: list[int]


#: pressure samples held and not yet released at most (51 s of them at 80 a second): with the
#: rudder angle's input dead and the pressures still coming, the oldest are let go unjudged
#: (counted in ``LiveMonitor.held_dropped``), so the node's memory stays bounded; with the
#: angle live they are released within a second or two of being held and never reach it
MAX_HELD = 4096

#: angle samples whose release of held pressure samples is judged later at most
#: (:meth:`LiveMonitor._take_instants`): whatever reads the residual, the rams' share or the
#: motion judges them first; this bounds the log between reads
CALLS_KEPT = 1024


class LiveMonitor:
    """Sample-by-sample state of the gear. Not thread-safe: feed it from one thread."""

    def __init__(self, gear: GearParams, gaps: Gaps, gaps_source: str = 'configured',
                 priors: FrictionParams | None = None, *, defer_share: bool = False,
                 ram_share_warn: float = 0.15) -> None:
        self.gear = gear
        #: :meth:`slot_state` leaves the load sharing to its caller (see there)
        self.defer_share = defer_share
        self.gaps = gaps
        self.gaps_source = gaps_source
        self.gaps_interval: dict[str, tuple[float, float | None]] | None = None
        self.estimate_info: dict[str, str] = {}   # what the estimator adds to the diagnostics
        self.priors = priors or FrictionParams()
        #: the tiller torque fitted with the clearances in use (None: the configured curve)
        self.torque: TorqueTable | None = None
        self.signals: dict[str, _Signal] = {name: _Signal() for name in INPUTS}
        self._model_signals = tuple(self.signals[n] for n in ('rudder_angle', *_PRESSURE_INDEX))
        self._history: deque[tuple[int, float]] = deque()   # the last 0.9 s of angles
        self._hist_base = 0                                  # angle samples dropped from its front
        self._plan: _AnglePlan | None = None                 # a replay run's slopes (plan_angles)
        # pressure samples held for the residual (where all four pressures are known), in the
        # order held, not yet released (_Held); how many were ever held
        self._pending = _Held()
        self._held_total = 0
        #: held pressure samples let go unjudged, the angle silent (:data:`MAX_HELD`)
        self.held_dropped = 0
        # per angle sample since the held samples were last judged (:meth:`_take_instants`),
        # flat: what it saw (instants.CALL_FIELDS) and the ship's speed and oil temperature
        # then; the angle samples themselves from global index _angles_first on
        self._calls: list[int] = []
        self._call_env: list[float] = []
        self._take_state = np.zeros(6, np.int64)
        self._take_given = np.zeros(6)
        self._angles_t: list[int] = []
        self._angles_a: list[float] = []
        self._angles_first = 0
        self._speed, self._oil = self.signals['ship_speed'], self.signals['oil_temperature']
        self._pressures = [math.nan] * 4
        self._dirty = False
        self._state: LiveState | None = None
        self.rate = 0.0
        # the last minute of steady motion since the clearances' source last changed, per
        # instant (alpha [rad], speed [m/s] or None, direction +-1, ram forces [N], rate
        # [rad/s], oil temperature [K]), and its residual pair [bar] under the model in use
        # (None: not judged); a new estimate recomputes them all, so the residual judges the
        # model now in use, never a mix of models replaced since (an early fit used for
        # seconds left 17 bar in the window)
        # (speed NaN where not known: _INSTANT's columns)
        self._motion = _Ring(RESIDUAL_SAMPLES // 2, len(_INSTANT))
        # the residual pairs of the instants of _motion, a ring of its length: the pair [bar] and
        # whether the instant was judged (1/0) (the minute's RMS is a correctly rounded sum, the
        # same whatever the rows' order)
        self._resid = _Ring(RESIDUAL_SAMPLES // 2, 3)
        self._resid_summary: tuple[int, int, float | None] | None = None   # of _resid, until it changes
        # the exact sum of the squares of _resid's judged pairs, kept as rows come and go
        # (:meth:`_keep_residuals`): its exact partials, their count, the judged values and
        # those whose square is not finite (then the sum is worked out from the rows)
        self._sq = np.zeros(MAX_PARTIALS)
        self._sq_k = 0
        self._sq_values = 0
        self._sq_bad = 0
        # instants of _motion not judged yet: judged together when the residuals are read
        # (:meth:`_summary`, the diagnostics once a second), as one vectorized solve
        self._unjudged = _Ring(RESIDUAL_SAMPLES // 2, len(_INSTANT))
        #: the rams check, fed the same instants whatever the model in use (the rams' share
        #: does not depend on it), the four pressures kept for its last window; ``ram_share_warn``
        #: its band (``diagnostics.ram_share_warn_pct`` as a fraction)
        self.rams = RamsCheck(ram_share_warn, gear.ram_area)
        #: the analysis the model in use comes from (None: the configured model); its effects
        #: and their coefficients, and how much later it reads the angle [ns]
        self.finding: Finding | None = None
        #: per clearance ('2z', 'zgb'), the last estimate that assessed it: (value, lo, hi [m],
        #: the data's time [ns]); kept by the analyses' state across restarts
        self.last_assessed: dict[str, tuple[float, float, float, int]] = {}
        self._effects: tuple[Effect, ...] = ()
        self._terms: dict[str, float] = {}
        self._shape: FrictionParams | None = None
        self._delay_ns = 0
        # steady motion counted [ns] (brackets of angle samples judged steady once each)
        self._motion_ns = 0
        self._counted_ns: int | None = None
        self._hard_over: tuple[float, int] | None = None  # (side, time last at hard over)
        self.hard_over_s: float | None = None
        self.response: Response | None = None
        self._last_order: float | None = None

    # --- clearances ----------------------------------------------------------------------
    def set_gaps(self, gaps: Gaps, source: str,
                 interval: dict[str, tuple[float, float | None]] | None = None,
                 friction: FrictionParams | None = None, torque: TorqueTable | None = None) -> None:
        """Use new clearance values (e.g. from the estimator) and say where they come from;
        with ``friction`` and ``torque``, the friction and tiller torque estimated together with
        them (the model's residual needs all three from the same fit: the fit's friction beside
        the configured torque is not the fit; torque and friction trade off on a few
        manoeuvres, and such a mix put the residual of a clean gear at 3-10 bar)."""
        self._take_instants()
        if source != self.gaps_source:
            self._motion.clear()    # motion judged under other clearances says nothing of these
        self.gaps, self.gaps_source, self.gaps_interval = gaps, source, interval
        if friction is not None:
            self.priors = friction
        self.torque = torque
        self._clear_residuals()
        self._keep_residuals(self._motion.ordered())
        self._unjudged.clear()
        self._resid_summary = None

    def set_finding(self, finding: Finding) -> None:
        """Use an analysis's answer as the model in use: its clearances with their intervals,
        the torque and friction fitted with them, its effects (their terms in the residual; a
        delay reads the angle later) and what the diagnostics add (K_gl max, the verdict).
        A delay beyond :data:`MAX_DELAY_NS` is read as that."""
        self._take_instants()
        self._effects = tuple(e for e in finding.model if e.name != 'angle_delay')
        self._terms = dict(finding.terms)
        temp = next((e for e in finding.model if e.name == 'temp_friction'), None)
        self._shape = FrictionParams(*temp.shape) if temp is not None and temp.shape is not None else None
        self._delay_ns = min(int(round(finding.terms.get('tau_s', 0.0) * 1e9)), MAX_DELAY_NS)
        self.finding = finding
        interval = {'2z': (finding.two_z.lo, finding.two_z.hi), 'zgb': (finding.z_gb.lo, finding.z_gb.hi)}
        self.set_gaps(Gaps(finding.two_z.value, finding.z_gb.value), 'estimated', interval,   # type: ignore[arg-type]
                      FrictionParams(*finding.friction), finding.torque_table(self.gear))
        k = finding.k_gl_max
        self.estimate_info = {'k_gl_max_estimated': f'{k.value:.3f}',
                              'k_gl_max_lo': 'n/a' if k.lo is None else f'{k.lo:.3f}',
                              'k_gl_max_hi': 'n/a' if k.hi is None else f'{k.hi:.3f}',
                              'estimate_rows': str(int(finding.rows)),
                              'estimate_motion_s': f'{finding.motion_s:.0f}',
                              'estimate_kind': finding.kind,
                              'estimate_data_until_utc': utc_json(finding.t_ns)}

    @property
    def motion_ns(self) -> int:
        """Steady rudder motion counted since this monitor started [ns]."""
        self._take_instants()
        return self._motion_ns

    @property
    def motion_s(self) -> float:
        """Seconds of steady rudder motion counted since this monitor started."""
        return self.motion_ns / 1e9

    def _keep_residuals(self, instants: NDArray[np.float64]) -> None:
        """The residual pairs of the next instants (n, len(_INSTANT)) into the ring."""
        self._push_residuals(self._residual_rows(instants))

    def _push_residuals(self, rows: NDArray[np.float64]) -> None:
        """Rows (n, 3) of residual pairs [bar] and whether judged (1/0) into the ring, the
        kept sum of squares following the rows it takes and lets go (one compiled pass:
        :func:`~steer_monitor.monitor.slopes.push_counting_squares`)."""
        ring = self._resid
        ring.next, ring.kept, self._sq_k, values, bad = push_counting_squares(
            ring.data, ring.next, ring.kept, np.ascontiguousarray(rows, float), self._sq, self._sq_k)
        self._sq_values += values
        self._sq_bad += bad

    def _clear_residuals(self) -> None:
        """The ring of residual pairs emptied, and its sum of squares."""
        self._resid.clear()
        self._sq_k = self._sq_values = self._sq_bad = 0

    def _summary(self) -> tuple[int, int, float | None]:
        """(residuals, instants not judged, RMS [bar]) of the kept minute, worked out once
        per change of it (the diagnostics read them several times a second, and at rest the
        minute does not change for hours)."""
        self._take_instants()
        if self._resid_summary is None:
            if self._unjudged.kept:
                self._keep_residuals(self._unjudged.ordered())
                self._unjudged.clear()
            kept, size = self._resid.kept, self._sq_values
            rms = None
            if size:                  # correctly rounded, as math.fsum: see _slope
                total = partials_total(self._sq, self._sq_k) if not self._sq_bad else math.nan
                if not math.isfinite(total):       # a square or the sum not finite: as math.fsum says
                    rows = self._resid.rows()
                    total = math.fsum(r * r for r in rows[rows[:, 2] != 0.0, :2].ravel().tolist())
                rms = math.sqrt(total / size)
            self._resid_summary = (size, kept - size // 2, rms)
        return self._resid_summary

    @property
    def residuals(self) -> list[float]:
        """The model's pressure residuals [bar] over the last minute of steady motion, two per
        judged instant (one per ram), oldest first, under the model now in use."""
        self._summary()
        rows = self._resid.ordered()
        return rows[rows[:, 2] != 0.0, :2].ravel().tolist()

    @property
    def residuals_skipped(self) -> int:
        """Instants of that minute the model in use cannot judge: where it clamps the ram (or
        touches the beam) at a clearance the estimate bounds from below only, or beyond the
        angles its fitted torque was learned at."""
        return self._summary()[1]

    def _residual_pair(self, instant: tuple[float, float, float, float, float, float, float]
                       ) -> tuple[float, float] | None:
        """The residual [bar] of each ram at one instant of steady motion under the model in
        use: A_r (p_stbd - p_port) against sign(alpha) Fa + direction F_fr + the effects'
        terms; None where the model cannot judge it."""
        alpha, speed, direction, force_1, force_2, rate, oil = instant
        gear, gaps = self.gear, self.gaps
        torque = (self.torque or gear.torque).scalar(alpha, None if math.isnan(speed) else speed)
        if math.isnan(torque):           # beyond the angles the fitted torque was learned at
            return None
        m = load_sharing_scalar(gear, alpha, torque, gaps.two_z, gaps.z_gb)
        # a clearance the estimate bounds only from below: the data never saw the ram clamp (or
        # the beam touch), so where the live model puts one, its residual judges a guess
        iv = self.gaps_interval or {}
        if ('2z' in iv and iv['2z'][1] is None and m.lateral > m.f_theta) or \
                ('zgb' in iv and iv['zgb'][1] is None and m.lateral > m.f_z):
            return None
        f_fr = float(friction_force(self.priors, m.r_a, m.r_e, m.m_a, m.guide_force, gear.bushing_length))
        predicted = math.copysign(m.axial, alpha) + direction * f_fr
        area = gear.ram_area
        if not self._effects:
            return (force_1 - predicted) / area / 1e5, (force_2 - predicted) / area / 1e5
        shape = 0.0 if self._shape is None else float(friction_force(self._shape, m.r_a, m.r_e, m.m_a, m.guide_force,
                                                                     gear.bushing_length))
        cos_a = math.cos(alpha)
        v_ram = gear.stock_to_ram / (cos_a * cos_a) * abs(rate)
        out = []
        for ram, force in enumerate((force_1, force_2)):
            term = live_term(self._effects, self._terms, direction, v_ram, abs(force), oil, shape, ram)
            out.append((force - predicted - term) / area / 1e5)
        return out[0], out[1]

    def _residual_rows(self, instants: NDArray[np.float64]) -> NDArray[np.float64]:
        """:meth:`_residual_pair` of many instants at once (the minute a new estimate re-judges,
        up to 600 instants once a second of motion: one compiled pass of the declared model,
        :func:`~steer_monitor.model.loadshare.declared_residuals`, instead of one solve per
        instant; every instant is judged here, the minute after a new estimate and the
        instants taken since the residuals were last read): rows (n, 3) of the pair [bar]
        (NaN where not judged) and whether the instant was judged (1.0 / 0.0). Equal to the
        one-instant results to rounding (tested); with the effects of an analysis in use,
        instant by instant. Element by element, so an instant's numbers do not depend on the
        others judged with it."""
        n = instants.shape[0]
        if self._effects or not n:
            rows = np.full((n, 3), math.nan)
            rows[:, 2] = 0.0
            for i, x in enumerate(instants.tolist()):
                pair = self._residual_pair(x)
                if pair is not None:
                    rows[i] = (pair[0], pair[1], 1.0)
            return rows
        gear = self.gear
        torque = (self.torque or gear.torque).scalars(instants[:, 0], instants[:, 1])
        iv = self.gaps_interval or {}
        rows = declared_residuals(gear, instants[:, 0], torque, instants[:, 2], instants[:, 3:5], self.gaps,
                                  self.priors, open_2z='2z' in iv and iv['2z'][1] is None,
                                  open_zgb='zgb' in iv and iv['zgb'][1] is None)
        rows[:, :2] /= 1e5           # [Pa] to [bar], as _residual_pair divides
        return rows

    # --- input ---------------------------------------------------------------------------
    def update(self, sample: Sample) -> None:
        """Take one sample. The live model is evaluated on demand (:attr:`state`), for the
        newest sample; the residual and the performance trackers see every sample."""
        sig = self.signals[sample.signal]
        sig.last_t_ns, sig.last_value = sample.t_ns, sample.value
        sig.arrive(sample.t_ns)
        name = sample.signal
        if name == 'rudder_angle':
            self._on_angle(sample.t_ns, sample.value)
            self._dirty = True
        elif name == 'rudder_order':
            self._on_order(sample.t_ns, sample.value)
        elif name in _PRESSURE_INDEX:
            self._pressures[_PRESSURE_INDEX[name]] = sample.value
            p = self._pressures
            if not math.isnan(p[0] + p[1] + p[2] + p[3]):
                self._pending.add_one(sample.t_ns, p)
                self._held_total += 1
                if len(self._pending) > MAX_HELD:
                    self._bound_held()
            self._dirty = True

    def record(self, name: str, times: list[int], values: list[float], ordered: bool) -> None:
        """Samples of ``name`` [ns, SI] as :meth:`update` records them (last value, arrivals),
        and nothing else: for the inputs whose samples only that (ship speed, oil temperature)
        or whose other work the caller does at once (the pressures: :meth:`hold_pressures`).
        ``ordered``: the times are in order (else they are taken one by one, as update does)."""
        if not times:
            return
        sig = self.signals[name]
        if ordered and sig.ordered and (not sig.kept() or times[0] >= sig.times[-1]):
            sig.arrive_many(times)
        else:
            for t in times:
                sig.arrive(t)
        sig.last_t_ns, sig.last_value = times[-1], values[-1]

    def hold_pressures(self, times: NDArray[np.int64], pressures: NDArray[np.float64],
                       last: tuple[float, float, float, float] | None) -> None:
        """What :meth:`update` of pressure samples holds for the residual: the samples at
        ``times`` (n,) [ns] where all four pressures are known, in order, and the four after
        each (``pressures`` (n, 4)) [Pa]; ``last`` the four after the last of them (None:
        unchanged)."""
        if times.shape[0]:
            self._pending.add(times, pressures)
            self._held_total += times.shape[0]
            if len(self._pending) > MAX_HELD:
                self._bound_held()
        if last is not None:
            self._pressures = list(last)

    def mark_read(self, state: LiveState | None, changed: bool) -> None:
        """After samples taken without :meth:`update` (a replay's run): the state last read by
        :meth:`slot_state` (None: unchanged) and whether a rudder or pressure sample came since."""
        if state is not None:
            self._state = state
        self._dirty = changed

    @property
    def changed(self) -> bool:
        """A rudder or pressure sample came since :attr:`state` was last read."""
        return self._dirty

    @property
    def state(self) -> LiveState | None:
        """The live model at the newest sample (None until angle and all four pressures)."""
        st = self.slot_state()
        if st is not None and st.share is None and st.torque_measured is not None:
            st = self._state = LiveState(st.t_ns, st.alpha, st.rate, st.moving, st.torque_measured, self.share_of(st),
                                         st.gaps)
        return st

    def slot_state(self) -> LiveState | None:
        """:attr:`state`, but with :attr:`defer_share` its load sharing is left to the caller
        (``share`` None, ``torque_measured`` set): a replay solves the states of many slots
        at once (:func:`~steer_monitor.model.loadshare.load_sharing`, the same numbers
        as :meth:`share_of`, to the bit)."""
        if self._dirty:
            self._dirty = False
            a, p0, p1, p2, p3 = self._model_signals
            t = max(a.last_t_ns or 0, p0.last_t_ns or 0, p1.last_t_ns or 0, p2.last_t_ns or 0, p3.last_t_ns or 0)
            self._state = self._evaluate(t) or self._state
        return self._state

    def share_of(self, state: LiveState) -> ShareScalar:
        """The load sharing of a state from its angle, measured torque and clearances."""
        assert state.torque_measured is not None
        return load_sharing_scalar(self.gear, state.alpha, state.torque_measured, state.gaps.two_z, state.gaps.z_gb)

    def rate_hz(self, name: str, now_ns: int, window_ns: int = RATE_WINDOW_NS) -> float:
        """Arrival rate of an input (Hz) from the spacing of its arrivals in the last
        ``window_ns`` (at most :data:`ARRIVALS_KEPT_NS`), so it is right from the second
        sample on; silence is judged by :meth:`silent_for`. A slow input needs a window of
        several of its periods: with two periods in it, one late frame reads as rate 0."""
        if window_ns > ARRIVALS_KEPT_NS:
            msg = f'rate window {window_ns / 1e9:g} s is longer than the {ARRIVALS_KEPT_NS / 1e9:g} s of arrivals kept'
            raise ValueError(msg)
        return self.signals[name].rate_hz(now_ns, window_ns)

    def silent_for(self, name: str, now_ns: int) -> float | None:
        """Seconds since the input was last heard (None: never)."""
        return self.signals[name].silent_for(now_ns)

    # --- rudder --------------------------------------------------------------------------
    @staticmethod
    def _slope(points: list[tuple[int, float]] | deque[tuple[int, float]]) -> float | None:
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
        return LiveMonitor._slope_fsum(points)

    @staticmethod
    def _slope_fsum(points: list[tuple[int, float]] | deque[tuple[int, float]]) -> float | None:
        """:meth:`_slope` summed by ``math.fsum`` (points holding a non-finite value)."""
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

    def plan_angles(self, times: list[int] | None, values: list[float] | None = None) -> None:
        """A replay's run of angle samples [ns, rad] about to be fed in this order: the rate
        each will need worked out at once by the same kernel, when the history and the run are
        in time order. Each is used only where the window :meth:`update` takes is the one
        worked out (else it is worked out then). None: forget the plan (the run's end)."""
        self._plan = None
        if not times or values is None:
            return
        t = np.fromiter(chain((p[0] for p in self._history), times), np.int64, len(self._history) + len(times))
        if np.any(np.diff(t) < 0):
            return
        a = np.fromiter(chain((p[1] for p in self._history), values), float, t.shape[0])
        n = t.shape[0]
        lo = np.searchsorted(t, t - SLOPE_WINDOW_NS, 'left')
        status = np.empty(n, np.int8)
        out = np.empty(n)
        window_slopes(t, a, lo, np.arange(1, n + 1), status, out)
        base = self._hist_base
        lo += base
        delay = self._delay_ns
        front = base + np.searchsorted(t, t - (3 * HALF_WINDOW_NS + delay), 'left')
        unplanned = np.concatenate([[0], np.cumsum((status == SPECIAL) | (lo < front))])
        past = np.concatenate([[0], np.cumsum(np.abs(a / DEG) >= min(HARD_OVER_DEG, OTHER_SIDE_DEG))])
        self._plan = _AnglePlan(base, n, t.tolist(), lo.tolist(), status.tolist(), out.tolist(), delay, front.tolist(),
                                unplanned.tolist(), past.tolist())

    def _on_angle(self, t_ns: int, alpha: float) -> None:
        hist = self._history
        hist.append((t_ns, alpha))
        delay = self._delay_ns
        while hist and hist[0][0] < t_ns - 3 * HALF_WINDOW_NS - delay:
            hist.popleft()
            self._hist_base += 1
        plan, slope, known = self._plan, None, False
        if plan is not None:
            k = self._hist_base + len(hist) - 1 - plan.base
            if 0 <= k < plan.n and plan.t[k] == t_ns:
                if plan.rate_lo[k] >= self._hist_base and plan.status[k] != SPECIAL:
                    known, slope = True, (plan.slope[k] if plan.status[k] == SLOPE else None)
            else:
                self._plan = None      # not the samples planned: work each out
        if not known:
            slope = self._slope([p for p in hist if p[0] >= t_ns - SLOPE_WINDOW_NS])
        if slope is not None:
            self.rate = slope
        # what this sample releases of the held pressure samples, judged later (_take_instants)
        self._angles_t.append(t_ns)
        self._angles_a.append(alpha)
        self._log_angles([t_ns], delay, [self._hist_base], [self._hist_base + len(hist) - 1], [self._held_total])
        self._call_env += (self._speed.last_value, self._oil.last_value)
        if len(self._calls) >= len(CALL_FIELDS) * CALLS_KEPT:
            self._take_instants()
        self._track_hard_over(t_ns, alpha)
        self._track_response(t_ns, alpha)

    def _log_angles(self, t_ns: list[int], delay: int, first: list[int], last: list[int], held: list[int]) -> None:
        """What angle samples at ``t_ns`` saw, into the log judged later (instants.CALL_FIELDS),
        one row each: the time up to which it releases held samples, the delay then [ns], the
        global indices of its history's first and last angle, the pressure samples held so far."""
        cut = HALF_WINDOW_NS + delay
        self._calls += chain.from_iterable(zip([t - cut for t in t_ns], [delay] * len(t_ns), first, last, held))

    def take_rudder(self, kinds: list[bool], angle_t: list[int], angle_a: list[float], held: list[int],
                    env: list[float], hold_t: NDArray[np.int64], hold_p: NDArray[np.float64], order_t: list[int],
                    order_v: list[float], orders_in_order: bool) -> list[float] | None:
        """:meth:`update` of a replay's span of rudder samples at once, where :meth:`plan_angles`
        planned the angle samples' rates: ``kinds`` the span's rudder samples in order (True: an
        angle sample, False: an order sample); the angle samples' times (m,) [ns] and angles
        (m,) [rad], with what each one logs beside it: how many of the pressure samples
        ``hold_t`` (k,) [ns], ``hold_p`` (k, 4) [Pa] (those :meth:`update` holds before the last
        angle sample, held here first) came before it (``held`` (m,)), and the ship's speed and
        oil temperature then (``env``, flat (2 m,)); the order samples' times [ns] and orders
        [rad] (``orders_in_order``: their times in order). The same state as taking them one by
        one with the pressure samples between them (the held samples the angle samples release
        judged later, as there); returns the rate [rad/s] after each angle sample, or None,
        having changed nothing, where the plan does not give them or the held samples would
        pass :data:`MAX_HELD` (then take them one by one)."""
        m = len(angle_t)
        rates: list[float] = []
        if m:
            plan = self._plan
            if plan is None or plan.delay != self._delay_ns or len(self._pending) + hold_t.shape[0] > MAX_HELD:
                return None
            k0 = self._hist_base + len(self._history) - plan.base    # the first one's place in the plan
            k1 = k0 + m
            if k0 < 0 or k1 > plan.n or plan.unplanned[k1] != plan.unplanned[k0] or plan.t[k0:k1] != angle_t \
                    or plan.front[k0] < self._hist_base:
                return None
            total = self._held_total
            self.hold_pressures(hold_t, hold_p, None)
            rate = self.rate
            for status, value in zip(plan.status[k0:k1], plan.slope[k0:k1]):
                if status == SLOPE:
                    rate = value
                rates.append(rate)
            front = plan.front[k0:k1]
            hist = self._history
            hist.extend(zip(angle_t, angle_a))
            for _ in range(front[-1] - self._hist_base):
                hist.popleft()
            self._hist_base = front[-1]
            self._angles_t += angle_t
            self._angles_a += angle_a
            delay = self._delay_ns
            first = plan.base + k0
            self._log_angles(angle_t, delay, front, list(range(first, first + m)), [total + h for h in held])
            self._call_env += env
            self.record('rudder_angle', angle_t, angle_a, True)
            self._dirty = True
            if len(self._calls) >= len(CALL_FIELDS) * CALLS_KEPT:
                self._take_instants()
            if plan.past[k1] != plan.past[k0]:           # the hard-over's tracker: past its smaller angle
                for j in range(m):
                    self._track_hard_over(angle_t[j], angle_a[j])
        if order_t:
            self.record('rudder_order', order_t, order_v, orders_in_order)
        ia = io = 0
        for is_angle in kinds:         # the response: angle and order samples in their order
            if is_angle:
                if self.response is not None:
                    self.rate = rates[ia]
                    self._track_response(angle_t[ia], angle_a[ia])
                ia += 1
            else:
                self._on_order(order_t[io], order_v[io])
                io += 1
        if m:
            self.rate = rates[-1]
        return rates

    def _bound_held(self) -> None:
        """At most :data:`MAX_HELD` held samples waiting: those released judged first, then
        the oldest of the rest let go."""
        self._take_instants()
        extra = len(self._pending) - MAX_HELD
        if extra <= 0:
            return
        self._pending.release(extra)
        self.held_dropped += extra

    def _take_instants(self) -> None:
        """The held pressure samples the angle samples since the last call released, judged
        as each of those angle samples saw them (:func:`~steer_monitor.monitor.instants.take_instants`):
        motion is judged once per pair of angle samples that brackets a held sample (with the
        model's delay: the angle that much later), the angle interpolated to its time (near
        midships the torque curve is steep: an angle 0.1 s old is worth several bar); the
        instants of steady motion kept for the residual and the rams' share. Each steady
        bracket counts its time of motion once (:attr:`motion_s`)."""
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
                n = take_instants(pend_t, pend_p, self._held_total - pend_t.shape[0], log, env, angle_t, angle_a,
                                  first, HALF_WINDOW_NS, MOVING_RATE, MOTION_STEP_NS, self.gear.ram_area, state, given,
                                  out, n)
                if state[5] < 0:
                    break
                # a window holding a non-finite angle: its slopes summed by math.fsum (see _slope)
                k, i = int(state[0]), int(state[5])
                lo, hi = int(log[k, 2]) - first, int(log[k, 3]) - first + 1
                points = list(zip(self._angles_t[lo:hi], self._angles_a[lo:hi]))
                times, t_i = self._angles_t[lo:hi], self._angles_t[i]
                s1 = self._slope(points[bisect.bisect_left(times, t_i - HALF_WINDOW_NS):i - lo + 1])
                s2 = self._slope(points[i - lo:bisect.bisect_right(times, t_i + HALF_WINDOW_NS)])
                given[:] = (k, i, s1 is not None, math.nan if s1 is None else s1, s2 is not None,
                            math.nan if s2 is None else s2)
            self._pending.release(int(state[1]))
            self._motion_ns += int(state[4])
            self._counted_ns = int(state[2]) if state[3] else None
            if n:
                instants = out[:n, :len(_INSTANT)]
                self._motion.push(instants)
                self._unjudged.push(instants)
                self._resid_summary = None
                self.rams.feed(pend_t[out[:n, _HELD].astype(np.int64)], out[:n, 3:5], out[:n, 7:11])
        calls.clear()
        self._call_env.clear()
        drop = self._hist_base - first          # the angles no history reaches back to any more
        del self._angles_t[:drop]
        del self._angles_a[:drop]
        self._angles_first = self._hist_base

    def _track_hard_over(self, t_ns: int, alpha: float) -> None:
        deg = alpha / DEG
        if abs(deg) >= HARD_OVER_DEG:
            self._hard_over = (math.copysign(1.0, deg), t_ns)
        elif self._hard_over is not None:
            side, t_leave = self._hard_over
            if side * deg <= -OTHER_SIDE_DEG:
                self.hard_over_s = (t_ns - t_leave) / 1e9
                self._hard_over = None

    def _on_order(self, t_ns: int, order: float) -> None:
        if self._last_order is not None and abs(order - self._last_order) >= ORDER_STEP:
            self.response = Response(order=order, t_step_ns=t_ns)
        elif self.response is not None:
            self.response.order = order
        self._last_order = order

    def _track_response(self, t_ns: int, alpha: float) -> None:
        r = self.response
        if r is None:
            return
        moving = abs(self.rate) > MOVING_RATE
        if r.direction_ok is None and not moving:
            stood = t_ns - r.t_step_ns
            if stood >= NO_RESPONSE_NS and abs(r.order - alpha) > NO_RESPONSE_ERR:
                r.stalled_s, r.stalled_at = stood / 1e9, alpha
        elif moving:
            r.stalled_s = r.stalled_at = None
        if r.direction_ok is None and moving:
            wanted = math.copysign(1.0, r.order - alpha) if abs(r.order - alpha) > 0.2 * DEG else 0.0
            ok = wanted == 0.0 or math.copysign(1.0, self.rate) == wanted
            if not ok and t_ns - r.t_step_ns < REVERSAL_NS:
                return        # still stopping and turning from before the order: judged later
            r.direction_ok = ok
            r.delay_s = (t_ns - r.t_step_ns) / 1e9
        if not moving and (t_ns - r.t_step_ns) > 2_000_000_000:
            r.accuracy = abs(r.order - alpha)

    # --- model ---------------------------------------------------------------------------
    def _evaluate(self, t_ns: int) -> LiveState | None:
        angle = self.signals['rudder_angle']
        a = angle.last_value
        p = self._pressures
        if math.isnan(a) or math.isnan(p[0] + p[1] + p[2] + p[3]):
            return None
        st = self.state_at(t_ns, a, angle.last_t_ns if angle.last_t_ns is not None else t_ns, self.rate, tuple(p))
        if self.defer_share:
            return st
        return replace(st, share=load_sharing_scalar(self.gear, st.alpha, st.torque_measured, self.gaps.two_z,
                                                     self.gaps.z_gb))

    def state_at(self, t_ns: int, alpha: float, alpha_t_ns: int, rate: float, pressures: tuple[float, ...]
                 ) -> LiveState:
        """The state :meth:`slot_state` makes at ``t_ns`` from the angle ``alpha`` [rad] read at
        ``alpha_t_ns``, the rate [rad/s] and the four pressures [Pa] standing then, its load
        sharing left to the caller (:func:`states_at`'s formulas, on floats)."""
        a = _carried(alpha, rate, t_ns, alpha_t_ns) if t_ns > alpha_t_ns else alpha
        torque = _torque(self.gear, math.cos(a), *pressures)
        return LiveState(t_ns, a, rate, abs(rate) > MOVING_RATE, torque, None, self.gaps)

    def residual_summary(self) -> tuple[int, int, float | None]:
        """(:attr:`residual_count`, :attr:`residuals_skipped`, :meth:`residual_rms_bar`) at once."""
        return self._summary()

    def residual_rms_bar(self) -> float | None:
        """RMS of the declared model's pressure residual over the last minute of motion [bar]."""
        return self._summary()[2]

    @property
    def residual_count(self) -> int:
        """How many residuals :attr:`residuals` holds."""
        return self._summary()[0]
