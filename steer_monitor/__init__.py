"""steer_monitor: condition monitoring of ram-type (Rapson-slide) hydraulic steering gear.

The physics and estimation live in :mod:`steer_monitor.model` (pure numpy, SI units);
everything that touches files, buses or ROS is an adapter around it.
"""

from steer_monitor.errors import (
    FitError,
    ModelError,
    ParameterError,
    SteerMonitorError,
)

__version__ = '0.1.0'

__all__ = [
    'FitError',
    'ModelError',
    'ParameterError',
    'SteerMonitorError',
    '__version__',
]
