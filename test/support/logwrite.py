"""Logs written for the tests: a log of any format through the package's writer, and an ASC
file as python-can writes it (with the milliseconds Vector tools write)."""

from __future__ import annotations

from pathlib import Path

from steer_monitor.can.frames import FrameArrays
from steer_monitor.logfiles.logs import LogWriter

__all__ = ['write_asc', 'write_log']


def write_log(path: Path, frames: FrameArrays) -> Path:
    """``frames`` into a log at ``path`` in the format its name says, by the package's writer."""
    with LogWriter(path) as w:
        for f in frames.frames():
            w.write(f)
    return path


def write_asc(path: Path, frames: FrameArrays) -> Path:
    """An ASC file as python-can writes it, with the trigger block's milliseconds written as
    Vector tools write them: python-can 4.6 writes them unpadded ("00:00:00.7" for 7 ms) and
    then reads them as 700 ms."""
    import re

    import can

    from steer_monitor.can.bus import message_from_frame
    with can.ASCWriter(str(path)) as w:
        for f in frames.frames():
            w.on_message_received(message_from_frame(f))
    text = re.sub(r'(Begin Triggerblock .* \d\d:\d\d:\d\d)\.(\d{1,3}) ',
                  lambda m: f'{m.group(1)}.{m.group(2).zfill(3)} ', path.read_text())
    path.write_text(text)
    return path
