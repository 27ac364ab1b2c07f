"""Counting what the CAN layer refuses, per reason, so diagnostics can show it.

Every frame or field that is not turned into a sample is counted under exactly one reason;
nothing is dropped silently. ``RejectCounter`` is thread-safe: the bus reader thread and the
decoder may share one.
"""

from __future__ import annotations

import threading
from collections import Counter
from dataclasses import dataclass

__all__ = ['MAX_DETAIL', 'REASONS', 'RejectCounter', 'RejectSnapshot']

#: longest example text kept per reason [characters]
MAX_DETAIL = 200

#: reason code -> what it means, as shown to engineers.
REASONS: dict[str, str] = {
    'malformed_record': 'log record that cannot be parsed',
    'long_line': 'bytes of a text log past 64 KiB without a line end (binary data, a run of NUL bytes after a power '
                 'cut): skipped to the next line end',
    'gateway_record': "gateway's own record, not a bus frame (PGN beyond the NMEA 2000 range, e.g. Actisense status)",
    'multi_frame': 'multi-frame PGN reassembled by the gateway (over 8 bytes; the DBC maps single frames only)',
    'corrupt_chunk': 'MCAP chunk failing its CRC or decompression (its frames are not used)',
    'error_frame': 'CAN error frame',
    'remote_frame': 'remote transmission request (NMEA 2000 sends none)',
    'not_extended': 'standard 11-bit identifier (NMEA 2000 uses 29-bit identifiers)',
    'address_claim': 'ISO address claim (PGN 60928): read for the device table, carries no input',
    'unknown_id': 'unknown identifier: PGN not in the DBC',
    'wrong_length': 'wrong data length for the PGN',
    'time_backwards': 'timestamp earlier than the previous frame with this identifier',
    'time_jump': 'timestamp far from the frames around it (a glitch, or a clock step too short to believe)',
    'duplicate': 'duplicate frame: same identifier, data and time as the previous one',
    'unmapped': "no input is mapped to this frame's instance, source field, address or device",
    'not_available': 'field not available (all-ones value)',
    'error_value': 'sensor reports an error (all-ones-minus-one value)',
    'out_of_range': 'physically impossible value',
    'bus_error': 'the bus raised an error',
    'bus_reopen': 'the bus was reopened after an error',
}


@dataclass(frozen=True)
class RejectSnapshot:
    """Counts at one moment: ``counts`` per reason, ``by_signal`` per (reason, input name) for
    field-level reasons, and ``last`` the text of the latest example of each reason."""

    counts: dict[str, int]
    by_signal: dict[tuple[str, str], int]
    last: dict[str, str]

    @property
    def total(self) -> int:
        return sum(self.counts.values())


class RejectCounter:
    """Thread-safe counts of rejects per reason, with the latest example's text."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._counts: Counter[str] = Counter()
        self._by_signal: Counter[tuple[str, str]] = Counter()
        self._last: dict[str, str] = {}

    def add(self, reason: str, detail: str = '', signal: str = '', n: int = 1) -> None:
        """Count ``n`` rejects of ``reason``; ``detail`` says which frame or value."""
        if reason not in REASONS:
            msg = f'unknown reject reason {reason!r}'
            raise KeyError(msg)
        if n <= 0:
            return
        if len(detail) > MAX_DETAIL:          # a hostile 50 MB line is not an example
            detail = detail[:MAX_DETAIL] + f'... ({len(detail)} characters)'
        with self._lock:
            self._counts[reason] += n
            if signal:
                self._by_signal[(reason, signal)] += n
            self._last[reason] = detail       # the example's text is made when asked for (snapshot)

    def merge(self, other: RejectSnapshot) -> None:
        """Add another counter's snapshot to this one."""
        with self._lock:
            self._counts.update(other.counts)
            self._by_signal.update(other.by_signal)
            for reason, text in other.last.items():
                self._last[reason] = text.removeprefix(REASONS[reason]).removeprefix(': ')

    def snapshot(self) -> RejectSnapshot:
        with self._lock:
            last = {r: f'{REASONS[r]}: {d}' if d else REASONS[r] for r, d in self._last.items()}
            return RejectSnapshot(dict(self._counts), dict(self._by_signal), last)

    def __getitem__(self, reason: str) -> int:
        with self._lock:
            return self._counts.get(reason, 0)
