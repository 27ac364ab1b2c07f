"""Any supported log as blocks of columns, in file order: the package's one reader of every
log, and what a log's first and last frame times are.

candump and MCAP are read into columns directly (:mod:`~steer_monitor.logfiles.candumpcols`,
:mod:`~steer_monitor.logfiles.mcapcols`: millions of frames a second); the other formats (ASC,
BLF through python-can; the gateway logs of :mod:`~steer_monitor.logfiles.gateway`) frame by
frame, gathered into blocks.
"""

from __future__ import annotations

import datetime
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from steer_monitor.can.frames import Frame, FrameArrays
from steer_monitor.can.rejects import RejectCounter
from steer_monitor.logfiles.candumpcols import BLOCK_FRAMES, CANDUMP_LINE, iter_candump_blocks
from steer_monitor.logfiles.logs import LogError, is_compressed, iter_log_as, log_format
from steer_monitor.logfiles.mcapcols import iter_mcap_blocks

__all__ = ['first_frame_ns', 'in_time_order', 'iter_log', 'iter_log_blocks', 'log_end_ns', 'read_log_fast']


def iter_log_blocks(path: str | Path, rejects: RejectCounter | None = None,
                    date: datetime.date | None = None) -> Iterator[FrameArrays]:
    """Any supported log as blocks of columns, in file order (``date``: see
    :func:`iter_log`)."""
    path = Path(path)
    fmt = log_format(path)
    if fmt == 'candump':
        yield from iter_candump_blocks(path, rejects)
        return
    if fmt == 'mcap':
        yield from iter_mcap_blocks(path, rejects)
        return
    block: list[Any] = []
    try:
        for frame in iter_log_as(path, fmt, rejects, date):
            block.append(frame)
            if len(block) >= BLOCK_FRAMES // 4:
                yield FrameArrays.from_frames(block)
                block = []
    except LogError:
        # a log that breaks off gives the frames before the break, then the error
        if block:
            yield FrameArrays.from_frames(block)
        raise
    if block:
        yield FrameArrays.from_frames(block)


def log_end_ns(path: str | Path) -> int | None:
    """The time of a log's last frame, cheaply (candump: its last line; MCAP: the summary's
    statistics), or None when it cannot be told without reading the whole log."""
    path = Path(path)
    try:
        fmt = log_format(path)
        if is_compressed(path):     # its end is known only once the whole is decompressed
            return None
        if fmt == 'candump':
            with open(path, 'rb') as fh:
                fh.seek(max(fh.seek(0, 2) - 4096, 0))
                for line in reversed(fh.read().splitlines()):
                    m = CANDUMP_LINE.match(line.strip())
                    if m is not None:
                        return int(m.group(1)) * 1_000_000_000 + int(m.group(2).ljust(9, b'0'))
        elif fmt == 'mcap':
            from steer_monitor._vendor.mcap.reader import make_reader
            with open(path, 'rb') as fh:
                summary = make_reader(fh).get_summary()
                if summary is not None and summary.statistics is not None and summary.statistics.message_count:
                    return int(summary.statistics.message_end_time)
    except Exception:   # a cut or odd file: the caller reads it and finds out
        return None
    return None


def first_frame_ns(path: str | Path, date: datetime.date | None = None) -> int | None:
    """The time of a log's first frame (None: no frame can be read), for putting logs in order."""
    try:
        for block in iter_log_blocks(path, date=date):
            if len(block):
                return int(block.t_ns[0])
    except LogError:
        pass
    return None


def in_time_order(paths: list[Path], date: datetime.date | None = None) -> list[Path]:
    """Logs in order of their first frame; one without a readable frame goes last (its error
    is reported when it is read)."""
    def key(p: Path) -> int:
        t = first_frame_ns(p, date)
        return 1 << 62 if t is None else t
    return sorted(paths, key=key) if len(paths) > 1 else list(paths)


def iter_log(path: str | Path, rejects: RejectCounter | None = None, date: datetime.date | None = None
             ) -> Iterator[Frame]:
    """Frames of any supported log, one at a time in file order (the blocks of
    :func:`iter_log_blocks`). Bad records are counted in ``rejects``; ``date``: the date of a
    YDWG log's first line (see :func:`~steer_monitor.logfiles.gateway.ydwg_date`)."""
    for block in iter_log_blocks(path, rejects, date):
        yield from block.frames()


def read_log_fast(path: str | Path, rejects: RejectCounter | None = None,
                  date: datetime.date | None = None) -> FrameArrays:
    """A whole log as columns (the blocks of :func:`iter_log_blocks` joined)."""
    return FrameArrays.concat(list(iter_log_blocks(path, rejects, date)))
