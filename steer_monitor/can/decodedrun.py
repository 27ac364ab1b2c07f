"""A run of frames decoded at once (:meth:`~steer_monitor.can.decoder.Decoder.decode_run`):
each frame's samples and rejects as columns, the rejects counted as the frames are reached, so
that a count read between frames is the frame-by-frame one. Pure: numpy only."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from steer_monitor.can.rejects import RejectCounter

__all__ = ['DecodedRun']


@dataclass
class DecodedRun:
    """A run of frames decoded at once (:meth:`Decoder.decode_run`). Per frame ``i`` (shapes
    (n,)): ``t_ns`` its stamp, ``ref_before``/``ref_after`` the stream's established time
    before and after it was decoded [ns] (``NO_TIME`` before the stream's first). Samples in
    frame-by-frame order: ``sample_row`` (the frame at whose arrival it is given,
    non-decreasing), ``sample_t_ns`` (its own frame's stamp: a frame held after a time jump
    gives its samples at the frame that confirms its chain), ``sample_spec`` (the number of
    its input in ``spec_names``; :attr:`sample_name` names them), ``sample_value`` [SI]."""

    t_ns: NDArray[np.int64]
    ref_before: NDArray[np.int64]
    ref_after: NDArray[np.int64]
    sample_row: NDArray[np.intp]
    sample_t_ns: NDArray[np.int64]
    sample_spec: NDArray[np.intp]
    spec_names: tuple[str, ...]
    sample_value: NDArray[np.float64]
    events: list[tuple[NDArray[np.intp], str, str]]     # (frames, reason, input or '')
    rejects: RejectCounter
    #: nothing decided across frames: every frame after the stream's first time, every sample
    #: given at its own frame
    settled: bool = True

    def __post_init__(self) -> None:
        parts = [(rows, k) for k, (rows, _, _) in enumerate(self.events) if rows.size]
        if len(parts) == 1:
            row, kind = parts[0][0], np.full(parts[0][0].size, parts[0][1])
        else:
            row = np.concatenate([r for r, _ in parts]) if parts else np.zeros(0, np.intp)
            kind = np.concatenate([np.full(r.size, k) for r, k in parts]) if parts else np.zeros(0, np.intp)
        order = np.argsort(row, kind='stable')
        self._event_row, self._event_kind = row[order], kind[order]
        self._next = 0                                   # the first event not counted

    @property
    def sample_name(self) -> list[str]:
        """Each sample's input."""
        names = self.spec_names
        return [names[i] for i in self.sample_spec.tolist()]

    def counting_rows(self, visited: NDArray[np.intp]) -> NDArray[np.intp]:
        """Of the frames ``visited`` (sorted) one by one with :meth:`count_rejects`, those at
        which it counts something (the first visited at or after each reject's frame): calling
        it at these alone counts the same, in the same order."""
        if self._event_row.size == 0 or visited.size == 0:
            return np.zeros(0, np.intp)
        at = np.searchsorted(visited, self._event_row[self._next:], 'left')
        return visited[np.unique(at[at < visited.size])]

    def count_rejects(self, upto: int) -> None:
        """Count the rejects of frames ``<= upto`` not counted yet."""
        rows, lo = self._event_row, self._next
        if lo >= rows.size or rows[lo] > upto:          # most frames: nothing to count
            return
        hi = int(np.searchsorted(rows, upto, 'right'))
        self._next = hi
        if hi - lo <= 64:                                # a few: counted as they come
            counts: dict[int, int] = {}
            for k in self._event_kind[lo:hi].tolist():
                counts[k] = counts.get(k, 0) + 1
            pairs = sorted(counts.items())
        else:
            kinds, many = np.unique(self._event_kind[lo:hi], return_counts=True)
            pairs = list(zip(kinds.tolist(), many.tolist()))
        for k, c in pairs:
            _, reason, signal = self.events[k]
            self.rejects.add(reason, 'in a log block', signal, int(c))
