"""The observed inputs: their names and the records that carry their values. Pure.

The vocabulary the physics, the estimator and the live monitor share with the layers that
read a bus or a log: those make ``Sample`` and ``Series`` of these inputs; nothing here
knows where they came from.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

__all__ = ['FAST_INPUTS', 'INPUTS', 'PRESSURE_INPUTS', 'REQUIRED', 'SLOW_INPUTS', 'Sample', 'Series', 'SignalSet']

#: every input the monitor reads, SI values: the rudder angle and the helm's order [rad], the
#: four cylinder pressures [Pa] (ram 1 and ram 2, the chamber that drives to starboard and to
#: port), the ship's speed through the water [m/s] and the steering gear's oil temperature [K]
INPUTS = ('rudder_angle', 'rudder_order', 'pressure_r1_stbd', 'pressure_r1_port',
          'pressure_r2_stbd', 'pressure_r2_port', 'ship_speed', 'oil_temperature')
PRESSURE_INPUTS = INPUTS[2:6]
#: what the load-sharing model and the estimator cannot do without
REQUIRED = ('rudder_angle',) + PRESSURE_INPUTS
#: sampled at 10-20 Hz (the steering gear's own signals) and at 0.5-1 Hz (the ship's)
FAST_INPUTS = INPUTS[:6]
SLOW_INPUTS = INPUTS[6:]


@dataclass(frozen=True, slots=True)
class Sample:
    """One decoded value: time [ns], input name, value [SI]."""

    t_ns: int
    signal: str
    value: float


@dataclass(frozen=True)
class Series:
    """One input over time: ``t_ns`` int64 (n,) [ns], ``value`` float64 (n,) [SI]."""

    t_ns: NDArray[np.int64]
    value: NDArray[np.float64]

    def __len__(self) -> int:
        return int(self.t_ns.shape[0])


SignalSet = dict[str, Series]
