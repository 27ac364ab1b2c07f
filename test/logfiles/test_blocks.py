"""Any log as blocks of columns: the same frames as the reference reader, a log's end, and
frames one at a time."""

from __future__ import annotations

import pytest

from steer_monitor.can import FrameArrays
from steer_monitor.logfiles.blocks import iter_log_blocks, log_end_ns, read_log_fast
from steer_monitor.logfiles.logs import LogError, LogWriter
from test.logfiles.reference_reader import iter_log_reference as iter_log
from test.support.logcols import both, same


@pytest.mark.parametrize('suffix', ['.log', '.mcap'])
def test_simulated_log_reads_the_same(tmp_path, simulated, suffix):
    path = tmp_path / f'x{suffix}'
    with LogWriter(path) as w:
        for f in simulated.frames():
            w.write(f)
    ref, got, _, _ = both(path)
    same(ref, got)


def test_cut_blf_gives_its_frames_before_the_error(tmp_path, simulated):
    """python-can's BLF reader stops quietly at a cut container and the reader raises after
    the last frame: the block reader must hand over the frames it holds before the error
    (it once dropped every frame of a cut BLF shorter than a block)."""
    path = tmp_path / 'x.blf'
    with LogWriter(path) as w:
        for f in simulated.frames():
            w.write(f)
    cut = tmp_path / 'cut.blf'
    cut.write_bytes(path.read_bytes()[: path.stat().st_size * 2 // 3])
    ref = []
    with pytest.raises(LogError, match='breaks off or is corrupt') as want:
        for f in iter_log(cut):
            ref.append(f)
    got = []
    with pytest.raises(LogError, match='breaks off or is corrupt') as err:
        for block in iter_log_blocks(cut):
            got.append(block)
    assert str(err.value) == str(want.value)
    assert 0 < len(ref) < len(simulated)
    same(FrameArrays.concat(got), FrameArrays.from_frames(ref))


def test_log_end(tmp_path, simulated):
    for suffix in ('.log', '.mcap'):
        path = tmp_path / f'x{suffix}'
        with LogWriter(path) as w:
            for f in simulated.frames():
                w.write(f)
        assert log_end_ns(path) == int(simulated.t_ns[-1]) // 1000 * 1000
    assert log_end_ns(tmp_path / 'missing.log') is None


def test_same_as_iter_log_on_frames(tmp_path, simulated):
    path = tmp_path / 'y.log'
    with LogWriter(path) as w:
        for f in simulated.frames():
            w.write(f)
    fast = read_log_fast(path).frames()
    assert fast == [f.__class__(f.t_ns, f.can_id, f.data, f.is_extended, f.is_error, f.is_remote, '')
                    for f in iter_log(path)]
