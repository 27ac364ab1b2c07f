"""Plain field dicts (:mod:`steer_monitor.monitor.messages`) -> rclpy messages."""

from __future__ import annotations

import importlib
from functools import cache
from typing import Any

from steer_monitor.errors import SteerMonitorError

__all__ = ['message_class', 'to_ros']


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


@cache
def _fields(cls: type) -> dict[str, str]:
    return dict(cls.get_fields_and_field_types())  # type: ignore[attr-defined]


def _fill(msg: Any, d: dict[str, Any]) -> Any:
    types = _fields(type(msg))
    for key, value in d.items():
        ftype = types[key]
        if isinstance(value, dict):
            _fill(getattr(msg, key), value)
        elif ftype in ('byte', 'octet') and isinstance(value, int):
            setattr(msg, key, bytes([value]))
        elif ftype.startswith('sequence<') and '/' in ftype:
            cls = message_class(ftype[len('sequence<'):].rstrip('>').split(',')[0])
            setattr(msg, key, [_fill(cls(), v) for v in value])
        else:
            setattr(msg, key, value)
    return msg


def to_ros(datatype: str, fields: dict[str, Any]) -> Any:
    """A new rclpy message of ``datatype`` with ``fields`` set (nested dicts for nested
    messages, lists of dicts for sequences of messages)."""
    return _fill(message_class(datatype)(), fields)
