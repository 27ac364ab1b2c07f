"""The plain log reader: the oracle the package's column readers
(:mod:`steer_monitor.logfiles.candumpcols`, :mod:`steer_monitor.logfiles.mcapcols`) are
checked against. Candump line by line with the package's line parser, MCAP with the mcap
library's own reader and mcap-ros2's decoder (an implementation independent of the
package's MCAP parser), the other formats as the package reads them (it has one reader of
those)."""

from __future__ import annotations

import datetime
from collections.abc import Iterator
from pathlib import Path
from typing import IO

from steer_monitor.can.frames import Frame, FrameArrays
from steer_monitor.can.rejects import RejectCounter
from steer_monitor.logfiles.logs import LogError, _candump_line, iter_log_as, log_format, open_log, open_text_log
from steer_monitor.logfiles.mcapio import FRAME_DATATYPE

__all__ = ['iter_log_reference', 'iter_mcap_frames', 'read_log_reference']


def iter_log_reference(path: str | Path, rejects: RejectCounter | None = None,
                       date: datetime.date | None = None) -> Iterator[Frame]:
    """Frames of a log in file order, bad records counted in ``rejects``."""
    path = Path(path)
    fmt = log_format(path)
    if fmt == 'candump':
        with open_text_log(path, rejects) as fh:
            for lineno, raw in enumerate(fh, 1):
                frame = _candump_line(raw.decode('ascii', 'replace'), lineno, rejects, path)
                if frame is not None:
                    yield frame
        return
    if fmt == 'mcap':
        with open_log(path) as fh:
            try:
                yield from iter_mcap_frames(fh)
            except Exception as exc:  # mcap raises its own record/CRC errors
                msg = f'{path}: MCAP breaks off or is corrupt ({type(exc).__name__}: {exc}); frames before it were read'
                raise LogError(msg) from exc
        return
    yield from iter_log_as(path, fmt, rejects, date)


def read_log_reference(path: str | Path, rejects: RejectCounter | None = None,
                       date: datetime.date | None = None) -> FrameArrays:
    """A whole log as columns, read by :func:`iter_log_reference`."""
    return FrameArrays.from_frames(iter_log_reference(path, rejects, date))


class _Sequential:
    """A read-only view of a stream that says it cannot seek, so mcap reads record by record."""

    def __init__(self, stream: IO[bytes]) -> None:
        self._stream = stream

    def read(self, n: int = -1) -> bytes:
        return self._stream.read(n)

    def seekable(self) -> bool:
        return False


def iter_mcap_frames(stream: IO[bytes], topic: str | None = None) -> Iterator[Frame]:
    """Frames from every ``can_msgs/msg/Frame`` channel (or one topic) of an MCAP stream, in
    file order, read record by record with the mcap library (a file cut short yields every
    frame before the cut and then raises the reader's error)."""
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    reader = make_reader(_Sequential(stream), validate_crcs=True, decoder_factories=[DecoderFactory()])
    for schema, channel, message, msg in reader.iter_decoded_messages(log_time_order=False):
        if schema is None or schema.name != FRAME_DATATYPE or (topic is not None and channel.topic != topic):
            continue
        stamp = msg.header.stamp
        t_ns = stamp.sec * 1_000_000_000 + stamp.nanosec if (stamp.sec or stamp.nanosec) else message.log_time
        dlc = min(int(msg.dlc), 8)
        yield Frame(t_ns=int(t_ns), can_id=int(msg.id), data=bytes(msg.data)[:dlc],
                    is_extended=bool(msg.is_extended), is_error=bool(msg.is_error),
                    is_remote=bool(msg.is_rtr), channel=msg.header.frame_id)
