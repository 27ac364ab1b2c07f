"""A replay's span of rudder samples taken at once through the live monitor's parts."""

from __future__ import annotations

import math

import numpy as np
import pytest

from steer_monitor.model import Clearances
from steer_monitor.monitor import LiveMonitor
from steer_monitor.monitor.runfeed import take_rudder
from steer_monitor.params import gear_from_params


def _rudder_stream(seed: int, seconds: float, nan_at_s: float | None = None, angle_hz: float = 10.0,
                   outage_s: tuple[float, float] | None = None):
    """Samples (t [ns], input, value) of a gear swinging through hard over and back, its orders
    stepping, four pressures and the ship's speed, in time order; the angle and order at
    ``angle_hz``, none of them within ``outage_s`` (start, end [s])."""
    from steer_monitor.model.inputs import PRESSURE_INPUTS
    rng = np.random.default_rng(seed)
    t0 = 1_700_000_000_000_000_000
    out = []
    period = int(1e9 / angle_hz)
    for k in range(int(seconds * angle_hz)):                    # angle and order
        t = t0 + k * period + int(rng.integers(0, 3_000_000))
        phase = 2 * math.pi * k / (30.0 * angle_hz)
        a = math.radians(37.0 * math.sin(phase) + rng.normal(0, 0.05))
        if nan_at_s is not None and abs(k / angle_hz - nan_at_s) < 1e-9:
            a = math.nan
        if outage_s is not None and outage_s[0] <= k / angle_hz < outage_s[1]:
            continue
        out.append((t, 'rudder_angle', a))
        out.append((t + 40_000_000, 'rudder_order', math.radians(35.0 * round(math.sin(phase)))))
    for k in range(int(seconds * 20)):                          # each pressure at 20 Hz
        for j, name in enumerate(PRESSURE_INPUTS):
            out.append((t0 + k * 50_000_000 + 7_000_000 + j, name, 40e5 + 30e5 * (j % 2) + rng.normal(0, 0.3e5)))
    for k in range(int(seconds)):
        out.append((t0 + k * 1_000_000_000 + 3_000_000, 'ship_speed', 6.0 + 0.1 * k))
    out.sort(key=lambda s: s[0])
    return out


def _take_in_spans(mon: LiveMonitor, stream, read: bool, span_s: float = 1.0) -> list[bool]:
    """``stream`` given to ``mon`` a span at a time as a replay's run gives it: the angle samples'
    rates planned, each span's rudder samples taken at once (the pressure samples before its last
    angle sample held with them, what each angle sample logs worked out from the stream), the
    rest one by one; a span the monitor does not take at once, one by one; with ``read`` the
    steady motion read after each span (as the diagnostics read it each second). Whether each
    span was taken at once."""
    from steer_monitor.model.inputs import PRESSURE_INPUTS, Sample
    angles = [(t, v) for t, n, v in stream if n == 'rudder_angle']
    mon.steady.plan([t for t, _ in angles], [v for _, v in angles])
    spans, start = [], stream[0][0]
    while start <= stream[-1][0]:
        spans.append([s for s in stream if start <= s[0] < start + int(span_s * 1e9)])
        start += int(span_s * 1e9)
    taken = []
    pressures = list(mon.pressures)
    speed = mon.signals['ship_speed'].last_value
    for span in spans:
        last = max((i for i, s in enumerate(span) if s[1] == 'rudder_angle'), default=-1)
        kinds, at, aa, held, env, hold_t, hold_p = [], [], [], [], [], [], []
        p, v = list(pressures), speed
        for t, name, value in span[:last + 1]:
            if name in PRESSURE_INPUTS:
                p[PRESSURE_INPUTS.index(name)] = value
                if not math.isnan(sum(p)):
                    hold_t.append(t)
                    hold_p.append(list(p))
            elif name == 'ship_speed':
                v = value
            elif name == 'rudder_angle':
                kinds.append(True)
                at.append(t)
                aa.append(value)
                held.append(len(hold_t))
                env += [v, math.nan]
            else:
                kinds.append(False)
        orders = [(t, value) for t, name, value in span[:last + 1] if name == 'rudder_order']
        rates = take_rudder(mon, kinds, at, aa, held, env, np.array(hold_t, np.int64),
                            np.array(hold_p, float).reshape(-1, 4), [t for t, _ in orders],
                            [o for _, o in orders], True)
        taken.append(rates is not None)
        if rates is not None:
            for t, name, value in span[:last + 1]:             # what the replay records beside them
                if name in PRESSURE_INPUTS:
                    mon.inputs.record(name, [t], [value], True)
                elif name == 'ship_speed':
                    mon.inputs.record(name, [t], [value], True)
            mon.pressures = list(p)
            rest = span[last + 1:]
        else:
            rest = span
        for t, name, value in rest:
            mon.update(Sample(t, name, value))
        pressures = list(mon.pressures)
        speed = mon.signals['ship_speed'].last_value
        if read:
            assert mon.motion_ns >= 0
    return taken


@pytest.mark.parametrize('nan_at_s, read, refused, angle_hz, outage_s', [
    (None, True, [], 10.0, None), (20.3, True, [20], 10.0, None), (None, False, [51], 10.0, None),
    # a gateway's slow angle (its rate read over its last three samples), and an outage of 12 s
    (None, True, [], 2.0, None), (None, True, [], 0.5, (20.0, 32.0)), (None, True, [], 10.0, (20.0, 32.0)),
])
def test_a_span_of_rudder_samples_taken_at_once_is_each_taken_alone(r18_params, nan_at_s, read, refused, angle_hz,
                                                                     outage_s):
    """take_rudder (a replay's spans of angle and order samples) leaves the monitor as update()
    of each sample does: the rate, the hard-over time, the response to the order steps, the
    history the residual's instants are judged from, the steady motion counted and the residual.
    A span is refused with nothing changed, and taken one by one, where an angle in its rate
    windows is not a number, or (nothing read for 51 s, so no held pressure sample released)
    where its held samples would pass MAX_HELD."""
    from steer_monitor.model.inputs import Sample
    gear = gear_from_params(r18_params)
    stream = _rudder_stream(3, 65.0, nan_at_s, angle_hz, outage_s)
    one = LiveMonitor(gear, Clearances.from_mm(0.6, 0.25))
    for t, name, value in stream:
        one.update(Sample(t, name, value))
    spans = LiveMonitor(gear, Clearances.from_mm(0.6, 0.25))
    taken = _take_in_spans(spans, stream, read)
    assert [i for i, ok in enumerate(taken) if not ok] == refused
    assert one.hard_over_s is not None and spans.hard_over_s == one.hard_over_s
    assert one.response is not None and spans.response == one.response
    assert spans.rate == one.rate and spans.steady.history == one.steady.history
    assert spans.steady.rate_span_ns == one.steady.rate_span_ns
    if angle_hz >= 10.0:            # steady motion is judged over 0.3 s either side of a sample
        assert spans.motion_ns == one.motion_ns > 0
        assert spans.residuals == one.residuals and len(one.residuals) > 100
    else:
        assert spans.motion_ns == one.motion_ns and spans.residuals == one.residuals
    assert spans.signals['rudder_order'].arrivals == one.signals['rudder_order'].arrivals


def test_a_span_is_refused_unchanged_past_the_held_bound_or_under_another_delay(r18_params):
    """Where one by one would judge the held samples as the bound is passed, or the history is
    cut under a delay the plan was not made with, take_rudder takes nothing."""
    from steer_monitor.monitor.steady import MAX_HELD
    gear = gear_from_params(r18_params)
    mon = LiveMonitor(gear, Clearances.from_mm(0.6, 0.25))
    mon.steady.plan([10, 20], [0.1, 0.2])
    args = ([True, True], [10, 20], [0.1, 0.2], [0, 0], [math.nan] * 4)
    many = np.arange(MAX_HELD + 1, dtype=np.int64)
    assert take_rudder(mon, *args, many, np.ones((many.size, 4)), [], [], True) is None
    mon.steady.delay_ns = 250_000_000
    assert take_rudder(mon, *args, np.zeros(0, np.int64), np.zeros((0, 4)), [], [], True) is None
    assert mon.steady.held_total == 0 and not mon.steady.history and mon.rate == 0.0
    mon.steady.delay_ns = 0
    assert take_rudder(mon, *args, np.zeros(0, np.int64), np.zeros((0, 4)), [], [], True) == [0.0, 0.0]
    assert [t for t, _ in mon.steady.history] == [10, 20]
