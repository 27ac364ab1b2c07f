"""Steering performance from the rudder's angle and the helm's order: hard-over times and the
response to order steps. Pure; one implementation for the node, replay and review.

* **Hard-over** (:class:`HardOverTracker`): from leaving 35 deg on one side to reaching 30 deg
  on the other (SOLAS's figures, read at :data:`HARD_OVER_DEG` and :data:`OTHER_SIDE_DEG` to
  allow for sensor noise and the valve's dead band).
* **Order response** (:class:`ResponseTracker`): after an order step of at least
  :data:`ORDER_STEP`, whether the rudder moved the right way, how soon, how close it settled,
  and whether it stood still while the order was away from it (no response).

Times are integer ns; angles [rad], rates [rad/s].
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass

from steer_monitor.estimate.observe import MOVING_RATE
from steer_monitor.model.hardover import HARD_OVER_FROM_DEG, HARD_OVER_TO_DEG
from steer_monitor.monitor.steady import SLOPE_WINDOW_NS

__all__ = ['HARD_OVER_DEG', 'MOVING_RATE', 'NO_RESPONSE_ERR', 'NO_RESPONSE_NS', 'ORDER_STEP', 'OTHER_SIDE_DEG',
           'REVERSAL_NS', 'TRACKED_FROM_DEG', 'HardOver', 'HardOverTracker', 'Response', 'ResponseTracker',
           'SteeringPerformance']

DEG = math.pi / 180.0
HARD_OVER_DEG = HARD_OVER_FROM_DEG   # "at 35 deg", allowing for sensor noise and the valve dead band
OTHER_SIDE_DEG = HARD_OVER_TO_DEG    # "at 30 deg" likewise: the valve stops within its dead band
#: an angle nearer midships than this [deg] changes nothing of the hard-over tracking
TRACKED_FROM_DEG = min(HARD_OVER_DEG, OTHER_SIDE_DEG)
ORDER_STEP = 1.0 * DEG
#: after an order step, how long the rudder may still move the old way: the rate read here
#: is a slope over half a second, so a turn shows a quarter of a second late, and the pump's
#: valve takes a moment to reverse the flow (the simulated gear stops in one 10 ms step)
REVERSAL_NS = SLOPE_WINDOW_NS + 500_000_000
#: a rudder that has not moved this long after an order step, the order still this far from
#: it, did not respond (the simulated gear starts in 0.1 s, a real one within a second or two;
#: one pump or cold oil make it slower to move, not slower to start)
NO_RESPONSE_NS = 5_000_000_000
NO_RESPONSE_ERR = 1.0 * DEG
SETTLED_NS = 2_000_000_000     # the accuracy is read once the rudder stands this long after the step


@dataclass(frozen=True)
class HardOver:
    """One hard-over: left ``side`` x 35 deg at ``t_leave_ns``, reached 30 deg the other side
    ``seconds`` later."""

    t_leave_ns: int
    seconds: float
    side: float


class HardOverTracker:
    """Hard-overs from the rudder's angle samples, in the order they came."""

    def __init__(self) -> None:
        self._at: tuple[float, int] | None = None     # (side, time last at hard over)
        #: the last hard-over's time [s] (None: none seen)
        self.last_s: float | None = None

    @property
    def at_hard_over(self) -> bool:
        """The rudder was last seen at hard over and has not reached the other side since."""
        return self._at is not None

    def angle(self, t_ns: int, alpha: float) -> HardOver | None:
        """One angle sample [ns, rad]; the hard-over it completes, if any."""
        deg = alpha / DEG
        if abs(deg) >= HARD_OVER_DEG:
            self._at = (math.copysign(1.0, deg), t_ns)
        elif self._at is not None:
            side, t_leave = self._at
            if side * deg <= -OTHER_SIDE_DEG:
                self._at = None
                self.last_s = (t_ns - t_leave) / 1e9
                return HardOver(t_leave, self.last_s, side)
        return None

    def angles(self, t_ns: Iterable[int], alpha: Iterable[float]) -> list[HardOver]:
        """Angle samples [ns, rad] in order, as :meth:`angle` of each: only those at least
        :data:`TRACKED_FROM_DEG` off midships are looked at (the rest change nothing)."""
        done = []
        for t, a in zip(t_ns, alpha):
            if abs(a / DEG) >= TRACKED_FROM_DEG:
                h = self.angle(t, a)
                if h is not None:
                    done.append(h)
        return done


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


class ResponseTracker:
    """The response to the last order step (:attr:`response`, None before the first step)."""

    def __init__(self) -> None:
        self.response: Response | None = None
        self._last_order: float | None = None

    def order(self, t_ns: int, order: float) -> None:
        """One order sample [ns, rad]: a step of at least :data:`ORDER_STEP` starts a new response."""
        if self._last_order is not None and abs(order - self._last_order) >= ORDER_STEP:
            self.response = Response(order=order, t_step_ns=t_ns)
        elif self.response is not None:
            self.response.order = order
        self._last_order = order

    def angle(self, t_ns: int, alpha: float, rate: float) -> None:
        """One angle sample [ns, rad] and the rudder's rate then [rad/s]."""
        r = self.response
        if r is None:
            return
        moving = abs(rate) > MOVING_RATE
        if r.direction_ok is None and not moving:
            stood = t_ns - r.t_step_ns
            if stood >= NO_RESPONSE_NS and abs(r.order - alpha) > NO_RESPONSE_ERR:
                r.stalled_s, r.stalled_at = stood / 1e9, alpha
        elif moving:
            r.stalled_s = r.stalled_at = None
        if r.direction_ok is None and moving:
            wanted = math.copysign(1.0, r.order - alpha) if abs(r.order - alpha) > 0.2 * DEG else 0.0
            ok = wanted == 0.0 or math.copysign(1.0, rate) == wanted
            if not ok and t_ns - r.t_step_ns < REVERSAL_NS:
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
        """The last hard-over's time [s] (None: none seen)."""
        return self.hard_over.last_s

    @property
    def response(self) -> Response | None:
        """The response to the last order step."""
        return self.responses.response

    def angle(self, t_ns: int, alpha: float, rate: float) -> None:
        """One angle sample [ns, rad] and the rate after it [rad/s]."""
        self.hard_over.angle(t_ns, alpha)
        self.responses.angle(t_ns, alpha, rate)

    def order(self, t_ns: int, order: float) -> None:
        """One order sample [ns, rad]."""
        self.responses.order(t_ns, order)
