"""Text logs with runs of bytes without a line end: a fixed buffer each, the run
counted as ``long_line`` bytes with where it was, the good lines before and after kept."""

from __future__ import annotations

import gzip
import io
import json
import subprocess
import sys
import time

import pytest
import zstandard

from steer_monitor.can.rejects import RejectCounter
from steer_monitor.logfiles.linebound import LineBound, bounded_lines

GOOD = b'(1767225600.000000) can0 09F10D0B#FFFF7F0000FFFFFF\n'


def _read(data: bytes, max_line: int, piece: int = 7) -> tuple[bytes, RejectCounter]:
    """Through LineBound, its input handed over ``piece`` bytes at a time (short reads, as a
    decompressor's at member ends)."""
    class Trickle(io.RawIOBase):
        def __init__(self) -> None:
            self.at = 0

        def readable(self) -> bool:
            return True

        def readinto(self, b) -> int:
            n = min(len(b), piece, len(data) - self.at)
            b[:n] = data[self.at:self.at + n]
            self.at += n
            return n

    r = RejectCounter()
    with LineBound(io.BufferedReader(Trickle(), 16), 'x.log', r, max_line=max_line) as lb:
        out = lb.read()
    return out, r


@pytest.mark.parametrize('piece', [1, 3, 7, 64, 1000])
@pytest.mark.parametrize('data, want, skipped', [
    (b'ab\ncd\n', b'ab\ncd\n', 0),                                  # short lines pass as they are
    (b'abcdefghij\n', b'abcdefghij\n', 0),                          # a line at the bound
    (b'abcdefghijk\nxy\n', b'abcdefghij\nxy\n', 2),                 # past it: cut, the rest to its end skipped
    (b'ab\n' + b'\0' * 50 + b'xy\n', b'ab\n' + b'\0' * 10 + b'\nxy\n', 40),   # NULs: a line starts after them
    (b'ab\n' + b'\xff' * 50, b'ab\n' + b'\xff' * 10 + b'\n', 40),   # a binary tail without an end
    (b'\0' * 25, b'\0' * 10 + b'\n', 15),
])
def test_lines_are_cut_at_the_bound_and_the_rest_counted(data, want, skipped, piece):
    out, r = _read(data, 10, piece)
    assert out == want
    assert r['long_line'] == skipped
    if skipped:
        assert 'x.log: ' in r.snapshot().last['long_line'] and 'bytes without a line end from byte' in \
            r.snapshot().last['long_line']


def test_a_long_text_is_read_unchanged():
    data = GOOD * 10000
    out, r = _read(data, 1000, 4096)
    assert out == data and r.snapshot().total == 0


def test_bounded_lines_reads_lines():
    r = RejectCounter()
    fh = bounded_lines(io.BytesIO(GOOD * 3 + b'x' * 200_000 + b'\n' + GOOD), 'y.log', r)
    lines = list(fh)
    assert lines[:3] == [GOOD] * 3 and lines[-1] == GOOD and len(lines) == 5
    assert r['long_line'] == 200_001 - 65536


def _gzip_bomb(path, zeros_gib: int) -> int:
    """Good lines, ``zeros_gib`` GiB of NUL bytes, good lines: gzip members (the zeros as
    1 MiB members, written once and repeated), a few MB on disk. Returns the good lines."""
    member = gzip.compress(b'\0' * (1 << 20), 9)
    lines = [b'(%d.%06d) can0 09F10D0B#FFFF7F0000FFFFFF\n' % (1767225600 + i // 10, (i % 10) * 100000)
             for i in range(2000)]
    with open(path, 'wb') as fh:
        fh.write(gzip.compress(b''.join(lines[:1000])))
        for _ in range(zeros_gib * 1024):
            fh.write(member)
        fh.write(gzip.compress(b''.join(lines[1000:])))
    return len(lines)


_MEASURE = """
import json, resource, subprocess, sys, time
t0 = time.perf_counter()
p = subprocess.run(sys.argv[1:], capture_output=True, text=True)
print(json.dumps({'rc': p.returncode, 'out': p.stdout, 'err': p.stderr, 'seconds': time.perf_counter() - t0,
                  'peak_mb': resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024}))
"""


def _measured(*args: str) -> dict:
    """A command run in a fresh process: its exit status, output, time and peak resident memory
    (of the command and any process it started)."""
    p = subprocess.run([sys.executable, '-c', _MEASURE, sys.executable, '-m', 'steer_monitor.cli.main', *args],
                       capture_output=True, text=True, check=True)
    return json.loads(p.stdout)


@pytest.mark.slow
def test_inspect_reads_a_4_gib_run_of_zeros_in_a_gzip_log_in_bounded_memory(tmp_path):
    """The power cut's NUL bytes, 4 GiB once decompressed (never written out): inspect keeps
    every good frame before and after, counts the run, stays under 400 MB and takes time in
    proportion to the bytes (over 50 MB/s here; about 300 MB/s on the machine alone)."""
    path = tmp_path / 'can0.log.gz'
    good = _gzip_bomb(path, 4)
    assert path.stat().st_size < 8 << 20
    m = _measured('inspect', str(path), '--json', '-')
    got = json.loads(m['out'])
    assert got['frames'] == good, m['err']
    assert got['rejects']['long_line'] == (4 << 30) - 65536
    assert 'bytes without a line end from byte' in got['reject_examples']['long_line']
    assert m['peak_mb'] < 400, m
    rate = (4 << 30) / 1e6 / m['seconds']
    assert rate > 50, f'{rate:.0f} MB/s'


@pytest.mark.slow
@pytest.mark.parametrize('command', ['analyze', 'replay', 'report'])
def test_the_other_readers_stay_bounded_on_a_zstd_bomb(tmp_path, r18_params, can_db, command):
    """A voyage's minute of frames, 1 GiB of zeros in one zstd frame (33 KB on disk), the rest
    of the voyage: analyze, replay and report read through it under 400 MB."""
    from steer_monitor import sim
    from steer_monitor.logfiles.logs import write_candump

    db, smap = can_db
    s = sim.run(r18_params, sim.SimConfig(program='hard_over_2,zigzag_10', max_duration_s=120.0), db, smap, 9)
    buf = io.BytesIO()
    write_candump(buf, s.frames)
    text = buf.getvalue()
    half = text.index(b'\n', len(text) // 2) + 1
    c = zstandard.ZstdCompressor(level=3)
    z = c.compressobj()
    parts = [z.compress(text[:half])]
    zeros = b'\0' * (64 << 20)
    for _ in range(16):
        parts.append(z.compress(zeros))
    parts += [z.compress(text[half:]), z.flush()]
    path = tmp_path / 'can0.log.zst'
    path.write_bytes(b''.join(parts))
    args = {'analyze': ['analyze', str(path), '--json', str(tmp_path / 'a.json')],
            'replay': ['replay', str(path), '--out', str(tmp_path / 'r.mcap'), '--no-frames'],
            'report': ['report', str(path), '--out', str(tmp_path / 'page')]}[command]
    t0 = time.perf_counter()
    m = _measured(*args)
    assert m['rc'] == 0, m['err']
    assert m['peak_mb'] < 400, m
    assert time.perf_counter() - t0 < 120
