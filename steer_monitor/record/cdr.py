"""Direct CDR encoders for the messages published a hundred times a second
(``sensor_msgs/msg/JointState``: the rudder and the load sharing) and with each second's
diagnostics (``diagnostic_msgs/msg/DiagnosticArray``, ``sensor_msgs/msg/JointState``: the
clearances, ``std_msgs/msg/String``).

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

__all__ = ['FAST_ENCODERS', 'MAX_STRINGS', 'encode_diagnostic_array', 'encode_joint_state', 'encode_string']

_HEADER = b'\x00\x01\x00\x00'
_U32 = struct.Struct('<I')

#: the CDR strings made so far, by text (a diagnostics round's names, keys and most of its
#: values recur every second): at most MAX_STRINGS kept, the others made each time
_STRINGS: dict[str, bytes] = {}
MAX_STRINGS = 4096


def _string(s: str) -> bytes:
    """A CDR string after its alignment: its length with the NUL (uint32), the UTF-8 bytes, the NUL."""
    got = _STRINGS.get(s)
    if got is None:
        raw = s.encode()
        got = _U32.pack(len(raw) + 1) + raw + b'\x00'
        if len(_STRINGS) < MAX_STRINGS:
            _STRINGS[s] = got
    return got


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

    def f64(self, *values: float) -> None:
        self.align(8)
        self.buf += struct.pack(f'<{len(values)}d', *values)

    def u8(self, v: int) -> None:
        self.buf += struct.pack('<B', v)

    def header(self, h: dict[str, Any]) -> None:
        """``std_msgs/Header``: stamp (int32 sec, uint32 nanosec) and frame_id."""
        self.i32(h['stamp']['sec'])
        self.u32(h['stamp']['nanosec'])
        self.string(h['frame_id'])

    def string(self, s: str) -> None:
        self.align(4)
        self.buf += _string(s)

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
    w.header(m['header'])
    w.strings(m['name'])
    w.doubles(m['position'])
    w.doubles(m['velocity'])
    w.doubles(m['effort'])
    return w.done()


def _put_string(buf: bytearray, s: str) -> None:
    """A CDR string at the end of ``buf`` (whose length counts from after the encapsulation
    header): aligned to 4, then :func:`_string`."""
    pad = -len(buf) % 4
    if pad:
        buf += b'\x00' * pad
    buf += _string(s)


def encode_diagnostic_array(m: dict[str, Any]) -> bytes:
    """``diagnostic_msgs/msg/DiagnosticArray``: the header, then each status (byte level,
    name, message, hardware_id, then its key/value strings). Written straight into one
    buffer: it is the replay's and the recorder's every second, about sixty strings each."""
    w = _Writer()
    w.header(m['header'])
    buf = w.buf
    w.u32(len(m['status']))
    for st in m['status']:
        buf.append(st['level'])
        _put_string(buf, st['name'])
        _put_string(buf, st['message'])
        _put_string(buf, st['hardware_id'])
        pad = -len(buf) % 4
        if pad:
            buf += b'\x00' * pad
        buf += _U32.pack(len(st['values']))
        for kv in st['values']:
            _put_string(buf, kv['key'])
            _put_string(buf, kv['value'])
    return w.done()


def encode_string(m: dict[str, Any]) -> bytes:
    """``std_msgs/msg/String``."""
    w = _Writer()
    w.string(m['data'])
    return w.done()


FAST_ENCODERS: dict[str, Callable[[dict[str, Any]], bytes]] = {
    'diagnostic_msgs/msg/DiagnosticArray': encode_diagnostic_array,
    'std_msgs/msg/String': encode_string,
    'sensor_msgs/msg/JointState': encode_joint_state,
}
