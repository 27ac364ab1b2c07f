"""Plain field dicts -> rclpy messages: the typed form rclpy serializes itself, the oracle the
node's CDR (:data:`~steer_monitor.record.cdr.FAST_ENCODERS`) is checked against."""

from __future__ import annotations

from functools import cache
from typing import Any

from steer_monitor.node.rosmsg import message_class

__all__ = ['to_ros']


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
