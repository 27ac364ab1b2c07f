"""The rclpy message classes of the published datatypes (the node publishes their CDR,
:data:`~steer_monitor.record.cdr.FAST_ENCODERS`)."""

from __future__ import annotations

import importlib
from functools import cache

from steer_monitor.errors import SteerMonitorError

__all__ = ['message_class']


@cache
def message_class(datatype: str) -> type:
    """``pkg/msg/Type`` or ``pkg/Type`` -> the rclpy message class. A package that is not
    built or not on the paths raises :class:`SteerMonitorError` naming it."""
    parts = datatype.split('/')
    pkg, name = parts[0], parts[-1]
    try:
        module = importlib.import_module(f'{pkg}.msg')
    except ImportError as exc:
        raise SteerMonitorError(f'message type {datatype}: cannot import {pkg}: {exc} (is ROS 2 sourced? '
                                'source /opt/ros/<distro>/setup.bash)') from None
    try:
        return getattr(module, name)
    except AttributeError:
        raise SteerMonitorError(f'message type {datatype}: {pkg} has no message {name} '
                                '(an older build of the package? rebuild it)') from None
