"""A progress bar over the data time of logs: percentage and ETA from where the logs' frames
have got to, on a terminal only (or when asked).

A log's length in frames is not known before it is read, but its span is, cheaply: the first
frame and, for candump and MCAP, the last (:func:`~steer_monitor.logfiles.blocks.log_end_ns`).
Logs are read in time order, so the data time reached says how much is done. Where a log's
end cannot be told (the gateways' text formats), the bar counts frames without a total.
"""

from __future__ import annotations

import datetime
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any, TextIO

__all__ = ['DataTimeProgress', 'log_spans']


def log_spans(paths: Sequence[str | Path], date: datetime.date | None = None) -> list[tuple[int, int]] | None:
    """(first, last) frame time [ns] of each log, or None when one of them cannot be told."""
    from steer_monitor.logfiles.blocks import first_frame_ns, log_end_ns

    spans = []
    for p in paths:
        first, last = first_frame_ns(p, date), log_end_ns(p)
        if first is None or last is None or last < first:
            return None
        spans.append((first, last))
    return spans


class DataTimeProgress:
    """Called with (frames done since the last call, data time reached [ns] or None). Shows
    the seconds of data done out of the logs' total with percentage, ETA and frames/s on
    ``file`` when it is a terminal or ``force``; nothing otherwise. Context manager."""

    def __init__(self, spans: list[tuple[int, int]] | None, desc: str, file: TextIO | None = None,
                 force: bool = False) -> None:
        from tqdm import tqdm

        # no tqdm monitor thread (it only retunes bars updated rarely; these are updated every
        # few thousand frames): a replay forks its estimator's worker only from a process with
        # no other thread (steer_monitor.ashore.replay_worker)
        tqdm.monitor_interval = 0
        file = file or sys.stderr
        enabled = force or file.isatty()
        self._spans = sorted(spans) if spans else None
        self._frames = 0
        if self._spans is not None:
            total = sum(e - s for s, e in self._spans) / 1e9
            self._bar: Any = tqdm(total=round(total, 1), unit='s', desc=f'{desc} (s of data)', file=file,
                                  disable=not enabled, bar_format='{l_bar}{bar}| {n:.0f}/{total:.0f} s '
                                  '[{elapsed}<{remaining}{postfix}]')
        else:
            self._bar = tqdm(unit='frame', unit_scale=True, desc=desc, file=file, disable=not enabled)

    def done_s(self, t_ns: int) -> float:
        """Seconds of data before ``t_ns`` over all the logs' spans."""
        assert self._spans is not None
        return sum(min(max(t_ns - s, 0), e - s) for s, e in self._spans) / 1e9

    def __call__(self, frames: int, t_ns: int | None = None) -> None:
        self._frames += frames
        if self._spans is None:
            self._bar.update(frames)
            return
        if t_ns is not None:
            n = min(round(self.done_s(t_ns), 1), self._bar.total)
            if n > self._bar.n:
                self._bar.set_postfix_str(f'{self._frames:,d} frames', refresh=False)
                self._bar.update(n - self._bar.n)     # throttled by tqdm

    def close(self) -> None:
        self._bar.close()

    def __enter__(self) -> DataTimeProgress:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
