"""Steering performance: the hard-over and order-response trackers, on angle sweeps whose
answers are known in closed form."""

from __future__ import annotations

import math

import numpy as np
import pytest

from steer_monitor.monitor.performance import (
    HARD_OVER_DEG,
    NO_RESPONSE_NS,
    OTHER_SIDE_DEG,
    HardOverTracker,
    ResponseTracker,
    SteeringPerformance,
)

S = 1_000_000_000


def _sweep(rate_deg_s: float, start_deg: float, end_deg: float, step_ns: int = 100_000_000):
    """Angle samples of a rudder turning at a constant rate from ``start_deg`` to ``end_deg``."""
    n = int(abs(end_deg - start_deg) / rate_deg_s * S / step_ns) + 1
    t = [k * step_ns for k in range(n)]
    a = [math.radians(start_deg + math.copysign(rate_deg_s, end_deg - start_deg) * k * step_ns / S) for k in range(n)]
    return t, a


@pytest.mark.parametrize('rate_deg_s', [2.5, 3.3, 5.0])
def test_a_hard_over_is_timed_from_leaving_35_to_reaching_30_the_other_side(rate_deg_s):
    """A sweep from 40 deg to -32 deg at a constant rate: the time from the last sample at or
    beyond 34.5 deg to the first at or beyond -29.5 deg, to the sampling step."""
    t, a = _sweep(rate_deg_s, 40.0, -32.0)
    tracker = HardOverTracker()
    done = tracker.angles(t, a)
    assert len(done) == 1 and done[0].side == 1.0
    want = (HARD_OVER_DEG + OTHER_SIDE_DEG) / rate_deg_s
    assert done[0].seconds == pytest.approx(want, abs=0.2 + 1e-9)
    assert tracker.last_s == done[0].seconds and not tracker.at_hard_over


def test_the_tracker_over_many_angles_is_the_tracker_angle_by_angle():
    """Hard-overs both ways, swings that stop short, noise at the thresholds: angles() (only
    the angles off midships looked at) gives what angle() of each gives."""
    rng = np.random.default_rng(3)
    t = np.cumsum(rng.integers(50_000_000, 150_000_000, 6000)).tolist()
    deg = 38.0 * np.sin(np.arange(6000) / 90.0) * rng.choice([1.0, 0.8], 6000) + rng.normal(0, 0.3, 6000)
    a = np.radians(deg)
    one, many = HardOverTracker(), HardOverTracker()
    want = [h for h in (one.angle(ti, float(ai)) for ti, ai in zip(t, a.tolist())) if h is not None]
    got = many.angles(t, a)
    assert got == want and len(want) > 5
    assert {h.side for h in want} == {1.0, -1.0}


def test_a_swing_that_stops_short_of_the_other_side_times_nothing():
    t, a = _sweep(5.0, 40.0, -25.0)
    tracker = HardOverTracker()
    assert tracker.angles(t, a) == [] and tracker.last_s is None and tracker.at_hard_over


def test_an_order_step_is_answered_the_right_way_after_its_delay():
    """An order step of 10 deg; the rudder starts 0.4 s later at 2.5 deg/s the right way and
    settles: direction right, delay 0.4 s, the settled error read once it stands."""
    perf = SteeringPerformance()
    perf.order(0, 0.0)
    perf.order(S, math.radians(10.0))
    for k in range(100):
        t = S + k * 100_000_000
        moving = 4 <= k < 44
        perf.angle(t, math.radians(min(max(k - 4, 0) * 0.25, 10.0) - 0.1 * (k >= 44)),
                   math.radians(2.5) if moving else 0.0)
    r = perf.response
    assert r is not None and r.direction_ok is True
    assert r.delay_s == pytest.approx(0.4)
    assert r.accuracy == pytest.approx(math.radians(0.1))
    assert r.stalled_s is None


def test_a_rudder_that_moves_the_wrong_way_past_the_reversal_time_is_wrong():
    responses = ResponseTracker()
    responses.order(0, 0.0)
    responses.order(S, math.radians(10.0))
    responses.angle(S + 500_000_000, 0.0, math.radians(-2.0))      # still turning from before: not judged
    assert responses.response.direction_ok is None
    responses.angle(S + 1_500_000_000, 0.0, math.radians(-2.0))
    assert responses.response.direction_ok is False and responses.response.delay_s == pytest.approx(1.5)


def test_a_rudder_that_stands_while_the_order_is_away_did_not_respond():
    """No motion for NO_RESPONSE_NS after a step, the order 10 deg away: stalled, and where;
    it clears once the rudder moves."""
    responses = ResponseTracker()
    responses.order(0, 0.0)
    responses.order(S, math.radians(10.0))
    responses.angle(S + NO_RESPONSE_NS - 1, 0.0, 0.0)
    assert responses.response.stalled_s is None
    responses.angle(S + NO_RESPONSE_NS, 0.0, 0.0)
    assert responses.response.stalled_s == pytest.approx(NO_RESPONSE_NS / 1e9) and responses.response.stalled_at == 0.0
    responses.angle(S + NO_RESPONSE_NS + 100_000_000, 0.001, math.radians(3.0))
    assert responses.response.stalled_s is None and responses.response.direction_ok is True


def test_small_order_changes_are_not_steps():
    responses = ResponseTracker()
    responses.order(0, 0.0)
    responses.order(S, math.radians(0.5))
    assert responses.response is None


def _slow_response(hz: float, frozen: bool, order_deg: float = 10.0, rate_deg_s: float = 2.5):
    """A live monitor's rate part and response tracker fed a rudder whose angle (and order) come
    at ``hz``: at rest at 0 deg, an order step to ``order_deg`` at 10 s, the rudder moving there
    at ``rate_deg_s`` from 0.3 s later; ``frozen``: its sensor sends 0 deg on. The rates are the
    live model's (SteadyMotion). The tracker and the time [s] the order step was seen."""
    from steer_monitor.monitor.steady import SteadyMotion
    steady, responses = SteadyMotion(0.045, lambda *a: None), ResponseTracker()
    period = 1.0 / hz
    step_seen = None
    for k in range(int(40 * hz)):
        t = k * period + 0.013
        order = order_deg if t >= 10.0 else 0.0
        truth = min(max(t - 10.3, 0.0) * rate_deg_s, order_deg)
        alpha = math.radians(0.0 if frozen else truth)
        if order and step_seen is None:
            step_seen = t
        responses.order(int(t * 1e9), math.radians(order))
        rate = steady.angle(int(t * 1e9), alpha, math.nan, math.nan)
        responses.angle(int(t * 1e9), alpha, rate, steady.rate_span_ns)
    return responses, step_seen


@pytest.mark.parametrize('hz', [0.5, 1.0, 2.0, 5.0, 10.0])
def test_a_slowly_sampled_rudder_that_moves_is_not_stalled(hz):
    responses, _ = _slow_response(hz, frozen=False)
    r = responses.response
    assert r.stalled_s is None and r.direction_ok is True
    assert r.delay_s <= 0.3 + 3.0 / hz             # seen moving within three of its samples


@pytest.mark.parametrize('hz', [0.5, 1.0, 2.0, 5.0, 10.0])
def test_a_frozen_sensor_is_found_at_any_rate_within_one_sample_of_the_rule(hz):
    """The stated time: NO_RESPONSE_NS after the order step is seen, at the first angle sample
    from then on (one period at most)."""
    responses, seen = _slow_response(hz, frozen=True)
    r = responses.response
    assert r.stalled_s is not None and r.direction_ok is None
    assert NO_RESPONSE_NS / 1e9 <= r.stalled_s <= 40.0 - seen
    assert _first_stall_time(hz) - seen <= NO_RESPONSE_NS / 1e9 + 1.0 / hz + 1e-9


def _first_stall_time(hz: float) -> float:
    from steer_monitor.monitor.steady import SteadyMotion
    steady, responses = SteadyMotion(0.045, lambda *a: None), ResponseTracker()
    for k in range(int(40 * hz)):
        t = k / hz + 0.013
        responses.order(int(t * 1e9), math.radians(10.0 if t >= 10.0 else 0.0))
        rate = steady.angle(int(t * 1e9), 0.0, math.nan, math.nan)
        responses.angle(int(t * 1e9), 0.0, rate, steady.rate_span_ns)
        if responses.response is not None and responses.response.stalled_s is not None:
            return t
    raise AssertionError('never raised')


@pytest.mark.parametrize('hz', [0.5, 1.0, 2.0])
def test_a_slowly_sampled_rudder_following_a_ramping_order_is_not_against_it(hz):
    """The autopilot's order stepping and then ramping on down; the rudder follows it, a little
    ahead. The frames of 11-15 s lost, it is first seen moving when already ahead of the order:
    going the way the step asked (from where it stood), not against it (it read so at 0.5 Hz,
    judged from where it was then)."""
    from steer_monitor.monitor.steady import SteadyMotion
    steady, responses = SteadyMotion(0.045, lambda *a: None), ResponseTracker()
    for k in range(int(30 * hz)):
        t = k / hz + 0.013
        if 11.0 < t < 15.0:
            continue
        order = 8.0 if t < 10.0 else 5.0 - 0.28 * (t - 10.0)
        alpha = 8.0 if t < 10.0 else max(8.0 - 1.5 * (t - 10.0), order - 0.35)
        responses.order(int(t * 1e9), math.radians(order))
        rate = steady.angle(int(t * 1e9), math.radians(alpha), math.nan, math.nan)
        responses.angle(int(t * 1e9), math.radians(alpha), rate, steady.rate_span_ns)
    assert responses.response.direction_ok is True


def test_a_sample_that_gives_no_rate_judges_nothing():
    responses = ResponseTracker()
    responses.order(0, 0.0)
    responses.order(S, math.radians(10.0))
    responses.angle(S + 2 * NO_RESPONSE_NS, 0.0, 0.0, None)
    assert responses.response.stalled_s is None and responses.response.direction_ok is None


@pytest.mark.parametrize('step_s', [0.1, 0.5, 2.0, 2.7])
@pytest.mark.parametrize('phase_s', [0.0, 0.37, 1.3])
def test_a_slowly_sampled_hard_over_is_bracketed(step_s, phase_s):
    """A sweep at 2.5 deg/s from 40 deg to -32 deg sampled every ``step_s``: the true time from
    35 deg to -30 deg lies between the shortest and longest readings, which are two samples
    apart at most; one sample at a time and all at once alike."""
    rate = 2.5
    t = [int((phase_s + k * step_s) * S) for k in range(int(30 / step_s) + 2)]
    a = [math.radians(40.0 - rate * (tk / S)) for tk in t]
    want = (HARD_OVER_DEG + OTHER_SIDE_DEG) / rate
    one, many = HardOverTracker(), HardOverTracker()
    h = [x for x in (one.angle(ti, ai) for ti, ai in zip(t, a)) if x is not None]
    assert many.angles(t, a) == h and len(h) == 1
    assert h[0].seconds_min <= want <= h[0].seconds
    assert h[0].seconds - h[0].seconds_min <= 2 * step_s + 1e-9


def test_an_order_the_rudder_owes_a_move_keeps_its_clock_through_new_steps():
    """A frozen sensor at 0 deg, the order stepping by 1.5 deg every 2 s (slowly sampled, an
    autopilot steps at nearly every sample): stalled 5 s after the first step, not never; where
    the rudder owed nothing (the order within a degree of it), a new step starts afresh."""
    responses = ResponseTracker()
    responses.order(0, 0.0)
    responses.angle(0, 0.0, 0.0)
    for k in range(1, 5):
        responses.order(k * 2 * S, math.radians(1.5 * k))
        responses.angle(k * 2 * S + 1, 0.0, 0.0)
    r = responses.response
    assert r.t_step_ns == 2 * S and r.stalled_s == pytest.approx(6.0, abs=1e-6)
    fresh = ResponseTracker()
    fresh.order(0, 0.0)
    fresh.angle(0, 0.0, 0.0)
    fresh.order(S, math.radians(1.2))            # a step the rudder (within 0.3 deg) need not answer
    fresh.angle(S + 1, math.radians(0.9), 0.0)
    fresh.order(30 * S, math.radians(10.0))      # 29 s later a new one: its own clock
    fresh.angle(30 * S + 1, math.radians(0.9), 0.0)
    assert fresh.response.t_step_ns == 30 * S and fresh.response.stalled_s is None


def test_a_rudder_that_moved_across_lost_frames_is_not_stalled():
    """Sampled every 2 s, the frames of 6 s lost while the rudder went from -5 deg to midships
    (the order's steps among them): the slope over the samples either side reads near zero,
    but the rudder stands 5 deg from where it stood at the step: moved, neither stalled nor
    owing the step a move; the next step starts its own clock."""
    from steer_monitor.monitor.steady import SteadyMotion
    steady, responses = SteadyMotion(0.045, lambda *a: None), ResponseTracker()
    samples = [(0.0, 0.56, -0.24), (2.0, -5.17, -5.41), (8.0, -0.1, 0.0), (10.0, -0.1, 0.0)]
    for t, alpha, order in samples:                # each angle frame just before the order's
        rate = steady.angle(int(t * S), math.radians(alpha), math.nan, math.nan)
        responses.angle(int(t * S), math.radians(alpha), rate, steady.rate_span_ns)
        assert responses.response is None or responses.response.stalled_s is None
        responses.order(int(t * S) + 1, math.radians(order))
    assert responses.response.t_step_ns == 8 * S + 1


def test_a_frozen_sensor_after_lost_frames_is_still_found():
    """The same, the sensor frozen at -5.17 deg: stalled once the rule's time has passed."""
    from steer_monitor.monitor.steady import SteadyMotion
    steady, responses = SteadyMotion(0.045, lambda *a: None), ResponseTracker()
    for t, order in ((0.0, -0.24), (2.0, -5.41), (8.0, 0.0), (10.0, 0.0), (14.0, 0.0)):
        rate = steady.angle(int(t * S), math.radians(-5.17), math.nan, math.nan)
        responses.angle(int(t * S), math.radians(-5.17), rate, steady.rate_span_ns)
        responses.order(int(t * S) + 1, math.radians(order))
    r = responses.response
    assert r.t_step_ns == 8 * S + 1 and r.stalled_s == pytest.approx(6.0, abs=1e-6)


def test_an_order_within_the_transmitters_zero_error_says_no_way_to_move():
    """The monitor's transmitter reads 1.5 deg more than the gear's own unit (a zero error): the
    rudder stands at 0.2 deg reading 1.7, the order steps to 1.4 and the gear moves it up: no
    fault (it would read as against the order); an order beyond the dead band still judged."""
    from steer_monitor.monitor.performance import DIRECTION_DEADBAND
    zero = math.radians(1.5)
    responses = ResponseTracker()
    responses.order(0, math.radians(0.2))
    responses.angle(S // 2, math.radians(0.2) + zero, 0.0)
    responses.order(S, math.radians(1.4))
    responses.angle(S + 1_500_000_000, math.radians(0.5) + zero, math.radians(1.0))
    assert responses.response.direction_ok is True
    assert DIRECTION_DEADBAND == pytest.approx(zero)
    far = ResponseTracker()
    far.order(0, math.radians(0.2))
    far.angle(S // 2, math.radians(0.2) + zero, 0.0)
    far.order(S, math.radians(-3.0))       # 4.9 deg below the reading: the way is clear
    far.angle(S + 1_500_000_000, math.radians(0.5) + zero, math.radians(1.0))
    assert far.response.direction_ok is False
