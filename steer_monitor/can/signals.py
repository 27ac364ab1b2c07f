"""The signal map: which PGN, field, instance and source feeds which input of the monitor.

Inputs (SI values): ``rudder_angle`` and ``rudder_order`` [rad, + starboard], the four
cylinder pressures ``pressure_r{1,2}_{stbd,port}`` [Pa], ``ship_speed`` [m/s] and
``oil_temperature`` [K]. Another vessel changes the DBC and this map (in its parameters
file), not the code.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from steer_monitor.can.codec import CanDatabase
from steer_monitor.can.timejump import DEFAULT_MAX_JUMP_NS
from steer_monitor.errors import ParameterError

__all__ = ['INPUTS', 'PRESSURE_INPUTS', 'SignalMap', 'SignalSpec']

INPUTS = ('rudder_angle', 'rudder_order', 'pressure_r1_stbd', 'pressure_r1_port',
          'pressure_r2_stbd', 'pressure_r2_port', 'ship_speed', 'oil_temperature')
PRESSURE_INPUTS = INPUTS[2:6]
REQUIRED = ('rudder_angle',) + PRESSURE_INPUTS


@dataclass(frozen=True)
class SignalSpec:
    """One input: where it comes from and what values are physically possible (SI)."""

    name: str
    pgn: int
    field: str
    instance: int
    source: int
    low: float
    high: float
    rate_hz: float


@dataclass(frozen=True)
class SignalMap:
    """The inputs carried on this bus, checked against a DBC."""

    specs: tuple[SignalSpec, ...]
    #: a frame more than this from the frames around it is a time jump [ns]
    max_jump_ns: int = DEFAULT_MAX_JUMP_NS

    def __post_init__(self) -> None:
        by_pgn: dict[int, list[SignalSpec]] = {}
        for s in self.specs:
            by_pgn.setdefault(s.pgn, []).append(s)
        object.__setattr__(self, '_by_pgn', {k: tuple(v) for k, v in by_pgn.items()})

    def for_pgn(self, pgn: int) -> tuple[SignalSpec, ...]:
        return self._by_pgn.get(pgn, ())  # type: ignore[attr-defined]

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(s.name for s in self.specs)

    def check(self, db: CanDatabase) -> None:
        """Every mapped PGN and field exists in the DBC, with instance/source fields where
        the map matches on them."""
        for s in self.specs:
            layout = db.message(s.pgn)
            if layout is None:
                msg = f'parameter signals.{s.name}.pgn: PGN {s.pgn} is not in the DBC {db.path}'
                raise ParameterError(msg)
            if s.field not in layout.fields:
                msg = (f'parameter signals.{s.name}.field: {layout.name} has no field {s.field!r} '
                       f'(fields: {", ".join(layout.fields)})')
                raise ParameterError(msg)
            for key, value, fname in (('instance', s.instance, 'Instance'), ('source', s.source, 'Source')):
                if value >= 0 and fname not in layout.fields:
                    msg = f'parameter signals.{s.name}.{key}: {layout.name} has no {fname} field to match'
                    raise ParameterError(msg)

    @classmethod
    def from_params(cls, p: Mapping[str, Any]) -> SignalMap:
        """Build from validated parameters (see :mod:`steer_monitor.params`)."""
        rudder = math.radians(p['can.max_abs_rudder_deg'])
        p_lo, p_hi = p['can.min_pressure_bar'] * 1e5, p['can.max_pressure_bar'] * 1e5
        limits = {'rudder_angle': (-rudder, rudder), 'rudder_order': (-rudder, rudder),
                  'ship_speed': (-15.0, 40.0), 'oil_temperature': (223.15, 473.15)}
        specs = []
        for name in INPUTS:
            pgn = p[f'signals.{name}.pgn']
            if pgn == 0:
                if name in REQUIRED:
                    msg = f'parameter signals.{name}.pgn: {name} is required, it cannot be 0'
                    raise ParameterError(msg)
                continue
            lo, hi = limits.get(name, (p_lo, p_hi))
            specs.append(SignalSpec(name, pgn, p[f'signals.{name}.field'], p[f'signals.{name}.instance'],
                                    p[f'signals.{name}.source'], lo, hi, p[f'signals.{name}.rate_hz']))
        return cls(tuple(specs), round(p['can.max_time_jump_s'] * 1e9))
