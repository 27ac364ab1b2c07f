"""CAN log files: candump, Vector ASC and BLF, MCAP, and NMEA 2000 gateways' logs (CANboat
plain, YDWG raw: :mod:`~steer_monitor.logfiles.gateway`).

A log's format is told by its content (:func:`log_format`: the MCAP and BLF magic, the shape
of the first text lines), and by its suffix when the content does not tell (an empty or
damaged file), so a candump capture saved as ``.txt`` or a gateway's ``.raw`` file is read
as what it is.

Reading yields :class:`~steer_monitor.can.frames.Frame` records (or columns for a whole
file). Records that cannot be parsed are counted as ``malformed_record`` and skipped; a
file that breaks off mid-way yields what came before and then raises :class:`LogError`, so
nothing read is lost. candump files are parsed here (python-can's reader stops at the first
bad line); ``.asc`` and ``.blf`` go through python-can (an ASC line it cannot parse is
counted and skipped here, where its reader would stop, and so is a BLF container whose data
is damaged, as a corrupt MCAP chunk is; an ASC file whose trigger block has no
``End TriggerBlock`` was cut short). python-can gives float seconds:
those are kept to the microsecond, the resolution every format here holds. An ``.asc`` file
carries its start time only to the millisecond (frame times relative to it are exact), so it
is a read format here: writers produce ``.log``, ``.blf`` and ``.mcap``, byte-reproducible.
"""

from __future__ import annotations

import datetime
import io
import itertools
import os
import re
import stat
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import IO, Any, BinaryIO

from steer_monitor.atomic import note_input
from steer_monitor.can.bus import frame_from_message, message_from_frame
from steer_monitor.can.frames import Frame, FrameArrays
from steer_monitor.can.rejects import RejectCounter
from steer_monitor.errors import SteerMonitorError
from steer_monitor.logfiles.compressed import COMPRESSED_SUFFIXES, compression, open_decompressed, plain_suffix
from steer_monitor.logfiles.formats import FORMATS
from steer_monitor.logfiles.gateway import CANBOAT_LINE, YDWG_LINE, canboat_frames, ydwg_date, ydwg_frames
from steer_monitor.logfiles.linebound import bounded_lines
from steer_monitor.logfiles.mcapio import McapWriter

__all__ = ['BINARY_FORMATS', 'FORMATS', 'READ_SUFFIXES', 'WRITE_SUFFIXES', 'LogError', 'LogWriter', 'candump_line',
           'is_compressed', 'iter_log_as', 'log_format', 'log_path_problem', 'open_log', 'open_text_log',
           'skipped_parts', 'write_candump']

READ_SUFFIXES = ('.log', '.asc', '.blf', '.mcap')
#: the formats of records, not lines (the rest are text, read a line at a time)
BINARY_FORMATS = ('blf', 'mcap')
_BY_SUFFIX = {'.log': 'candump', '.asc': 'asc', '.blf': 'blf', '.mcap': 'mcap'}
_SNIFF_BYTES = 4096
#: the most a BLF log container may declare uncompressed [bytes]; writers use 128 KiB
MAX_CONTAINER_BYTES = 64 << 20
WRITE_SUFFIXES = ('.log', '.blf', '.mcap')
#: lines :func:`write_candump` writes at a time
WRITE_BLOCK = 65_536

CAN_ERR_FLAG = 0x20000000
_CANDUMP = re.compile(r'^\((\d+)\.(\d{1,9})\)\s+(\S+)\s+([0-9A-Fa-f]{1,8})#(R?)([0-9A-Fa-f]*)\s*$')


class LogError(SteerMonitorError):
    """A log file cannot be opened, is of an unknown kind, or breaks off."""


def _suffix(path: Path, allowed: tuple[str, ...]) -> str:
    suffix = path.suffix.lower()
    if suffix not in allowed:
        msg = f'{path}: unsupported log format {suffix or "(no suffix)"!r} (supported: {", ".join(allowed)})'
        raise LogError(msg)
    return suffix


def log_format(path: str | Path) -> str:
    """The format of a log to read (a key of :data:`FORMATS`), by content, else by suffix.

    Raises:
        LogError: the file cannot be opened, or neither its content nor its suffix is a
            format read here.
    """
    path = Path(path)
    with open_log(path) as fh:
        try:
            head = fh.read(_SNIFF_BYTES)
        except OSError as exc:
            msg = f'cannot read log {path}: {exc.strerror or exc}'
            raise LogError(msg) from exc
    for magic, name in ((b'\x89MCAP', 'mcap'), (b'LOGG', 'blf')):
        if head.startswith(magic):
            if is_compressed(path):
                msg = (f'{path}: a compressed {FORMATS[name]} file: decompress it first (the format '
                       'compresses its own contents, and is read here by seeking in it)')
                raise LogError(msg)
            return name
    lines = head.split(b'\n')
    if len(head) == _SNIFF_BYTES:
        lines = lines[:-1]          # the last may be cut
    for raw in lines[:20]:
        line = raw.decode('ascii', 'replace').strip()
        if not line or line.startswith('#'):
            continue
        if _CANDUMP.match(line):
            return 'candump'
        if CANBOAT_LINE.match(line):
            return 'canboat'
        if YDWG_LINE.match(line):
            return 'ydwg'
        if line.lower().startswith(('date ', 'base ', 'begin triggerblock')):
            return 'asc'
    suffix = plain_suffix(path)
    fmt = _BY_SUFFIX.get(suffix)
    if fmt is None and not head:
        msg = f'{path}: empty file: no CAN frames'
        raise LogError(msg)
    if fmt is None:
        msg = (f'{path}: unsupported log format {suffix or "(no suffix)"!r}: its content is none of '
               f'{", ".join(FORMATS.values())} (suffixes: {", ".join(READ_SUFFIXES)}, '
               f'each also compressed: {", ".join(COMPRESSED_SUFFIXES)})')
        raise LogError(msg)
    return fmt


def open_log(path: Path) -> BinaryIO:
    """``path`` opened for reading bytes, decompressed if it is compressed (gzip, xz, bzip2,
    zstd: :mod:`~steer_monitor.logfiles.compressed`); :class:`LogError` naming it when it cannot
    be."""
    note_input(path)
    try:
        fh = open(path, 'rb')
    except OSError as exc:
        msg = f'cannot open log {path}: {exc.strerror or exc}'
        raise LogError(msg) from exc
    try:
        kind = compression(fh.peek(8)[:8])
    except OSError as exc:
        fh.close()
        msg = f'cannot read log {path}: {exc.strerror or exc}'
        raise LogError(msg) from exc
    if kind is None:
        return fh
    try:
        return open_decompressed(fh, kind, path, LogError)
    except Exception as exc:            # a header the decompressor refuses at once
        fh.close()
        msg = f'{path}: {kind} data corrupt ({type(exc).__name__}: {exc})'
        raise LogError(msg) from exc


def open_text_log(path: Path, rejects: RejectCounter | None) -> BinaryIO:
    """:func:`open_log` of a text log, its lines bounded (:mod:`~steer_monitor.logfiles.linebound`):
    a run of bytes without a line end costs a fixed buffer, and is counted in ``rejects``."""
    return bounded_lines(open_log(path), path, rejects)


def is_compressed(path: str | Path) -> bool:
    """Whether ``path`` holds compressed data (False when it cannot be read)."""
    try:
        with open(path, 'rb') as fh:
            return compression(fh.read(8)) is not None
    except OSError:
        return False


def _candump_line(line: str, lineno: int, rejects: RejectCounter | None, path: Path) -> Frame | None:
    m = _CANDUMP.match(line)
    if m is None:
        if line.strip() and rejects is not None:
            rejects.add('malformed_record', f'{path.name} line {lineno}: {line.strip()[:60]!r}')
        return None
    sec, frac, channel, ident, rtr, data = m.groups()
    if len(data) % 2 or len(data) > 16:
        if rejects is not None:
            rejects.add('malformed_record', f'{path.name} line {lineno}: payload {data!r}')
        return None
    t_ns = int(sec) * 1_000_000_000 + int(frac.ljust(9, '0'))
    if t_ns >= 1 << 63:
        if rejects is not None:
            rejects.add('malformed_record', f'{path.name} line {lineno}: timestamp ({sec}.{frac}) out of range')
        return None
    can_id = int(ident, 16)
    is_error = bool(can_id & CAN_ERR_FLAG) and len(ident) == 8
    return Frame(t_ns=t_ns, can_id=can_id & 0x1FFFFFFF, data=bytes.fromhex(data),
                 is_extended=len(ident) == 8, is_error=is_error, is_remote=bool(rtr), channel=channel)


def iter_log_as(path: Path, fmt: str, rejects: RejectCounter | None = None, date: datetime.date | None = None
                ) -> Iterator[Frame]:
    """Frames, one at a time, of a log whose format (:func:`log_format`) is known already and
    has no column reader: ASC and BLF (python-can), CANboat plain and YDWG raw. Candump and
    MCAP are read in columns (:func:`~steer_monitor.logfiles.blocks.iter_log_blocks`, the one
    reader of every format). Bad records are counted in ``rejects``; ``date``: the date of a YDWG
    log's first line (see :func:`~steer_monitor.logfiles.gateway.ydwg_date`)."""
    if fmt in ('candump', 'mcap'):
        msg = f'{fmt} logs are read in columns (blocks.iter_log_blocks), not here'
        raise ValueError(msg)
    if fmt == 'ydwg':
        try:
            day, _ = ydwg_date(path, date)
        except OSError as exc:
            msg = f'cannot read log {path}: {exc.strerror or exc}'
            raise LogError(msg) from exc
    with (open_log(path) if fmt in BINARY_FORMATS else open_text_log(path, rejects)) as fh:
        if fmt == 'canboat':
            yield from canboat_frames(fh, path, rejects)
            return
        if fmt == 'ydwg':
            yield from ydwg_frames(fh, path, day, rejects)
            return
    yield from _iter_python_can(path, '.' + fmt, rejects)


#: a line shaped like an ASC frame line (time, channel, something, Rx/Tx): one that python-can's
#: reader then does not take as a frame was damaged, not an event it does not know
_ASC_FRAME_SHAPE = re.compile(r'\s*\d+\.\d+\s+\d+\s+\S+\s+(?:Rx|Tx)\b')


class _Lines:
    """A text file's lines, counted, for naming a line the ASC reader could not parse; and
    whether a trigger block is open (begun, not ended), to tell a file that was cut short.
    A line shaped like a frame that python-can's pattern for frames does not match is
    counted as ``malformed_record`` here (the reader skips it as it skips unknown events)."""

    def __init__(self, fh: Any, path: Path, rejects: RejectCounter | None) -> None:
        from can.io.asc import ASC_MESSAGE_REGEX  # python-can's pattern for a line it reads as a frame

        self.frame_pattern = ASC_MESSAGE_REGEX
        self.fh = fh
        self.path = path
        self.rejects = rejects
        self.lineno = 0
        self.line = ''
        self.block_open = False

    def __iter__(self) -> _Lines:
        return self

    def __next__(self) -> str:
        line = next(self.fh)
        self.lineno += 1
        self.line = line
        head = line.lstrip()[:18].lower()
        if head.startswith('begin triggerblock'):
            self.block_open = True
        elif head.startswith('end triggerblock'):
            self.block_open = False
        elif self.rejects is not None and _ASC_FRAME_SHAPE.match(line) and not self.frame_pattern.match(line.strip()):
            self.rejects.add('malformed_record', f'{self.path.name} line {self.lineno}: {line.strip()[:60]!r}')
        return line

    def close(self) -> None:
        self.fh.close()


def _asc_reader(path: Path, rejects: RejectCounter | None) -> tuple[Any, _Lines]:
    """python-can's ASC reader over ``path``, a frame line it cannot parse counted as
    ``malformed_record`` and skipped instead of ending the log (its own reader stops at the
    first one, losing the rest of the file). Read as Latin-1, so no byte is a decoding error:
    a damaged byte in a frame line makes that line malformed."""
    import can

    try:
        lines = _Lines(io.TextIOWrapper(open_text_log(path, rejects), encoding='latin-1', newline=None), path, rejects)
    except OSError as exc:
        msg = f'cannot read {path}: {exc.strerror or exc}'
        raise LogError(msg) from exc

    def tolerant(process: Any) -> Any:
        def parse(self: Any, line: str, msg_kwargs: dict[str, Any]) -> Any:
            try:
                return process(self, line, msg_kwargs)
            except (ValueError, IndexError, TypeError):
                if rejects is not None:
                    rejects.add('malformed_record', f'{path.name} line {lines.lineno}: {lines.line.strip()[:60]!r}')
                return None
        return parse

    class Reader(can.ASCReader):  # type: ignore[misc]
        _process_classic_can_frame = tolerant(can.ASCReader._process_classic_can_frame)
        _process_fd_can_frame = tolerant(can.ASCReader._process_fd_can_frame)

    try:
        return Reader(lines, relative_timestamp=False), lines
    except Exception as exc:
        lines.close()
        msg = f'cannot read {path}: {type(exc).__name__}: {exc}'
        raise LogError(msg) from exc


def _next_signature(fh: BinaryIO, start: int, signature: bytes = b'LOBJ', block: int = 1 << 20) -> int | None:
    """The offset of the next ``signature`` at or after ``start`` in ``fh`` (None: none)."""
    fh.seek(start)
    pos, carry = start, b''
    while True:
        data = fh.read(block)
        if not data:
            return None
        buf = carry + data
        k = buf.find(signature)
        if k >= 0:
            return pos - len(carry) + k
        carry = buf[-(len(signature) - 1):]
        pos += len(data)


def _blf_reader(path: Path, damaged: list[str], rejects: RejectCounter | None = None) -> Any:
    """python-can's BLF reader, a container that is damaged skipped instead of ending the
    log (its own reader stops at the first one, losing the rest of the file), as a corrupt
    MCAP chunk is: a container whose compressed data fails its check, or an object header
    that is not one (then the next object is looked for). Each skip is appended to
    ``damaged`` and counted as ``corrupt_chunk``. Objects that straddle a skipped container
    are dropped, not guessed."""
    import zlib

    import can
    from can.io import blf

    def skip(what: str) -> None:
        damaged.append(what)
        if rejects is not None:
            rejects.add('corrupt_chunk', f'{path.name} {what}')

    class Reader(can.BLFReader):  # type: ignore[misc]
        def __iter__(self) -> Iterator[Any]:
            fh = self.file
            base = blf.OBJ_HEADER_BASE_STRUCT
            resync = False
            while True:
                at = fh.tell()
                head = fh.read(base.size)
                if len(head) < base.size:
                    break
                signature, _, _, obj_size, obj_type = base.unpack(head)
                if signature != b'LOBJ' or obj_size < base.size:
                    skip(f'byte {at}: not an object header')
                    nxt = _next_signature(fh, at + 1)
                    if nxt is None:
                        break
                    fh.seek(nxt)
                    self._tail, resync = b'', True
                    continue
                body = fh.read(obj_size - base.size)
                fh.read(obj_size % 4)
                if obj_type != blf.LOG_CONTAINER:
                    continue
                method, size = blf.LOG_CONTAINER_STRUCT.unpack_from(body)
                packed = body[blf.LOG_CONTAINER_STRUCT.size:]
                try:
                    if method == blf.NO_COMPRESSION:
                        data = packed
                    elif method == blf.ZLIB_DEFLATE:
                        # never past what the container declares, nor past what one may hold: a
                        # few kB of deflate can inflate to hundreds of MB
                        if size > MAX_CONTAINER_BYTES:
                            msg = (f'declares {size} bytes uncompressed, more than the '
                                   f'{MAX_CONTAINER_BYTES >> 20} MiB a container may hold here')
                            raise ValueError(msg)
                        data = zlib.decompressobj().decompress(packed, size + 1)
                        if len(data) > size:
                            msg = f'inflates past the {size} bytes it declares'
                            raise ValueError(msg)
                    else:
                        msg = f'unknown compression method {method}'
                        raise ValueError(msg)
                except (zlib.error, ValueError) as exc:
                    skip(f'byte {at}: container broken ({exc})')
                    self._tail, resync = b'', True
                    continue
                if resync:          # the container begins inside an object the skip cut
                    k = data.find(b'LOBJ')
                    data = data[k:] if k >= 0 else b''
                    resync = False
                try:
                    yield from self._parse_container(data)
                except blf.BLFParseError as exc:
                    skip(f'byte {at}: objects in the container broken ({exc or "no object header"})')
                    self._tail, resync = b'', True
            self.stop()

    return Reader(str(path))


def _iter_python_can(path: Path, suffix: str, rejects: RejectCounter | None = None) -> Iterator[Frame]:
    lines: _Lines | None = None
    damaged: list[str] = []
    try:
        if suffix == '.asc':
            reader, lines = _asc_reader(path, rejects)
        else:
            reader = _blf_reader(path, damaged, rejects)
    except LogError:
        raise
    except Exception as exc:
        msg = f'cannot read {path}: {type(exc).__name__}: {exc}'
        raise LogError(msg) from exc
    n = 0
    try:
        for msg_ in reader:
            n += 1
            yield frame_from_message(msg_)
    except Exception as exc:
        msg = f'{path}: log breaks off or is corrupt ({type(exc).__name__}: {exc}); frames before it were read'
        raise LogError(msg) from exc
    finally:
        reader.stop()
    if lines is not None and lines.block_open:
        # a trigger block begun and never ended: the file was cut short (an excerpt without
        # any trigger block, as some tools export, is read as it is)
        msg = f'{path}: log breaks off (the ASC file ends without "End TriggerBlock"); {n} frames before it were read'
        raise LogError(msg)
    if suffix == '.blf':
        # python-can stops quietly at a cut container; the header knows the real size.
        size = path.stat().st_size
        if reader.file_size and size < reader.file_size:
            msg = (f'{path}: log breaks off or is corrupt (BLF is {size} bytes, its header says '
                   f'{reader.file_size}); {n} frames before it were read'
                   + (f'; {len(damaged)} damaged container(s) skipped before that' if damaged else ''))
            raise LogError(msg)
    if damaged:
        raise LogError(f'{path}: ' + skipped_parts(damaged, 'damaged container(s)'))


def log_path_problem(path: Path) -> str | None:
    """What is wrong with ``path`` as a log to read (None: a file)."""
    try:
        mode = os.stat(path).st_mode
    except FileNotFoundError:
        return f'log {path} does not exist' + (' (a broken symbolic link)' if path.is_symlink() else '')
    except OSError as exc:          # e.g. a name too long, a loop of symbolic links
        return f'cannot open log {path}: {exc.strerror or exc}'
    if stat.S_ISREG(mode):
        return None
    if stat.S_ISDIR(mode):
        return f'log {path} is a directory, not a file'
    return f'log {path} is not a regular file'


def skipped_parts(where: list[str], what: str) -> str:
    """The sentence for parts of a log skipped as damaged (MCAP chunks, BLF containers):
    how many, the first one (``where``: one text per part), and that the rest was read."""
    return (f'{len(where)} {what} skipped ({where[0]}' + (', ...' if len(where) > 1 else '')
            + '); the frames before and after them were read')


def candump_line(frame: Frame, channel: str) -> str:
    """A frame as a candump ``-L`` line (with its newline), time to the microsecond."""
    if frame.is_error:
        ident = f'{CAN_ERR_FLAG | frame.can_id:08X}'
    else:
        ident = f'{frame.can_id:08X}' if frame.is_extended else f'{frame.can_id:03X}'
    body = 'R' if frame.is_remote else frame.data.hex().upper()
    sec, ns = divmod(frame.t_ns, 1_000_000_000)
    return f'({sec}.{ns // 1000:06d}) {channel} {ident}#{body}\n'


def write_candump(fh: IO[bytes], frames: Iterable[Frame] | FrameArrays, channel: str = 'can0') -> None:
    """Frames as candump ``-L`` lines (:func:`candump_line`, what :class:`LogWriter` writes) to
    a binary file, a block of lines a write: for making long logs."""
    it = iter(frames.frames() if isinstance(frames, FrameArrays) else frames)
    while block := [candump_line(f, channel) for f in itertools.islice(it, WRITE_BLOCK)]:
        fh.write(''.join(block).encode('ascii'))


class LogWriter:
    """Write frames to ``.log`` (candump -L), ``.blf`` or ``.mcap``.

    Context manager; :meth:`close` finishes the file and is idempotent. The candump and MCAP
    outputs are byte-for-byte reproducible for the same frames.
    """

    def __init__(self, path: str | Path, channel: str = 'can0') -> None:
        self.path = Path(path)
        self.suffix = _suffix(self.path, WRITE_SUFFIXES)
        self.channel = channel
        self._closed = False
        try:
            if self.suffix == '.log':
                self._fh: Any = open(self.path, 'w', encoding='ascii', newline='\n')
            elif self.suffix == '.mcap':
                self._fh = McapWriter(self.path)
            else:
                import can
                self._fh = can.Logger(str(self.path))
        except OSError as exc:
            msg = f'cannot write log {self.path}: {exc.strerror or exc}'
            raise LogError(msg) from exc

    def write(self, frame: Frame) -> None:
        if self.suffix == '.log':
            self._fh.write(candump_line(frame, self.channel))
        elif self.suffix == '.mcap':
            self._fh.write_frame(frame)
        else:
            m = message_from_frame(frame)
            m.channel = self.channel
            self._fh.on_message_received(m)

    def close(self) -> None:
        if self._closed:
            return
        self._closed = True
        if self.suffix == '.log':
            self._fh.close()
        elif self.suffix == '.mcap':
            self._fh.close()
        else:
            self._fh.stop()

    def __enter__(self) -> LogWriter:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
