"""Make an unfinished MCAP readable again (after a crash or a SIGKILL).

Reads the file record by record, as far as it is intact, and writes every schema, channel
and message found into a new, finished MCAP (zstd chunks, summary, CRCs).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from steer_monitor.errors import SteerMonitorError

__all__ = ['RecoverError', 'RecoverResult', 'recover']


class RecoverError(SteerMonitorError):
    """The file cannot be recovered at all (not MCAP, or unreadable)."""


@dataclass(frozen=True)
class RecoverResult:
    source: str
    output: str
    messages: int
    channels: int
    first_ns: int | None
    last_ns: int | None
    complete: bool
    stopped_at: str | None


def recover(path: str | Path, output: str | Path | None = None) -> RecoverResult:
    """Copy what is readable of ``path`` into ``output`` (default ``<name>.recovered.mcap``)."""
    from mcap.records import Channel, Footer, Message, Schema
    from mcap.stream_reader import StreamReader
    from mcap.writer import CompressionType, Writer

    src = Path(path)
    dst = Path(output) if output is not None else src.with_name(src.stem + '.recovered.mcap')
    if dst.resolve() == src.resolve():
        msg = f'recover would overwrite its input {src}; give another output'
        raise RecoverError(msg)
    try:
        fin = open(src, 'rb')
    except OSError as exc:
        msg = f'cannot open {src}: {exc.strerror or exc}'
        raise RecoverError(msg) from exc
    schemas: dict[int, int] = {}
    channels: dict[int, int] = {}
    count = 0
    first = last = None
    complete = False
    stopped = None
    with fin, open(dst, 'wb') as fout:
        writer = Writer(fout, compression=CompressionType.ZSTD, enable_crcs=True)
        writer.start(profile='ros2', library='steer_monitor recover')
        try:
            for record in StreamReader(fin, record_size_limit=1 << 30).records:
                if isinstance(record, Schema) and record.id not in schemas:
                    schemas[record.id] = writer.register_schema(record.name, record.encoding, record.data)
                elif isinstance(record, Channel) and record.id not in channels:
                    channels[record.id] = writer.register_channel(
                        record.topic, record.message_encoding, schemas.get(record.schema_id, 0),
                        dict(record.metadata))
                elif isinstance(record, Message) and record.channel_id in channels:
                    writer.add_message(channels[record.channel_id], log_time=record.log_time,
                                       publish_time=record.publish_time, data=record.data,
                                       sequence=record.sequence)
                    count += 1
                    first = record.log_time if first is None else min(first, record.log_time)
                    last = record.log_time if last is None else max(last, record.log_time)
                elif isinstance(record, Footer):
                    complete = True
        except Exception as exc:  # the cut: mcap raises its own errors on a partial record
            stopped = f'{type(exc).__name__}: {exc}'
            if count == 0 and not schemas:
                writer.finish()
                fout.close()
                dst.unlink(missing_ok=True)
                msg = f'{src} holds no readable MCAP records ({stopped})'
                raise RecoverError(msg) from exc
        writer.finish()
    return RecoverResult(str(src), str(dst), count, len(channels), first, last, complete, stopped)
