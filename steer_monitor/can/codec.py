"""The DBC's messages as the codec's layouts: one frame decoded with Python integers, whole
arrays of frames decoded and encoded with numpy, both from the same bit positions, sizes,
signedness and scales (:mod:`~steer_monitor.can.dbcfile` reads them from the file). The tests
check the two against each other and against cantools, frame by frame and on random payloads.

NMEA 2000 sentinels: the all-ones value of a field means "not available" and all ones
minus one means "error". For a signed field "all ones" is the largest positive value
(0x7FFF for 16 bits), as NMEA 2000 defines it.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from steer_monitor.can.dbcfile import DbcError, DbcMessage, read_dbc
from steer_monitor.can.frames import MAX_DLC, pgn_of

__all__ = ['CanDatabase', 'DbcError', 'FieldLayout', 'MessageLayout', 'load_dbc']


@dataclass(frozen=True)
class FieldLayout:
    """One little-endian signal of a message (bits counted from bit 0 of byte 0)."""

    name: str
    start: int
    length: int
    signed: bool
    scale: float
    offset: float
    unit: str

    @property
    def mask(self) -> int:
        return (1 << self.length) - 1

    @property
    def not_available(self) -> int:
        """Raw value meaning "not available"."""
        return (1 << (self.length - 1)) - 1 if self.signed else (1 << self.length) - 1

    @property
    def error(self) -> int:
        """Raw value meaning "error"."""
        return self.not_available - 1

    def to_physical(self, raw: Any) -> Any:
        return raw * self.scale + self.offset


@dataclass(frozen=True)
class MessageLayout:
    """One PGN of the DBC."""

    name: str
    pgn: int
    length: int
    fields: dict[str, FieldLayout]


def _layout_of(message: DbcMessage) -> MessageLayout:
    fields = {}
    for sig in message.signals:
        if not sig.little_endian:
            msg = (f'signal {message.name}.{sig.name} is big-endian; NMEA 2000 fields are '
                   f'little-endian and the codec supports only those')
            raise DbcError(msg)
        if sig.is_float:
            msg = f'signal {message.name}.{sig.name} is an IEEE float; the codec supports integer fields only'
            raise DbcError(msg)
        if sig.multiplex is not None:
            msg = f'signal {message.name}.{sig.name} is multiplexed; the codec supports plain fields only'
            raise DbcError(msg)
        if sig.start + sig.length > 8 * MAX_DLC:
            msg = f'signal {message.name}.{sig.name} reaches beyond 8 bytes'
            raise DbcError(msg)
        fields[sig.name] = FieldLayout(sig.name, sig.start, sig.length, sig.signed, sig.scale, sig.offset, sig.unit)
    if not message.extended:
        msg = f'message {message.name} has an 11-bit identifier; NMEA 2000 PGNs need 29-bit ones'
        raise DbcError(msg)
    if message.length > MAX_DLC:
        msg = f'message {message.name} is {message.length} bytes; only single-frame PGNs are supported'
        raise DbcError(msg)
    return MessageLayout(message.name, int(pgn_of(message.frame_id)), int(message.length), fields)


class CanDatabase:
    """The messages of a DBC, looked up by PGN whatever the priority and source address."""

    def __init__(self, messages: list[DbcMessage], path: str = '') -> None:
        self.path = path
        self.by_pgn: dict[int, MessageLayout] = {}
        for m in messages:
            layout = _layout_of(m)
            if layout.pgn in self.by_pgn:
                msg = f'PGN {layout.pgn} is defined twice ({self.by_pgn[layout.pgn].name}, {m.name})'
                raise DbcError(msg)
            self.by_pgn[layout.pgn] = layout

    def message(self, pgn: int) -> MessageLayout | None:
        return self.by_pgn.get(pgn)

    # --- one frame (Python integers) -----------------------------------------------------
    @staticmethod
    def decode_raw(layout: MessageLayout, data: bytes) -> dict[str, int]:
        """Raw (unscaled) field values of one frame of the layout's length (the decoder
        refuses frames of another before asking), sign-extended."""
        word = int.from_bytes(bytes(data), 'little')
        out = {}
        for name, f in layout.fields.items():
            raw = (word >> f.start) & f.mask
            out[name] = raw - (1 << f.length) if f.signed and raw >> (f.length - 1) else raw
        return out

    # --- many frames (numpy) -------------------------------------------------------------
    @staticmethod
    def words(data: NDArray[np.uint8]) -> NDArray[np.uint64]:
        """The 8 payload bytes of each row as one little-endian uint64; shape (n,)."""
        return np.ascontiguousarray(data, dtype=np.uint8).view('<u8').reshape(-1)

    @staticmethod
    def extract(f: FieldLayout, words: NDArray[np.uint64]) -> NDArray[np.int64]:
        """Raw values of field ``f`` from payload words; shape (n,), sign-extended."""
        raw = (words >> np.uint64(f.start)) & np.uint64(f.mask)
        out = raw.astype(np.int64)
        if f.signed:
            sign = np.int64(1 << (f.length - 1))
            out = np.where(out >= sign, out - np.int64(1 << f.length), out)
        return out

    @staticmethod
    def encode(layout: MessageLayout, raw: dict[str, NDArray[np.int64]], n: int) -> NDArray[np.uint8]:
        """Payloads of ``n`` frames from raw field values; bits no field covers are 1, as
        NMEA 2000 requires of reserved bits. Returns uint8 (n, 8)."""
        covered = 0
        for f in layout.fields.values():
            covered |= f.mask << f.start
        words = np.full(n, np.uint64(~covered & 0xFFFFFFFFFFFFFFFF), dtype=np.uint64)
        for name, values in raw.items():
            f = layout.fields[name]
            v = np.asarray(values, dtype=np.int64)
            lo, hi = (-(1 << (f.length - 1)), (1 << (f.length - 1)) - 1) if f.signed else (0, f.mask)
            if np.any((v < lo) | (v > hi)):
                msg = f'{layout.name}.{name}: raw value outside {lo}..{hi}'
                raise ValueError(msg)
            bits = (v & np.int64(f.mask)).astype(np.uint64) if f.signed else v.astype(np.uint64)
            words |= bits << np.uint64(f.start)
        data = words.astype('<u8').view(np.uint8).reshape(n, 8)
        return data[:, :layout.length].copy() if layout.length < 8 else data.copy()


def load_dbc(path: str | Path) -> CanDatabase:
    """The codec of the DBC file at ``path`` (:func:`~steer_monitor.can.dbcfile.read_dbc`);
    what it cannot read or the codec does not support: :class:`DbcError`."""
    return CanDatabase(read_dbc(path), str(path))
