"""A direct CDR encoder for the message published a hundred times a second
(``sensor_msgs/msg/JointState``: the rudder, the load sharing, the clearances).

Why our own: mcap-ros2-support's generic encoder walks the schema per message and costs
about 150 us each, which made it most of a replay's time; this costs a few us. It takes the
same field dicts (:mod:`steer_monitor.monitor.messages`) and gives the same bytes (checked
against the generic encoder in the tests; rclpy's Fast-CDR reads them back, empty sequences
included, though it pads those differently when it writes). Little-endian CDR with its 4-byte encapsulation
header; alignment counts from after that header.
"""

from __future__ import annotations

import struct
from collections.abc import Callable
from typing import Any

__all__ = ['FAST_ENCODERS', 'encode_joint_state']

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


FAST_ENCODERS: dict[str, Callable[[dict[str, Any]], bytes]] = {
    'sensor_msgs/msg/JointState': encode_joint_state,
}
