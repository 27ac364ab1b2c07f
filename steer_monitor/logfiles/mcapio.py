"""Raw CAN frames in MCAP: ``can_msgs/msg/Frame``-compatible ROS 2 messages (profile ros2,
cdr encoding, ros2msg schema), as the node records them and ``replay`` reads them."""

from __future__ import annotations

import os
import struct
from collections.abc import Sequence
from pathlib import Path
from typing import IO, Any

import numpy as np
from numpy.typing import NDArray

from steer_monitor._vendor.mcap.opcode import Opcode
from steer_monitor._vendor.mcap.records import MessageIndex
from steer_monitor.can.frames import FLAG_ERROR, FLAG_EXTENDED, FLAG_REMOTE, MAX_DLC, Frame, FrameArrays
from steer_monitor.logfiles.rosbag2meta import METADATA_NAME, TopicCount, offered_qos_profiles, serialized_metadata
from steer_monitor.logfiles.typehash import type_hash
from steer_monitor.rostime import SEC_MAX, ros_time

__all__ = ['DEFAULT_QOS', 'FRAME_DATATYPE', 'FRAME_MSGDEF', 'FRAME_TOPIC', 'MESSAGE_HEAD', 'Counted', 'McapWriter',
           'frame_cdr', 'frame_message', 'frame_records', 'leading_metadata', 'message_head', 'pack_messages',
           'record_dtype']

FRAME_TOPIC = '/steering_can/rx'
FRAME_DATATYPE = 'can_msgs/msg/Frame'
# can_msgs/msg/Frame (ros-industrial ros_canopen), with its dependencies in ros2msg form.
FRAME_MSGDEF = """std_msgs/Header header
uint32 id
bool is_rtr
bool is_extended
bool is_error
uint8 dlc
uint8[8] data
================================================================================
MSG: std_msgs/Header
builtin_interfaces/Time stamp
string frame_id
================================================================================
MSG: builtin_interfaces/Time
int32 sec
uint32 nanosec
"""

#: offered_qos_profiles of a topic whose publisher's QoS is not given: a reliable, volatile
#: keep-last publisher of depth 10 (rclpy's default)
DEFAULT_QOS = offered_qos_profiles(10, False)


_CDR_HEADER = b'\x00\x01\x00\x00'  # CDR, little-endian


#: the head of an MCAP Message record: opcode, length, channel, sequence, log and publish time
MESSAGE_HEAD = struct.Struct('<BQHIQQ')


def message_head(channel_id: int, log_time_ns: int, data_size: int) -> bytes:
    """The head of a Message record of ``data_size`` bytes on ``channel_id``, sequence 0, logged
    and published at ``log_time_ns``: as mcap's writer makes it for ``add_message``."""
    return MESSAGE_HEAD.pack(Opcode.MESSAGE, MESSAGE_HEAD.size - 9 + data_size, channel_id, 0, log_time_ns,
                             log_time_ns)


def pack_messages(channels: NDArray[np.uint16], datas: Sequence[bytes], log_times: NDArray[np.int64]
                  ) -> tuple[bytes, NDArray[np.int64]]:
    """Already-serialized messages as Message records for :meth:`McapWriter.write_records`:
    message ``i`` (``datas[i]``) on ``channels[i]`` at ``log_times[i]`` [ns]. Returns the
    records' bytes and their offsets ((n + 1,): record ``i`` is ``data[offsets[i]:offsets[i + 1]]``)."""
    n = len(datas)
    data = b''.join([part for cid, d, t in zip(channels.tolist(), datas, log_times.tolist())
                     for part in (message_head(cid, t, len(d)), d)])
    offsets = np.zeros(n + 1, np.int64)
    if n:
        np.cumsum(np.fromiter((len(d) for d in datas), np.int64, n) + MESSAGE_HEAD.size, out=offsets[1:])
    return data, offsets


def frame_cdr(frame: Frame, frame_id: str = 'steering_can') -> bytes:
    """The CDR bytes of a can_msgs/msg/Frame, packed directly (about 20x faster than the
    generic encoder; ``test_mcapio`` checks they are identical)."""
    fid = frame_id.encode() + b'\x00'
    pad = (-len(fid)) % 4
    sec, nsec = ros_time(frame.t_ns)
    data = bytes(frame.data[:8]).ljust(8, b'\x00')
    return b''.join((_CDR_HEADER, struct.pack('<iII', sec, nsec, len(fid)), fid, b'\x00' * pad,
                     struct.pack('<I4B', frame.can_id, frame.is_remote, frame.is_extended, frame.is_error,
                                 min(len(frame.data), 8)), data))


def record_dtype(frame_id: str) -> tuple[np.dtype, bytes]:
    """The numpy layout of a frame's MCAP message record (opcode, length, channel, sequence,
    times, the CDR of a ``can_msgs/msg/Frame`` with ``frame_id``) and the frame_id's bytes
    as written (NUL-terminated, padded to four)."""
    fid = frame_id.encode() + b'\x00'
    fid += b'\x00' * ((-len(fid)) % 4)
    dtype = np.dtype([('opcode', 'u1'), ('length', '<u8'), ('channel', '<u2'), ('sequence', '<u4'),
                      ('log_time', '<u8'), ('publish_time', '<u8'), ('cdr_header', 'V4'), ('sec', '<i4'),
                      ('nsec', '<u4'), ('fid_len', '<u4'), ('fid', f'V{len(fid)}'), ('id', '<u4'),
                      ('rtr', 'u1'), ('ext', 'u1'), ('err', 'u1'), ('dlc', 'u1'), ('data', 'V8')])
    return dtype, fid


def frame_records(frames: Sequence[Frame] | FrameArrays, channel_id: int, frame_id: str = 'steering_can'
                  ) -> tuple[bytes, list[int], int]:
    """MCAP Message records (opcode, length, channel, sequence 0, log and publish time = the
    frame's time, then :func:`frame_cdr`'s bytes) of many frames at once, packed by numpy:
    (the records, their log times [ns], the size of one record [bytes])."""
    fa = frames if isinstance(frames, FrameArrays) else FrameArrays.from_frames(frames)
    dtype, fid = record_dtype(frame_id)
    n = len(fa)
    rec = np.zeros(n, dtype)
    t = fa.t_ns
    rec['opcode'] = 0x05
    rec['length'] = dtype.itemsize - 9
    rec['channel'] = channel_id
    rec['log_time'] = t
    rec['publish_time'] = t
    rec['cdr_header'] = np.void(_CDR_HEADER)
    sec, nsec = np.divmod(t, 1_000_000_000)
    unset = (sec > SEC_MAX) | (sec < -SEC_MAX - 1)      # see ros_time
    rec['sec'], rec['nsec'] = np.where(unset, 0, sec), np.where(unset, 0, nsec)
    rec['fid_len'] = len(frame_id.encode()) + 1
    rec['fid'] = np.void(fid)
    rec['id'] = fa.can_id
    rec['rtr'] = (fa.flags & FLAG_REMOTE) != 0
    rec['ext'] = (fa.flags & FLAG_EXTENDED) != 0
    rec['err'] = (fa.flags & FLAG_ERROR) != 0
    dlc = np.minimum(fa.dlc, MAX_DLC)                     # longer than 8 (kept as 255): its first 8 bytes
    rec['dlc'] = dlc
    data = np.where(np.arange(MAX_DLC) < dlc[:, None], fa.data, 0).astype(np.uint8)
    rec['data'] = np.ascontiguousarray(data).view('V8')[:, 0]
    return rec.tobytes(), t.tolist(), dtype.itemsize


def frame_message(frame: Frame, frame_id: str = 'steering_can') -> dict[str, Any]:
    """The can_msgs/msg/Frame fields of a frame."""
    data = bytes(frame.data[:8]).ljust(8, b'\0')
    sec, nsec = ros_time(frame.t_ns)
    return {
        'header': {'stamp': {'sec': sec, 'nanosec': nsec},
                   'frame_id': frame_id},
        'id': frame.can_id, 'is_rtr': frame.is_remote, 'is_extended': frame.is_extended,
        'is_error': frame.is_error, 'dlc': min(len(frame.data), 8), 'data': list(data),
    }


class _PackedIndex(MessageIndex):
    """An MCAP MessageIndex whose entries come in numpy runs: written as one block of bytes
    (mcap's own writes 16 bytes at a time, about 1.5 us an entry: a second of an hour's
    replay). Entries ``add_message`` appends to ``records`` meanwhile keep their place."""

    def __init__(self, channel_id: int, records: list[tuple[int, int]] | None = None) -> None:
        super().__init__(channel_id=channel_id, records=list(records or []))
        self._parts: list[NDArray[np.uint64]] = []     # (k, 2): log time, offset

    def _take_records(self) -> None:
        if self.records:
            self._parts.append(np.array(self.records, np.uint64).reshape(-1, 2))
            self.records.clear()

    def add(self, log_times: NDArray[np.int64], offsets: NDArray[np.int64]) -> None:
        self._take_records()
        self._parts.append(np.stack([log_times.astype(np.uint64), offsets.astype(np.uint64)], axis=1))

    def write(self, stream: Any) -> None:
        self._take_records()
        entries = np.concatenate(self._parts) if self._parts else np.zeros((0, 2), np.uint64)
        stream.start_record(Opcode.MESSAGE_INDEX)
        stream.write2(self.channel_id)
        stream.write4(entries.shape[0] * 16)
        stream.write(entries.astype('<u8').tobytes())
        stream.finish_record()


class Counted:
    """A stream that cannot seek (a pipe, a terminal) with the ``tell`` a writer of MCAP
    needs for its summary's offsets: the bytes written so far."""

    def __init__(self, raw: IO[bytes]) -> None:
        self._raw = raw
        self._count = 0

    def write(self, data: bytes) -> int:
        self._raw.write(data)
        self._count += len(data)
        return len(data)

    def tell(self) -> int:
        return self._count

    def flush(self) -> None:
        self._raw.flush()

    def close(self) -> None:
        self._raw.close()


class McapWriter:
    """A ROS 2 MCAP writer (zstd chunks, CRCs) as rosbag2's MCAP storage writes: each channel
    with its offered QoS and its type hash, and at the end the ``rosbag2`` metadata record
    (:mod:`~steer_monitor.logfiles.rosbag2meta`; ``ros_distro`` by default ``$ROS_DISTRO``).

    Context manager; :meth:`close` finishes the file and is idempotent.
    """

    def __init__(self, output: str | Path | IO[bytes], chunk_size: int = 1024 * 1024,
                 library: str = 'steer_monitor', ros_distro: str | None = None) -> None:
        from steer_monitor._vendor.mcap.writer import CompressionType
        from steer_monitor._vendor.mcap.writer import Writer as _Writer

        self._own = not hasattr(output, 'write')
        self._stream: IO[bytes] = open(output, 'wb') if self._own else output  # type: ignore[assignment]
        if self._own and not self._stream.seekable():      # a pipe: mcap asks where it is
            self._stream = Counted(self._stream)           # type: ignore[assignment]
        self._writer = _Writer(self._stream, chunk_size=chunk_size, compression=CompressionType.ZSTD,
                               enable_crcs=True)
        self._writer.start(profile='ros2', library=library)
        self._schemas: dict[str, tuple[int, str]] = {}     # datatype -> (schema id, msgdef)
        self._channels: dict[str, tuple[int, str]] = {}    # topic -> (channel id, datatype)
        self._encoders: dict[str, Any] = {}
        self._closed = False
        # for the rosbag2 metadata record: each channel's QoS and type hash (the messages and the
        # span are the writer's own statistics)
        self.ros_distro = ros_distro if ros_distro is not None else os.environ.get('ROS_DISTRO', '')
        self._hashes: dict[str, str] = {}                  # datatype -> type hash
        self._qos: dict[int, str] = {}

    def add_metadata(self, name: str, data: dict[str, str]) -> None:
        """Write an MCAP metadata record (``mcap info`` and the readers list them)."""
        self._writer.add_metadata(name, dict(data))

    def add_schema(self, datatype: str, msgdef: str) -> None:
        """Register a ros2msg schema (once per datatype)."""
        if datatype not in self._schemas:
            sid = self._writer.register_schema(datatype, 'ros2msg', msgdef.encode())
            self._schemas[datatype] = (sid, msgdef)
            self._hashes[datatype] = type_hash(datatype, msgdef)

    def add_channel(self, topic: str, datatype: str, qos: str = DEFAULT_QOS) -> None:
        """Register a cdr channel for a registered datatype, with its offered QoS
        (:func:`~steer_monitor.logfiles.rosbag2meta.offered_qos_profiles`) and type hash."""
        if topic not in self._channels:
            sid, _ = self._schemas[datatype]
            cid = self._writer.register_channel(topic, 'cdr', sid, {'offered_qos_profiles': qos,
                                                                    'topic_type_hash': self._hashes[datatype]})
            self._channels[topic] = (cid, datatype)
            self._qos[cid] = qos

    def write_cdr(self, topic: str, data: bytes, log_time_ns: int, publish_time_ns: int | None = None) -> None:
        """Write one already-serialized message."""
        self._writer.add_message(self._channels[topic][0], log_time=log_time_ns,
                                 publish_time=log_time_ns if publish_time_ns is None else publish_time_ns,
                                 data=data)

    def write(self, topic: str, message: Any, log_time_ns: int, publish_time_ns: int | None = None) -> None:
        """Write one message given as a dict of its fields (encoded by the generic CDR encoder)."""
        datatype = self._channels[topic][1]
        encoder = self._encoders.get(datatype)
        if encoder is None:
            from mcap_ros2._dynamic import serialize_dynamic
            encoder = self._encoders[datatype] = serialize_dynamic(datatype, self._schemas[datatype][1])[datatype]
        self.write_cdr(topic, encoder(message), log_time_ns, publish_time_ns)

    def write_frame(self, frame: Frame, topic: str = FRAME_TOPIC) -> None:
        if topic not in self._channels:
            self.add_schema(FRAME_DATATYPE, FRAME_MSGDEF)
            self.add_channel(topic, FRAME_DATATYPE)
        self.write_cdr(topic, frame_cdr(frame), frame.t_ns)

    def write_frames(self, frames: Sequence[Frame] | FrameArrays, topic: str = FRAME_TOPIC) -> None:
        """Write many frames (records, or the columns of a log block): the same file as
        :meth:`write_frame` one by one, byte for byte (``test_mcapio`` checks), at a tenth of
        the cost. The records are packed by numpy (:func:`frame_records`) and appended by
        :meth:`write_records`."""
        if not len(frames):
            return
        if topic not in self._channels:
            self.add_schema(FRAME_DATATYPE, FRAME_MSGDEF)
            self.add_channel(topic, FRAME_DATATYPE)
        cid = self._channels[topic][0]
        data, times, size = frame_records(frames, cid)
        n = len(times)
        self.write_records(data, np.full(n, cid, np.uint16), np.array(times, np.int64),
                           np.arange(n + 1, dtype=np.int64) * size)

    def write_messages(self, topics: Sequence[str], datas: Sequence[bytes], log_times: Sequence[int]) -> None:
        """Write many already-serialized messages, message ``i`` on ``topics[i]`` at
        ``log_times[i]`` [ns] (publish time the same): the same file as :meth:`write_cdr` of
        each in turn, byte for byte (``test_mcapio`` checks), their records packed here and
        appended at once (:meth:`write_records`)."""
        n = len(datas)
        if n == 0:
            return
        channels = np.fromiter((self._channels[t][0] for t in topics), np.uint16, n)
        times = np.fromiter(log_times, np.int64, n)
        data, offsets = pack_messages(channels, datas, times)
        self.write_records(data, channels, times, offsets)

    def channel_id(self, topic: str) -> int:
        """The MCAP channel id of a registered topic (for :meth:`write_records`)."""
        return self._channels[topic][0]

    def write_records(self, data: bytes, channels: NDArray[np.uint16], log_times: NDArray[np.int64],
                      offsets: NDArray[np.int64]) -> None:
        """Append already-packed MCAP Message records: record ``i`` is
        ``data[offsets[i]:offsets[i + 1]]`` on channel ``channels[i]`` at ``log_times[i]`` [ns]
        (shapes (n,), (n,), (n + 1,)). The same file as :meth:`write_cdr` of each message in
        turn, byte for byte, chunk boundaries included (``test_mcapio`` checks).

        mcap's writer is pure Python and spends 30-45 us per message building each record
        field by field; at the full bus rate that alone was a fifth of a core in the node, and
        most of a replay's writing. Here the records go to the writer's open chunk with its
        message indexes and statistics updated as ``Writer.add_message`` would, and the chunk is
        closed after the first record that takes it past the chunk size, as ``add_message``
        closes it (mcap 1.x internals; a writer without them gets one message at a time)."""
        n = int(log_times.shape[0])
        if n == 0:
            return
        w = self._writer
        chunk = getattr(w, '_Writer__chunk_builder', None)
        stats = getattr(w, '_Writer__statistics', None)
        finalize = getattr(w, '_Writer__maybe_finalize_chunk', None)
        if chunk is None or stats is None or finalize is None or not hasattr(chunk, 'record_writer') \
                or not hasattr(w, '_Writer__chunk_size'):
            for i in range(n):      # a record is opcode (1), length (8), channel (2), sequence (4),
                a, b = int(offsets[i]) + MESSAGE_HEAD.size, int(offsets[i + 1])     # log and publish time (8, 8)
                w.add_message(int(channels[i]), log_time=int(log_times[i]), data=data[a:b],
                              publish_time=int(log_times[i]))
            return
        limit = w._Writer__chunk_size  # type: ignore[attr-defined]
        view = memoryview(data)
        i = 0
        while i < n:
            start = chunk.record_writer.count
            # the first record after which the chunk holds more than its size closes it
            over = np.flatnonzero(start + offsets[i + 1:] - offsets[i] > limit)
            j = n if over.size == 0 else i + int(over[0]) + 1
            t = log_times[i:j]
            t_min, t_max = int(t.min()), int(t.max())
            stats.message_start_time = t_min if stats.message_count == 0 else min(t_min, stats.message_start_time)
            stats.message_end_time = max(t_max, stats.message_end_time)
            stats.message_count += j - i
            chunk.message_start_time = t_min if chunk.num_messages == 0 else min(chunk.message_start_time, t_min)
            chunk.message_end_time = max(chunk.message_end_time, t_max)
            chunk.num_messages += j - i
            ch = channels[i:j]
            ids, first = np.unique(ch, return_index=True)
            for cid in ids[np.argsort(first)].tolist():      # indexes in order of first appearance
                sel = ch == cid
                stats.channel_message_counts[cid] += int(np.count_nonzero(sel))
                index = chunk.message_indices.get(cid)
                if index is None:
                    index = chunk.message_indices[cid] = _PackedIndex(cid)
                elif not isinstance(index, _PackedIndex):    # made by add_message: keep its entries
                    index = chunk.message_indices[cid] = _PackedIndex(cid, index.records)
                index.add(t[sel], (start + offsets[i:j] - offsets[i])[sel])
            chunk.record_writer.write(view[int(offsets[i]):int(offsets[j])])
            finalize()
            i = j

    def flush(self) -> None:
        """Close the chunk in progress and write everything out (not fsync)."""
        self._writer.flush()

    def bag_metadata(self) -> str:
        """The ``serialized_metadata`` of the file as written so far."""
        # the Statistics record mcap's writer keeps for the summary (mcap 1.x; write_records
        # keeps it as add_message does): messages per channel, first and last log time
        stats = self._writer._Writer__statistics  # type: ignore[attr-defined]
        counts = stats.channel_message_counts
        topics = [TopicCount(topic, datatype, self._qos[cid], self._hashes[datatype], counts.get(cid, 0))
                  for topic, (cid, datatype) in self._channels.items()]
        first, last = (stats.message_start_time, stats.message_end_time) if stats.message_count else (0, 0)
        return serialized_metadata(topics, first, last, self.ros_distro)

    def close(self) -> None:
        if self._closed:
            return
        self._closed = True
        try:
            try:
                self._writer.add_metadata(METADATA_NAME, {'serialized_metadata': self.bag_metadata()})
            finally:
                self._writer.finish()
        finally:
            if self._own:
                self._stream.close()

    def __enter__(self) -> McapWriter:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def leading_metadata(path: str | Path, limit_bytes: int = 1 << 20) -> dict[str, dict[str, str]]:
    """The metadata records written before the first chunk or message of an MCAP file (where
    the node's recorder and ``replay`` put theirs: :mod:`~steer_monitor.record.provenance`),
    by name. Reads the file's head only (records up to ``limit_bytes`` each), so a file cut
    short or damaged further on is read as far as that; {} when the head is not MCAP or holds
    none. Never raises for the file's content."""
    from steer_monitor._vendor.mcap.exceptions import McapError
    from steer_monitor._vendor.mcap.records import Chunk, Message, Metadata
    from steer_monitor._vendor.mcap.stream_reader import StreamReader

    out: dict[str, dict[str, str]] = {}
    try:
        with open(path, 'rb') as fh:
            for record in StreamReader(fh, emit_chunks=True, record_size_limit=limit_bytes).records:
                if isinstance(record, Chunk | Message):
                    break
                if isinstance(record, Metadata):
                    out[record.name] = dict(record.metadata)
    except (McapError, ValueError, struct.error, EOFError, UnicodeDecodeError):
        pass
    return out
