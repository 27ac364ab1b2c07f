"""MCAP logs of ``can_msgs/msg/Frame`` into columns without a Python object per frame, chunk
by chunk (memory stays bounded whatever the log's length), laid out as the mcap library's own
reader is: records, the summary section, chunks and their decompression.

Why our own reader: mcap's builds one object per message (a few us each). It gives the same
frames and reject counts as the mcap library (the tests' oracle,
``test/logfiles/reference_reader.py``). Chunks are decompressed whole; inside one, a run of
``can_msgs/msg/Frame`` message records of equal size on one channel (how both the recorder and
the log writer lay them out) is found with one vectorized comparison, and each field read as a
strided view of its type. Other records are stepped over. A corrupt chunk is skipped and
counted; a finished file's summary repeats the schemas and channels, read first, so a corrupt
first chunk does not lose them.
"""

from __future__ import annotations

import contextlib
import os
import struct
import zlib
from collections.abc import Iterator
from pathlib import Path
from typing import IO, Any

import numpy as np
from numpy.typing import NDArray

from steer_monitor.can.frames import FLAG_ERROR, FLAG_EXTENDED, FLAG_REMOTE, MAX_DLC, FrameArrays
from steer_monitor.can.rejects import RejectCounter
from steer_monitor.logfiles.candumpcols import BLOCK_FRAMES
from steer_monitor.logfiles.logs import LogError, open_log, skipped_parts
from steer_monitor.logfiles.mcapio import FRAME_DATATYPE

__all__ = ['MAX_CHUNK_BYTES', 'MAX_SUMMARY_BYTES', 'CorruptChunk', 'McapState', 'decompress_chunk', 'iter_mcap_blocks',
           'mcap_chunks_within_limits', 'summary_section', 'walk_records']


_MSG = 0x05
_SCHEMA = 0x03
_CHANNEL = 0x04


def _string(b: bytes, off: int) -> tuple[str, int]:
    (n,) = struct.unpack_from('<I', b, off)
    return b[off + 4:off + 4 + n].decode('utf-8', 'replace'), off + 4 + n


#: the fields of ROS 2's can_msgs/msg/Frame, the layout the column reader reads
_FRAME_FIELDS = (('std_msgs/Header', 'header'), ('uint32', 'id'), ('bool', 'is_rtr'), ('bool', 'is_extended'),
                 ('bool', 'is_error'), ('uint8', 'dlc'), ('uint8[8]', 'data'))


def _msg_fields(definition: str) -> tuple[tuple[str, str], ...]:
    """(type, name) of a ros2msg definition's own fields (its first section; comments,
    blank lines and constants left out; ``Header`` as ``std_msgs/Header``)."""
    fields = []
    for line in definition.split('\n'):
        if line.startswith('=' * 8):
            break
        words = line.split('#', 1)[0].split()
        if len(words) < 2 or '=' in line.split('#', 1)[0]:
            continue
        kind = 'std_msgs/Header' if words[0] == 'Header' else words[0].replace('/msg/', '/')
        fields.append((kind, words[1]))
    return tuple(fields)


def _frame_channel_problem(schema_encoding: str, schema_data: bytes, message_encoding: str) -> str | None:
    """Why a channel whose schema is named can_msgs/msg/Frame cannot be read as one (None: it can)."""
    if message_encoding != 'cdr':
        return f'its messages are in {message_encoding or "no"} encoding, this tool reads CDR'
    if schema_encoding == 'ros2msg':
        fields = _msg_fields(schema_data.decode('utf-8', 'replace'))
        if fields != _FRAME_FIELDS:
            shown = ', '.join(f'{t} {n}' for t, n in fields[:8]) or 'no fields'
            return f'its definition ({shown}) is not ROS 2\'s can_msgs/msg/Frame'
    return None


class McapState:
    """What an MCAP file has declared so far: its schemas and channels, which channels carry CAN
    frames this reader takes (``frame_channels``) and which it cannot (``refused``, with why),
    judged again whichever of a channel and its schema comes first."""

    def __init__(self) -> None:
        self.schemas: dict[int, tuple[str, str, bytes]] = {}      # id -> name, encoding, data
        self.channels: dict[int, tuple[int, str, str]] = {}       # id -> schema id, topic, message encoding
        self.frame_channels: set[int] = set()
        self.refused: dict[int, str] = {}      # a can_msgs/msg/Frame channel that cannot be read -> why
        self.refused_messages: dict[int, int] = {}
        self._by_schema: dict[int, set[int]] = {}   # schema id -> the channels that name it

    def schema(self, sid: int, name: str, encoding: str = '', data: bytes = b'') -> None:
        self.schemas[sid] = (name, encoding, data)
        for cid in self._by_schema.get(sid, ()):
            self._judge(cid)

    def channel(self, cid: int, sid: int, topic: str = '', message_encoding: str = 'cdr') -> None:
        old = self.channels.get(cid)
        if old is not None:
            self._by_schema.get(old[0], set()).discard(cid)
        self.channels[cid] = (sid, topic, message_encoding)
        self._by_schema.setdefault(sid, set()).add(cid)
        self._judge(cid)

    def _judge(self, cid: int) -> None:
        """Whether channel ``cid`` carries frames this reader takes (one channel at a time: a
        file of 100,000 channel records took minutes when every record judged them all)."""
        self.frame_channels.discard(cid)
        self.refused.pop(cid, None)
        sid, _, msg_enc = self.channels[cid]
        name, enc, data = self.schemas.get(sid, ('', '', b''))
        if name != FRAME_DATATYPE:
            return
        why = _frame_channel_problem(enc, data, msg_enc)
        if why is None:
            self.frame_channels.add(cid)
        else:
            self.refused[cid] = why

    def problems(self) -> list[str]:
        """What kept frames from being read: refused frame channels that held messages, or,
        when no channel carries frames, the channels the file has instead."""
        out = [f'{self.channels[c][1]}: {n} can_msgs/msg/Frame message(s) not read ({self.refused[c]})'
               for c, n in self.refused_messages.items() if n]
        if not self.frame_channels and not out and self.channels:
            listed = [f'{topic} ({self.schemas.get(sid, ("?",))[0] or "no schema"}, {enc})'
                      for sid, topic, enc in self.channels.values()]
            ours = any(topic == '/diagnostics' or topic.startswith('/steer_monitor/')
                       for _, topic, _ in self.channels.values())
            out.append('no CAN frames: no can_msgs/msg/Frame channel in CDR; its channels: '
                       + ', '.join(listed[:6]) + (f' and {len(listed) - 6} more' if len(listed) > 6 else '')
                       + ('; these are the monitor\'s topics without the raw frames, as a replay made with '
                          '--no-frames writes them: replay the log it was made from without --no-frames'
                          if ours else ''))
        return out


_DLC_MASK = np.array([(1 << (8 * k)) - 1 for k in range(MAX_DLC)] + [(1 << 64) - 1], np.uint64)


def _frames_from_records(b: bytes, pos: int, stride: int, k: int) -> FrameArrays:
    """Frame columns of ``k`` equal-size can_msgs/msg/Frame message records, the first at
    ``pos`` of ``b``, every ``stride`` bytes: each field read as a strided view of its type."""
    def col(off: int, dt: str) -> NDArray:
        return np.ndarray((k,), dt, buffer=b, offset=pos + off, strides=(stride,))
    log_time = col(15, '<u8').astype(np.int64)
    sec = col(35, '<i4').astype(np.int64)
    nsec = col(39, '<u4').astype(np.int64)
    fid_len = int(col(43, '<u4')[0])
    p = 35 + ((12 + fid_len + 3) // 4) * 4
    if p + 8 + MAX_DLC > stride:
        msg = f'a can_msgs/msg/Frame record of {stride - 9} bytes cannot hold a frame_id of {fid_len} bytes'
        raise ValueError(msg)
    stamp = sec * 1_000_000_000 + nsec
    t_ns = np.where((sec != 0) | (nsec != 0), stamp, log_time)
    dlc = np.minimum(col(p + 7, 'u1'), MAX_DLC).astype(np.uint8)
    data = (col(p + 8, '<u8') & _DLC_MASK[dlc]).astype('<u8').view(np.uint8).reshape(k, MAX_DLC)
    flags = (FLAG_EXTENDED * (col(p + 5, 'u1') != 0) | FLAG_ERROR * (col(p + 6, 'u1') != 0)
             | FLAG_REMOTE * (col(p + 4, 'u1') != 0)).astype(np.uint8)
    return FrameArrays(t_ns, col(p, '<u4').astype(np.uint32), dlc, data, flags)


def walk_records(b: bytes, state: McapState) -> list[FrameArrays]:
    """Frames of the records in ``b`` (a chunk's records, decompressed)."""
    n = len(b)
    out: list[FrameArrays] = []
    pos = 0
    unpack = struct.unpack_from
    while pos + 9 <= n:
        op = b[pos]
        (ln,) = unpack('<Q', b, pos + 1)
        stride = 9 + ln
        if op == _MSG and pos + 11 <= n:
            (cid,) = unpack('<H', b, pos + 9)
            if cid in state.frame_channels and ln >= 22 + 4 + 12 and pos + stride <= n:
                # the run of records like this one: same opcode, length and channel (bytes
                # 0..10, as two words); the length fixes where the fields after frame_id lie
                k_max = (n - pos) // stride
                same = np.ones(k_max, bool)
                for off, dt in ((0, '<u8'), (7, '<u4')):
                    words = np.ndarray((k_max,), dt, buffer=b, offset=pos + off, strides=(stride,))
                    same &= words == words[0]
                run = k_max if same.all() else int(np.argmin(same))
                out.append(_frames_from_records(b, pos, stride, run))
                pos += run * stride
                continue
            if cid in state.refused:
                state.refused_messages[cid] = state.refused_messages.get(cid, 0) + 1
        elif op == _SCHEMA:
            (sid,) = unpack('<H', b, pos + 9)
            name, off = _string(b, pos + 11)
            encoding, off = _string(b, off)
            (size,) = unpack('<I', b, off)
            state.schema(sid, name, encoding, bytes(b[off + 4:off + 4 + size]))
        elif op == _CHANNEL:
            cid, sid = unpack('<HH', b, pos + 9)
            topic, off = _string(b, pos + 13)
            message_encoding, _ = _string(b, off)
            state.channel(cid, sid, topic, message_encoding)
        pos += stride
    return out


_MAGIC = b'\x89MCAP0\r\n'
_FOOTER = 0x02
_CHUNK = 0x06
_DATA_END = 0x0F


#: the most of a summary section read for its schemas and channels [bytes]
MAX_SUMMARY_BYTES = 64 << 20


def summary_section(fh: IO[bytes]) -> bytes | None:
    """The records of a finished MCAP's summary section (writers repeat their schemas and
    channels there), when the footer, the section's bounds (at most
    :data:`MAX_SUMMARY_BYTES`) and its CRC (when written) check out; None otherwise, or for a
    stream that cannot seek. Leaves ``fh`` at the start."""
    try:
        if not fh.seekable():
            return None
        size = fh.seek(0, os.SEEK_END)
        if size < 8 + 29 + 8 + 8:
            return None
        fh.seek(size - 8 - 29)
        tail = fh.read(29 + 8)
        if tail[-8:] != _MAGIC or tail[0] != _FOOTER or struct.unpack_from('<Q', tail, 1)[0] != 20:
            return None
        start, offset_start, crc = struct.unpack_from('<QQI', tail, 9)
        footer = size - 8 - 29
        end = offset_start or footer
        if not 8 < start < end <= footer or footer - start > MAX_SUMMARY_BYTES:
            return None
        fh.seek(start)
        checked = fh.read(size - 8 - 4 - start)      # the summary through the footer's fields before the CRC
        if crc and zlib.crc32(checked) != crc:
            return None
        return checked[:end - start]
    except (OSError, ValueError, struct.error):
        return None
    finally:
        with contextlib.suppress(OSError, ValueError):
            fh.seek(0)


def _seed_from_summary(fh: IO[bytes], state: McapState) -> None:
    """The schemas and channels of a finished file's summary section, before its data is
    read: a corrupt chunk that held a channel's definition (the first chunk holds them all)
    does not then lose every later message of that channel. Only a summary that checks out is
    used (:func:`summary_section`); otherwise the definitions in the data count alone."""
    section = summary_section(fh)
    if section is not None:
        walk_records(section, state)


def mcap_chunks_within_limits(path: str | Path) -> bool:
    """Whether no chunk of the MCAP ``path`` declares more than :data:`MAX_CHUNK_BYTES`
    uncompressed: checked before handing a file to a reader that inflates a chunk to what it
    declares (mcap's own). Reads the records' headers only; False for a file that is not an
    MCAP or cannot be read."""
    try:
        with open(path, 'rb') as fh:
            if fh.read(8) != _MAGIC:
                return False
            while True:
                head = fh.read(9)
                if len(head) < 9:
                    return True
                op, ln = struct.unpack('<BQ', head)
                if op in (_FOOTER, _DATA_END):
                    return True
                if op == _CHUNK:
                    body = fh.read(24)
                    if len(body) < 24:
                        return True
                    if struct.unpack_from('<Q', body, 16)[0] > MAX_CHUNK_BYTES:
                        return False
                    fh.seek(ln - 24, 1)
                else:
                    fh.seek(ln, 1)
    except (OSError, struct.error, ValueError, OverflowError):
        return False


def _top_records(fh: IO[bytes], path: Path) -> Iterator[tuple[int, int, bytes]]:
    """(offset, opcode, body) of the data section's records, read sequentially. mcap's
    StreamReader builds an object per message-index entry as well (most of its time on a
    log); here everything but chunks, schemas, channels and loose messages is stepped over."""
    if fh.read(8) != _MAGIC:
        msg = f'{path}: not an MCAP file (no magic)'
        raise LogError(msg)
    size = os.fstat(fh.fileno()).st_size if hasattr(fh, 'fileno') else None
    while True:
        at = fh.tell()
        head = fh.read(9)
        if len(head) < 9:
            msg = f'{path}: MCAP breaks off (no footer) after {at} bytes; frames before it were read'
            raise LogError(msg)
        op, ln = struct.unpack('<BQ', head)
        if op in (_FOOTER, _DATA_END):
            return
        if size is not None and at + 9 + ln > size:
            msg = (f'{path}: MCAP breaks off inside a record at byte {at} (it claims {ln} bytes, the file '
                   f'ends first); frames before it were read')
            raise LogError(msg)
        if op in (_CHUNK, _SCHEMA, _CHANNEL, _MSG):
            body = fh.read(ln)
            if len(body) < ln:
                msg = f'{path}: MCAP breaks off inside a record at byte {at}; frames before it were read'
                raise LogError(msg)
            yield at, op, body
        else:
            fh.seek(ln, 1)


class CorruptChunk(ValueError):
    """A chunk whose records cannot be trusted (CRC mismatch, broken compression)."""


#: the most a chunk may declare uncompressed [bytes]. Writers use about 1 MiB (mcap's 1 MiB,
#: rosbag2's and Foxglove's 768 KiB, the recorder here 1 MiB); a chunk declaring more is taken
#: as damaged or hostile: a 100 kB chunk of zstd can declare 3 GiB of zeros (tried: 3.2 GB of
#: memory and a minute for a 1 MB file), one without a content size in its frame 16 TiB
MAX_CHUNK_BYTES = 256 << 20
#: the chunk compressions MCAP defines ('' for none)
COMPRESSIONS = ('', 'zstd', 'lz4')


def decompress_chunk(compression: str, data: bytes, size: int, crc: int, dctx: Any = None) -> bytes:
    """A chunk's records: ``data`` decompressed (``''``, ``zstd`` or ``lz4``) to the ``size``
    the chunk declares, never more, and checked against its ``crc`` (when the writer set one);
    :class:`CorruptChunk` saying why not. ``dctx``: a zstandard decompressor to reuse."""
    import zstandard

    if size > MAX_CHUNK_BYTES:
        msg = (f'declares {size} bytes uncompressed, more than the {MAX_CHUNK_BYTES >> 20} MiB a chunk may '
               'hold here')
        raise CorruptChunk(msg)
    if compression not in COMPRESSIONS:
        msg = f'unknown compression {compression!r}'
        raise CorruptChunk(msg)
    try:
        if compression == '':
            out = bytes(data)
        elif compression == 'zstd':
            out = (dctx or zstandard.ZstdDecompressor()).decompress(data, max_output_size=size)
        else:
            import lz4.frame
            out = lz4.frame.LZ4FrameDecompressor().decompress(data, max_length=size + 1)
    except (zstandard.ZstdError, RuntimeError, ValueError, MemoryError) as exc:
        msg = f'{compression} data broken ({type(exc).__name__}: {exc})' if isinstance(exc, MemoryError) \
            else f'{compression} data broken ({exc})'
        raise CorruptChunk(msg) from exc
    if len(out) != size:
        msg = f'{len(out)}{"+" if len(out) > size else ""} bytes decompressed, the chunk says {size}'
        raise CorruptChunk(msg)
    if crc and zlib.crc32(out) != crc:
        msg = 'CRC mismatch'
        raise CorruptChunk(msg)
    return out


def _chunk_records(body: bytes, path: Path, dctx: Any) -> bytes:
    """The records of a chunk record's ``body``, decompressed and checked
    (:func:`decompress_chunk`); :class:`CorruptChunk` otherwise, :class:`LogError` for a
    compression this reader does not know (the whole file has it)."""
    try:
        size, crc = struct.unpack_from('<QI', body, 16)
        compression, off = _string(body, 28)
        (n,) = struct.unpack_from('<Q', body, off)
    except struct.error as exc:
        msg = 'chunk header cut short'
        raise CorruptChunk(msg) from exc
    data = body[off + 8:off + 8 + n]
    if len(data) < n:
        msg = 'chunk records cut short'
        raise CorruptChunk(msg)
    if compression not in COMPRESSIONS:
        msg = f'{path}: MCAP chunk compressed with {compression!r}, which this reader does not know'
        raise LogError(msg)
    return decompress_chunk(compression, data, size, crc, dctx)


def iter_mcap_blocks(path: str | Path, rejects: RejectCounter | None = None) -> Iterator[FrameArrays]:
    """Frames of every ``can_msgs/msg/Frame`` channel of an MCAP in file order, a chunk (or a
    few) at a time. Every chunk is checked against its CRC: a corrupt one is counted in
    ``rejects`` (``corrupt_chunk``) and skipped, the chunks after it are read, and at the end
    :class:`LogError` says what was skipped. A file cut short yields every frame before the
    cut, then raises :class:`LogError`."""
    import zstandard

    path = Path(path)
    fh = open_log(path)
    state = McapState()
    dctx = zstandard.ZstdDecompressor()
    pending: list[FrameArrays] = []
    held = 0
    corrupt: list[str] = []
    with fh:
        _seed_from_summary(fh, state)
        try:
            for at, op, body in _top_records(fh, path):
                if op == _CHUNK:
                    try:
                        records = _chunk_records(body, path, dctx)
                    except CorruptChunk as exc:
                        corrupt.append(f'byte {at}: {exc}')
                        if rejects is not None:
                            rejects.add('corrupt_chunk', f'{path.name} chunk at byte {at}: {exc}')
                        continue
                    parts = walk_records(records, state)
                else:   # a schema, channel or message outside chunks: walk it as a one-record chunk
                    parts = walk_records(struct.pack('<BQ', op, len(body)) + body, state)
                if parts:
                    pending += parts
                    held += sum(len(p) for p in parts)
                    if held >= BLOCK_FRAMES:
                        yield FrameArrays.concat(pending)
                        pending, held = [], 0
        except (LogError, ValueError, struct.error) as exc:
            if pending:
                yield FrameArrays.concat(pending)
            if isinstance(exc, LogError):
                raise
            msg = f'{path}: MCAP breaks off or is corrupt ({type(exc).__name__}: {exc}); frames before it were read'
            raise LogError(msg) from exc
    if pending:
        yield FrameArrays.concat(pending)
    problems = state.problems()
    if corrupt:
        problems.insert(0, skipped_parts(corrupt, 'corrupt chunk(s)'))
    if problems:
        raise LogError(f'{path}: ' + '; '.join(problems))
