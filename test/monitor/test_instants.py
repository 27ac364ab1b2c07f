"""The residual's instants of steady motion, judged later for many angle samples at once
(monitor/instants.py through ``LiveMonitor``), against an oracle that judges the held pressure
samples as each angle sample comes, in plain Python: the same instants, in the same order,
to the bit, and the same motion counted, whenever the monitor is read."""

from __future__ import annotations

import bisect
import math
from collections import deque

import numpy as np
import pytest

from steer_monitor.model import Clearances
from steer_monitor.model.inputs import PRESSURE_INPUTS as PRESSURES
from steer_monitor.model.inputs import Sample
from steer_monitor.monitor import LiveMonitor
from steer_monitor.monitor.steady import HALF_WINDOW_NS, MOTION_STEP_NS, MOVING_RATE, SteadyMotion
from steer_monitor.params import gear_from_params


class _Oracle:
    """The judging as it was written sample by sample: each angle sample releases the held
    samples 0.3 s (and the delay) older than it, judged against the 0.9 s of angles it keeps,
    the slopes of a bracket over 0.3 s either side by ``SteadyMotion.rate_of``."""

    def __init__(self, area: float) -> None:
        self.area = area
        self.history: deque[tuple[int, float]] = deque()
        self.pending: deque[tuple[int, float, float, float, float]] = deque()
        self.pressures = [math.nan] * 4
        self.speed = self.oil = math.nan
        self.instants: list[tuple[float, ...]] = []
        self.rows: list[tuple[float, ...]] = []
        self.motion_ns = 0
        self.counted: int | None = None

    def update(self, s: Sample, delay: int) -> None:
        if s.signal in PRESSURES:
            self.pressures[PRESSURES.index(s.signal)] = s.value
            if not any(math.isnan(p) for p in self.pressures):
                self.pending.append((s.t_ns, *self.pressures))
        elif s.signal == 'ship_speed':
            self.speed = s.value
        elif s.signal == 'oil_temperature':
            self.oil = s.value
        elif s.signal == 'rudder_angle':
            self.angle(s.t_ns, s.value, delay)

    def steady(self, i: int) -> tuple[float, float]:
        points = list(self.history)
        times = [p[0] for p in points]
        t = times[i]
        s1 = SteadyMotion.rate_of(points[bisect.bisect_left(times, t - HALF_WINDOW_NS):i + 1])
        s2 = SteadyMotion.rate_of(points[i:bisect.bisect_right(times, t + HALF_WINDOW_NS)])
        if s1 is None or s2 is None or min(abs(s1), abs(s2)) <= MOVING_RATE or (s1 > 0) != (s2 > 0):
            return 0.0, 0.0
        return (1.0 if s1 > 0 else -1.0), 0.5 * (s1 + s2)

    def angle(self, t_ns: int, alpha: float, delay: int) -> None:
        hist = self.history
        hist.append((t_ns, alpha))
        while hist and hist[0][0] < t_ns - 3 * HALF_WINDOW_NS - delay:
            hist.popleft()
        t_end = t_ns - HALF_WINDOW_NS - delay
        times = [p[0] for p in hist]
        while self.pending and self.pending[0][0] <= t_end:
            t, c0, c1, c2, c3 = self.pending.popleft()
            i = bisect.bisect_right(times, t + delay) - 1
            if i < 0 or i + 1 >= len(hist):
                continue
            direction, rate = self.steady(i)
            if direction != 0.0 and (self.counted is None or times[i] > self.counted):
                self.motion_ns += min(times[i + 1] - times[i], MOTION_STEP_NS)
                self.counted = times[i]
            if direction == 0.0:
                continue
            (t_a, a_a), (t_b, a_b) = hist[i], hist[i + 1]
            a = a_a + (a_b - a_a) * (t + delay - t_a) / (t_b - t_a)
            self.instants.append((a, self.speed, direction, self.area * (c0 - c1), self.area * (c2 - c3), rate,
                                  self.oil))
            self.rows.append((c0, c1, c2, c3))


def _stream(seed: int, seconds: float, disorder: bool, gaps: bool, nan_angles: bool) -> list[Sample]:
    """A rudder swinging with stops, sampled at 10 Hz with jitter (some stamps out of order,
    some silences past the history, a few NaN angles where asked), four pressures at 20 Hz each
    that follow it (some stamped up to 0.9 s early where asked), the ship's speed and oil
    temperature at 10 Hz, in arrival order."""
    rng = np.random.default_rng(seed)
    out: list[tuple[int, int, Sample]] = []
    t0 = 1_700_000_000_000_000_000

    def rudder(t: float) -> float:
        return math.radians(25.0) * math.sin(0.35 * t) * (1.0 if (t % 40.0) < 30.0 else 0.0)
    t = 0.0
    while t < seconds:
        if gaps and rng.random() < 0.01:
            t += rng.uniform(0.8, 3.0)                  # the angle silent past its 0.9 s of history
        made = t0 + int(t * 1e9) + int(rng.integers(-3_000_000, 3_000_000))
        stamp = made - (int(rng.integers(50_000_000, 400_000_000)) if disorder and rng.random() < 0.03 else 0)
        value = math.nan if nan_angles and rng.random() < 0.01 else rudder(t) + rng.normal(0.0, 2e-4)
        out.append((made, 0, Sample(stamp, 'rudder_angle', value)))
        t += 0.1
    for k in range(int(seconds * 20)):
        t = k / 20.0
        load = 60e5 * rudder(t + 0.05)
        for j, name in enumerate(PRESSURES):
            made = t0 + int(t * 1e9) + 1_000_000 * (j + 1)
            stamp = made - (int(rng.integers(300_000_000, 900_000_000)) if disorder and rng.random() < 0.1 else 0)
            out.append((made, 1, Sample(stamp, name, 20e5 + (load if j % 2 == 0 else -load) * 0.5
                                        + rng.normal(0.0, 3e4))))
    for k in range(int(seconds * 10)):                  # 10 Hz, every value new
        stamp = t0 + k * 100_000_000 + 50_500_000
        out.append((stamp, 2, Sample(stamp, 'ship_speed', 5.0 + 0.01 * k if k % 70 else math.nan)))
        out.append((stamp, 2, Sample(stamp, 'oil_temperature', 310.0 + 0.001 * k)))
    # in arrival order: by the time each was made (a sample stamped early comes where it was made)
    order = sorted(range(len(out)), key=lambda i: (out[i][0], out[i][1]))
    arrival = []
    for i in order:
        arrival.append(out[i][2])
    return arrival


@pytest.mark.parametrize('seed, disorder, gaps, nan_angles, delay_ms', [
    (1, False, False, False, 0),
    (2, True, False, False, 0),
    (3, False, True, False, 250),
    (4, True, True, False, 700),
    (5, False, False, True, 0),
])
def test_instants_judged_later_are_those_judged_as_each_angle_came(r18_params, seed, disorder, gaps, nan_angles,
                                                                     delay_ms):
    gear = gear_from_params(r18_params)
    mon = LiveMonitor(gear, Clearances.from_mm(0.3, 0.2))
    mon.steady.delay_ns = delay_ms * 1_000_000      # as set_finding sets it from an adopted delay
    oracle = _Oracle(gear.ram_area)
    rng = np.random.default_rng(100 + seed)
    samples = _stream(seed, 240.0, disorder, gaps, nan_angles)
    for s in samples:
        mon.update(s)
        oracle.update(s, mon.steady.delay_ns)
        if rng.random() < 0.002:                 # read at random times: judged then
            assert mon.motion_ns == oracle.motion_ns
    assert mon.motion_ns == oracle.motion_ns > 0
    kept = mon.residual.instants
    want = np.array(oracle.instants[-kept.shape[0]:])
    assert kept.shape[0] == min(len(oracle.instants), kept.shape[0]) > 100
    np.testing.assert_array_equal(kept, want)                 # to the bit (NaN where NaN)
    check = mon.rams                                          # the rams check took the same instants
    check.finish()
    assert check.instants == len(oracle.rows)
    whole = len(oracle.rows) // check.window * check.window
    last = oracle.rows[whole - check.window:whole] if whole < len(oracle.rows) else oracle.rows[-check.window:]
    if whole < len(oracle.rows):
        last = oracle.rows[whole:]                            # finish judged the rest as a window
    np.testing.assert_array_equal(check.last_aux, np.array(last))


def test_the_log_between_reads_is_bounded(r18_params):
    """Fed for long without being read, the monitor judges what its angle samples released
    once a thousand of them are waiting: the log stays bounded."""
    from steer_monitor.monitor.steady import CALLS_KEPT
    mon = LiveMonitor(gear_from_params(r18_params), Clearances.from_mm(0.3, 0.2))
    for s in _stream(9, 300.0, False, False, False):
        mon.update(s)
        logged, kept = mon.steady.log_kept
        assert logged < CALLS_KEPT
        assert kept < CALLS_KEPT + 20


def test_a_sample_held_after_an_angle_sample_is_not_released_by_it(r18_params):
    """A pressure sample stamped 0.4 s early that comes just after an angle sample (nothing
    else held) is released by the next angle sample, not by that one: it is judged with the
    ship's speed standing then."""
    gear = gear_from_params(r18_params)
    mon = LiveMonitor(gear, Clearances.from_mm(0.3, 0.2))
    oracle = _Oracle(gear.ram_area)
    t0 = 1_700_000_000_000_000_000
    ms = 1_000_000
    feed: list[Sample] = [Sample(t0, 'ship_speed', 5.0)]
    for k in range(101):                                   # the rudder turning at 10 deg/s for 10 s
        t = t0 + 100 * ms * k
        feed.append(Sample(t, 'rudder_angle', math.radians(-40.0 + k)))
        if k < 50:
            feed += [Sample(t + (j + 1) * ms, name, 20e5 + 1e5 * j + 1e3 * k) for j, name in enumerate(PRESSURES)]
        if k == 60:                                        # just after the angle at 6.0 s, stamped 5.6 s
            feed.append(Sample(t - 400 * ms, PRESSURES[0], 25e5))
            feed.append(Sample(t + 50 * ms, 'ship_speed', 6.0))
    for s in feed:
        mon.update(s)
        oracle.update(s, 0)
    assert mon.motion_ns == oracle.motion_ns > 0            # read: judged now
    assert oracle.instants[-1][1] == 6.0                   # judged at 6.1 s, with the new speed
    np.testing.assert_array_equal(mon.residual.instants, np.array(oracle.instants[-600:]))


def test_with_the_angle_dead_the_held_samples_stay_bounded(r18_params):
    """Ten minutes of pressures without a rudder angle: the held samples stop at MAX_HELD, the
    oldest let go and counted; once the angle comes back the residual's instants come as on
    a monitor that never waited."""
    from steer_monitor.monitor.steady import MAX_HELD
    gear = gear_from_params(r18_params)
    stream = _stream(11, 240.0, False, False, False)
    t_back = stream[0].t_ns + 600 * 1_000_000_000
    shift = 600 * 1_000_000_000
    waited = LiveMonitor(gear, Clearances.from_mm(0.3, 0.2))
    t0 = stream[0].t_ns
    for k in range(600 * 20):                                    # the pressures alone, 20 Hz each
        for j, name in enumerate(PRESSURES):
            waited.update(Sample(t0 + k * 50_000_000 + j, name, 20e5 + 1e4 * j))
        assert waited.steady.held <= MAX_HELD
    assert waited.steady.held_dropped == 600 * 20 * 4 - 3 - MAX_HELD    # the first three lack a pressure
    assert waited.motion_ns == 0 and waited.steady.held == MAX_HELD
    fresh = LiveMonitor(gear, Clearances.from_mm(0.3, 0.2))
    for s in stream:                                             # then the gear as before, ten minutes on
        moved = Sample(s.t_ns + shift, s.signal, s.value)
        assert moved.t_ns >= t_back
        waited.update(moved)
        fresh.update(moved)
    assert waited.motion_ns == fresh.motion_ns > 0
    np.testing.assert_array_equal(waited.residual.instants, fresh.residual.instants)


def test_a_bracket_judged_again_after_one_with_a_nan_angle_keeps_its_own_slopes(r18_params):
    """One angle sample releases, in this order, samples in a bracket whose windows hold a NaN
    angle (its slopes worked out by the caller's math.fsum) and in a bracket of steady motion,
    twice: the second in the steady bracket is judged with that bracket's slopes."""
    gear = gear_from_params(r18_params)
    mon = LiveMonitor(gear, Clearances.from_mm(0.3, 0.2))
    oracle = _Oracle(gear.ram_area)
    t0 = 1_700_000_000_000_000_000
    ms = 1_000_000
    feed = [Sample(t0 + j, name, 20e5 + 1e5 * j) for j, name in enumerate(PRESSURES)]
    for k in range(21):                                        # 10 deg/s, the sample at 1.7 s NaN
        t = t0 + 100 * ms * k
        if k == 20:                                            # held just before the angle at 2.0 s
            feed += [Sample(t0 + 1700 * ms, PRESSURES[0], 21e5), Sample(t0 + 1310 * ms, PRESSURES[0], 22e5),
                     Sample(t0 + 1700 * ms, PRESSURES[0], 23e5), Sample(t0 + 1320 * ms, PRESSURES[0], 24e5)]
        feed.append(Sample(t, 'rudder_angle', math.nan if k == 17 else math.radians(-10.0 + k)))
    for s in feed:
        mon.update(s)
        oracle.update(s, 0)
    assert mon.motion_ns == oracle.motion_ns
    got = mon.residual.instants
    want = np.array(oracle.instants[-4:])
    assert got.shape == (4, 7) and want[1, 2] == want[3, 2] == 1.0       # the steady bracket, twice
    np.testing.assert_array_equal(got, want)
