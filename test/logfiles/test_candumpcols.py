"""The candump column reader gives what the reference reader (test/logfiles/reference_reader.py)
gives, line by line: frames and rejects; and the column writer writes what the log writer does."""

from __future__ import annotations

import io

import numpy as np
import pytest

from steer_monitor.can import FrameArrays
from steer_monitor.logfiles.blocks import read_log_fast
from steer_monitor.logfiles.logs import LogWriter, write_candump
from test.logfiles.reference_reader import read_log_reference as read_log_arrays
from test.support.logcols import both, same

MIXED = [
    '(1767225600.000100) can0 09F10D10#00F80000FFFFFFFF',
    'garbage line',
    '(1767225600.000200) can0 09F10D10#00F8000',                 # odd payload
    '(99999999999999999999.0) can0 09F10D10#00',                 # time out of range
    '(1767225600.000300) can0 123#R',                            # remote, standard id
    '(1767225600.000350) vcan12 123#DEADBEEF',                   # standard id, other channel
    '(1767225600.5) can0 09F10D10#00f80000ffffffff',             # short fraction, lower case
    '(1767225600.000400) can0 29F10D10#0011',                    # error frame flag
    '(1767225600.000500) can0 09F10D10#',                        # empty payload
    '(1767225600.000600) can0 09F10D10#00F80000FFFFFFFF00',      # 9 bytes
    '(1767225600.000700)  can0 09F10D10#00',                     # two spaces
    '(1767225600.000800) can0 09F10D10#0G',                      # not hex
    '(1767225600.000900) can0 09F10D10#00F80000FFFFFFFF\r',      # CRLF
]


@pytest.mark.parametrize('repeat', [1, 40])
def test_every_kind_of_line_as_the_line_parser_reads_it(tmp_path, repeat):
    """Odd lines alone and among many usual ones (the column path takes a layout once it
    has 16 lines of it)."""
    usual = [f'(1767225601.{i:06d}) can0 09F10D10#00F80000FFFF{i % 256:02X}FF' for i in range(50)]
    lines = (MIXED * repeat) + usual + MIXED
    path = tmp_path / 'mixed.log'
    path.write_bytes(('\n'.join(lines) + '\n').encode())
    for block in (1 << 20, 97):   # one block, and blocks that cut lines anywhere
        ref, got, r1, r2 = both(path, block_bytes=block)
        same(ref, got)
        assert r1.counts == r2.counts and r1.counts['malformed_record'] > 0


def test_last_line_without_newline_and_empty_file(tmp_path):
    path = tmp_path / 'n.log'
    path.write_bytes(b'(1767225600.000100) can0 09F10D10#00F80000FFFFFFFF\n(1767225600.000200) can0 123#01')
    ref, got, _, _ = both(path)
    same(ref, got)
    empty = tmp_path / 'e.log'
    empty.write_bytes(b'')
    assert len(read_log_fast(empty)) == 0


def test_writing_a_log_at_once_is_the_log_writer(tmp_path, simulated):
    ref = tmp_path / 'ref.log'
    with LogWriter(ref) as w:
        for f in simulated.frames():
            w.write(f)
    buf = io.BytesIO()
    write_candump(buf, simulated)
    assert buf.getvalue() == ref.read_bytes()
    odd = read_log_arrays(tmp_path / 'ref.log').take(np.arange(5))
    odd = FrameArrays(odd.t_ns, odd.can_id, odd.dlc, odd.data, odd.flags & 0)   # standard ids: the slow path
    buf2 = io.BytesIO()
    write_candump(buf2, odd)
    back = tmp_path / 'odd.log'
    back.write_bytes(buf2.getvalue())
    same(read_log_arrays(back), read_log_fast(back))


USUAL = b'(1767225600.008079) can0 09F10D10#00F800000100FFFF'


SUBSTITUTES = b'0 9aFG.#(x\x00\x7f\xff\t\r\x0b'   # with whitespace the line parser splits on and the columns do not


def _block(lines: list[bytes]):
    from steer_monitor.logfiles import candumpcols
    raw = b''.join(line + b'\n' for line in lines)
    pb = candumpcols._PAD_BYTES + raw + candumpcols._PAD_BYTES
    return pb, np.frombuffer(pb, np.uint8, count=len(raw), offset=candumpcols._PAD)


def test_a_block_of_one_layout_is_read_by_strided_words():
    from steer_monitor.logfiles.candumpcols import uniform_frames
    lines = [USUAL.replace(b'008079', f'{i:06d}'.encode()) for i in range(40)]
    fa = uniform_frames(*_block(lines))
    assert fa is not None and len(fa) == 40
    np.testing.assert_array_equal(fa.t_ns, 1767225600_000000000 + np.arange(40) * 1000)
    assert set(fa.can_id.tolist()) == {0x09F10D10} and bytes(fa.data[0]) == bytes.fromhex('00F800000100FFFF')


@pytest.mark.parametrize('pos', range(len(USUAL)))
def test_one_changed_character_anywhere(tmp_path, pos):
    """Each character of a usual line replaced by digits, letters, delimiters and control
    bytes, among lines of its layout: what the line parser makes of it, whichever path reads
    it; the one-layout path declines a block with a line it would reject."""
    from steer_monitor.logfiles.candumpcols import uniform_frames
    good = [USUAL] * 20
    for c in SUBSTITUTES:
        line = USUAL[:pos] + bytes([c]) + USUAL[pos + 1:]
        lines = good[:10] + [line] + good[10:]
        path = tmp_path / f'{pos}_{c}.log'
        path.write_bytes(b''.join(x + b'\n' for x in lines))
        ref, got, r1, r2 = both(path)
        same(ref, got)
        assert r1.counts == r2.counts
        fast = uniform_frames(*_block(lines))
        if len(ref) < len(lines):
            assert fast is None, (pos, c)
        elif fast is not None:
            same(ref, fast)


def test_lines_longer_than_a_block(tmp_path):
    """A line longer than the block read (the buffer grows to hold it) among usual lines."""
    usual = [f'(1767225601.{i:06d}) can0 09F10D10#00F80000FFFF{i:02X}FF' for i in range(40)]
    lines = usual[:20] + ['x' * 500, '(1767225601.5) can0 09F10D10#' + '0' * 300] + usual[20:]
    path = tmp_path / 'long.log'
    path.write_bytes(('\n'.join(lines) + '\n').encode())
    ref, got, r1, r2 = both(path, block_bytes=97)
    same(ref, got)
    assert len(got) == 40 and r1.counts == r2.counts
