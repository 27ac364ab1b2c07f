"""Reading a kinematic-chain YAML file (the input of ``steer-monitor backlash``).

Format (lengths in mm, angles in degrees; SI records come out)::

    chain:
      name: R-18 ram to rudder stock
      stock_to_ram_m: 0.600          # H, for the Rapson arm H / cos^2(alpha)
      max_rudder_deg: 35.0
      actuator: {backlash_mean_mm: 0.0, backlash_dev_mm: 0.0}
      joints:
        - {name: crosshead pin, fit: 180 H7/f7, coefficient: 1.0}
        - {name: tiller slot, nominal_mm: 300.0, hole_mm: [0.130, 0.0],
           shaft_mm: [-0.056, -0.186], coefficient: 1.0}
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from steer_monitor.errors import ParameterError
from steer_monitor.model.backlash import ChainJoint
from steer_monitor.model.isofits import parse_fit
from steer_monitor.yamlfile import load_yaml

__all__ = ['Chain', 'load_chain']


@dataclass(frozen=True)
class Chain:
    """A chain read from file: its joints, actuator backlash [m] and Rapson geometry [m, rad]."""

    name: str
    joints: tuple[ChainJoint, ...]
    actuator_mean: float
    actuator_dev: float
    stock_to_ram: float
    max_rudder: float


def _number(where: str, value: Any, minimum: float | None = None) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        msg = f'{where}: expected a number, got {value!r}'
        raise ParameterError(msg)
    if minimum is not None and value < minimum:
        msg = f'{where}: must be >= {minimum:g}, got {value!r}'
        raise ParameterError(msg)
    return float(value)


def _pair(where: str, value: Any) -> tuple[float, float]:
    if not isinstance(value, (list, tuple)) or len(value) != 2:
        msg = f'{where}: expected [upper, lower] deviations in mm, got {value!r}'
        raise ParameterError(msg)
    return _number(f'{where}[0]', value[0]) * 1e-3, _number(f'{where}[1]', value[1]) * 1e-3


def _joint(i: int, item: Any) -> ChainJoint:
    where = f'chain.joints[{i}]'
    if not isinstance(item, Mapping):
        msg = f'{where}: expected a mapping with name and fit (or nominal_mm, hole_mm, shaft_mm)'
        raise ParameterError(msg)
    allowed = {'name', 'fit', 'coefficient', 'nominal_mm', 'hole_mm', 'shaft_mm'}
    extra = sorted(set(item) - allowed)
    if extra:
        msg = f'{where}: unknown key {extra[0]!r}'
        raise ParameterError(msg)
    name = str(item.get('name', f'joint {i + 1}'))
    coefficient = _number(f'{where}.coefficient', item.get('coefficient', 1.0), 0.0)
    if 'fit' in item:
        if {'nominal_mm', 'hole_mm', 'shaft_mm'} & set(item):
            msg = f'{where}: give either fit or nominal_mm/hole_mm/shaft_mm, not both'
            raise ParameterError(msg)
        try:
            fit = parse_fit(item['fit'])
        except ValueError as exc:
            msg = f'{where}.fit: {exc}'
            raise ParameterError(msg) from exc
        return ChainJoint.from_fit(name, fit, coefficient)
    missing = [k for k in ('nominal_mm', 'hole_mm', 'shaft_mm') if k not in item]
    if missing:
        msg = f'{where}: missing {missing[0]} (or give an ISO fit as fit: "180 H7/f7")'
        raise ParameterError(msg)
    nominal = _number(f'{where}.nominal_mm', item['nominal_mm'], 0.0) * 1e-3
    try:
        return ChainJoint.from_deviations(name, nominal, _pair(f'{where}.hole_mm', item['hole_mm']),
                                          _pair(f'{where}.shaft_mm', item['shaft_mm']), coefficient)
    except ValueError as exc:
        msg = f'{where}: {exc}'
        raise ParameterError(msg) from exc


def load_chain(path: str | Path) -> Chain:
    """Read and check a chain file; errors name the file and the bad key."""
    path = Path(path)
    doc = load_yaml(path, 'chain file')
    try:
        if not isinstance(doc, Mapping) or not isinstance(doc.get('chain'), Mapping):
            msg = 'expected a top-level "chain:" mapping'
            raise ParameterError(msg)
        c = doc['chain']
        extra = sorted(set(c) - {'name', 'stock_to_ram_m', 'max_rudder_deg', 'actuator', 'joints'})
        if extra:
            msg = f'chain: unknown key {extra[0]!r}'
            raise ParameterError(msg)
        joints = c.get('joints')
        if not isinstance(joints, list) or not joints:
            msg = 'chain.joints: expected a non-empty list of joints'
            raise ParameterError(msg)
        act = c.get('actuator', {}) or {}
        if not isinstance(act, Mapping):
            msg = 'chain.actuator: expected a mapping with backlash_mean_mm and backlash_dev_mm'
            raise ParameterError(msg)
        if 'stock_to_ram_m' not in c:
            msg = 'chain.stock_to_ram_m: missing (H, rudder-stock axis to ram axis, m)'
            raise ParameterError(msg)
        h = _number('chain.stock_to_ram_m', c['stock_to_ram_m'], 0.0)
        if h <= 0:
            msg = f'chain.stock_to_ram_m: must be > 0, got {h!r}'
            raise ParameterError(msg)
        max_deg = _number('chain.max_rudder_deg', c.get('max_rudder_deg', 35.0), 0.0)
        if not 0 < max_deg < 90:
            msg = f'chain.max_rudder_deg: must lie in (0, 90), got {max_deg!r}'
            raise ParameterError(msg)
        return Chain(
            name=str(c.get('name', path.stem)),
            joints=tuple(_joint(i, j) for i, j in enumerate(joints)),
            actuator_mean=_number('chain.actuator.backlash_mean_mm', act.get('backlash_mean_mm', 0.0)) * 1e-3,
            actuator_dev=_number('chain.actuator.backlash_dev_mm', act.get('backlash_dev_mm', 0.0), 0.0) * 1e-3,
            stock_to_ram=h,
            max_rudder=math.radians(max_deg),
        )
    except ParameterError as exc:
        msg = f'{path}: {exc}'
        raise ParameterError(msg) from exc
