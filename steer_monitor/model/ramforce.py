"""The axial force a ram's two chambers put on the tiller, from their pressures. Pure.

One definition for the vessel, replay and the analyses: a ram of piston area A_r [m^2] with
its starboard chamber at p_stbd and its port chamber at p_port [Pa] pushes with
F = A_r (p_stbd - p_port) [N] (positive towards port). :func:`ram_force` takes floats or
arrays alike; :data:`ram_force_compiled` is the same function compiled for the kernels that
call it element by element (the same operations, so the same bits); :func:`ram_forces` the
two rams' forces from the four pressures in the inputs' order.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from steer_monitor.compiled import njit

__all__ = ['ram_force', 'ram_force_compiled', 'ram_forces']


def ram_force(area: Any, p_stbd: Any, p_port: Any) -> Any:
    """A_r (p_stbd - p_port) [N] of a ram of piston area ``area`` [m^2], pressures [Pa];
    floats or arrays."""
    return area * (p_stbd - p_port)


#: :func:`ram_force` compiled (for numba kernels)
ram_force_compiled = njit(cache=True, nogil=True)(ram_force)


def ram_forces(area: float, pressures: NDArray[np.float64]) -> NDArray[np.float64]:
    """The two rams' forces (n, 2) [N] from the four pressures (n, 4) [Pa] in the inputs'
    order (ram 1 starboard and port, ram 2 starboard and port)."""
    p = pressures
    return np.stack([ram_force(area, p[:, 0], p[:, 1]), ram_force(area, p[:, 2], p[:, 3])], axis=1)
