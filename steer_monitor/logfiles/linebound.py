"""Text logs read with bounded memory, whatever they hold between two line ends.

A text log (candump, ASC, the gateways') is read a line at a time. A run of bytes without a
line end (the NUL bytes a power cut leaves on an SD card, a binary blob pasted into a text
file, a compressed stream that expands a thousand-fold into one "line") would otherwise be
held whole while the reader looks for its end. :class:`LineBound` wraps the log's byte stream
and lets no line grow past :data:`MAX_LINE_BYTES`: the first ``MAX_LINE_BYTES`` of such a run
pass (a line the readers then refuse as ``malformed_record``), the rest up to the next line
end (or, in a run of NUL bytes, up to the first byte that is not one) is skipped and counted as ``long_line`` bytes
with one example saying where, and reading
goes on at the next line. Memory: the wrapper holds one piece (:data:`PIECE_BYTES`) at a time.
"""

from __future__ import annotations

import io
from pathlib import Path
from typing import Any, BinaryIO

from steer_monitor.can.rejects import RejectCounter

__all__ = ['MAX_LINE_BYTES', 'PIECE_BYTES', 'LineBound', 'bounded_lines']

#: the longest line passed on [bytes]: a log line is under 200 bytes; a hostile one costs this
MAX_LINE_BYTES = 64 << 10
#: bytes read from the stream at a time (no more than ``MAX_LINE_BYTES``: see ``_fill``)
PIECE_BYTES = 64 << 10


class LineBound(io.RawIOBase):
    """The bytes of ``raw`` with every line cut at ``max_line`` bytes (see the module
    docstring); what is cut is counted in ``rejects`` as ``long_line``. Closing it closes
    ``raw``."""

    def __init__(self, raw: BinaryIO, path: str | Path, rejects: RejectCounter | None,
                 max_line: int = MAX_LINE_BYTES) -> None:
        super().__init__()
        self._raw = raw
        self._name = Path(path).name
        self._rejects = rejects
        self._max = max_line
        self._since = 0            # bytes passed since the last line end
        self._skipping = False     # inside a run being skipped
        self._skip_from = 0        # where it started, in the log's bytes
        self._skipped = 0          # its bytes so far
        self._nul_run = False      # the last bytes skipped were NUL
        self._pos = 0              # bytes of the log read
        self._out: list[bytes] = []   # passed, not yet handed out
        self._held = 0                # their bytes
        self._error: Exception | None = None   # the stream's error, raised once _out is handed out
        # one read of the stream at a time: a damaged compressed stream raises after handing out
        # what came before the damage, which a read that fills its buffer would lose
        self._read = getattr(raw, 'read1', raw.read)
        self.skipped_total = 0

    def readable(self) -> bool:
        return True

    def _said(self) -> None:
        if self._skipped:
            self.skipped_total += self._skipped
            if self._rejects is not None:
                self._rejects.add('long_line', f'{self._name}: {self._skipped} bytes without a line end from byte '
                                               f'{self._skip_from} (after the first {self._max} of the line)',
                                  n=self._skipped)
        self._skipping, self._skipped, self._nul_run = False, 0, False

    def _fill(self) -> bool:
        """Pass the next piece on; False at the end of the stream."""
        piece = self._read(min(PIECE_BYTES, self._max))
        if not piece:
            if self._skipping:
                self._said()
            return False
        start = self._pos
        self._pos += len(piece)
        at = 0
        out = []
        while at < len(piece):
            if self._skipping:
                at = self._skip(piece, at)
                continue
            # a line inside the piece is shorter than the piece (PIECE_BYTES <= max_line): only
            # the one the piece continues can grow past the bound
            nl = piece.find(b'\n', at)
            head = (len(piece) if nl < 0 else nl) - at
            room = self._max - self._since
            if head > room:                      # it grows past the bound: cut it there
                out.append(piece[at:at + room])
                out.append(b'\n')
                self._skipping, self._skip_from, self._skipped, self._nul_run = True, start + at + room, 0, False
                at += room
                self._since = 0
                continue
            out.append(piece[at:])
            self._since = self._since + head if nl < 0 else len(piece) - piece.rfind(b'\n') - 1
            break
        for part in out:
            if part:
                self._out.append(part)
                self._held += len(part)
        return True

    def _skip(self, piece: bytes, at: int) -> int:
        """Skip in ``piece`` from ``at``: to its end, or to where a line starts again (after
        the next line end, or where a run of NUL bytes ends); returns where reading goes on."""
        if self._nul_run and piece[at] != 0:         # a run of NUL bytes ends: a line may start here
            self._said()
            self._since = 0
            return at
        nl = piece.find(b'\n', at)
        end = len(piece) if nl < 0 else nl
        if piece[at] == 0:                           # NULs (a power cut's): to the first other byte
            seg = piece if at == 0 and nl < 0 else piece[at:end]
            k = at + len(seg) - len(seg.lstrip(b'\0'))
            self._skipped += k - at
            self._nul_run = True
            return k                                 # the piece's end, a byte that is not NUL, or the line end
        self._nul_run = False
        if nl < 0:
            self._skipped += len(piece) - at
            return len(piece)
        self._skipped += nl + 1 - at
        self._said()
        self._since = 0
        return nl + 1

    def readinto(self, buffer: Any) -> int:
        """As much as ``buffer`` holds, or what there is up to the end of the stream; an error
        of the stream (damaged compressed data) once what came before it is handed out."""
        view = memoryview(buffer).cast('B')
        while self._held < len(view) and self._error is None:
            try:
                if not self._fill():
                    break
            except Exception as exc:          # the stream's own error: raised after what came before
                self._error = exc
        if not self._held and self._error is not None:
            exc, self._error = self._error, None
            raise exc
        data = self._out[0] if len(self._out) == 1 else b''.join(self._out)
        n = min(len(view), len(data))
        view[:n] = data[:n]
        self._out = [data[n:]] if n < len(data) else []
        self._held = len(data) - n
        return n

    def close(self) -> None:
        if not self.closed:
            self._raw.close()
        super().close()


def bounded_lines(raw: BinaryIO, path: str | Path, rejects: RejectCounter | None) -> BinaryIO:
    """``raw`` (a text log's bytes) as a buffered stream whose lines are at most
    :data:`MAX_LINE_BYTES` long (:class:`LineBound`)."""
    return io.BufferedReader(LineBound(raw, path, rejects), buffer_size=PIECE_BYTES)
