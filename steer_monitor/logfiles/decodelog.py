"""Whole logs to decoded series, streamed a block of columns at a time.

What ``inspect``, ``analyze`` and ``report`` read: every log in turn through the column
readers (:func:`~steer_monitor.logfiles.blocks.iter_log_blocks`) and the array decoder, so
memory holds one block of frames and the decoded samples, never an object per frame. A log
that breaks off or holds corrupt parts gives what could be read; what was wrong is kept, one
line per log, for the command to report.
"""

from __future__ import annotations

import datetime
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from steer_monitor.can.codec import CanDatabase
from steer_monitor.can.decoder import ClockStep, Decoder, Series, SignalSet, clock_notes
from steer_monitor.can.frames import FrameArrays
from steer_monitor.can.rejects import RejectCounter
from steer_monitor.can.signals import SignalMap
from steer_monitor.logfiles.blocks import iter_log_blocks
from steer_monitor.logfiles.logs import LogError
from steer_monitor.utc import time_json

__all__ = ['DecodedLogs', 'clock_steps_json', 'decode_logs']


@dataclass(frozen=True)
class DecodedLogs:
    """Decoded series of one or more logs.

    Attributes:
        signals: per input, its samples in arrival order.
        frames: frames read (all of them, rejected ones too).
        first_ns, last_ns: the span of the accepted samples [ns] (None without any): a
            glitched frame's time, rejected, does not stretch it.
        errors: one line per log that broke off or had corrupt parts (its readable frames
            are in ``signals``).
        clock_steps: the steps of the frames' clock met (:class:`~steer_monitor.can.decoder.ClockStep`);
            the samples after a step back follow those before it (their times shifted).
        notes: what to say of them, a line each.
    """

    signals: SignalSet
    frames: int
    first_ns: int | None
    last_ns: int | None
    errors: tuple[str, ...]
    clock_steps: tuple[ClockStep, ...] = ()
    notes: tuple[str, ...] = ()

    @property
    def span_s(self) -> float:
        return 0.0 if self.first_ns is None or self.last_ns is None else (self.last_ns - self.first_ns) / 1e9


def decode_logs(paths: Sequence[str | Path], db: CanDatabase, smap: SignalMap, rejects: RejectCounter, *,
                since_ns: int | None = None, progress: Callable[[int], None] | None = None,
                date: datetime.date | None = None) -> DecodedLogs:
    """Read and decode ``paths`` in the order given as one stream (frames before ``since_ns``
    left out); rejects are counted in ``rejects``. ``progress`` hears the frames of each block.
    ``date``: of a YDWG raw log's first line (:func:`~steer_monitor.logfiles.gateway.ydwg_date`)."""
    decoder = Decoder(db, smap, rejects, stitch=True)
    parts: dict[str, list[Series]] = {name: [] for name in smap.names}
    frames = 0
    errors: list[str] = []

    def take(signals: SignalSet) -> None:
        for name, series in signals.items():
            if len(series):
                parts[name].append(series)

    for path in paths:
        try:
            for block in iter_log_blocks(path, rejects, date):
                frames += len(block)
                if progress is not None:
                    progress(len(block))
                if since_ns is not None:
                    block = block.take(np.nonzero(block.t_ns >= since_ns)[0])
                take(decoder.decode_arrays(block))
        except LogError as exc:
            errors.append(str(exc))
    take(decoder.decode_arrays(FrameArrays.empty(), final=True))
    signals = {name: Series(np.concatenate([s.t_ns for s in ps]) if ps else np.zeros(0, np.int64),
                            np.concatenate([s.value for s in ps]) if ps else np.zeros(0, np.float64))
               for name, ps in parts.items()}
    firsts = [int(s.t_ns.min()) for s in signals.values() if len(s)]
    lasts = [int(s.t_ns.max()) for s in signals.values() if len(s)]
    return DecodedLogs(signals, frames, min(firsts) if firsts else None, max(lasts) if lasts else None,
                       tuple(errors), tuple(decoder.clock_steps), tuple(clock_notes(decoder.clock_steps)))


def clock_steps_json(steps: Sequence[ClockStep]) -> list[dict[str, object]]:
    """The clock steps as JSON: ``{"before_utc", "after_utc", "before_ns", "after_ns",
    "step_s", "shift_s"}`` each (``shift_s``: what the data after it were moved by)."""
    return [{**time_json('before', st.before_ns), **time_json('after', st.after_ns), 'step_s': round(st.step_s, 3),
             'shift_s': round(st.shift_ns / 1e9, 3)} for st in steps]
