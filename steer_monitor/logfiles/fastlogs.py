"""Whole logs into columns without a Python object per frame: candump and MCAP at millions of
frames per second, block by block so memory stays bounded whatever the log's length.

Why our own readers: python-can's and mcap's readers build one object per frame (a few us
each); a month of one vessel's steering bus is a few hundred million frames. These are the
package's one reader of every log; they give the same frames and reject counts as a plain
reader, line by line and with the mcap library (the tests' oracle,
``test/logfiles/reference_reader.py``, compared on every kind of line):

* candump: lines of the usual shape ``(sec.frac) chan ID#HEX`` are parsed eight characters
  at a time (:mod:`~steer_monitor.logfiles.digits`) at the offsets of their layout. A block whose
  lines are all of one length and layout (one writer, one DLC: the usual log) is read with
  strided words straight from the block, without finding its lines; otherwise the block is
  split on newlines and the lines grouped by length. Any other line (remote frames, odd
  payloads, garbage) goes through the line parser of :mod:`~steer_monitor.logfiles.logs`, which
  counts what it rejects.
* MCAP: chunks are decompressed whole; inside one, a run of ``can_msgs/msg/Frame`` message
  records of equal size on one channel (how both the recorder and the log writer lay them
  out) is found with one vectorized comparison, and each field read as a strided view of its
  type. Other records are stepped over.
* other formats (ASC, BLF through python-can; the gateway logs of :mod:`~steer_monitor.logfiles.gateway`):
  read frame by frame, gathered into blocks.
"""

from __future__ import annotations

import contextlib
import datetime
import os
import re
import struct
import zlib
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import IO, Any

import numpy as np
from numpy.typing import NDArray

from steer_monitor.can.frames import FLAG_ERROR, FLAG_EXTENDED, FLAG_REMOTE, MAX_DLC, Frame, FrameArrays
from steer_monitor.can.rejects import RejectCounter
from steer_monitor.logfiles import digits
from steer_monitor.logfiles.logs import (
    CAN_ERR_FLAG,
    LogError,
    _candump_line,
    candump_line,
    is_compressed,
    iter_log_as,
    log_format,
    open_log,
    open_text_log,
    skipped_parts,
)
from steer_monitor.logfiles.mcapio import FRAME_DATATYPE

__all__ = [
    'BLOCK_BYTES',
    'BLOCK_FRAMES',
    'MAX_CHUNK_BYTES',
    'CorruptChunk',
    'decompress_chunk',
    'mcap_chunks_within_limits',
    'summary_section',
    'iter_candump_blocks',
    'iter_log_blocks',
    'first_frame_ns',
    'in_time_order',
    'iter_mcap_blocks',
    'log_end_ns',
    'iter_log',
    'read_log_fast',
    'write_candump_arrays',
]

BLOCK_BYTES = 16 << 20
BLOCK_FRAMES = 1 << 18
_PAD = 16          # bytes before and after a candump block, so words may be read across its ends
_PAD_BYTES = bytes(_PAD)

_HEX = np.full(256, 255, np.uint8)
for _i, _c in enumerate(b'0123456789'):
    _HEX[_c] = _i
for _i, _c in enumerate(b'abcdef'):
    _HEX[_c] = 10 + _i
    _HEX[_c - 32] = 10 + _i
_DEC = np.full(256, 255, np.uint8)
_DEC[48:58] = np.arange(10)


def _field(a: NDArray[np.uint8], start: NDArray[np.intp], end: NDArray[np.intp], lut: NDArray[np.uint8],
           base: int) -> tuple[NDArray[np.int64], NDArray[np.bool_]]:
    """Numbers in ``a[start:end]`` per row (digits of ``base`` via ``lut``), all rows at once
    (grouped by width, each group by :func:`_digits`). Returns (values, valid)."""
    n = start.size
    values = np.zeros(n, np.int64)
    valid = np.ones(n, bool)
    width = end - start
    for w in np.unique(width):
        rows = np.nonzero(width == w)[0]
        if w <= 0 or w > 18:
            valid[rows] = False
            continue
        values[rows], valid[rows] = _digits(a[start[rows, None] + np.arange(w)], lut, base)
    return values, valid


def _digits(m: NDArray[np.uint8], lut: NDArray[np.uint8], base: int) -> tuple[NDArray[np.int64], NDArray[np.bool_]]:
    """The numbers written in the columns of ``m`` (n, w): (values, valid). Float64 matmul is
    exact here (at most 16 hex or 10 decimal digits of a timestamp's seconds < 2**53)."""
    d = lut[m]
    valid = (d < base).all(axis=1)
    powers = float(base) ** np.arange(m.shape[1] - 1, -1, -1)
    return (d.astype(np.float64) @ powers).astype(np.int64), valid


def _assemble(sec: NDArray[np.int64], frac: NDArray[np.int64], frac_width: Any, ident: NDArray[np.int64],
              id_width: Any, nbytes: Any, data: NDArray[np.uint8], good: NDArray[np.bool_]) -> FrameArrays:
    """The frames of the ``good`` lines from their parsed fields (widths and payload lengths
    per line, or one for all)."""
    t_ns = sec * 1_000_000_000 + frac * 10 ** (9 - frac_width)
    extended = np.broadcast_to(id_width == 8, good.shape)
    is_error = extended & ((ident & CAN_ERR_FLAG) != 0)
    flags = (FLAG_EXTENDED * extended | FLAG_ERROR * is_error).astype(np.uint8)
    nbytes = np.broadcast_to(nbytes, good.shape)
    if good.all():
        return FrameArrays(t_ns.astype(np.int64, copy=False), (ident & 0x1FFFFFFF).astype(np.uint32),
                           nbytes.astype(np.uint8), data, flags)
    return FrameArrays(t_ns[good].astype(np.int64), (ident[good] & 0x1FFFFFFF).astype(np.uint32),
                       nbytes[good].astype(np.uint8), data[good], flags[good])


def _fields(a: NDArray[np.uint8], s: NDArray[np.intp], e: NDArray[np.intp], dot: NDArray[np.intp],
            cp: NDArray[np.intp], sp2: NDArray[np.intp], hs: NDArray[np.intp]
            ) -> tuple[FrameArrays, NDArray[np.bool_]]:
    """Frames of lines whose delimiters are known to sit at these positions; returns the
    frames of the lines whose fields are valid and a mask of those lines."""
    dlen = e - hs - 1
    sec, v1 = _field(a, s + 1, dot, _DEC, 10)
    frac, v2 = _field(a, dot + 1, cp, _DEC, 10)
    ident, v3 = _field(a, sp2 + 1, hs, _HEX, 16)
    good = v1 & v2 & v3 & (sec < 9_223_372_035)
    nbytes = dlen // 2
    data = np.zeros((s.size, MAX_DLC), np.uint8)
    for k in range(MAX_DLC):
        has = nbytes > k
        if not has.any():
            break
        hi = _HEX[a[np.where(has, hs + 1 + 2 * k, 0)]]
        lo = _HEX[a[np.where(has, hs + 2 + 2 * k, 0)]]
        good &= ~has | ((hi < 16) & (lo < 16))
        data[:, k] = np.where(has, (hi.astype(np.uint16) << 4 | lo) & 0xFF, 0)
    return _assemble(sec, frac, cp - dot - 1, ident, hs - sp2 - 1, nbytes, data, good), good


def _shape_ok(s: NDArray[np.intp], e: NDArray[np.intp], dot: NDArray[np.intp], cp: NDArray[np.intp],
              sp1: NDArray[np.intp], sp2: NDArray[np.intp], hs: NDArray[np.intp]) -> NDArray[np.bool_]:
    dlen = e - hs - 1
    return ((s < dot) & (dot < cp) & (sp1 == cp + 1) & (sp2 > sp1 + 1) & (hs > sp2 + 1) & (hs - sp2 - 1 <= 8)
            & (cp - dot - 1 >= 1) & (cp - dot - 1 <= 9) & (dot - s - 1 >= 1) & (dlen % 2 == 0) & (dlen <= 16))


_LINE = re.compile(rb'^\((\d+)\.(\d{1,9})\) (\S+) ([0-9A-Fa-f]{1,8})#([0-9A-Fa-f]*)$')


Words = Callable[[int], NDArray[np.uint64]]
Bytes = Callable[[int], NDArray[np.uint8]]


def _dec_field(words: Words, e: int, w: int) -> tuple[NDArray[np.int64], NDArray[np.bool_]]:
    """The decimal number of ``w`` (1..16) characters ending before line offset ``e``."""
    v, ok = digits.dec8(digits.keep_last(words(e - 8), min(w, 8)))
    if w > 8:
        hi, ok_hi = digits.dec8(digits.keep_last(words(e - 16), w - 8))
        v, ok = hi * np.uint64(100_000_000) + v, ok & ok_hi
    return v.astype(np.int64), ok


def _layout_frames(words: Words, byte_at: Bytes, n: int, dot: int, cp: int, sp2: int, hs: int, length: int
                   ) -> tuple[FrameArrays, NDArray[np.bool_]]:
    """Frames of ``n`` lines of one layout (delimiters at these offsets, ``length``
    characters): ``words(off)`` gives the eight characters at line offset ``off`` of each line
    as a uint64 (:mod:`~steer_monitor.logfiles.digits`), ``byte_at(off)`` the one character.
    Returns the frames of the lines that are of that layout and valid, and a mask of them."""
    good = byte_at(0) == ord('(')
    for off, ch in ((dot, b'.'), (cp, b')'), (cp + 1, b' '), (sp2, b' '), (hs, b'#')):
        good &= byte_at(off) == ord(ch)
    for off in range(cp + 2, sp2):                      # the channel: no blank or control
        good &= byte_at(off) > 32
    sec, ok = _dec_field(words, dot, dot - 1)
    good &= ok & (sec < 9_223_372_035)
    frac, ok = _dec_field(words, cp, cp - dot - 1)
    good &= ok
    ident, ok = digits.hex8(digits.keep_last(words(hs - 8), hs - sp2 - 1))
    good &= ok
    chars = length - hs - 1                             # even, at most 16 (the layout's check)
    data = np.zeros((n, 2), '<u4')
    for k in range((chars + 7) // 8):
        data[:, k], ok = digits.hex8_bytes(digits.keep_first(words(hs + 1 + 8 * k), min(chars - 8 * k, 8)))
        good &= ok
    return _assemble(sec, frac, cp - dot - 1, ident.astype(np.int64), hs - sp2 - 1, chars // 2,
                     data.view(np.uint8).reshape(n, MAX_DLC), good), good


def _layout(line: bytes) -> tuple[int, int, int, int] | None:
    """(dot, cp, sp2, hs) of a line of the usual shape whose fields the word parser takes
    (seconds up to 16 digits), else None."""
    m = _LINE.match(line)
    if m is None:
        return None
    dot, cp, sp2, hs = m.end(1), m.end(2), m.end(3), m.end(4)
    if (len(line) - hs - 1) % 2 or len(line) - hs - 1 > 16 or dot - 1 > 16:
        return None
    return dot, cp, sp2, hs


def _uniform_frames(pb: bytes | bytearray, a: NDArray[np.uint8]) -> FrameArrays | None:
    """The frames of a block of lines all of one length and layout (the usual log: one
    writer, one DLC), read with strided words straight from the block; None when the
    block is not such, or any line is not valid (the general parse then takes it)."""
    stride = pb.find(b'\n', _PAD, _PAD + a.size) + 1 - _PAD
    if stride < 2 or a.size % stride:
        return None
    if not (a[stride - 1::stride] == 10).all():
        return None
    if np.count_nonzero(a < 32) != a.size // stride:     # a tab or other control byte: the line parser's
        return None
    lay = _layout(bytes(a[:stride - 1]))
    if lay is None:
        return None
    n = a.size // stride

    def words(off: int) -> NDArray[np.uint64]:
        return np.ndarray((n,), '<u8', buffer=pb, offset=_PAD + off, strides=(stride,))

    fa, good = _layout_frames(words, lambda off: a[off::stride], n, *lay, stride - 1)
    return fa if good.all() else None


def _templates(pb: bytes | bytearray, a: NDArray[np.uint8], starts: NDArray[np.intp], ends: NDArray[np.intp],
               skip: NDArray[np.bool_]) -> tuple[list[FrameArrays], list[NDArray[np.intp]], NDArray[np.bool_]]:
    """Lines of one length whose delimiters sit where the first such line has them (a log is
    mostly one or a few line layouts), parsed by words at fixed offsets; not the lines of
    ``skip``. Returns frames, their lines, and a mask of the lines handled."""
    n = starts.size
    done = np.zeros(n, bool)
    parts: list[FrameArrays] = []
    lines: list[NDArray[np.intp]] = []
    length = np.where(skip, -1, ends - starts)
    values, counts = np.unique(length, return_counts=True)
    every = np.ndarray((len(pb) - 7,), '<u8', buffer=pb, strides=(1,))    # the word at every byte
    for L, count in zip(values.tolist(), counts.tolist()):
        if count < 16 or L < 0:
            continue
        first_row = int(np.argmax(length == L))
        lay = _layout(bytes(a[starts[first_row]:ends[first_row]]))
        if lay is None:
            continue
        rows = np.nonzero(length == L)[0]
        at = starts[rows]
        fa, good = _layout_frames(lambda off, at=at: every[at + (_PAD + off)], lambda off, at=at: a[at + off],
                                  rows.size, *lay, L)
        parts.append(fa)
        lines.append(rows[good])
        done[rows[good]] = True
    return parts, lines, done


def _odd_lines(a: NDArray[np.uint8], starts: NDArray[np.intp], ends: NDArray[np.intp], newlines_and_crs: int
               ) -> NDArray[np.bool_]:
    """Mask of the lines holding a control byte (a tab, say) other than their newline and a
    stripped CR. One comparison over the block when there is none."""
    skip = np.zeros(starts.size, bool)
    if np.count_nonzero(a < 32) == newlines_and_crs:
        return skip
    ctrl = np.flatnonzero(a < 32)
    ctrl = ctrl[a[ctrl] != 10]
    owner = np.searchsorted(starts, ctrl, side='right') - 1
    inside = (owner >= 0) & (ctrl < ends[np.clip(owner, 0, None)])      # not a stripped CR
    skip[owner[inside]] = True
    return skip


def _parse_candump(pb: bytes | bytearray, a: NDArray[np.uint8], starts: NDArray[np.intp], ends: NDArray[np.intp],
                   skip: NDArray[np.bool_]) -> tuple[FrameArrays, NDArray[np.bool_]]:
    """Vectorized parse of lines ``a[starts[i]:ends[i]]`` (no newline; ``a`` is ``pb``
    without its padding). Returns the frames of the lines of the usual shape, in line order,
    and a mask of those lines. The lines of ``skip`` (a control byte: :func:`_odd_lines`) are
    left to the line parser, which judges whitespace (here only the two spaces delimit)."""
    parts, lines, mask = _templates(pb, a, starts, ends, skip)
    rest = np.nonzero(~mask & ~skip)[0]
    if rest.size:
        # the other lines: find each delimiter's line; the usual shape has exactly one of
        # each (two spaces)
        rs, re_ = starts[rest], ends[rest]
        ok = np.ones(rest.size, bool)
        found: dict[int, NDArray[np.intp]] = {}
        for ch in (ord('('), ord(')'), ord('.'), ord(' '), ord('#')):
            where = np.flatnonzero(a == ch)
            owner = np.searchsorted(rs, where, side='right') - 1
            inside = (owner >= 0) & (where < re_[np.clip(owner, 0, None)])
            where, owner = where[inside], owner[inside]
            count = np.bincount(owner, minlength=rest.size)
            ok &= count == (2 if ch == ord(' ') else 1)
            first = np.full(rest.size, -1, np.intp)
            u, i = np.unique(owner, return_index=True)
            first[u] = where[i]
            found[ch] = first
            if ch == ord(' '):
                last = np.full(rest.size, -1, np.intp)
                u, i = np.unique(owner[::-1], return_index=True)
                last[u] = where[::-1][i]
                found[-1] = last
        sel = np.nonzero(ok)[0]
        s, e = rs[sel], re_[sel]
        op, dot, cp, sp1, sp2, hs = (found[ord('(')][sel], found[ord('.')][sel], found[ord(')')][sel],
                                      found[ord(' ')][sel], found[-1][sel], found[ord('#')][sel])
        shape = (op == s) & _shape_ok(s, e, dot, cp, sp1, sp2, hs)
        sel = sel[shape]
        fa, good = _fields(a, *(x[shape] for x in (s, e, dot, cp, sp2, hs)))
        parts.append(fa)
        lines.append(rest[sel[good]])
        mask[rest[sel[good]]] = True
    if not parts:
        return FrameArrays.empty(), mask
    fa = FrameArrays.concat(parts)
    order = np.concatenate(lines)
    if order.size and (np.diff(order) < 0).any():
        fa = fa.take(np.argsort(order, kind='stable'))
    return fa, mask


def iter_candump_blocks(path: str | Path, rejects: RejectCounter | None = None,
                        block_bytes: int = BLOCK_BYTES) -> Iterator[FrameArrays]:
    """Frames of a candump ``.log`` in file order, a block of about ``block_bytes`` at a time.
    Lines of another shape are parsed one by one (and counted in ``rejects`` if bad)."""
    path = Path(path)
    fh = open_text_log(path, rejects)     # lines bounded: the carried part of a line stays small
    lineno = 0
    carry = b''
    # one buffer for every block: the carried part of a line, the block read into it after,
    # _PAD zero bytes either side; the frames made from it are copies
    ba = bytearray(2 * _PAD + 2 * block_bytes)
    with fh:
        while True:
            if len(ba) < 2 * _PAD + len(carry) + block_bytes:
                ba = bytearray(2 * _PAD + 2 * (len(carry) + block_bytes))
            ba[_PAD:_PAD + len(carry)] = carry
            start = _PAD + len(carry)
            got = fh.readinto1(memoryview(ba)[start:start + block_bytes])
            if not got and not carry:
                return
            end = start + got
            if got:
                cut = ba.rfind(b'\n', _PAD, end) + 1
                if cut == 0:
                    carry = bytes(ba[_PAD:end])
                    continue
                carry = bytes(ba[cut:end])
            else:
                cut, carry = end, b''
            ba[cut:cut + _PAD] = _PAD_BYTES
            a = np.frombuffer(ba, np.uint8, count=cut - _PAD, offset=_PAD)
            fa = _uniform_frames(ba, a)
            if fa is not None:
                lineno += len(fa)
                yield fa
                continue
            nl = np.flatnonzero(a == 10)
            starts = np.concatenate([[0], nl + 1]).astype(np.intp)
            ends = np.concatenate([nl, [a.size]]).astype(np.intp)
            if starts[-1] >= a.size:                 # the block ends with its newline
                starts, ends = starts[:-1], ends[:-1]
            cr = (ends > starts) & (a[np.clip(ends - 1, 0, None)] == 13)
            ends = ends - cr
            fa, mask = _parse_candump(ba, a, starts, ends, _odd_lines(a, starts, ends, nl.size + int(cr.sum())))
            slow = np.nonzero(~mask)[0]
            if slow.size:
                fa = _merge_slow(fa, mask, slow, a, starts, ends, lineno, rejects, path)
            lineno += starts.size
            if len(fa):
                yield fa


def _merge_slow(fa: FrameArrays, mask: NDArray[np.bool_], slow: NDArray[np.intp], a: NDArray[np.uint8],
                starts: NDArray[np.intp], ends: NDArray[np.intp], lineno: int, rejects: RejectCounter | None,
                path: Path) -> FrameArrays:
    """The lines the column parser left, through the line parser, merged in line order."""
    extra: list[Frame] = []
    at: list[int] = []
    for i in slow.tolist():
        text = a[starts[i]:ends[i]].tobytes().decode('ascii', 'replace')
        f = _candump_line(text, lineno + i + 1, rejects, path)
        if f is not None:
            extra.append(f)
            at.append(i)
    if not extra:
        return fa
    fast_lines = np.nonzero(mask)[0]
    both = FrameArrays.concat([fa, FrameArrays.from_frames(extra)])
    order = np.argsort(np.concatenate([fast_lines, np.array(at, np.intp)]), kind='stable')
    return both.take(order)


# --- MCAP ---------------------------------------------------------------------------------
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


class _McapState:
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


def _walk_records(b: bytes, state: _McapState) -> list[FrameArrays]:
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


def _seed_from_summary(fh: IO[bytes], state: _McapState) -> None:
    """The schemas and channels of a finished file's summary section, before its data is
    read: a corrupt chunk that held a channel's definition (the first chunk holds them all)
    does not then lose every later message of that channel. Only a summary that checks out is
    used (:func:`summary_section`); otherwise the definitions in the data count alone."""
    section = summary_section(fh)
    if section is not None:
        _walk_records(section, state)


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
    state = _McapState()
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
                    parts = _walk_records(records, state)
                else:   # a schema, channel or message outside chunks: walk it as a one-record chunk
                    parts = _walk_records(struct.pack('<BQ', op, len(body)) + body, state)
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


def iter_log_blocks(path: str | Path, rejects: RejectCounter | None = None,
                    date: datetime.date | None = None) -> Iterator[FrameArrays]:
    """Any supported log as blocks of columns, in file order (``date``: see
    :func:`iter_log`)."""
    path = Path(path)
    fmt = log_format(path)
    if fmt == 'candump':
        yield from iter_candump_blocks(path, rejects)
        return
    if fmt == 'mcap':
        yield from iter_mcap_blocks(path, rejects)
        return
    block: list[Any] = []
    try:
        for frame in iter_log_as(path, fmt, rejects, date):
            block.append(frame)
            if len(block) >= BLOCK_FRAMES // 4:
                yield FrameArrays.from_frames(block)
                block = []
    except LogError:
        # a log that breaks off gives the frames before the break, then the error
        if block:
            yield FrameArrays.from_frames(block)
        raise
    if block:
        yield FrameArrays.from_frames(block)


def log_end_ns(path: str | Path) -> int | None:
    """The time of a log's last frame, cheaply (candump: its last line; MCAP: the summary's
    statistics), or None when it cannot be told without reading the whole log."""
    path = Path(path)
    try:
        fmt = log_format(path)
        if is_compressed(path):     # its end is known only once the whole is decompressed
            return None
        if fmt == 'candump':
            with open(path, 'rb') as fh:
                fh.seek(max(fh.seek(0, 2) - 4096, 0))
                for line in reversed(fh.read().splitlines()):
                    m = _LINE.match(line.strip())
                    if m is not None:
                        return int(m.group(1)) * 1_000_000_000 + int(m.group(2).ljust(9, b'0'))
        elif fmt == 'mcap':
            from mcap.reader import make_reader
            with open(path, 'rb') as fh:
                summary = make_reader(fh).get_summary()
                if summary is not None and summary.statistics is not None and summary.statistics.message_count:
                    return int(summary.statistics.message_end_time)
    except Exception:   # a cut or odd file: the caller reads it and finds out
        return None
    return None


def first_frame_ns(path: str | Path, date: datetime.date | None = None) -> int | None:
    """The time of a log's first frame (None: no frame can be read), for putting logs in order."""
    try:
        for block in iter_log_blocks(path, date=date):
            if len(block):
                return int(block.t_ns[0])
    except LogError:
        pass
    return None


def in_time_order(paths: list[Path], date: datetime.date | None = None) -> list[Path]:
    """Logs in order of their first frame; one without a readable frame goes last (its error
    is reported when it is read)."""
    def key(p: Path) -> int:
        t = first_frame_ns(p, date)
        return 1 << 62 if t is None else t
    return sorted(paths, key=key) if len(paths) > 1 else list(paths)


def iter_log(path: str | Path, rejects: RejectCounter | None = None, date: datetime.date | None = None
             ) -> Iterator[Frame]:
    """Frames of any supported log, one at a time in file order (the blocks of
    :func:`iter_log_blocks`). Bad records are counted in ``rejects``; ``date``: the date of a
    YDWG log's first line (see :func:`~steer_monitor.logfiles.gateway.ydwg_date`)."""
    for block in iter_log_blocks(path, rejects, date):
        yield from block.frames()


def read_log_fast(path: str | Path, rejects: RejectCounter | None = None,
                  date: datetime.date | None = None) -> FrameArrays:
    """A whole log as columns (the blocks of :func:`iter_log_blocks` joined)."""
    return FrameArrays.concat(list(iter_log_blocks(path, rejects, date)))


def write_candump_arrays(fh: IO[bytes], fa: FrameArrays, channel: str = 'can0') -> None:
    """Write frames as candump ``-L`` lines (what :class:`~steer_monitor.logfiles.logs.LogWriter`
    writes, byte for byte) with numpy: for making long logs quickly."""
    n = len(fa)
    if n == 0:
        return
    ext = (fa.flags & FLAG_EXTENDED) != 0
    err = (fa.flags & FLAG_ERROR) != 0
    rtr = (fa.flags & FLAG_REMOTE) != 0
    sec, ns = np.divmod(fa.t_ns, 1_000_000_000)
    sec_txt = sec.astype('U20').astype('S20')
    width_sec = np.char.str_len(sec_txt)
    if (~ext).any() or err.any() or rtr.any() or (fa.dlc > MAX_DLC).any() or (width_sec != width_sec[0]).any():
        # not one fixed layout: line by line
        fh.write(''.join(candump_line(f, channel) for f in fa.frames()).encode('ascii'))
        return
    usec = ns // 1000
    hexd = np.frombuffer(b'0123456789ABCDEF', np.uint8)
    chan = channel.encode()
    ws = int(width_sec[0])
    max_d = int(fa.dlc.max())
    line_w = 1 + ws + 1 + 6 + 2 + len(chan) + 1 + 8 + 1 + 2 * max_d + 1
    m = np.full((n, line_w), ord(' '), np.uint8)
    c = 0
    m[:, c] = ord('(')
    c += 1
    m[:, c:c + ws] = np.frombuffer(sec_txt.tobytes(), np.uint8).reshape(n, 20)[:, :ws]
    c += ws
    m[:, c] = ord('.')
    c += 1
    for k in range(6):
        m[:, c + k] = 48 + (usec // 10 ** (5 - k)) % 10
    c += 6
    m[:, c] = ord(')')
    c += 2
    m[:, c:c + len(chan)] = np.frombuffer(chan, np.uint8)
    c += len(chan) + 1
    ids = fa.can_id.astype(np.int64)
    for k in range(8):
        m[:, c + k] = hexd[(ids >> (4 * (7 - k))) & 0xF]
    c += 8
    m[:, c] = ord('#')
    c += 1
    for k in range(max_d):
        m[:, c + 2 * k] = hexd[fa.data[:, k] >> 4]
        m[:, c + 2 * k + 1] = hexd[fa.data[:, k] & 0xF]
    ends = c + 2 * fa.dlc.astype(np.intp)
    m[np.arange(n), ends] = 10
    if (fa.dlc == max_d).all():
        fh.write(m[:, :line_w].tobytes())
        return
    keep = np.arange(line_w) <= ends[:, None]
    fh.write(m[keep].tobytes())

