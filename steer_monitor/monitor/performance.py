"""Steering performance from the rudder's angle and the helm's order: hard-over times and the
response to order steps. Pure; one implementation for the node, replay and review.

* **Hard-over** (:class:`HardOverTracker`): from leaving 35 deg on one side to reaching 30 deg
  on the other (SOLAS's figures, read at :data:`HARD_OVER_DEG` and :data:`OTHER_SIDE_DEG` to
  allow for sensor noise and the valve's dead band).
* **Order response** (:class:`ResponseTracker`): after an order step of at least
  :data:`ORDER_STEP`, whether the rudder moved the right way, how soon, how close it settled,
  and whether it stood still while the order was away from it (no response).

The rate is the live model's (:mod:`~steer_monitor.monitor.steady`): a slope over the last
0.5 s, or over the last three samples where the angle comes slower (a gateway), with the span it
was read over. A rate read over a longer span turns later: the response allows for the span it
is given. A sample that gives no rate (an outage) judges nothing. So a slowly sampled moving
rudder is never read as standing, nor one seen more than :data:`NO_RESPONSE_ERR` from where it
stood at the step (it moved, between samples or across lost frames), while a frozen sensor (the
same reading sent on, its slope 0) is found at any rate: :data:`NO_RESPONSE_NS` after an order
step more than :data:`NO_RESPONSE_ERR` away from it, at the first angle sample from then on.

Times are integer ns; angles [rad], rates [rad/s].
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

from steer_monitor.estimate.observe import MOVING_RATE
from steer_monitor.model.hardover import HARD_OVER_FROM_DEG, HARD_OVER_TO_DEG
from steer_monitor.monitor.steady import SLOPE_WINDOW_NS

__all__ = ['DIRECTION_DEADBAND', 'HARD_OVER_DEG', 'MOVING_RATE', 'NO_RESPONSE_ERR', 'NO_RESPONSE_NS', 'ORDER_STEP',
           'OTHER_SIDE_DEG', 'REVERSAL_NS', 'REVERSAL_TURN_NS', 'TRACKED_FROM_DEG', 'HardOver', 'HardOverTracker',
           'Response', 'ResponseTracker', 'SteeringPerformance', 'hard_over_words', 'solas_judgement']

DEG = math.pi / 180.0
HARD_OVER_DEG = HARD_OVER_FROM_DEG   # "at 35 deg", allowing for sensor noise and the valve dead band
OTHER_SIDE_DEG = HARD_OVER_TO_DEG    # "at 30 deg" likewise: the valve stops within its dead band
#: an angle nearer midships than this [deg] changes nothing of the hard-over tracking
TRACKED_FROM_DEG = min(HARD_OVER_DEG, OTHER_SIDE_DEG)
ORDER_STEP = 1.0 * DEG
#: after an order step, how long the rudder may still move the old way: the span the rate was
#: read over (a turn shows half of it late, all of it once the window holds nothing from before)
#: and this, the pump's valve reversing the flow (the simulated gear stops in one 10 ms step)
REVERSAL_TURN_NS = 500_000_000
#: ... which for a rate read over half a second, the angle at its full rate, is this
REVERSAL_NS = SLOPE_WINDOW_NS + REVERSAL_TURN_NS
#: a rudder that has not moved this long after an order step, the order still this far from
#: it, did not respond (the simulated gear starts in 0.1 s, a real one within a second or two;
#: one pump or cold oil make it slower to move, not slower to start)
NO_RESPONSE_NS = 5_000_000_000
NO_RESPONSE_ERR = 1.0 * DEG
SETTLED_NS = 2_000_000_000     # the accuracy is read once the rudder stands this long after the step
#: an order nearer than this to where the monitor's transmitter reads the rudder says no way for
#: it to move: the gear stops where its own follow-up unit says, and the two units' zeros may
#: disagree by this much (0.2-1.5 deg in service). Nearer, a rudder reading 1.7 deg that the gear
#: moves from 0.2 to an order of 1.1 deg would read as moving against it
DIRECTION_DEADBAND = 1.5 * DEG


@dataclass(frozen=True)
class HardOver:
    """One hard-over: last seen at ``side`` x 35 deg at ``t_leave_ns``, first seen at 30 deg the
    other side ``seconds`` later. The angle is sampled: the rudder left 35 deg before the next
    sample and reached 30 deg after the one before, so the hard-over took between
    ``seconds_min`` and ``seconds`` (a tenth of a second apart at 10 Hz, four seconds at 0.5 Hz)."""

    t_leave_ns: int
    seconds: float
    side: float
    seconds_min: float = 0.0


def solas_judgement(h: HardOver, limit_s: float) -> bool | None:
    """Whether the hard-over ``h`` was within the SOLAS time ``limit_s`` [s]: True when even its
    longest reading is, False when even its shortest is over it, None when the angle's sampling
    leaves it open (the time between the two reads either side of the limit)."""
    if h.seconds <= limit_s:
        return True
    if h.seconds_min > limit_s:
        return False
    return None


def hard_over_words(h: HardOver) -> str:
    """The hard-over's time in words: ``27.3 s``, or ``26.0-30.0 s`` where the angle's sampling
    leaves half a second or more open."""
    if h.seconds - h.seconds_min >= 0.5:
        return f'{h.seconds_min:.1f}-{h.seconds:.1f} s'
    return f'{h.seconds:.1f} s'


class HardOverTracker:
    """Hard-overs from the rudder's angle samples, in the order they came."""

    def __init__(self) -> None:
        # (side, time last at hard over, time of the sample after it or None)
        self._at: tuple[float, int, int | None] | None = None
        self._prev_t: int | None = None     # the time of the last sample seen
        #: the last hard-over (None: none seen)
        self.last: HardOver | None = None

    @property
    def last_s(self) -> float | None:
        """The last hard-over's time [s], its longest reading (None: none seen)."""
        return None if self.last is None else self.last.seconds

    @property
    def at_hard_over(self) -> bool:
        """The rudder was last seen at hard over and has not reached the other side since."""
        return self._at is not None

    def angle(self, t_ns: int, alpha: float) -> HardOver | None:
        """One angle sample [ns, rad]; the hard-over it completes, if any."""
        at = self._at
        if at is not None and at[2] is None:
            self._at = (at[0], at[1], t_ns)
        h = self._judge(t_ns, alpha, None, self._prev_t)
        self._prev_t = t_ns
        return h

    def _judge(self, t_ns: int, alpha: float, following: int | None, prev: int | None) -> HardOver | None:
        """One sample at ``t_ns`` [ns] of ``alpha`` [rad], the sample after it at ``following``
        (None: not yet known) and the one before at ``prev``."""
        deg = alpha / DEG
        done = None
        if self._at is not None:
            side, t_leave, after = self._at
            if side * deg <= -OTHER_SIDE_DEG:          # at 30 deg the other side, or past 35 there
                self._at = None
                shortest = 0 if after is None or prev is None else max(prev - after, 0)
                self.last = done = HardOver(t_leave, (t_ns - t_leave) / 1e9, side, shortest / 1e9)
        if abs(deg) >= HARD_OVER_DEG:
            self._at = (math.copysign(1.0, deg), t_ns, following)
        return done

    def angles(self, t_ns: Sequence[int], alpha: Sequence[float]) -> list[HardOver]:
        """Angle samples [ns, rad] in order, as :meth:`angle` of each: only those at least
        :data:`TRACKED_FROM_DEG` off midships are looked at (the rest change nothing but the
        times either side of one, which are read from the sequence)."""
        n = len(t_ns)
        if not n:
            return []
        at = self._at
        if at is not None and at[2] is None:
            self._at = (at[0], at[1], t_ns[0])
        done = []
        for i, a in enumerate(alpha):
            if abs(a / DEG) >= TRACKED_FROM_DEG:
                h = self._judge(t_ns[i], a, t_ns[i + 1] if i + 1 < n else None,
                                t_ns[i - 1] if i else self._prev_t)
                if h is not None:
                    done.append(h)
        self._prev_t = t_ns[-1]
        return done


@dataclass
class Response:
    """Order-to-response of the last order step: direction right, delay [s], settled error
    [rad]; ``stalled_s`` [s] and ``stalled_at`` [rad]: how long the rudder has stood since the
    step while the order was more than ``NO_RESPONSE_ERR`` away, and where (None while it has
    not stood ``NO_RESPONSE_NS``, and again once it moves). ``from_alpha`` [rad]: the rudder's
    last angle when the order stepped (None: none heard yet), the way it should move judged from
    there: judged from where it is when it is first seen moving, a slowly sampled rudder that
    has all but reached an order moving on (the autopilot's ramp) would read as going the
    wrong way whenever it is a little ahead."""

    order: float
    t_step_ns: int
    from_alpha: float | None = None
    direction_ok: bool | None = None
    delay_s: float | None = None
    accuracy: float | None = None
    stalled_s: float | None = None
    stalled_at: float | None = None

    def shifted(self, alpha: float) -> bool:
        """Whether the rudder at ``alpha`` [rad] stands more than :data:`NO_RESPONSE_ERR` from
        where it stood at the step: it has moved since, whatever its rate reads (frames lost
        across the move leave a slope over samples either side of it near zero), so it neither
        stalled nor owes the step a move. A frozen sensor sends the angle of the step on."""
        return self.from_alpha is not None and abs(alpha - self.from_alpha) > NO_RESPONSE_ERR


class ResponseTracker:
    """The response to the last order step (:attr:`response`, None before the first step)."""

    def __init__(self) -> None:
        self.response: Response | None = None
        self._last_order: float | None = None
        self._last_alpha: float | None = None

    def order(self, t_ns: int, order: float) -> None:
        """One order sample [ns, rad]: a step of at least :data:`ORDER_STEP` starts a new response,
        unless the rudder still owes the last one a move (not seen moving since, that order more
        than :data:`NO_RESPONSE_ERR` from it): then that one goes on with the new order, the
        rudder having stood since it (slowly sampled, an autopilot's order steps at nearly every
        sample, and a frozen sensor would never stand 5 s past the last)."""
        r = self.response
        owed = (r is not None and r.direction_ok is None and self._last_alpha is not None
                and abs(r.order - self._last_alpha) > NO_RESPONSE_ERR and not r.shifted(self._last_alpha))
        if self._last_order is not None and abs(order - self._last_order) >= ORDER_STEP and not owed:
            self.response = Response(order=order, t_step_ns=t_ns, from_alpha=self._last_alpha)
        elif r is not None:
            r.order = order
        self._last_order = order

    def angle(self, t_ns: int, alpha: float, rate: float, span_ns: int | None = SLOPE_WINDOW_NS) -> None:
        """One angle sample [ns, rad], the rudder's rate then [rad/s] and the span it was read
        over [ns] (None: this sample gave no rate, and nothing is judged on it)."""
        self._last_alpha = alpha
        r = self.response
        if r is None or span_ns is None:
            return
        moving = abs(rate) > MOVING_RATE
        if r.direction_ok is None and not moving and not r.shifted(alpha):
            stood = t_ns - r.t_step_ns
            if stood >= NO_RESPONSE_NS and abs(r.order - alpha) > NO_RESPONSE_ERR:
                r.stalled_s, r.stalled_at = stood / 1e9, alpha
        elif moving or r.shifted(alpha):
            r.stalled_s = r.stalled_at = None
        if r.direction_ok is None and moving:
            start = alpha if r.from_alpha is None else r.from_alpha
            wanted = math.copysign(1.0, r.order - start) if abs(r.order - start) > DIRECTION_DEADBAND else 0.0
            ok = wanted == 0.0 or math.copysign(1.0, rate) == wanted
            if not ok and t_ns - r.t_step_ns < span_ns + REVERSAL_TURN_NS:
                return        # still stopping and turning from before the order: judged later
            r.direction_ok = ok
            r.delay_s = (t_ns - r.t_step_ns) / 1e9
        if not moving and (t_ns - r.t_step_ns) > SETTLED_NS:
            r.accuracy = abs(r.order - alpha)


class SteeringPerformance:
    """The hard-over and order-response trackers fed together."""

    def __init__(self) -> None:
        self.hard_over = HardOverTracker()
        self.responses = ResponseTracker()

    @property
    def hard_over_s(self) -> float | None:
        """The last hard-over's time [s], its longest reading (None: none seen)."""
        return self.hard_over.last_s

    @property
    def last_hard_over(self) -> HardOver | None:
        """The last hard-over (None: none seen)."""
        return self.hard_over.last

    @property
    def response(self) -> Response | None:
        """The response to the last order step."""
        return self.responses.response

    def angle(self, t_ns: int, alpha: float, rate: float, span_ns: int | None = SLOPE_WINDOW_NS) -> None:
        """One angle sample [ns, rad], the rate after it [rad/s] and the span it was read over
        [ns] (None: none)."""
        self.hard_over.angle(t_ns, alpha)
        self.responses.angle(t_ns, alpha, rate, span_ns)

    def order(self, t_ns: int, order: float) -> None:
        """One order sample [ns, rad]."""
        self.responses.order(t_ns, order)
