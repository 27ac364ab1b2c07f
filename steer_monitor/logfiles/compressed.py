"""Logs kept compressed: gzip, xz, bzip2 or zstd, as log rotation and archives leave them.

A compressed log is told by its first bytes (not its name) and read through a decompressing
stream, so every reader of text logs (candump, ASC, the gateways') takes ``can0.log.1.gz`` as
it takes ``can0.log``. Damaged or cut-short compressed data (a copy interrupted, a bad
sector) does not lose what came before it: the stream hands out what it decompressed before
the damage in pieces of :data:`PIECE_BYTES`, then raises the caller's error naming the file
and the point where the data went bad. Pure Python (the standard library's gzip, lzma, bz2;
zstandard, which MCAP's chunks already need).
"""

from __future__ import annotations

import bz2
import gzip
import io
import lzma
import zlib
from collections.abc import Callable
from pathlib import Path
from typing import Any, BinaryIO

__all__ = ['COMPRESSED_SUFFIXES', 'PIECE_BYTES', 'compression', 'open_decompressed', 'plain_suffix']

#: the first bytes of each kind of compressed file, and its name
_MAGIC = ((b'\x1f\x8b', 'gzip'), (b'\xfd7zXZ\x00', 'xz'), (b'BZh', 'bzip2'), (b'\x28\xb5\x2f\xfd', 'zstd'))
#: the suffixes those files usually carry
COMPRESSED_SUFFIXES = ('.gz', '.xz', '.bz2', '.zst')
#: decompressed bytes handed out at a time: what a damage further on can cost [bytes]
PIECE_BYTES = 16 << 10


def compression(head: bytes) -> str | None:
    """The kind of compression a file starting with ``head`` holds (``'gzip'``, ``'xz'``,
    ``'bzip2'``, ``'zstd'``), or None for a file that is not compressed."""
    for magic, kind in _MAGIC:
        if head.startswith(magic):
            return kind
    return None


def plain_suffix(path: str | Path) -> str:
    """A log's suffix with a compression suffix and then a rotation number taken off
    (``can0.log.gz``, ``can0.log.1.gz``, ``can0.log.1`` -> ``.log``), lower case; ``''``
    when there is none."""
    p = Path(path)
    if p.suffix.lower() in COMPRESSED_SUFFIXES:
        p = p.with_suffix('')
    if p.suffix[1:].isdigit():
        p = p.with_suffix('')
    return p.suffix.lower()


def _decompressor(raw: BinaryIO, kind: str) -> Any:
    if kind == 'gzip':
        return gzip.GzipFile(fileobj=raw, mode='rb')
    if kind == 'xz':
        return lzma.LZMAFile(raw)
    if kind == 'bzip2':
        return bz2.BZ2File(raw)
    return _Zstd(raw)


#: compressed bytes fed to the zstd decoder at a time: a zstd block of at most 128 KiB can be
#: written in 4 bytes (a run of one byte), so this bounds what one call gives at 8 MiB
ZSTD_FEED_BYTES = 256


class _Zstd:
    """``read`` of zstd data, frame after frame, that raises ``EOFError`` when the data ends
    inside a frame (zstandard's ``stream_reader`` then simply ends: a log cut short would
    pass for a whole one). The compressed bytes go in ``ZSTD_FEED_BYTES`` at a time, so a
    stream that expands a thousand-fold (a run of zeros) costs at most 8 MiB of memory."""

    def __init__(self, raw: BinaryIO) -> None:
        import zstandard
        self._zstd = zstandard.ZstdDecompressor()
        self._raw = raw
        self._obj = self._zstd.decompressobj()
        self._started = False       # the current frame has had input
        self._in = b''              # compressed bytes read, not yet fed
        self._out = b''             # decompressed, from ``_at`` on not yet handed out
        self._at = 0

    def _more(self) -> bool:
        """Decompress the next few compressed bytes; False at the end of the data."""
        if not self._in:
            self._in = self._raw.read(PIECE_BYTES)
            if not self._in:
                if self._started and not self._obj.eof:
                    raise EOFError('zstd data ended inside a frame')
                return False
        data, self._in = self._in[:ZSTD_FEED_BYTES], self._in[ZSTD_FEED_BYTES:]
        self._started = True
        got = self._obj.decompress(data)
        if self._obj.eof:           # the next frame, if any, in a fresh decoder
            self._in = self._obj.unused_data + self._in
            self._obj = self._zstd.decompressobj()
            self._started = False
        self._out, self._at = self._out[self._at:] + got, 0
        return True

    def read(self, n: int) -> bytes:
        while len(self._out) - self._at < n:
            if not self._more():
                break
        piece = self._out[self._at:self._at + n]
        self._at += len(piece)
        return piece

    def close(self) -> None:
        self._raw.close()


def _damage_types() -> tuple[type[BaseException], ...]:
    import zstandard
    return (EOFError, OSError, zlib.error, lzma.LZMAError, zstandard.ZstdError, ValueError)


class _Decompressed(io.RawIOBase):
    """The decompressed bytes of ``raw``; damage raises ``error(message)`` once the bytes
    before it have been read."""

    def __init__(self, raw: BinaryIO, kind: str, path: Path, error: Callable[[str], Exception]) -> None:
        super().__init__()
        self._raw = raw
        self._kind = kind
        self._path = path
        self._error = error
        self._inner = _decompressor(raw, kind)
        self._damage = _damage_types()
        self._failed: Exception | None = None
        self._out = 0           # decompressed bytes handed out

    def readable(self) -> bool:
        return True

    def readinto(self, buffer: Any) -> int:
        if self._failed is not None:
            raise self._failed
        view = memoryview(buffer).cast('B')
        done = 0
        while done < len(view):
            want = min(PIECE_BYTES, len(view) - done)
            try:
                piece = self._inner.read(want)
            except self._damage as exc:
                what = 'cut short' if isinstance(exc, EOFError) else f'corrupt ({type(exc).__name__}: {exc})'
                self._failed = self._error(
                    f'{self._path}: {self._kind} data {what} after {self._out + done} bytes of log; '
                    'frames before it were read')
                if done:
                    break
                raise self._failed from exc
            if not piece:
                break
            view[done:done + len(piece)] = piece
            done += len(piece)
        self._out += done
        return done

    def close(self) -> None:
        if not self.closed:
            try:
                self._inner.close()
            finally:
                self._raw.close()
        super().close()


def open_decompressed(raw: BinaryIO, kind: str, path: str | Path, error: Callable[[str], Exception]) -> BinaryIO:
    """``raw`` (a file of compression ``kind``, at its start) as a buffered binary stream of
    its decompressed bytes; closing it closes ``raw``. Damaged data raises ``error`` with a
    message naming ``path``."""
    return io.BufferedReader(_Decompressed(raw, kind, Path(path), error), buffer_size=PIECE_BYTES)
