"""Make an unfinished or damaged MCAP readable again (after a crash, a SIGKILL, a bad disk).

Reads the file record by record, as far as its framing holds, and writes every schema,
channel and message found into a new, finished MCAP (zstd chunks, summary, CRCs). Each
chunk is checked before its messages are copied: a chunk whose CRC does not match, or whose
compression is broken, is dropped (never rewritten under fresh, valid CRCs) and the result
says which and why; the chunks after it are read on. The output is written to a temporary
name and renamed when finished.
"""

from __future__ import annotations

import io
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from steer_monitor.atomic import atomic_path, check_target, os_reason
from steer_monitor.errors import SteerMonitorError
from steer_monitor.logfiles.mcapcols import decompress_chunk, summary_section
from steer_monitor.logfiles.mcapio import Counted
from steer_monitor.logfiles.rosbag2meta import METADATA_NAME

__all__ = ['RecoverError', 'RecoverResult', 'recover', 'summary_definitions']


class RecoverError(SteerMonitorError):
    """The file cannot be recovered at all (not MCAP, or unreadable)."""


@dataclass(frozen=True)
class RecoverResult:
    """What ``recover`` copied: ``complete`` when the file ended with its footer and nothing
    was dropped; ``stopped_at`` why reading stopped early (None: it did not); ``dropped`` one
    text per chunk left out and why."""

    source: str
    output: str
    messages: int
    channels: int
    first_ns: int | None
    last_ns: int | None
    complete: bool
    stopped_at: str | None
    dropped: list[str] = field(default_factory=list)


def summary_definitions(fin: Any) -> list[Any]:
    """The schemas, then the channels, of the MCAP ``fin``'s summary section when it checks
    out (:func:`~steer_monitor.logfiles.mcapcols.summary_section`: footer, bounds, CRC, which
    mcap's reader does not check) and reads whole; none otherwise. Leaves ``fin`` at the start."""
    from steer_monitor._vendor.mcap.exceptions import EndOfFile
    from steer_monitor._vendor.mcap.records import Channel, Schema
    from steer_monitor._vendor.mcap.stream_reader import StreamReader

    section = summary_section(fin)
    if section is None:
        return []
    records: list[Any] = []
    try:
        for record in StreamReader(io.BytesIO(section), skip_magic=True).records:
            records.append(record)
    except EndOfFile:        # the end of the section's records
        pass
    except Exception:   # noqa: BLE001 - mcap's own errors on records that do not parse: none taken
        return []
    return ([r for r in records if isinstance(r, Schema)] + [r for r in records if isinstance(r, Channel)])


def _chunk_records(chunk: Any) -> bytes:
    """The records of an mcap ``Chunk``, decompressed (never past the size it declares, nor
    past the most a chunk may hold) and checked; ValueError saying why not."""
    return decompress_chunk(chunk.compression, chunk.data, chunk.uncompressed_size, chunk.uncompressed_crc)


MCAP_MAGIC = b'\x89MCAP0\r\n'


def recover(path: str | Path, output: str | Path | None = None) -> RecoverResult:
    """Copy what is readable of ``path`` into ``output`` (default ``<name>.recovered.mcap``)."""
    from steer_monitor._vendor.mcap.exceptions import EndOfFile
    from steer_monitor._vendor.mcap.records import Channel, Chunk, Footer, Message, Metadata, Schema
    from steer_monitor._vendor.mcap.stream_reader import StreamReader
    from steer_monitor._vendor.mcap.writer import CompressionType, Writer

    src = Path(path)
    dst = Path(output) if output is not None else src.with_name(src.stem + '.recovered.mcap')
    check_target(dst, [src])       # not over its input unless --force: the rule every command follows
    try:
        fin = open(src, 'rb')
        head = fin.read(len(MCAP_MAGIC))
        fin.seek(0)
    except OSError as exc:
        msg = f'cannot open {src}: {os_reason(exc)}'
        raise RecoverError(msg) from exc
    if head != MCAP_MAGIC:
        fin.close()
        shown = head.decode('ascii', 'replace') if head.isascii() else head.hex(' ')
        guess = ' (a candump log?)' if head.startswith(b'(') else ''
        msg = (f'{src} is not an MCAP recording: it begins {shown!r}{guess}, not the MCAP magic; recover mends '
               'MCAP files cut short (analyze, replay and report read a candump log as it is)' if head else
               f'{src} is empty: there is nothing to recover')
        raise RecoverError(msg)
    schemas: dict[int, int] = {}
    channels: dict[int, int] = {}
    metadata: set[str] = set()
    count = 0
    first = last = None
    footer = False
    stopped = None
    dropped: list[str] = []

    def copy(record: Any) -> None:
        nonlocal count, first, last
        if isinstance(record, Schema) and record.id not in schemas:
            schemas[record.id] = writer.register_schema(record.name, record.encoding, record.data)
        elif isinstance(record, Channel) and record.id not in channels:
            channels[record.id] = writer.register_channel(
                record.topic, record.message_encoding, schemas.get(record.schema_id, 0), dict(record.metadata))
        elif isinstance(record, Metadata) and record.name not in metadata and record.name != METADATA_NAME:
            # what the recording was made with: kept (not rosbag2's record, which counts the
            # messages of the file it ends, not of this one)
            metadata.add(record.name)
            writer.add_metadata(record.name, dict(record.metadata))
        elif isinstance(record, Message) and record.channel_id in channels:
            writer.add_message(channels[record.channel_id], log_time=record.log_time,
                               publish_time=record.publish_time, data=record.data, sequence=record.sequence)
            count += 1
            first = record.log_time if first is None else min(first, record.log_time)
            last = record.log_time if last is None else max(last, record.log_time)

    with fin, atomic_path(dst) as tmp:
        try:
            fout = open(tmp, 'wb')
        except OSError as exc:
            msg = f'cannot write {dst}: {os_reason(exc)}'
            raise RecoverError(msg) from exc
        with fout:
            writer = Writer(
                fout if fout.seekable() else Counted(fout), compression=CompressionType.ZSTD, enable_crcs=True
            )
            writer.start(profile='ros2', library='steer_monitor recover')
            # a finished file repeats its schemas and channels in its summary: taken first, so
            # a dropped chunk that defined them (the first one defines them all) does not take
            # every later message of theirs with it
            for record in summary_definitions(fin):
                copy(record)
            try:
                for record in StreamReader(fin, record_size_limit=1 << 30, emit_chunks=True).records:
                    if isinstance(record, Chunk):
                        try:
                            inner = _chunk_records(record)
                        except ValueError as exc:
                            dropped.append(f'chunk of messages {record.message_start_time}..'
                                           f'{record.message_end_time} ns: {exc}')
                            continue
                        try:
                            for r in StreamReader(io.BytesIO(inner), skip_magic=True).records:
                                copy(r)
                        except EndOfFile:    # the end of the chunk's records, not of the file
                            pass
                    elif isinstance(record, Footer):
                        footer = True
                    else:
                        copy(record)
            except EndOfFile:         # the file ends inside a record: the crash's cut
                stopped = 'it ends inside a record'
            except Exception as exc:  # noqa: BLE001 - broken framing: mcap raises its own errors
                stopped = f'{exc}' if str(exc).strip() else f'a record that does not parse ({type(exc).__name__})'
            if count == 0 and not schemas:
                msg = f'{src} holds no readable MCAP records ({stopped or "; ".join(dropped) or "empty"})'
                raise RecoverError(msg)
            writer.finish()
    return RecoverResult(str(src), str(dst), count, len(channels), first, last,
                         footer and not dropped and stopped is None, stopped, dropped)
