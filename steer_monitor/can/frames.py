"""CAN frames as records (live) and as columns (logs). Pure: no python-can here.

Timestamps are integer nanoseconds since the Unix epoch. NMEA 2000 frames have 29-bit
identifiers: ``id = priority << 26 | PGN << 8 | source`` for PDU2 (broadcast) PGNs.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

__all__ = [
    'MAX_DLC',
    'Frame',
    'FrameArrays',
    'make_id',
    'pgn_of',
    'priority_of',
    'source_of',
]

MAX_DLC = 8


def pgn_of(can_id: int | NDArray[np.uint32]) -> int | NDArray[np.uint32]:
    """PGN of a 29-bit identifier (PDU1 PGNs have their destination byte cleared)."""
    pgn = (can_id >> 8) & 0x3FFFF
    pdu_format = (pgn >> 8) & 0xFF
    if isinstance(pgn, np.ndarray):
        return np.where(pdu_format < 240, pgn & 0x3FF00, pgn)
    return pgn & 0x3FF00 if pdu_format < 240 else pgn


def priority_of(can_id: int) -> int:
    """Priority (0..7) of a 29-bit identifier."""
    return (can_id >> 26) & 0x7


def source_of(can_id: int) -> int:
    """Source address of a 29-bit identifier."""
    return can_id & 0xFF


def make_id(priority: int, pgn: int, source: int) -> int:
    """29-bit identifier of a PDU2 PGN sent with ``priority`` from ``source``."""
    if not (0 <= priority <= 7 and 0 <= pgn <= 0x3FFFF and 0 <= source <= 0xFF):
        msg = f'cannot build an identifier from priority {priority}, PGN {pgn}, source {source}'
        raise ValueError(msg)
    return (priority << 26) | (pgn << 8) | source


@dataclass(frozen=True, slots=True)
class Frame:
    """One CAN frame.

    Attributes:
        t_ns: receive time [ns since epoch].
        can_id: arbitration identifier (29 bits when ``is_extended``).
        data: payload, 0..8 bytes.
        is_extended: 29-bit identifier.
        is_error: CAN error frame.
        is_remote: remote transmission request.
        channel: bus name the frame came from ('' when unknown).
    """

    t_ns: int
    can_id: int
    data: bytes
    is_extended: bool = True
    is_error: bool = False
    is_remote: bool = False
    channel: str = ''


FLAG_EXTENDED = 1
FLAG_ERROR = 2
FLAG_REMOTE = 4


@dataclass(frozen=True)
class FrameArrays:
    """Many frames as columns, for logs.

    Attributes:
        t_ns: int64, shape (n,) [ns].
        can_id: uint32, shape (n,).
        dlc: uint8, shape (n,), payload length.
        data: uint8, shape (n, 8); bytes beyond ``dlc`` are 0.
        flags: uint8, shape (n,): 1 extended, 2 error frame, 4 remote.
    """

    t_ns: NDArray[np.int64]
    can_id: NDArray[np.uint32]
    dlc: NDArray[np.uint8]
    data: NDArray[np.uint8]
    flags: NDArray[np.uint8]

    def __len__(self) -> int:
        return int(self.t_ns.shape[0])

    @classmethod
    def empty(cls) -> FrameArrays:
        return cls(np.zeros(0, np.int64), np.zeros(0, np.uint32), np.zeros(0, np.uint8),
                   np.zeros((0, MAX_DLC), np.uint8), np.zeros(0, np.uint8))

    @classmethod
    def from_frames(cls, frames: Iterable[Frame]) -> FrameArrays:
        frames = list(frames)
        n = len(frames)
        t = np.fromiter((f.t_ns for f in frames), np.int64, n)
        ids = np.fromiter((f.can_id for f in frames), np.uint32, n)
        dlc = np.fromiter((min(len(f.data), MAX_DLC) for f in frames), np.uint8, n)
        flags = np.fromiter((FLAG_EXTENDED * f.is_extended | FLAG_ERROR * f.is_error
                             | FLAG_REMOTE * f.is_remote for f in frames), np.uint8, n)
        data = np.zeros((n, MAX_DLC), np.uint8)
        if n:
            joined = b''.join(f.data[:MAX_DLC].ljust(MAX_DLC, b'\0') for f in frames)
            data[:] = np.frombuffer(joined, np.uint8).reshape(n, MAX_DLC)
        # Frames longer than 8 bytes cannot be classic CAN: mark them with dlc 9+ kept as 255.
        too_long = np.fromiter((len(f.data) > MAX_DLC for f in frames), bool, n)
        dlc[too_long] = 255
        return cls(t, ids, dlc, data, flags)

    def frame(self, i: int, channel: str = '') -> Frame:
        """Row ``i`` as a record (payload cut to ``dlc``)."""
        fl = int(self.flags[i])
        return Frame(int(self.t_ns[i]), int(self.can_id[i]), bytes(self.data[i, :min(int(self.dlc[i]), MAX_DLC)]),
                     bool(fl & FLAG_EXTENDED), bool(fl & FLAG_ERROR), bool(fl & FLAG_REMOTE), channel)

    def frames(self, channel: str = '') -> list[Frame]:
        """All rows as records."""
        return [self.frame(i, channel) for i in range(len(self))]

    def take(self, index: NDArray) -> FrameArrays:
        """A subset or reordering of the rows."""
        return FrameArrays(self.t_ns[index], self.can_id[index], self.dlc[index],
                           self.data[index], self.flags[index])

    @staticmethod
    def concat(parts: Iterable[FrameArrays]) -> FrameArrays:
        parts = list(parts)
        if not parts:
            return FrameArrays.empty()
        return FrameArrays(*(np.concatenate([getattr(p, f) for p in parts])
                             for f in ('t_ns', 'can_id', 'dlc', 'data', 'flags')))
