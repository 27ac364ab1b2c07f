"""Helm programs: what the wheel or the autopilot orders, step by step.

A program is a comma-separated list of steps run one after the other, each ``name`` or
``name:value``:

* ``hard_over_2`` / ``hard_over_1``: SOLAS test with two / one pump(s): midships, hard over
  to 35 deg starboard, then to 30 deg port, then midships; each order held until reached
  plus a few seconds;
* ``zigzag_N``: zigzag manoeuvre, rudder +-N deg (1..35, e.g. ``zigzag_10``), switched when
  the heading change reaches the same angle (four switches);
* ``autopilot[:seconds]``: course keeping (default 300 s), with course changes, through the
  gear's proportional (floating-lever) valve: smooth rudder motion;
* ``autopilot_db[:seconds]``: course keeping as a track-pilot does it on solenoid valves
  (default 300 s): the course drifts slowly, the heading carries the yaw of the waves, and a
  new order goes to the gear only when the pilot's wish leaves a 0.5 deg dead band; the
  valves open fully or not at all, so the rudder moves in short steps with pauses
  (stop-start motion that looks steady over a 0.3 s window);
* ``hold[:seconds]``: rudder held at midships (default 60 s);
* ``hold_at:DEG[/SECONDS]``: rudder put to DEG (negative to port) and held (default 45 s);
* ``speed:KN``: the engine order changes; the ship's speed goes to KN with the hull's
  first-order lag (``SPEED_TAU_S``), so it steps and then drifts;
* ``pumps:N``: the pumps that the following autopilot and zigzag steps run (1 or 2);
* ``voyage``: a fixed mixed 25-minute voyage (autopilot, hard-overs, zigzags, holds);
* ``realistic[:seconds]``: a ship's operation drawn from the seed (default 1500 s): speed
  changes between manoeuvres (8 to 17 kn), pump changes, dead-band autopilot stretches,
  holds at odd angles, zigzags of several amplitudes and hard-overs, mixed at random.

Pure: the programme runs inside the plant's time loop (zigzag and autopilot close the loop
on heading).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from steer_monitor.errors import ParameterError

__all__ = ['PROGRAMS', 'REALISTIC_S', 'SPEED_TAU_S', 'HelmProgram', 'Step', 'parse_program', 'realistic_program']

DEG = math.pi / 180.0

PROGRAMS = ('hard_over_2', 'hard_over_1', 'zigzag_N', 'autopilot', 'autopilot_db', 'hold', 'hold_at',
            'speed', 'pumps', 'voyage', 'realistic')
SPEED_TAU_S = 40.0           # the hull's speed lag after an engine order [s]
REALISTIC_S = 1500.0         # a realistic voyage's default length [s]

VOYAGE = ('autopilot:240,hard_over_2,autopilot:180,zigzag_10,hold:30,autopilot:180,'
          'zigzag_20,autopilot:120,hard_over_1,hold:30')


@dataclass(frozen=True)
class Step:
    """One programme step: kind, its numeric value (seconds or degrees), pumps to run, and
    a second value where the kind takes one (``hold_at``: seconds)."""

    kind: str
    value: float
    pumps: int
    extra: float = 0.0


def _number(part: str, arg: str, *, positive: bool = True) -> float:
    try:
        value = float(arg)
    except ValueError:
        value = math.nan
    if not math.isfinite(value) or (positive and value <= 0):
        need = 'a positive number' if positive else 'a number'
        msg = f'helm programme {part!r}: the value after ":" must be {need}'
        raise ParameterError(msg)
    return value


def parse_program(text: str, pumps_available: int = 2, rng: np.random.Generator | None = None) -> tuple[Step, ...]:
    """Steps of a programme text such as ``'hard_over_2,zigzag_10,autopilot:600'``.
    ``realistic`` draws its steps from ``rng`` (a fixed seed when None)."""
    if not isinstance(text, str) or not text.strip():
        msg = f'empty helm programme (choose from: {", ".join(PROGRAMS)})'
        raise ParameterError(msg)
    steps: list[Step] = []
    pumps = pumps_available
    for part in text.split(','):
        part = part.strip()
        name, _, arg = part.partition(':')
        if name == 'voyage':
            steps.extend(parse_program(VOYAGE, pumps_available))
            continue
        if name == 'realistic':
            length = _number(part, arg) if arg else REALISTIC_S
            gen = rng if rng is not None else np.random.default_rng(0)
            steps.extend(parse_program(realistic_program(gen, length, pumps_available), pumps_available))
            continue
        zig = name.startswith('zigzag_')
        if name not in PROGRAMS and not zig:
            msg = f'unknown helm programme {name!r} (choose from: {", ".join(PROGRAMS)})'
            raise ParameterError(msg)
        if name.startswith('hard_over'):
            n = int(name[-1])
            if n > pumps_available:
                msg = f'helm programme {name}: the gear has only {pumps_available} pump(s)'
                raise ParameterError(msg)
            steps.append(Step('hard_over', 0.0, n))
        elif zig:
            amp = _number(part, name[len('zigzag_'):])
            if amp > 35:
                msg = f'helm programme {part!r}: a zigzag of at most 35 deg'
                raise ParameterError(msg)
            steps.append(Step('zigzag', amp, pumps))
        elif name in ('autopilot', 'autopilot_db'):
            steps.append(Step(name, _number(part, arg) if arg else 300.0, 1 if name == 'autopilot' else pumps))
        elif name == 'hold':
            steps.append(Step('hold', _number(part, arg) if arg else 60.0, 1))
        elif name == 'hold_at':
            angle, _, secs = arg.partition('/')
            deg = _number(part, angle, positive=False)
            if abs(deg) > 35:
                msg = f'helm programme {part!r}: the rudder goes to at most 35 deg'
                raise ParameterError(msg)
            steps.append(Step('hold_at', deg, pumps, _number(part, secs) if secs else 45.0))
        elif name == 'speed':
            kn = _number(part, arg, positive=False)
            if not 0 <= kn <= 40:
                msg = f'helm programme {part!r}: a speed in 0..40 kn'
                raise ParameterError(msg)
            steps.append(Step('speed', kn, pumps))
        else:  # pumps
            n = _number(part, arg)
            if n not in (1.0, 2.0) or n > pumps_available:
                msg = f'helm programme {part!r}: 1 or {pumps_available} pump(s)'
                raise ParameterError(msg)
            pumps = int(n)
            steps.append(Step('pumps', n, pumps))
    return tuple(steps)


def realistic_program(rng: np.random.Generator, length_s: float = REALISTIC_S, pumps_available: int = 2) -> str:
    """A ship's operation of about ``length_s`` seconds as programme text, drawn from ``rng``:
    a speed change (8..17 kn) before most manoeuvres, the pump count changed now and then,
    and manoeuvres mixed at random (dead-band autopilot most of the time, holds at odd
    angles, zigzags of 5..20 deg, at most two hard-overs)."""
    parts = [f'speed:{rng.uniform(8.0, 17.0):.1f}', 'autopilot_db:90']
    t = 90.0
    hard_overs = 0
    while t < length_s:
        if rng.random() < 0.7:
            parts.append(f'speed:{rng.uniform(8.0, 17.0):.1f}')
        if pumps_available > 1 and rng.random() < 0.4:
            parts.append(f'pumps:{int(rng.integers(1, pumps_available + 1))}')
        kind = rng.choice(['autopilot_db', 'autopilot_db', 'autopilot', 'hold_at', 'zigzag', 'hard_over', 'hold'])
        if kind == 'hard_over' and hard_overs >= 2:
            kind = 'autopilot_db'
        if kind in ('autopilot_db', 'autopilot'):
            secs = float(rng.uniform(60.0, 180.0))
            parts.append(f'{kind}:{secs:.0f}')
            t += secs
        elif kind == 'hold_at':
            deg = float(rng.choice([-1.0, 1.0]) * rng.uniform(3.0, 25.0))
            secs = float(rng.uniform(20.0, 60.0))
            parts.append(f'hold_at:{deg:.1f}/{secs:.0f}')
            t += secs + 15.0
        elif kind == 'zigzag':
            parts.append(f'zigzag_{int(rng.choice([5, 10, 15, 20]))}')
            t += 150.0
        elif kind == 'hard_over':
            hard_overs += 1
            parts.append(f'hard_over_{int(rng.integers(1, pumps_available + 1))}')
            t += 110.0
        else:
            secs = float(rng.uniform(10.0, 40.0))
            parts.append(f'hold:{secs:.0f}')
            t += secs
    return ','.join(parts)


class HelmProgram:
    """Runs a programme: each call gives the rudder order [rad] and pumps for time t.

    ``rng`` drives the autopilot's course changes; everything is deterministic given it.
    """

    REACHED = 0.5 * DEG
    HOLD_AFTER_REACH = 5.0
    STEP_TIMEOUT = 180.0

    DB_DEAD_BAND = 0.5 * DEG      # autopilot_db: the pilot's dead band on its order
    DB_ORDER_LIMIT = 15 * DEG
    WAVE_PERIOD_S = 9.0           # autopilot_db: yaw of the waves in the heading it sees
    WAVE_YAW = 0.6 * DEG

    def __init__(self, steps: tuple[Step, ...], rng: np.random.Generator) -> None:
        self.steps = steps
        self.rng = rng
        self.speed_target: float | None = None    # [kn] after a ``speed`` step
        self.solenoid = False                     # the current step drives the gear's solenoid valves
        self._db_order = 0.0
        self._wave_phase = 0.0
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

    def _dead_band_pilot(self, t: float, alpha: float, heading: float, yaw_rate: float, step: Step
                         ) -> tuple[float, int]:
        if t - self._start >= step.value:
            self._advance(t, heading)
            return self(t, alpha, heading, yaw_rate)
        if t == self._start:
            self._db_order = alpha
            self._wave_phase = float(self.rng.uniform(0.0, 2 * math.pi))
            self._course = heading
        if t >= self._next_change:      # the track drifts: small course changes
            self._course += float(self.rng.normal(0.0, 2.0)) * DEG
            self._next_change = t + float(self.rng.uniform(20.0, 60.0))
        w = 2 * math.pi / self.WAVE_PERIOD_S
        seen = heading + self.WAVE_YAW * math.sin(w * t + self._wave_phase)
        seen_rate = yaw_rate + self.WAVE_YAW * w * math.cos(w * t + self._wave_phase)
        wish = float(np.clip(1.2 * (self._course - seen) - 12.0 * seen_rate, -self.DB_ORDER_LIMIT, self.DB_ORDER_LIMIT))
        if abs(wish - self._db_order) > self.DB_DEAD_BAND:
            self._db_order = wish
        return self._db_order, step.pumps

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
        self.solenoid = step.kind == 'autopilot_db'
        if step.kind in ('speed', 'pumps'):
            if step.kind == 'speed':
                self.speed_target = step.value
            self._advance(t, heading)
            return self(t, alpha, heading, yaw_rate)
        if step.kind == 'hold_at':      # held for step.extra seconds once reached
            if self._reached_at is None and abs(alpha - step.value * DEG) < self.REACHED:
                self._reached_at = t
            if ((self._reached_at is not None and t - self._reached_at >= step.extra)
                    or t - self._start > step.extra + self.STEP_TIMEOUT):
                self._advance(t, heading)
                return self(t, alpha, heading, yaw_rate)
            return step.value * DEG, step.pumps
        if step.kind == 'autopilot_db':
            return self._dead_band_pilot(t, alpha, heading, yaw_rate, step)
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
