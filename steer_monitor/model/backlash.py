"""Backlash of a kinematic chain from the fits of its joints (paper 000).

Reduced to the actuator rod (the ram)::

    L  = L_act + sum(c_i L_i)
    dL = sqrt(dL_act^2 + sum(c_i^2 dL_i^2))    probable (root-sum-square)
    dL = dL_act + sum(c_i dL_i)                 worst case

where L_i and dL_i are each joint's mean clearance and deviation and c_i its transmission
coefficient (rod displacement per unit clearance of the joint). Reduced to the rudder
angle by dividing by the reduced arm; for a Rapson slide the rod moves H / cos^2(alpha) per
radian, so the arm is smallest, and the angular backlash largest, at midships.

Lengths in metres, angles in radians.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from steer_monitor.errors import ParameterError
from steer_monitor.model.isofits import GRADES, Clearance, Fit, Tolerance, clearance_of

__all__ = [
    'BacklashResult',
    'ChainJoint',
    'GradeCheck',
    'chain_backlash',
    'grade_for_limit',
    'rapson_arm',
]


def rapson_arm(stock_to_ram: float, alpha: ArrayLike) -> NDArray[np.float64]:
    """Reduced arm of a Rapson slide, H / cos^2(alpha) [m of rod per rad of rudder]."""
    return stock_to_ram / np.cos(np.asarray(alpha, dtype=float)) ** 2


@dataclass(frozen=True)
class ChainJoint:
    """One joint of the chain: its clearance and transmission coefficient c.

    ``fit`` is kept when the joint was given by an ISO designation, so the grade can be
    changed by :func:`grade_for_limit`; joints given by deviations keep their clearance.
    """

    name: str
    clearance: Clearance
    coefficient: float = 1.0
    fit: Fit | None = None

    def __post_init__(self) -> None:
        if not (math.isfinite(self.coefficient) and self.coefficient >= 0):
            msg = f'joint {self.name!r}: transmission coefficient must be >= 0, got {self.coefficient!r}'
            raise ParameterError(msg)

    @classmethod
    def from_fit(cls, name: str, fit: Fit, coefficient: float = 1.0) -> ChainJoint:
        """A joint made to an ISO 286 fit."""
        return cls(name, fit.clearance, coefficient, fit)

    @classmethod
    def from_deviations(cls, name: str, nominal: float, hole: tuple[float, float],
                        shaft: tuple[float, float], coefficient: float = 1.0) -> ChainJoint:
        """A joint from its hole and shaft limit deviations (upper, lower), all in metres."""
        h = Tolerance.from_deviations(nominal, hole[0], hole[1], f'{name} hole')
        s = Tolerance.from_deviations(nominal, shaft[0], shaft[1], f'{name} shaft')
        return cls(name, clearance_of(h, s), coefficient, None)

    def with_grade(self, grade: int) -> ChainJoint:
        """This joint with its fit at IT ``grade`` (unchanged when given by deviations)."""
        if self.fit is None:
            return self
        return ChainJoint.from_fit(self.name, self.fit.with_grade(grade), self.coefficient)


@dataclass(frozen=True)
class BacklashResult:
    """Backlash of the chain reduced to the rod [m]: mean and its two deviations."""

    mean: float
    probable_dev: float
    worst_dev: float

    def angle(self, arm: ArrayLike) -> dict[str, NDArray[np.float64]]:
        """Backlash reduced to the output axis by the arm [m/rad]: mean, probable and worst
        bounds, each in radians."""
        arm = np.asarray(arm, dtype=float)
        return {
            'mean': self.mean / arm,
            'probable_min': (self.mean - self.probable_dev) / arm,
            'probable_max': (self.mean + self.probable_dev) / arm,
            'worst_max': (self.mean + self.worst_dev) / arm,
        }


def chain_backlash(joints: Sequence[ChainJoint], actuator_mean: float = 0.0,
                   actuator_dev: float = 0.0) -> BacklashResult:
    """Backlash of the chain at the actuator rod [m], paper 000's L and dL."""
    if not (math.isfinite(actuator_mean) and math.isfinite(actuator_dev) and actuator_dev >= 0):
        msg = (f'actuator backlash must be finite with a deviation >= 0, got mean '
               f'{actuator_mean!r} m, deviation {actuator_dev!r} m')
        raise ParameterError(msg)
    c = np.array([j.coefficient for j in joints], dtype=float)
    means = np.array([j.clearance.mean for j in joints], dtype=float)
    dev = np.array([j.clearance.probable_dev for j in joints], dtype=float)
    worst = np.array([j.clearance.worst_dev for j in joints], dtype=float)
    return BacklashResult(
        mean=float(actuator_mean + np.sum(c * means)),
        probable_dev=float(math.sqrt(actuator_dev**2 + np.sum((c * dev) ** 2))),
        worst_dev=float(actuator_dev + np.sum(c * worst)),
    )


@dataclass(frozen=True)
class GradeCheck:
    """Backlash at the output with every fitted joint at IT ``grade`` [rad]."""

    grade: int
    probable_max: float
    worst_max: float
    within: bool


def grade_for_limit(joints: Sequence[ChainJoint], limit: float, arm: float,
                    actuator_mean: float = 0.0, actuator_dev: float = 0.0,
                    basis: str = 'worst') -> tuple[int | None, list[GradeCheck]]:
    """The coarsest IT grade that keeps the chain's output backlash within ``limit`` [rad].

    Every joint given by a fit is set to the same grade (hole and shaft); joints given by
    deviations and the actuator stay as they are. ``arm`` is the reduced arm [m/rad] to
    check at (the smallest, for the worst case). ``basis`` is ``'worst'`` (mean + sum of
    deviations) or ``'probable'`` (mean + root-sum-square).

    Returns (grade or None when no supported grade suffices, the check of every grade).
    """
    if basis not in ('worst', 'probable'):
        msg = f"basis must be 'worst' or 'probable', got {basis!r}"
        raise ParameterError(msg)
    if not (math.isfinite(limit) and limit > 0):
        msg = f'backlash limit must be a positive angle, got {limit!r} rad'
        raise ParameterError(msg)
    checks = []
    for grade in GRADES:
        result = chain_backlash([j.with_grade(grade) for j in joints], actuator_mean, actuator_dev)
        ang = result.angle(arm)
        value = float(ang['worst_max'] if basis == 'worst' else ang['probable_max'])
        checks.append(GradeCheck(grade, float(ang['probable_max']), float(ang['worst_max']),
                                 value <= limit))
    passing = [c.grade for c in checks if c.within]
    return (max(passing) if passing else None), checks
