"""Rapson-slide kinematics and forces of one ram (docs/physics.md)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from steer_monitor.model.gear import GearParams

__all__ = ['RapsonState', 'axial_of_torque', 'rapson_state', 'torque_of_axial']


@dataclass(frozen=True)
class RapsonState:
    """Geometry and forces of one ram at rudder angle alpha and tiller torque M.

    Arrays all have the broadcast shape of (alpha, torque). Magnitudes, SI.

    Attributes:
        travel: crosshead travel from mid-span, x = H tan|alpha| [m].
        near: a = L - L1, load point B to the near bushing A [m].
        far: b = L1 = L/2 + x, load point B to the far bushing E [m].
        guide_a: a_g = L_gb/2 - x, load point to the near guide-beam clamp [m].
        guide_b: b_g = L_gb - a_g [m].
        axial: Fa = |M| cos^2(alpha) / (n H) [N].
        lateral: Fl = Fa tan|alpha| [N].
        euler: F_Eu = pi^2 E J_r / L1^2 [N].
    """

    travel: NDArray[np.float64]
    near: NDArray[np.float64]
    far: NDArray[np.float64]
    guide_a: NDArray[np.float64]
    guide_b: NDArray[np.float64]
    axial: NDArray[np.float64]
    lateral: NDArray[np.float64]
    euler: NDArray[np.float64]

    @property
    def amplification(self) -> NDArray[np.float64]:
        """Deflection amplification of the axially loaded ram, 1 / (1 - Fa / F_Eu)."""
        return 1.0 / (1.0 - self.axial / self.euler)


def axial_of_torque(gear: GearParams, torque: Any, cos_a: Any) -> Any:
    """The axial force on each ram [N] the tiller torque ``torque`` [N m] needs where
    cos(alpha) is ``cos_a``: Fa = M cos^2(alpha) / (n H); floats or arrays (the one definition
    of the slide's lever, :func:`torque_of_axial` its inverse)."""
    return torque * (cos_a * cos_a) / (gear.rams * gear.stock_to_ram)


def torque_of_axial(gear: GearParams, axial: Any, cos_a: Any) -> Any:
    """The tiller torque [N m] an axial force ``axial`` on each ram [N] gives where cos(alpha)
    is ``cos_a``: M = Fa n H / cos^2(alpha); floats or arrays."""
    return axial * gear.rams * gear.stock_to_ram / (cos_a * cos_a)


def rapson_state(gear: GearParams, alpha: ArrayLike, torque: ArrayLike) -> RapsonState:
    """Kinematics and forces of one ram at rudder angle ``alpha`` [rad], tiller torque [N m]."""
    a_abs = np.abs(np.asarray(alpha, dtype=float))
    m_abs = np.abs(np.asarray(torque, dtype=float))
    a_abs, m_abs = np.broadcast_arrays(a_abs, m_abs)
    travel = gear.stock_to_ram * np.tan(a_abs)
    far = gear.bushing_span / 2.0 + travel
    near = gear.bushing_span - far
    guide_a = gear.guide_beam_span / 2.0 - travel
    guide_b = gear.guide_beam_span - guide_a
    axial = axial_of_torque(gear, m_abs, np.cos(a_abs))
    lateral = axial * np.tan(a_abs)
    euler = np.pi**2 * gear.youngs_modulus * gear.ram_inertia / far**2
    return RapsonState(travel, near, far, guide_a, guide_b, axial, lateral, euler)
