"""The signal map: which PGN, field, instance and source feeds which input of the monitor.

A frame feeds an input when its PGN is the input's and, for each of these the input names,
its ``Instance`` field, its ``Source`` field (PGN 130314/130316: what is measured), the
CAN source address it came from (``address``) and the device holding that address
(``device_name``, the 64-bit NAME of ISO address claims: the device is followed when it
takes another address) match. A frame whose instance is 255 ("not available": a sender of
one instance) feeds an input bound to its device (by address or NAME) whatever instance
the input names.

Inputs (SI values): ``rudder_angle`` and ``rudder_order`` [rad, + starboard], the four
cylinder pressures ``pressure_r{1,2}_{stbd,port}`` [Pa], ``ship_speed`` [m/s] and
``oil_temperature`` [K]. Another vessel changes the DBC and this map (in its parameters
file), not the code.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from steer_monitor.can.codec import CanDatabase
from steer_monitor.can.devices import parse_name
from steer_monitor.can.timejump import DEFAULT_MAX_JUMP_NS
from steer_monitor.errors import ParameterError
from steer_monitor.model.inputs import INPUTS, PRESSURE_INPUTS, REQUIRED

__all__ = ['INPUTS', 'PRESSURE_INPUTS', 'SignalMap', 'SignalSpec']



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
    #: CAN source address to match (-1: any); with ``device_name``, where that device is
    #: until an address claim says otherwise
    address: int = -1
    #: NAME of the device to match, wherever it is on the bus (None: any)
    device_name: int | None = None

    @property
    def bound(self) -> bool:
        """Bound to one device (so instance 255 from it is this input's)."""
        return self.address >= 0 or self.device_name is not None


@dataclass(frozen=True)
class SignalMap:
    """The inputs carried on this bus, checked against a DBC."""

    specs: tuple[SignalSpec, ...]
    #: a frame more than this from the frames around it is a time jump [ns]
    max_jump_ns: int = DEFAULT_MAX_JUMP_NS
    #: the distinct device NAMEs the map matches on
    device_names: tuple[int, ...] = field(init=False, default=())

    def __post_init__(self) -> None:
        by_pgn: dict[int, list[SignalSpec]] = {}
        for s in self.specs:
            by_pgn.setdefault(s.pgn, []).append(s)
        object.__setattr__(self, '_by_pgn', {k: tuple(v) for k, v in by_pgn.items()})
        names = tuple(dict.fromkeys(s.device_name for s in self.specs if s.device_name is not None))
        object.__setattr__(self, 'device_names', names)

    def for_pgn(self, pgn: int) -> tuple[SignalSpec, ...]:
        return self._by_pgn.get(pgn, ())  # type: ignore[attr-defined]

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(s.name for s in self.specs)

    def period_ns(self, name: str) -> int | None:
        """The configured period of input ``name`` [ns] (None: not mapped)."""
        spec = next((s for s in self.specs if s.name == name), None)
        return None if spec is None else int(round(1e9 / spec.rate_hz))

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
            device = p.get(f'signals.{name}.device_name', '')
            try:
                device_name = parse_name(device) if device else None
            except ValueError as exc:
                msg = f'parameter signals.{name}.device_name: {exc}'
                raise ParameterError(msg) from None
            specs.append(SignalSpec(name, pgn, p[f'signals.{name}.field'], p[f'signals.{name}.instance'],
                                    p[f'signals.{name}.source'], lo, hi, p[f'signals.{name}.rate_hz'],
                                    p.get(f'signals.{name}.address', -1), device_name))
        return cls(tuple(specs), round(p['can.max_time_jump_s'] * 1e9))
