"""Helm programs: what the wheel or the autopilot orders, step by step.

A program is a comma-separated list of steps run one after the other, each ``name`` or
``name:value``:

* ``hard_over_2`` / ``hard_over_1``: SOLAS test with two / one pump(s): midships, hard over
  to 35 deg starboard, then to 30 deg port, then midships; each order held until reached
  plus a few seconds;
* ``zigzag_10`` / ``zigzag_20``: zigzag manoeuvre, rudder +-10 / +-20 deg, switched when the
  heading change reaches the same angle (four switches);
* ``autopilot[:seconds]``: course keeping in waves (default 300 s), with course changes;
* ``hold[:seconds]``: rudder held at midships (default 60 s);
* ``voyage``: a mixed 25-minute voyage (autopilot, hard-overs, zigzags, holds).

Pure: the programme runs inside the plant's time loop (zigzag and autopilot close the loop
on heading).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from steer_monitor.errors import ParameterError

__all__ = ['PROGRAMS', 'HelmProgram', 'Step', 'parse_program']

DEG = math.pi / 180.0

PROGRAMS = ('hard_over_2', 'hard_over_1', 'zigzag_10', 'zigzag_20', 'autopilot', 'hold', 'voyage')

VOYAGE = ('autopilot:240,hard_over_2,autopilot:180,zigzag_10,hold:30,autopilot:180,'
          'zigzag_20,autopilot:120,hard_over_1,hold:30')


@dataclass(frozen=True)
class Step:
    """One programme step: kind, its numeric value (seconds or degrees), pumps to run."""

    kind: str
    value: float
    pumps: int


def parse_program(text: str, pumps_available: int = 2) -> tuple[Step, ...]:
    """Steps of a programme text such as ``'hard_over_2,zigzag_10,autopilot:600'``."""
    if not isinstance(text, str) or not text.strip():
        msg = f'empty helm programme (choose from: {", ".join(PROGRAMS)})'
        raise ParameterError(msg)
    steps: list[Step] = []
    for part in text.split(','):
        name, _, arg = part.strip().partition(':')
        if name == 'voyage':
            steps.extend(parse_program(VOYAGE, pumps_available))
            continue
        if name not in PROGRAMS:
            msg = f'unknown helm programme {name!r} (choose from: {", ".join(PROGRAMS)})'
            raise ParameterError(msg)
        value = None
        if arg:
            try:
                value = float(arg)
            except ValueError:
                value = None
            if value is None or not math.isfinite(value) or value <= 0:
                msg = f'helm programme {part.strip()!r}: the value after ":" must be a positive number'
                raise ParameterError(msg)
        if name.startswith('hard_over'):
            pumps = int(name[-1])
            if pumps > pumps_available:
                msg = f'helm programme {name}: the gear has only {pumps_available} pump(s)'
                raise ParameterError(msg)
            steps.append(Step('hard_over', 0.0, pumps))
        elif name.startswith('zigzag'):
            steps.append(Step('zigzag', float(name.split('_')[1]), pumps_available))
        elif name == 'autopilot':
            steps.append(Step('autopilot', value or 300.0, 1))
        else:
            steps.append(Step('hold', value or 60.0, 1))
    return tuple(steps)


class HelmProgram:
    """Runs a programme: each call gives the rudder order [rad] and pumps for time t.

    ``rng`` drives the autopilot's course changes; everything is deterministic given it.
    """

    REACHED = 0.5 * DEG
    HOLD_AFTER_REACH = 5.0
    STEP_TIMEOUT = 180.0

    def __init__(self, steps: tuple[Step, ...], rng: np.random.Generator) -> None:
        self.steps = steps
        self.rng = rng
        self.index = 0
        self._start = 0.0
        self._phase = 0
        self._reached_at: float | None = None
        self._zig_sign = 1.0
        self._zig_count = 0
        self._heading0 = 0.0
        self._course = 0.0
        self._next_change = 0.0
        self.done = not steps

    def _advance(self, t: float, heading: float) -> None:
        self.index += 1
        self._start = t
        self._phase = 0
        self._reached_at = None
        self._zig_sign = 1.0
        self._zig_count = 0
        self._heading0 = heading
        self._course = heading
        self._next_change = t + 60.0
        self.done = self.index >= len(self.steps)

    def __call__(self, t: float, alpha: float, heading: float, yaw_rate: float) -> tuple[float, int]:
        if self.done:
            return 0.0, 1
        step = self.steps[self.index]
        if self.index == 0 and t == 0.0:
            self._heading0 = self._course = heading
            self._next_change = 60.0
        if step.kind == 'hold':
            if t - self._start >= step.value:
                self._advance(t, heading)
                return self(t, alpha, heading, yaw_rate)
            return 0.0, step.pumps
        if step.kind == 'hard_over':
            targets = (0.0, 35 * DEG, -30 * DEG, 0.0)
            target = targets[self._phase]
            if abs(alpha - target) < self.REACHED:
                if self._reached_at is None:
                    self._reached_at = t
                if t - self._reached_at >= self.HOLD_AFTER_REACH:
                    self._phase += 1
                    self._reached_at = None
                    if self._phase == len(targets):
                        self._advance(t, heading)
                        return self(t, alpha, heading, yaw_rate)
                    target = targets[self._phase]
            elif t - self._start > self.STEP_TIMEOUT * (self._phase + 1):
                self._advance(t, heading)
                return self(t, alpha, heading, yaw_rate)
            return target, step.pumps
        if step.kind == 'zigzag':
            amp = step.value * DEG
            change = heading - self._heading0
            if self._zig_sign * change >= amp:
                self._zig_sign = -self._zig_sign
                self._zig_count += 1
            if self._zig_count >= 4 or t - self._start > 600.0:
                self._advance(t, heading)
                return 0.0, 1
            return self._zig_sign * amp, step.pumps
        # autopilot: PD on heading error, limited to 10 deg, course changes every ~60-120 s.
        if t - self._start >= step.value:
            self._advance(t, heading)
            return self(t, alpha, heading, yaw_rate)
        if t >= self._next_change:
            self._course += float(self.rng.choice([-1.0, 1.0])) * float(self.rng.uniform(3.0, 15.0)) * DEG
            self._next_change = t + float(self.rng.uniform(60.0, 120.0))
        error = self._course - heading
        order = float(np.clip(1.2 * error - 12.0 * yaw_rate, -10 * DEG, 10 * DEG))
        return order, step.pumps
