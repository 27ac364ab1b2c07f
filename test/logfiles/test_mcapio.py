"""The packed can_msgs/msg/Frame CDR against the generic ROS 2 encoder; the batch writer against
the one-frame writer."""

from __future__ import annotations

import io

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from mcap_ros2._dynamic import serialize_dynamic

from steer_monitor.can import Frame
from steer_monitor.logfiles.mcapio import (
    FRAME_DATATYPE,
    FRAME_MSGDEF,
    McapWriter,
    frame_cdr,
    frame_message,
)
from test.logfiles.reference_reader import iter_mcap_frames

ENCODE = serialize_dynamic(FRAME_DATATYPE, FRAME_MSGDEF)[FRAME_DATATYPE]


@settings(max_examples=300, deadline=None)
@given(t=st.integers(0, 2**62), can_id=st.integers(0, 0x1FFFFFFF), data=st.binary(max_size=8),
       ext=st.booleans(), err=st.booleans(), rtr=st.booleans(),
       frame_id=st.text(alphabet='abcdefgh_/', max_size=12))
def test_packed_cdr_equals_generic_encoder(t, can_id, data, ext, err, rtr, frame_id):
    f = Frame(t, can_id, data, ext, err, rtr)     # past 2038 both leave the stamp unset
    assert frame_cdr(f, frame_id) == ENCODE(frame_message(f, frame_id))


def _frames(n: int) -> list[Frame]:
    t0 = 1_767_225_600_000_000_000
    return [Frame(t0 + i * 523_000, (0x09F10D10 + i) & 0x1FFFFFFF, bytes(range(i % 9)), bool(i % 2),
                  bool(i % 5 == 0), bool(i % 7 == 0)) for i in range(n)]


@pytest.mark.parametrize('chunk_size', [1 << 24, 4096, 100])
@pytest.mark.parametrize('batch', [1, 7, 256, 5000])
def test_write_frames_gives_the_same_file_as_one_at_a_time(batch, chunk_size):
    """Chunk boundaries included: a batch that fills a chunk is split where one message at a
    time would close it."""
    frames = _frames(3000)
    one, many = io.BytesIO(), io.BytesIO()
    with McapWriter(one, chunk_size=chunk_size) as w:
        for f in frames[:1000]:
            w.write_frame(f)
        w.flush()                       # a chunk boundary, as the recorder's 1 s flush makes
        for f in frames[1000:]:
            w.write_frame(f)
    with McapWriter(many, chunk_size=chunk_size) as w:
        for i in range(0, 1000, batch):
            w.write_frames(frames[i:min(i + batch, 1000)])
        w.flush()
        for i in range(1000, 3000, batch):
            w.write_frames(frames[i:min(i + batch, 3000)])
    assert many.getvalue() == one.getvalue()


@pytest.mark.parametrize('chunk_size', [1 << 24, 300])
@pytest.mark.parametrize('batch', [1, 3, 50])
def test_write_messages_gives_the_same_file_as_one_at_a_time(batch, chunk_size):
    """Messages of several sizes on two topics among frames, in batches across chunk ends."""
    msgs = [('/a' if i % 3 else '/b', bytes([i % 251]) * (4 + i % 17), 1_000 + 7 * i) for i in range(200)]
    frames = _frames(200)

    def writer(buf):
        w = McapWriter(buf, chunk_size=chunk_size)
        w.add_schema('std_msgs/msg/String', 'string data\n')
        w.add_channel('/a', 'std_msgs/msg/String')
        w.add_channel('/b', 'std_msgs/msg/String')
        return w

    one, many = io.BytesIO(), io.BytesIO()
    with writer(one) as w:
        for i in range(0, 200, batch):
            for f in frames[i:i + batch]:
                w.write_frame(f)
            for topic, data, t in msgs[i:i + batch]:
                w.write_cdr(topic, data, t)
    with writer(many) as w:
        for i in range(0, 200, batch):
            w.write_frames(frames[i:i + batch])
            part = msgs[i:i + batch]
            w.write_messages([m[0] for m in part], [m[1] for m in part], [m[2] for m in part])
        w.write_messages([], [], [])
    assert many.getvalue() == one.getvalue()


def test_write_frames_across_chunk_rollover_reads_back_with_crcs():
    from mcap.reader import make_reader
    frames = _frames(2000)
    buf = io.BytesIO()
    with McapWriter(buf, chunk_size=4096) as w:
        for i in range(0, 2000, 300):
            w.write_frames(frames[i:i + 300])
        w.write_frames([])
    buf.seek(0)
    reader = make_reader(buf, validate_crcs=True)
    got = list(reader.iter_messages())
    assert [m.log_time for _, _, m in got] == [f.t_ns for f in frames]
    stats = reader.get_summary().statistics
    one = io.BytesIO()
    with McapWriter(one, chunk_size=4096) as w:
        for f in frames:
            w.write_frame(f)
    one.seek(0)
    assert stats.message_count == 2000
    assert stats.chunk_count == make_reader(one).get_summary().statistics.chunk_count > 30   # closed as they fill
    buf.seek(0)
    back = list(iter_mcap_frames(buf))
    assert back == [Frame(f.t_ns, f.can_id, f.data, f.is_extended, f.is_error, f.is_remote, 'steering_can')
                    for f in frames]


@pytest.mark.parametrize('t_ns', [
    (1 << 31) * 1_000_000_000 - 1,          # the last nanosecond ROS time holds (2038-01-19)
    (1 << 31) * 1_000_000_000,              # the first it does not
    4_102_444_800_123_456_789,              # 2100
    9_000_000_000_000_000_000,              # 2255
])
def test_times_past_2038_are_kept_in_the_log_time(tmp_path, t_ns):
    """ROS time has int32 seconds: past 2038 the header stamp is left unset (0, 0) and the
    record's uint64 log time carries the time; both readers take it from there."""
    from steer_monitor.logfiles.mcapcols import iter_mcap_blocks
    from steer_monitor.rostime import ros_time
    f = Frame(t_ns, 0x09F10D10, bytes(8))
    sec, nsec = ros_time(t_ns)
    assert (sec, nsec) == ((t_ns // 10**9, t_ns % 10**9) if t_ns < (1 << 31) * 10**9 else (0, 0))
    path = tmp_path / 'late.mcap'
    with McapWriter(path) as w:
        w.write_frames([f, Frame(t_ns + 1000, 0x09F10D10, bytes(8))])
        w.write_frame(Frame(t_ns + 2000, 0x09F10D10, bytes(8)))
    blocks = list(iter_mcap_blocks(path))
    assert [int(t) for b in blocks for t in b.t_ns] == [t_ns, t_ns + 1000, t_ns + 2000]
    with open(path, 'rb') as fh:
        assert [g.t_ns for g in iter_mcap_frames(fh)] == [t_ns, t_ns + 1000, t_ns + 2000]


def test_frames_as_columns_write_the_records_bytes():
    """A log block's columns (payload bytes past the DLC set, a frame over 8 bytes kept as DLC
    255) give the records of the frames they hold."""
    from steer_monitor.can.frames import FrameArrays
    frames = _frames(300) + [Frame(1_767_225_601_000_000_000, 0x09F10D10, bytes(range(12)))]
    fa = FrameArrays.from_frames(frames)
    fa.data[fa.dlc < 8, -1] = 0xEE                  # bytes past the DLC are not the frame's
    one, many = io.BytesIO(), io.BytesIO()
    with McapWriter(one, chunk_size=4096) as w:
        for f in frames:
            w.write_frame(f)
    with McapWriter(many, chunk_size=4096) as w:
        w.write_frames(fa)
    assert many.getvalue() == one.getvalue()
