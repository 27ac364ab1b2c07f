"""The MCAP column reader gives what the mcap library gives (test/logfiles/reference_reader.py):
frames and rejects; chunks, channels and damaged files."""

from __future__ import annotations

import struct

import numpy as np
import pytest

from steer_monitor.can import FrameArrays
from steer_monitor.logfiles.blocks import read_log_fast
from steer_monitor.logfiles.logs import LogError
from steer_monitor.logfiles.mcapcols import iter_mcap_blocks
from steer_monitor.logfiles.mcapio import McapWriter
from test.support.logcols import both, same


def test_mcap_with_other_topics_and_small_chunks(tmp_path, simulated):
    """A node's recording: frames in batches among other topics, chunks cut anywhere."""
    from steer_monitor.record import msgdef
    path = tmp_path / 'rec.mcap'
    frames = simulated.frames()
    with McapWriter(path, chunk_size=3000) as w:
        w.add_schema('std_msgs/msg/String', msgdef('std_msgs/msg/String'))
        w.add_channel('/other', 'std_msgs/msg/String')
        for i in range(0, len(frames), 37):
            w.write_frames(frames[i:i + 37])
            w.write('/other', {'data': 'x' * (i % 13)}, frames[i].t_ns)
        w.write_frame(frames[0], '/steering_can/second')  # a second frame channel, one frame
    ref, got, _, _ = both(path)
    same(ref, got)


def test_cut_mcap_keeps_what_came_before(tmp_path, simulated):
    path = tmp_path / 'x.mcap'
    frames = simulated.frames()
    with McapWriter(path, chunk_size=4096) as w:
        for i in range(0, len(frames), 50):
            w.write_frames(frames[i:i + 50])
    data = path.read_bytes()
    cut = tmp_path / 'cut.mcap'
    cut.write_bytes(data[: len(data) * 2 // 3])
    got = []
    with pytest.raises(LogError, match='breaks off'):
        for block in iter_mcap_blocks(cut):
            got.append(block)
    n = sum(len(b) for b in got)
    assert 0 < n < len(simulated)
    np.testing.assert_array_equal(FrameArrays.concat(got).t_ns, simulated.t_ns[:n])
    bad = tmp_path / 'bad.mcap'
    bad.write_bytes(b'not an mcap at all')
    with pytest.raises(LogError, match='not an MCAP file'):
        list(iter_mcap_blocks(bad))


def _mcap_with(path, schema_name, schema_encoding, definition, message_encoding, frames, topic='/steering_can/rx'):
    """An MCAP of ``frames`` (their CDR) on one channel as given, beside a second channel."""
    from mcap.writer import Writer

    from steer_monitor.logfiles.mcapio import frame_cdr
    with open(path, 'wb') as fh:
        w = Writer(fh)
        w.start(profile='ros2', library='test')
        sid = w.register_schema(schema_name, schema_encoding, definition.encode())
        cid = w.register_channel(topic, message_encoding, sid)
        other = w.register_channel(
            '/rosout', 'cdr', w.register_schema('rcl_interfaces/msg/Log', 'ros2msg', b'uint8 level')
        )
        for f in frames:
            w.add_message(cid, log_time=f.t_ns, publish_time=f.t_ns, data=frame_cdr(f))
        w.add_message(other, log_time=frames[0].t_ns, publish_time=0, data=b'\x00\x01\x00\x00\x14')
        w.finish()
    return path


def test_frame_channel_as_rosbag2_writes_it_is_read(tmp_path, simulated):
    """A definition with comments, the short ``Header`` and a topic of its own (as rosbag2
    records ros2_socketcan's frames) is can_msgs/msg/Frame all the same."""
    from steer_monitor.logfiles.mcapio import FRAME_MSGDEF
    definition = ('# a CAN frame\nHeader header  # stamp\nuint32 id\nbool is_rtr\nbool is_extended\nbool is_error\n'
                  'uint8 dlc\nuint8[8] data\n' + FRAME_MSGDEF[FRAME_MSGDEF.index('====='):])
    frames = simulated.frames()[:300]
    path = _mcap_with(tmp_path / 'x.mcap', 'can_msgs/msg/Frame', 'ros2msg', definition, 'cdr', frames,
                      topic='/from_can_bus')
    got = read_log_fast(path)
    np.testing.assert_array_equal(got.can_id, [f.can_id for f in frames])


@pytest.mark.parametrize('case, want', [
    ('json', r'/steering_can/rx: 300 can_msgs/msg/Frame message\(s\) not read \(its messages are in json encoding, '
             r'this tool reads CDR\)'),
    ('other definition', r"/steering_can/rx: 300 can_msgs/msg/Frame message\(s\) not read \(its definition "
                         r"\(uint32 id, uint8\[\] data\) is not ROS 2's can_msgs/msg/Frame\)"),
    ('no frame channel', r'no CAN frames: no can_msgs/msg/Frame channel in CDR; its channels: /steering_can/rx '
                         r'\(my_msgs/msg/CanFrame, cdr\), /rosout \(rcl_interfaces/msg/Log, cdr\)'),
])
def test_frames_that_cannot_be_read_are_named(tmp_path, simulated, case, want):
    """An MCAP whose CAN frames are not ROS 2 can_msgs/msg/Frame in CDR is one error naming
    the channel and what it holds instead, not a silent empty log."""
    from steer_monitor.logfiles.mcapio import FRAME_MSGDEF
    name, encoding, definition = {'json': ('can_msgs/msg/Frame', 'jsonschema', '{}'),
                                  'other definition': ('can_msgs/msg/Frame', 'ros2msg', 'uint32 id\nuint8[] data\n'),
                                  'no frame channel': ('my_msgs/msg/CanFrame', 'ros2msg', FRAME_MSGDEF)}[case]
    path = _mcap_with(tmp_path / 'x.mcap', name, encoding, definition, 'json' if case == 'json' else 'cdr',
                      simulated.frames()[:300])
    got = []
    with pytest.raises(LogError, match=want):
        for block in iter_mcap_blocks(path):
            got.append(block)
    assert sum(len(b) for b in got) == 0


def test_frame_records_as_columns():
    """Runs of frame records among other records: flags, DLC (above 8 read as 8) and the
    payload bytes past the DLC (not the frame's) dropped; a record too short for its frame_id
    is an error that says so."""
    from steer_monitor.can.frames import Frame
    from steer_monitor.logfiles.mcapcols import McapState, walk_records
    from steer_monitor.logfiles.mcapio import FRAME_DATATYPE, frame_records, record_dtype
    dlcs = [0, 3, 8, 15, 1]
    frames = [Frame(1_767_225_600_000_000_000 + i * 1000, 0x100 + i, bytes(8), i % 2 == 0, i == 2, i == 4, '')
              for i in range(len(dlcs))]
    raw, _, size = frame_records(frames, 3)
    dtype, _ = record_dtype('steering_can')
    rec = np.frombuffer(raw, dtype).copy()
    rec['dlc'] = dlcs
    rec['data'] = np.void(bytes(range(0xA1, 0xA9)))
    state = McapState()
    state.schema(1, FRAME_DATATYPE)
    state.channel(3, 1)
    other = bytes([0x05]) + struct.pack('<QH', 30, 4) + bytes(28)          # a message on another channel
    alike = rec[:1].copy()
    alike['channel'] = 4                                                   # of a frame's size
    got = FrameArrays.concat(walk_records(rec[:2].tobytes() + other + rec[2:4].tobytes() + alike.tobytes()
                                           + rec[4:].tobytes(), state))
    assert len(got) == len(dlcs)
    np.testing.assert_array_equal(got.t_ns, [f.t_ns for f in frames])
    np.testing.assert_array_equal(got.can_id, [f.can_id for f in frames])
    np.testing.assert_array_equal(got.dlc, [0, 3, 8, 8, 1])
    for row, n in zip(got.data, [0, 3, 8, 8, 1]):
        assert bytes(row) == bytes(range(0xA1, 0xA1 + n)) + bytes(8 - n)
    assert [f.is_extended for f in got.frames()] == [True, False, True, False, True]
    assert [f.is_error for f in got.frames()] == [False, False, True, False, False]
    assert [f.is_remote for f in got.frames()] == [False, False, False, False, True]
    bad = rec[:1].copy()
    bad['fid_len'] = 200
    with pytest.raises(ValueError, match='cannot hold a frame_id of 200 bytes'):
        walk_records(bad.tobytes(), state)


@pytest.mark.parametrize('compression', ['', 'zstd', 'lz4'])
def test_a_chunk_is_decompressed_and_checked(compression):
    import zlib

    import lz4.frame
    import zstandard

    from steer_monitor.logfiles.mcapcols import CorruptChunk, decompress_chunk
    raw = bytes(range(256)) * 64
    data = {'': raw, 'zstd': zstandard.ZstdCompressor().compress(raw), 'lz4': lz4.frame.compress(raw)}[compression]
    assert decompress_chunk(compression, data, len(raw), zlib.crc32(raw)) == raw
    assert decompress_chunk(compression, data, len(raw), 0) == raw                 # no CRC written
    with pytest.raises(CorruptChunk, match='CRC mismatch'):
        decompress_chunk(compression, data, len(raw), zlib.crc32(raw) ^ 1)
    with pytest.raises(CorruptChunk, match=f'the chunk says {len(raw) + 1}'):
        decompress_chunk(compression, data, len(raw) + 1, 0)


@pytest.mark.parametrize('compression', ['zstd', 'lz4'])
def test_a_chunk_that_inflates_past_its_declared_size_is_not_inflated(compression):
    """A bomb: 64 MiB of zeros in a few kB, the chunk declaring 1000 bytes (zstd without a
    content size in its frame, where the declared size is all a reader has). Refused, and no
    more than the declared size (plus one byte) is ever made: lz4's decompress had inflated
    all of it first."""
    import tracemalloc

    import lz4.frame
    import zstandard

    from steer_monitor.logfiles.mcapcols import CorruptChunk, decompress_chunk
    zeros = bytes(64 << 20)
    data = (zstandard.ZstdCompressor(write_content_size=False).compress(zeros) if compression == 'zstd'
            else lz4.frame.compress(zeros))
    del zeros
    tracemalloc.start()
    try:
        with pytest.raises(CorruptChunk):
            decompress_chunk(compression, data, 1000, 0)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert peak < 1 << 20, peak


def test_a_chunk_declaring_more_than_a_chunk_may_hold_is_refused_at_once():
    """Declared sizes are what a zstd frame without a content size is inflated into: 16 TiB
    made the whole file fail as 'out of memory'; 3 GiB of honest zeros in 100 kB took 3.2 GB
    and a minute. Beyond MAX_CHUNK_BYTES the chunk is corrupt before anything is inflated."""
    import zstandard

    from steer_monitor.logfiles.mcapcols import MAX_CHUNK_BYTES, CorruptChunk, decompress_chunk
    data = zstandard.ZstdCompressor(write_content_size=False).compress(b'x' * 1000)
    for size in (MAX_CHUNK_BYTES + 1, 1 << 44):
        with pytest.raises(CorruptChunk, match=f'declares {size} bytes uncompressed, more than the 256 MiB'):
            decompress_chunk('zstd', data, size, 0)
    with pytest.raises(CorruptChunk, match="unknown compression 'brotli'"):
        decompress_chunk('brotli', data, 1000, 0)


def test_channels_are_judged_whichever_comes_first_schema_or_channel():
    """A channel naming a schema given later, a channel given again with another schema, a
    schema given again: the frame channels follow, one channel judged at a time."""
    from steer_monitor.logfiles.mcapcols import McapState
    from steer_monitor.logfiles.mcapio import FRAME_DATATYPE, FRAME_MSGDEF
    st = McapState()
    st.channel(1, 7, '/steering_can/rx', 'cdr')
    assert st.frame_channels == set()
    st.schema(7, FRAME_DATATYPE, 'ros2msg', FRAME_MSGDEF.encode())
    assert st.frame_channels == {1}
    st.channel(2, 7, '/other_can', 'json')                 # a frame channel this reader cannot take
    assert st.frame_channels == {1} and set(st.refused) == {2}
    st.schema(8, 'std_msgs/msg/String', 'ros2msg', b'string data')
    st.channel(1, 8, '/steering_can/rx', 'cdr')            # given again, another schema
    assert st.frame_channels == set() and set(st.refused) == {2}
    st.schema(7, 'std_msgs/msg/String', 'ros2msg', b'string data')   # schema 7 given again: no frames
    assert st.frame_channels == set() and st.refused == {}


def test_a_file_of_sixty_thousand_channels_is_read_in_time(tmp_path, simulated):
    """Every channel record judged every channel again: 20,000 channels took 8.7 s, 60,000
    (a 2 MB file) over a minute. The frames after them are read, in seconds."""
    import time as _time

    from mcap.writer import CompressionType, Writer

    from steer_monitor.logfiles.mcapio import DEFAULT_QOS, FRAME_DATATYPE, FRAME_MSGDEF, FRAME_TOPIC, frame_cdr
    path = tmp_path / 'channels.mcap'
    with open(path, 'wb') as fh:
        w = Writer(fh, compression=CompressionType.ZSTD)
        w.start(profile='ros2', library='test')
        other = w.register_schema('std_msgs/msg/String', 'ros2msg', b'string data')
        for i in range(60_000):                      # channel ids are 16-bit
            w.register_channel(f'/t{i}', 'cdr', other)
        sid = w.register_schema(FRAME_DATATYPE, 'ros2msg', FRAME_MSGDEF.encode())
        cid = w.register_channel(FRAME_TOPIC, 'cdr', sid, {'offered_qos_profiles': DEFAULT_QOS})
        for f in simulated.frames():
            w.add_message(cid, log_time=f.t_ns, publish_time=f.t_ns, data=frame_cdr(f))
        w.finish()
    t0 = _time.perf_counter()
    got = FrameArrays.concat(list(iter_mcap_blocks(path)))
    assert _time.perf_counter() - t0 < 10.0
    np.testing.assert_array_equal(got.t_ns, simulated.t_ns)
