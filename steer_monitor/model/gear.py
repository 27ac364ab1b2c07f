"""Typed records of the gear's geometry and its wear clearances (SI units)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from steer_monitor.errors import ParameterError
from steer_monitor.model.torque import TorqueCurve

__all__ = ['Clearances', 'GearParams', 'ram_inertia']


def ram_inertia(d: float, d1: float) -> float:
    """Second moment of area of a hollow ram, pi (d^4 - d1^4) / 64 [m^4]; d, d1 in m."""
    return math.pi * (d**4 - d1**4) / 64.0


def _positive(name: str, value: float) -> None:
    if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
        msg = f'{name} must be a positive finite number, got {value!r}'
        raise ParameterError(msg)


@dataclass(frozen=True)
class GearParams:
    """Geometry and material of a four-cylinder, two-ram Rapson-slide gear. SI units.

    Attributes:
        stock_to_ram: H, rudder-stock axis to ram axis [m].
        bushing_span: L, distance between the two cylinder bushings A and E of one ram [m].
        ram_outer_diameter: d [m].
        ram_inner_diameter: d1 [m] (0 for a solid ram).
        youngs_modulus: E of ram and guide beam [Pa].
        guide_beam_inertia: J_gb [m^4].
        guide_beam_span: L_gb, both ends clamped [m].
        bushing_length: l_s, length of the ram bushing [m].
        rams: n, rams acting on the tiller.
        torque: tiller torque at service speed against rudder angle.
        max_rudder: largest rudder angle of the gear [rad].
        euler_amplification: multiply the ram compliances by 1 / (1 - Fa / F_Eu). The paper
            neglects it (0.31 % at 35 deg); off by default so the paper's landmarks hold.
    """

    stock_to_ram: float
    bushing_span: float
    ram_outer_diameter: float
    ram_inner_diameter: float
    youngs_modulus: float
    guide_beam_inertia: float
    guide_beam_span: float
    bushing_length: float
    rams: int
    torque: TorqueCurve = field(repr=False)
    max_rudder: float = math.radians(35.0)
    euler_amplification: bool = False

    def __post_init__(self) -> None:
        for name in ('stock_to_ram', 'bushing_span', 'ram_outer_diameter', 'youngs_modulus',
                     'guide_beam_inertia', 'guide_beam_span', 'bushing_length', 'max_rudder'):
            _positive(name, getattr(self, name))
        if not (0.0 <= self.ram_inner_diameter < self.ram_outer_diameter):
            msg = (f'ram_inner_diameter must lie in [0, ram_outer_diameter), got '
                   f'{self.ram_inner_diameter!r} with outer {self.ram_outer_diameter!r}')
            raise ParameterError(msg)
        if self.bushing_length >= self.bushing_span:
            msg = (f'bushing_length must be shorter than bushing_span (the bushings at A and E would '
                   f'overlap), got {self.bushing_length!r} with span {self.bushing_span!r}')
            raise ParameterError(msg)
        if not (isinstance(self.rams, int) and self.rams >= 1):
            msg = f'rams must be a whole number >= 1, got {self.rams!r}'
            raise ParameterError(msg)
        travel = self.stock_to_ram * math.tan(self.max_rudder)
        if travel >= min(self.bushing_span, self.guide_beam_span) / 2.0:
            msg = (f'max_rudder {math.degrees(self.max_rudder):.1f} deg moves the crosshead '
                   f'{travel:.3f} m, beyond half the bushing span or guide-beam span')
            raise ParameterError(msg)

    @property
    def ram_inertia(self) -> float:
        """J_r of the (hollow) ram [m^4]."""
        return ram_inertia(self.ram_outer_diameter, self.ram_inner_diameter)

    @property
    def ram_area(self) -> float:
        """A_r = pi d^2 / 4, the area the cylinder pressure acts on [m^2]."""
        return math.pi * self.ram_outer_diameter**2 / 4.0


@dataclass(frozen=True)
class Clearances:
    """Wear clearances [m]: ``two_z`` ram/bushing diametral (2Z), ``z_gb`` slipper/guide beam."""

    two_z: float
    z_gb: float

    def __post_init__(self) -> None:
        for name in ('two_z', 'z_gb'):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value >= 0):
                msg = f'clearance {name} must be a finite number >= 0 m, got {value!r}'
                raise ParameterError(msg)

    @classmethod
    def from_mm(cls, gap_2z_mm: float, gap_zgb_mm: float) -> Clearances:
        """Build from millimetres, as engineers give them."""
        return cls(two_z=gap_2z_mm * 1e-3, z_gb=gap_zgb_mm * 1e-3)
