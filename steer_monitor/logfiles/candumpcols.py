"""candump logs into columns without a Python object per frame, block by block (memory stays
bounded whatever the log's length), and columns back into candump lines.

Why our own reader: python-can's builds one object per frame (a few us each); a month of one
vessel's steering bus is a few hundred million frames. It gives the same frames and reject
counts as a plain reader line by line (the tests' oracle, ``test/logfiles/reference_reader.py``,
compared on every kind of line). Lines of the usual shape ``(sec.frac) chan ID#HEX`` are parsed
eight characters at a time (:mod:`~steer_monitor.logfiles.digits`) at the offsets of their
layout. A block whose lines are all of one length and layout (one writer, one DLC: the usual
log) is read with strided words straight from the block, without finding its lines; otherwise
the block is split on newlines and the lines grouped by length. Any other line (remote frames,
odd payloads, garbage) goes through the line parser of :mod:`~steer_monitor.logfiles.logs`,
which counts what it rejects.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from steer_monitor.can.frames import FLAG_ERROR, FLAG_EXTENDED, MAX_DLC, Frame, FrameArrays
from steer_monitor.can.rejects import RejectCounter
from steer_monitor.logfiles import digits
from steer_monitor.logfiles.logs import CAN_ERR_FLAG, _candump_line, open_text_log

__all__ = ['BLOCK_BYTES', 'BLOCK_FRAMES', 'CANDUMP_LINE', 'iter_candump_blocks', 'uniform_frames']


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


CANDUMP_LINE = re.compile(rb'^\((\d+)\.(\d{1,9})\) (\S+) ([0-9A-Fa-f]{1,8})#([0-9A-Fa-f]*)$')


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
    m = CANDUMP_LINE.match(line)
    if m is None:
        return None
    dot, cp, sp2, hs = m.end(1), m.end(2), m.end(3), m.end(4)
    if (len(line) - hs - 1) % 2 or len(line) - hs - 1 > 16 or dot - 1 > 16:
        return None
    return dot, cp, sp2, hs


def uniform_frames(pb: bytes | bytearray, a: NDArray[np.uint8]) -> FrameArrays | None:
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
            fa = uniform_frames(ba, a)
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
