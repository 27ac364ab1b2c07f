"""Compressed logs (gzip, xz, bzip2, zstd) read as the logs they hold; damage keeps what came
before; the real captures of ``../shared/realbus`` compressed give the frames they give plain."""

from __future__ import annotations

import bz2
import datetime
import gzip
import lzma
import zlib
from pathlib import Path

import numpy as np
import pytest
import zstandard

from steer_monitor.ashore.fleet import find_vessels
from steer_monitor.can import FrameArrays, RejectCounter
from steer_monitor.logfiles.blocks import iter_log, iter_log_blocks, log_end_ns, read_log_fast
from steer_monitor.logfiles.compressed import PIECE_BYTES, compression, plain_suffix
from steer_monitor.logfiles.logs import LogError, log_format
from test.support.captures import MERRIMAC, SUSTERANNA, capture
from test.support.logwrite import write_asc, write_log

PACK = {'.gz': gzip.compress, '.xz': lzma.compress, '.bz2': bz2.compress,
        '.zst': lambda b: zstandard.ZstdCompressor().compress(b)}


@pytest.fixture(scope='module')
def simulated(r18_params, can_db):
    from steer_monitor import sim
    db, smap = can_db
    return sim.run(r18_params, sim.SimConfig(program='zigzag_10', max_duration_s=40.0), db, smap, seed=3)


def _packed(plain: Path, suffix: str, name: str | None = None) -> Path:
    out = plain.with_name(name or plain.name + suffix)
    out.write_bytes(PACK[suffix](plain.read_bytes()))
    return out


def _same(a: FrameArrays, b: FrameArrays) -> bool:
    return len(a) == len(b) and all(np.array_equal(getattr(a, k), getattr(b, k))
                                    for k in ('t_ns', 'can_id', 'dlc', 'data', 'flags'))


@pytest.mark.parametrize('suffix', sorted(PACK))
@pytest.mark.parametrize('fmt', ['.log', '.asc'])
def test_a_compressed_log_gives_the_frames_of_the_plain_one(tmp_path, simulated, suffix, fmt):
    plain = write_log(tmp_path / 'x.log', simulated.frames) if fmt == '.log' else \
        write_asc(tmp_path / 'x.asc', simulated.frames)
    packed = _packed(plain, suffix)
    assert log_format(packed) == log_format(plain)
    assert _same(read_log_fast(packed), read_log_fast(plain))
    assert [f.t_ns for f in iter_log(packed)] == [f.t_ns for f in iter_log(plain)]
    assert log_end_ns(packed) is None       # not known without decompressing the whole


@pytest.mark.parametrize('path, date', [(SUSTERANNA, None), (MERRIMAC, datetime.date(2020, 8, 22))])
def test_real_captures_compressed_give_their_frames(tmp_path, path, date):
    """Logs we did not make (a CANboat plain and a YDWG raw capture), as a vessel's log
    rotation would leave them, with names that do not say what they hold."""
    plain = capture(path)
    packed = tmp_path / (plain.stem + '.1.gz')
    packed.write_bytes(gzip.compress(plain.read_bytes()))
    assert log_format(packed) == log_format(plain)
    assert _same(read_log_fast(packed, date=date), read_log_fast(plain, date=date))


@pytest.mark.parametrize('suffix', ['.gz', '.xz', '.zst'])
def test_a_compressed_log_cut_short_keeps_what_came_before_it(tmp_path, r18_params, can_db, suffix):
    """A copy interrupted: the frames up to the cut are read, but for at most one piece of
    decompressed log, and the error says where."""
    from steer_monitor import sim
    db, smap = can_db
    s = sim.run(r18_params, sim.SimConfig(program='zigzag_10', max_duration_s=300.0), db, smap, seed=4)
    plain = write_log(tmp_path / 'x.log', s.frames)
    packed = _packed(plain, suffix).read_bytes()
    cut = tmp_path / f'cut.log{suffix}'
    cut.write_bytes(packed[:len(packed) // 2])
    decoder = {'.gz': lambda: zlib.decompressobj(31), '.xz': lzma.LZMADecompressor,
               '.zst': lambda: zstandard.ZstdDecompressor().decompressobj()}[suffix]()
    whole_lines = decoder.decompress(cut.read_bytes()).count(b'\n')       # what the cut leaves
    got: list[FrameArrays] = []
    with pytest.raises(LogError, match=rf'cut\.log{suffix}: \w+ data cut short after \d+ bytes of log; '
                                       'frames before it were read'):
        for block in iter_log_blocks(cut, RejectCounter()):
            got.append(block)
    n = sum(len(b) for b in got)
    line_bytes = plain.stat().st_size / len(s.frames)
    assert whole_lines - PIECE_BYTES / line_bytes - 1 <= n <= whole_lines
    assert _same(FrameArrays.concat(got), s.frames.take(np.arange(n)))


@pytest.mark.parametrize('fmt', ['.mcap', '.blf'])
def test_a_compressed_mcap_or_blf_is_named_as_such(tmp_path, simulated, fmt):
    packed = _packed(write_log(tmp_path / f'x{fmt}', simulated.frames), '.gz')
    with pytest.raises(LogError, match=rf'x{fmt}\.gz: a compressed (MCAP|Vector BLF) file: decompress it first'):
        list(iter_log_blocks(packed))


def test_a_compressed_file_of_something_else_names_the_suffixes(tmp_path):
    p = tmp_path / 'notes.txt.gz'
    p.write_bytes(gzip.compress(b'hello, world\n'))
    with pytest.raises(LogError, match=r"notes.txt.gz: unsupported log format '.txt': .*\(suffixes: .log, .asc, "
                                       r".blf, .mcap, each also compressed: .gz, .xz, .bz2, .zst\)"):
        list(iter_log(p))
    bad = tmp_path / 'bad.log.gz'
    bad.write_bytes(b'\x1f\x8b' + b'\x00' * 40)
    with pytest.raises(LogError, match=r'bad.log.gz: gzip data'):
        list(iter_log_blocks(bad))


@pytest.mark.parametrize('head, kind', [(b'\x1f\x8b\x08', 'gzip'), (b'\xfd7zXZ\x00\x00', 'xz'), (b'BZh91AY', 'bzip2'),
                                        (b'\x28\xb5\x2f\xfd\x00', 'zstd'), (b'(1745600961.3) can0', None), (b'', None)])
def test_compression_by_first_bytes(head, kind):
    assert compression(head) == kind


@pytest.mark.parametrize('name, suffix', [('can0.log.gz', '.log'), ('a.ASC.XZ', '.asc'), ('a.mcap', '.mcap'),
                                          ('can0.log.1.gz', '.log'), ('can0.log.12', '.log'), ('a.gz', ''),
                                          ('a', ''), ('a.1', '')])
def test_plain_suffix(name, suffix):
    assert plain_suffix(name) == suffix


def test_the_fleet_takes_compressed_logs(tmp_path):
    vessel = tmp_path / 'mv_alpha'
    vessel.mkdir()
    for name in ('a.log', 'b.log.1.gz', 'c.log.gz', 'd.mcap', 'notes.gz', 'e.txt.gz', 'f.log.2', 'g.1'):
        (vessel / name).write_bytes(b'')
    (v,) = find_vessels([vessel])
    assert [p.name for p in v.logs] == ['a.log', 'b.log.1.gz', 'c.log.gz', 'd.mcap', 'f.log.2']


@pytest.mark.parametrize('suffix', ['.gz', '.zst', '.xz', '.bz2'])
def test_a_log_compressed_in_parts_is_read_whole(tmp_path, simulated, suffix):
    """Parts compressed one after another into one file (``cat a.gz b.gz``, a logger that
    compresses as it goes): every part is read."""
    plain = write_log(tmp_path / 'x.log', simulated.frames).read_bytes()
    half = plain.index(b'\n', len(plain) // 2) + 1
    packed = tmp_path / f'x.log{suffix}'
    packed.write_bytes(PACK[suffix](plain[:half]) + PACK[suffix](plain[half:]))
    assert _same(read_log_fast(packed), simulated.frames)
