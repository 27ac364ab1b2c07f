"""Logs given twice: the same file under two names, or a copy of it, is read once.

Read twice, one stretch of data is a clock set back (its second reading refused frame by frame
as older than the first, or, where the decoder restarts, counted again), and a report's
intervals narrow as if it were two logs. ``report`` and ``replay`` take their logs through
:func:`distinct_logs` and say what they left out; the fleet, which keeps each log's digest,
counts a log of the same time as another once (:func:`~steer_monitor.ashore.fleet.same_time_as`).
"""

from __future__ import annotations

import hashlib
import os
import stat
from collections.abc import Sequence
from pathlib import Path

__all__ = ['distinct_logs']

_PIECE = 1 << 20


def _digest(path: Path) -> str | None:
    h = hashlib.sha256()
    try:
        with open(path, 'rb') as fh:
            while piece := fh.read(_PIECE):
                h.update(piece)
    except OSError:
        return None                 # unreadable: the reader says why, in its own words
    return h.hexdigest()


def distinct_logs(paths: Sequence[str | Path]) -> tuple[list[Path], list[str]]:
    """``paths`` without the ones that hold the same bytes as one before them (the same file
    through another name or link, or a copy), in the order given, and a note for each left
    out."""
    kept: list[Path] = []
    notes: list[str] = []
    seen: dict[tuple[int, str], Path] = {}
    for p in map(Path, paths):
        try:
            st = os.stat(p)
        except (OSError, ValueError):
            kept.append(p)
            continue
        if not stat.S_ISREG(st.st_mode):      # a device or a pipe is never read here (/dev/zero has no end)
            kept.append(p)
            continue
        size = st.st_size
        same = next((q for q in kept if _samefile(p, q)), None)
        digest = None if same is not None else _digest(p)
        if same is None and digest is not None:
            same = seen.get((size, digest))
        if same is not None:
            notes.append(f'{p} holds the same data as {same}: read once')
            continue
        if digest is not None:
            seen[(size, digest)] = p
        kept.append(p)
    return kept, notes


def _samefile(a: Path, b: Path) -> bool:
    try:
        return os.path.samefile(a, b)
    except (OSError, ValueError):
        return False
