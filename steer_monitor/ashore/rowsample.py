"""The steady-motion rows a review window's residual spread is measured on.

A window's estimate comes from the binned moments of every row before its end; its interval
is scaled by the spread of the residuals (their correlation in time and each parameter's
cluster-robust scale, :func:`~steer_monitor.estimate.batch.sample_spread`), which needs the
rows themselves. Measured on the last minutes of motion only, the spread can miss what the
moments hold: on a voyage whose high loads came early, the recent rows never brought the guide
beam into contact, Z_gb's robust scale could not be measured there, and a window put a worn
slipper (0.347 mm) at 0.262 mm [0.260 .. 0.265]. So a window is told of a sample spread over all
its rows: the rows of every ``s``-th chunk of ``CHUNK_NS`` of data time before its end
(chunk ``c = t // CHUNK_NS``, kept where ``c % s == 0``), ``s`` the least power of two that
leaves at most ``max_rows`` rows (all of them, on a voyage of up to ``max_rows`` rows of motion).

The sample of a window depends on the rows before its end alone (whenever it is estimated,
however the log is cut into blocks), provided windows end on whole chunks (they end on whole
10-minute slices) or after every row (the whole log's estimate). The rows no window still to
come can ask for are dropped (:meth:`RowSample.prune`): what is kept is about ``max_rows``
for a planned review and grows with the logarithm of the log's length for one that is not.

Pure: :class:`~steer_monitor.estimate.observe.Observations` in and out, times integer ns.
"""

from __future__ import annotations

import numpy as np

from steer_monitor.estimate.observe import Observations

__all__ = ['CHUNK_NS', 'MAX_ROWS', 'RowSample', 'concat_observations']

CHUNK_NS = 300 * 1_000_000_000     # as long as the longest time cluster of the robust scales
MAX_ROWS = 48_000                  # 40 minutes of steady motion on the 50 ms grid


def concat_observations(parts: list[Observations]) -> Observations:
    """``parts`` (at least one) as one, in the order given."""
    if len(parts) == 1:
        return parts[0]
    names = [f for f in Observations.__dataclass_fields__ if f not in ('step_ns', 'shared_ns')]
    return Observations(*(np.concatenate([getattr(p, f) for p in parts]) for f in names),
                        step_ns=max(p.step_ns for p in parts), shared_ns=max(p.shared_ns for p in parts))


class RowSample:
    """Rows in, in time order (:meth:`add`); a window's sample out (:meth:`before`)."""

    def __init__(self, max_rows: int | None = None, chunk_ns: int = CHUNK_NS) -> None:
        max_rows = MAX_ROWS if max_rows is None else max_rows
        if max_rows < 1 or chunk_ns < 1:
            msg = f'a row sample needs max_rows and chunk_ns >= 1, got {max_rows}, {chunk_ns}'
            raise ValueError(msg)
        self.max_rows, self.chunk_ns = max_rows, chunk_ns
        self._ids: list[int] = []                         # every chunk seen, in order
        self._counts: list[int] = []                      # rows added to each
        self._rows: dict[int, list[Observations]] = {}    # the rows kept, per chunk
        self._latest: int | None = None                   # the latest row's time [ns]
        self._settled = -1              # not planned: chunks up to this one are kept or dropped for good

    def add(self, obs: Observations) -> None:
        """Rows later than any added before."""
        if not len(obs):
            return
        chunk = obs.t_ns // self.chunk_ns
        for c in np.unique(chunk).tolist():
            part = obs.select(chunk == c)
            if self._ids and self._ids[-1] == c:
                self._counts[-1] += len(part)
            else:
                self._ids.append(c)
                self._counts.append(len(part))
            self._rows.setdefault(c, []).append(part)
        self._latest = int(obs.t_ns[-1])

    @property
    def kept(self) -> int:
        """How many rows are held."""
        return sum(len(p) for parts in self._rows.values() for p in parts)

    def first_ns(self) -> int | None:
        """The time of the earliest row held [ns] (None when none is)."""
        return int(self._rows[min(self._rows)][0].t_ns[0]) if self._rows else None

    def stride(self, end_ns: int) -> int:
        """The sample's stride for a window ending at ``end_ns``: the least power of two ``s``
        with at most ``max_rows`` rows in the chunks begun before ``end_ns`` whose index is a
        multiple of ``s``."""
        k = int(np.searchsorted(self._ids, -(-end_ns // self.chunk_ns)))
        ids, counts = np.asarray(self._ids[:k], np.int64), np.asarray(self._counts[:k], np.int64)
        s = 1
        while int(counts[ids % s == 0].sum()) > self.max_rows:
            s *= 2
        return s

    def before(self, end_ns: int) -> Observations | None:
        """The sample of a window ending at ``end_ns``: its rows before ``end_ns`` in every
        :meth:`stride`-th chunk (None when there are none)."""
        s = self.stride(end_ns)
        parts = [p for c in sorted(self._rows) if c % s == 0 for p in self._rows[c] if p.t_ns[0] < end_ns]
        if not parts:
            return None
        last = parts[-1]
        if last.t_ns[-1] >= end_ns:
            parts[-1] = last.select(last.t_ns < end_ns)
        return concat_observations(parts)

    def prune(self, *, next_end_ns: int | None = None, step_ns: int | None = None,
              boundary_ns: int | None = None) -> None:
        """Drop the chunks no window still to come can ask for. Windows to come end at
        ``next_end_ns`` and every ``step_ns`` after it (a planned review), or at any multiple
        of ``boundary_ns`` (one that is not); the whole log's estimate, after every row, asks
        for the largest stride of all. A chunk is asked for by the first window ending after
        its start, at a stride no smaller than that window's as counted now."""
        planned = next_end_ns is not None and step_ns is not None
        if not planned and boundary_ns is None:
            return
        if any(x is not None and x % self.chunk_ns for x in (next_end_ns, step_ns, boundary_ns)):
            msg = f'windows must end on whole chunks of {self.chunk_ns} ns'
            raise ValueError(msg)
        strides: dict[int, int] = {}
        for c in [c for c in self._rows if planned or c > self._settled]:
            start = c * self.chunk_ns
            if planned:
                end = next_end_ns if start < next_end_ns else \
                    next_end_ns + (-(-(start + 1 - next_end_ns) // step_ns)) * step_ns
            else:
                end = (start // boundary_ns + 1) * boundary_ns
            s = strides.get(end)
            if s is None:
                s = strides[end] = self.stride(end)
            if c % s:
                del self._rows[c]
            if not planned and self._latest is not None and end <= self._latest:
                self._settled = c       # the rows before its window's end are all in: its stride is final
