"""Log files: every format gives the same samples; bad records are counted; a log that breaks
off keeps what came before."""

from __future__ import annotations

import numpy as np
import pytest

from steer_monitor import sim
from steer_monitor.can import Decoder, FrameArrays, RejectCounter
from steer_monitor.logfiles.blocks import iter_log
from steer_monitor.logfiles.blocks import read_log_fast as read_log_arrays
from steer_monitor.logfiles.logs import LogError, LogWriter
from steer_monitor.logfiles.mcapio import FRAME_TOPIC
from test.support.logwrite import write_asc, write_log

FORMATS = ('.log', '.blf', '.mcap')


@pytest.fixture(scope='module')
def simulated(r18_params, can_db):
    db, smap = can_db
    cfg = sim.SimConfig(program='hard_over_2', max_duration_s=20.0)
    return sim.run(r18_params, cfg, db, smap, seed=11)


@pytest.mark.parametrize('suffix', FORMATS)
def test_every_format_decodes_to_the_same_samples(tmp_path, can_db, simulated, suffix):
    db, smap = can_db
    reference = Decoder(db, smap).decode_arrays(simulated.frames)
    path = write_log(tmp_path / f'x{suffix}', simulated.frames)
    rejects = RejectCounter()
    back = read_log_arrays(path, rejects)
    assert len(back) == len(simulated.frames)
    assert np.array_equal(back.t_ns, simulated.frames.t_ns)
    assert np.array_equal(back.can_id, simulated.frames.can_id)
    assert np.array_equal(back.data, simulated.frames.data)
    got = Decoder(db, smap, rejects).decode_arrays(back)
    assert rejects.snapshot().total == 0
    for name in smap.names:
        assert np.array_equal(got[name].t_ns, reference[name].t_ns)
        assert np.array_equal(got[name].value, reference[name].value)


def test_asc_decodes_to_the_same_samples(tmp_path, can_db, simulated):
    """ASC (written by python-can, as Vector tools would) holds its start to the millisecond:
    values and relative times come back exactly, the absolute start within 1 ms."""
    db, smap = can_db
    path = write_asc(tmp_path / 'x.asc', simulated.frames)
    back = read_log_arrays(path)
    ref = simulated.frames
    assert len(back) == len(ref)
    assert np.array_equal(back.data, ref.data) and np.array_equal(back.can_id, ref.can_id)
    assert np.array_equal(back.t_ns - back.t_ns[0], ref.t_ns - ref.t_ns[0])
    assert abs(int(back.t_ns[0]) - int(ref.t_ns[0])) < 1_000_000
    got = Decoder(db, smap).decode_arrays(back)
    want = Decoder(db, smap).decode_arrays(ref)
    for name in smap.names:
        assert np.array_equal(got[name].value, want[name].value)


def test_noise_free_round_trip_within_one_quantisation_step(tmp_path, r18_params, can_db):
    db, smap = can_db
    cfg = sim.SimConfig(program='zigzag_20', noise=False, max_duration_s=60.0)
    s = sim.run(r18_params, cfg, db, smap, seed=2)
    path = write_log(tmp_path / 'clean.log', s.frames)
    got = Decoder(db, smap).decode_arrays(read_log_arrays(path))
    steps = {'rudder_angle': 1e-4, 'rudder_order': 1e-4, 'ship_speed': 0.01, 'oil_temperature': 0.001}
    stream = {'rudder_angle': 'rudder', 'rudder_order': 'rudder'}
    for name in smap.names:
        step = steps.get(name, 0.1)  # pressures: 0.1 Pa
        exact = s.sensors.exact[name]
        assert np.array_equal(got[name].t_ns, s.sensors.t_ns[stream.get(name, name)])
        assert np.max(np.abs(got[name].value - exact)) <= step / 2 + 1e-9 * max(1.0, np.max(np.abs(exact))), name


def test_mcap_read_by_rosbags_and_with_crcs(tmp_path, simulated):
    from mcap.reader import make_reader
    from rosbags.highlevel import AnyReader
    path = write_log(tmp_path / 'x.mcap', simulated.frames)
    with open(path, 'rb') as fh:
        reader = make_reader(fh, validate_crcs=True)
        n = sum(1 for _ in reader.iter_messages())
        summary = reader.get_summary()
    assert n == len(simulated.frames)
    assert {c.topic for c in summary.channels.values()} == {FRAME_TOPIC}
    assert all(c.metadata.get('offered_qos_profiles') for c in summary.channels.values())
    with AnyReader([path]) as r:
        msgs = [r.deserialize(raw, c.msgtype) for c, _, raw in r.messages()]
    assert len(msgs) == len(simulated.frames)
    assert msgs[0].id == int(simulated.frames.can_id[0]) and msgs[0].is_extended
    assert bytes(msgs[0].data) == simulated.frames.data[0].tobytes()


def test_candump_is_read_independently_by_python_can(tmp_path, simulated):
    import can
    path = write_log(tmp_path / 'x.log', simulated.frames)
    msgs = list(can.CanutilsLogReader(str(path)))
    assert len(msgs) == len(simulated.frames)
    assert msgs[5].arbitration_id == int(simulated.frames.can_id[5])
    assert bytes(msgs[5].data) == simulated.frames.data[5].tobytes()


def test_malformed_candump_lines_are_counted_not_fatal(tmp_path):
    path = tmp_path / 'bad.log'
    path.write_text('(1767225600.000100) can0 09F10D10#00F80000FFFFFFFF\n'
                    'garbage line\n'
                    '(1767225600.000200) can0 09F10D10#00F8000\n'
                    '(99999999999999999999.0) can0 09F10D10#00\n'
                    '(1767225600.000300) can0 123#R\n'
                    '(1767225600.000400) can0 09F10D10#00F80000FFFFFFFF\n')
    rejects = RejectCounter()
    frames = list(iter_log(path, rejects))
    assert len(frames) == 3
    assert frames[1].is_remote and not frames[1].is_extended
    snap = rejects.snapshot()
    assert snap.counts == {'malformed_record': 3}
    assert snap.last['malformed_record'].startswith('log record that cannot be parsed: bad.log line 4')


@pytest.mark.parametrize('suffix', ['.mcap', '.blf'])
def test_truncated_file_keeps_what_came_before(tmp_path, simulated, suffix):
    if suffix == '.mcap':  # small chunks, so the cut lands inside the data, not the summary
        from steer_monitor.logfiles.mcapio import McapWriter
        path = tmp_path / 'x.mcap'
        with McapWriter(path, chunk_size=4096) as w:
            for f in simulated.frames.frames():
                w.write_frame(f)
    else:
        path = write_log(tmp_path / f'x{suffix}', simulated.frames)
    data = path.read_bytes()
    cut = tmp_path / f'cut{suffix}'
    cut.write_bytes(data[: len(data) * 2 // 3])
    got = []
    with pytest.raises(LogError, match='breaks off'):
        for f in iter_log(cut):
            got.append(f)
    assert 0 < len(got) < len(simulated.frames)
    assert got[0].t_ns == int(simulated.frames.t_ns[0])


def test_unsupported_and_missing(tmp_path):
    (tmp_path / 'x.txt').write_text('hello, world\n')
    with pytest.raises(
        LogError,
        match=r"x.txt: unsupported log format '.txt': its content is none of candump -L, "
        r"Vector ASC, .*, Yacht Devices YDWG raw \(suffixes: .log, .asc, .blf, .mcap, each also "
        r"compressed: .gz, .xz, .bz2, .zst\)",
    ):
        list(iter_log(tmp_path / 'x.txt'))
    with pytest.raises(LogError, match='cannot open log'):
        list(iter_log(tmp_path / 'missing.log'))


def test_writer_close_is_idempotent(tmp_path, simulated):
    w = LogWriter(tmp_path / 'x.mcap')
    w.write(simulated.frames.frames()[0])
    w.close()
    w.close()
    assert len(list(iter_log(tmp_path / 'x.mcap'))) == 1


def _frame_lines(text: str) -> list[int]:
    return [i for i, line in enumerate(text.splitlines(keepends=True)) if ' Rx ' in line]


@pytest.mark.parametrize('damage', ['letter in the id', 'byte not UTF-8', 'payload byte cut', 'sign in the id'])
def test_asc_line_that_cannot_be_parsed_is_counted_and_the_rest_read(tmp_path, simulated, damage):
    """python-can's ASC reader ends the log at the first frame line it cannot parse; here that
    line is counted and the frames after it are read; so is a line still shaped like a frame
    that the reader would skip as an event it does not know (a sign in the id)."""
    path = write_asc(tmp_path / 'x.asc', simulated.frames)
    lines = path.read_bytes().splitlines(keepends=True)
    k = _frame_lines(path.read_text())[len(simulated.frames) // 2]
    tokens = lines[k].split()       # time, channel, id, Rx, d, dlc, payload bytes
    token = tokens[2] if damage in ('letter in the id', 'sign in the id') else tokens[-2]
    bad = {'letter in the id': b'1Z' + token[2:], 'byte not UTF-8': b'\xe9' + token[1:],
           'payload byte cut': b'G', 'sign in the id': token[:1] + b'\xbb' + token[2:]}[damage]
    lines[k] = lines[k].replace(b' ' + token + b' ', b' ' + bad + b' ', 1)
    assert bad in lines[k]
    path.write_bytes(b''.join(lines))
    rejects = RejectCounter()
    back = FrameArrays.from_frames(list(iter_log(path, rejects)))
    keep = np.ones(len(simulated.frames), bool)
    keep[len(simulated.frames) // 2] = False
    assert len(back) == len(simulated.frames) - 1
    assert np.array_equal(back.can_id, simulated.frames.can_id[keep])
    assert np.array_equal(back.data, simulated.frames.data[keep])
    snap = rejects.snapshot()
    assert snap.counts == {'malformed_record': 1}
    assert snap.last['malformed_record'].startswith(f'log record that cannot be parsed: x.asc line {k + 1}: ')
    if damage != 'sign in the id':      # that one stops it under a UTF-8 locale, is skipped under Latin-1
        import can
        with pytest.raises((ValueError, UnicodeDecodeError)):     # python-can's own reader stops there
            list(can.ASCReader(str(path), relative_timestamp=False))


def test_cut_asc_keeps_what_came_before_and_says_so(tmp_path, simulated):
    path = write_asc(tmp_path / 'x.asc', simulated.frames)
    data = path.read_bytes()
    cut = tmp_path / 'cut.asc'
    cut.write_bytes(data[: len(data) * 2 // 3])
    got = []
    with pytest.raises(LogError, match=r'cut\.asc: log breaks off \(the ASC file ends without "End TriggerBlock"\); '
                                       r'\d+ frames before it were read'):
        for f in iter_log(cut):
            got.append(f)
    assert 0 < len(got) < len(simulated.frames)
    assert [f.can_id for f in got[:-1]] == simulated.frames.can_id[:len(got) - 1].tolist()


def test_asc_without_a_trigger_block_is_read_as_it_is(tmp_path):
    """Some tools export an excerpt with the header and frame lines only, no trigger block:
    that is not a file cut short."""
    path = tmp_path / 'excerpt.asc'
    path.write_text('date Tue May 27 04:09:35.000 pm 2014\n'
                    'base hex  timestamps absolute\n'
                    'internal events logged\n'
                    '// version 10.0.1\n'
                    '   0.019968 1  9F10D10x        Rx   d 8 00 F8 00 00 FF FF FF FF\n'
                    '   0.029964 1  9F10D10x        Rx   d 8 00 F9 00 00 FF FF FF FF\n')
    rejects = RejectCounter()
    frames = list(iter_log(path, rejects))
    assert [f.data[1] for f in frames] == [0xF8, 0xF9]
    assert rejects.snapshot().total == 0


def _blf_objects(data: bytes) -> list[tuple[int, int, int]]:
    """(offset, size, type) of a BLF file's top-level objects (the containers), read here
    from the format: a LOGG header of its own size, then LOBJ headers with size and type."""
    import struct
    assert data[:4] == b'LOGG'
    pos = struct.unpack_from('<I', data, 4)[0]
    out = []
    while pos + 16 <= len(data):
        sig, _, _, size, kind = struct.unpack_from('<4sHHII', data, pos)
        assert sig == b'LOBJ'
        out.append((pos, size, kind))
        pos += size + size % 4
    return out


@pytest.fixture(scope='module')
def longer(r18_params, can_db):
    """Two minutes of frames: a BLF of several containers."""
    db, smap = can_db
    cfg = sim.SimConfig(program='hard_over_2,zigzag_10', max_duration_s=120.0)
    return sim.run(r18_params, cfg, db, smap, seed=11).frames


@pytest.mark.parametrize('damage', ['compressed data', 'object header'])
def test_damaged_blf_container_is_skipped_and_the_rest_read(tmp_path, longer, damage):
    """python-can's BLF reader ends the log at a damaged container; here the container is
    skipped (counted, and named in the error after the frames) and the ones after it read."""
    path = write_log(tmp_path / 'x.blf', longer)
    data = bytearray(path.read_bytes())
    containers = _blf_objects(bytes(data))
    assert len(containers) >= 3
    at, size, _ = containers[1]
    if damage == 'compressed data':
        data[at + size // 2] ^= 0xFF
    else:
        data[at:at + 4] = b'XXXX'
    bad = tmp_path / 'bad.blf'
    bad.write_bytes(bytes(data))
    rejects = RejectCounter()
    got = []
    with pytest.raises(LogError) as err:
        for f in iter_log(bad, rejects):
            got.append(f)
    assert str(err.value).startswith(f'{bad}: 1 damaged container(s) skipped (byte {at}: ')
    assert str(err.value).endswith('); the frames before and after them were read')
    assert rejects.snapshot().counts == {'corrupt_chunk': 1}
    back = FrameArrays.from_frames(got)
    # what was read is the log less one container's frames (and the objects it cut), in order
    k = np.searchsorted(longer.t_ns, back.t_ns)
    assert np.array_equal(longer.t_ns[k], back.t_ns) and np.array_equal(longer.data[k], back.data)
    lost = len(longer) - len(back)
    per_container = len(longer) / len(containers)
    assert 0.5 * per_container < lost < 1.5 * per_container + 2
    assert back.t_ns[-1] == longer.t_ns[-1]          # the containers after it were read
    import can
    with pytest.raises(Exception):  # noqa: B017  python-can's own reader stops there, with an error of its choosing
        list(can.BLFReader(str(bad)))



@pytest.mark.parametrize('declared', [1000, 1 << 31])
def test_a_blf_container_that_would_inflate_past_its_size_is_skipped_uninflated(tmp_path, longer, declared):
    """A container of a few kB of deflate holding 64 MiB of zeros, declaring 1000 bytes (or
    2 GiB): skipped as damaged, the rest read, and never inflated (zlib inflated all of it)."""
    import struct
    import tracemalloc
    import zlib
    path = write_log(tmp_path / 'x.blf', longer)
    data = bytes(path.read_bytes())
    at, size, kind = _blf_objects(data)[1]
    packed = zlib.compress(bytes(64 << 20), 9)
    body = struct.pack('<H6xI4x', 2, declared) + packed
    header = bytearray(data[at:at + 16])
    struct.pack_into('<I', header, 8, 16 + len(body))
    bomb = bytes(header) + body + bytes((16 + len(body)) % 4)
    bad = tmp_path / 'bomb.blf'
    bad.write_bytes(data[:at] + bomb + data[at:])           # an extra container before the second
    rejects = RejectCounter()
    tracemalloc.start()
    try:
        with pytest.raises(LogError, match=r'1 damaged container\(s\) skipped'):
            got = []
            for f in iter_log(bad, rejects):
                got.append(f)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    # every real container read (less the one frame the skip cut, which spans two containers)
    assert len(longer) - 1 <= len(got) <= len(longer)
    assert peak < 16 << 20, peak
    assert rejects.snapshot().counts == {'corrupt_chunk': 1}
