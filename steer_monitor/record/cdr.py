"""Direct CDR encoders for the two messages published a hundred times a second
(``sensor_msgs/msg/JointState`` and ``std_msgs/msg/Float64MultiArray``).

Why our own: mcap-ros2-support's generic encoder walks the schema per message and costs
about 150 us each, which made it most of a replay's time; these cost a few us. They take the
same field dicts (:mod:`steer_monitor.monitor.messages`) and give the same bytes (checked
against the generic encoder in the tests). Little-endian CDR with its 4-byte encapsulation
header; alignment counts from after that header.
"""

from __future__ import annotations

import struct
from collections.abc import Callable
from typing import Any

__all__ = ['FAST_ENCODERS', 'encode_float64_multiarray', 'encode_joint_state']

_HEADER = b'\x00\x01\x00\x00'


class _Writer:
    __slots__ = ('buf',)

    def __init__(self) -> None:
        self.buf = bytearray()

    def align(self, n: int) -> None:
        pad = -len(self.buf) % n
        if pad:
            self.buf += b'\x00' * pad

    def u32(self, v: int) -> None:
        self.align(4)
        self.buf += struct.pack('<I', v)

    def i32(self, v: int) -> None:
        self.align(4)
        self.buf += struct.pack('<i', v)

    def string(self, s: str) -> None:
        raw = s.encode()
        self.u32(len(raw) + 1)
        self.buf += raw + b'\x00'

    def strings(self, items: list[str]) -> None:
        self.u32(len(items))
        for s in items:
            self.string(s)

    def doubles(self, values: list[float]) -> None:
        self.u32(len(values))
        if values:
            self.align(8)
            self.buf += struct.pack(f'<{len(values)}d', *values)

    def done(self) -> bytes:
        return _HEADER + bytes(self.buf)


def encode_joint_state(m: dict[str, Any]) -> bytes:
    w = _Writer()
    h = m['header']
    w.i32(h['stamp']['sec'])
    w.u32(h['stamp']['nanosec'])
    w.string(h['frame_id'])
    w.strings(m['name'])
    w.doubles(m['position'])
    w.doubles(m['velocity'])
    w.doubles(m['effort'])
    return w.done()


def encode_float64_multiarray(m: dict[str, Any]) -> bytes:
    w = _Writer()
    dims = m['layout']['dim']
    w.u32(len(dims))
    for d in dims:
        w.string(d['label'])
        w.u32(d['size'])
        w.u32(d['stride'])
    w.u32(m['layout']['data_offset'])
    w.doubles(m['data'])
    return w.done()


FAST_ENCODERS: dict[str, Callable[[dict[str, Any]], bytes]] = {
    'sensor_msgs/msg/JointState': encode_joint_state,
    'std_msgs/msg/Float64MultiArray': encode_float64_multiarray,
}
