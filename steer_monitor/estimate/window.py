"""The data an analysis looks at: the most recent steady rudder motion, bounded.

A node runs for months; the analysis (:func:`~steer_monitor.estimate.analyze.analyze`) looks at
the data it keeps, and ``analyze`` of a log takes the same window, so that what the vessel
says at a time is what the shore says of the log cut there. The window is

* the steady-motion instants of the observations (:mod:`~steer_monitor.estimate.observe`),
  the most recent ``motion_s`` seconds of them (0: all);
* every input's samples within ``FAST_MARGIN_NS`` (angle, order, pressures) or
  ``SLOW_MARGIN_NS`` (ship speed, oil temperature) of those instants; the rest is left out.
  The margins hold every sample the observations of those instants are made from (the
  angle's slopes and steadiness segments reach 0.35 s, an interpolation bracket 0.25 s, a
  slow input's 10 s; where the angle or the pressures come slower than the design rates,
  the windows they are judged over: :attr:`~steer_monitor.estimate.observe.Windows.reach_ns`),
  so the observations of the window's instants are those of the whole data, to the bit. (The
  margin before the first instant may also show up to 2 s of motion before it: an analysis
  of the window sees that too, the node's and a log's alike.)

So memory is bounded by the motion kept (about 1.5 MB a hour of motion), not by the time a
ship lies in port. :func:`compact` is what a node does with the samples it holds: it drops
what no later window can use (settled rest and motion older than the window), so the samples
it keeps are always a superset of the next window's and :func:`select` of them gives what
:func:`select` of the whole log would. Pure.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from steer_monitor.estimate.observe import GRID_NS, EstimateError, Windows, build_observations
from steer_monitor.model.inputs import FAST_INPUTS, Series

__all__ = ['FAST_MARGIN_NS', 'SETTLE_NS', 'SLOW_MARGIN_NS', 'Window', 'WindowBuffer', 'before', 'compact', 'select']

FAST_MARGIN_NS = 2_000_000_000      # angle and pressures kept this far either side of motion
SLOW_MARGIN_NS = 15_000_000_000     # speed and oil temperature (their interpolation bracket is 10 s)
SETTLE_NS = 2_000_000_000           # observations older than this before the newest angle are final


@dataclass(frozen=True)
class Window:
    """A window of the data (see the module docstring).

    Attributes:
        signals: the samples of each input inside it.
        start_ns: the first steady-motion instant it holds [ns] (None: no motion).
        motion_s: the steady motion it holds [s] (instants x their spacing, 50 ms at the
            design rates).
        spans: (k, 2) [ns]: the stretches of steady motion it holds, each [first, last instant].
    """

    signals: dict[str, Series]
    start_ns: int | None
    motion_s: float
    spans: NDArray[np.int64]


def _spans(t_ns: NDArray[np.int64], step_ns: int = GRID_NS) -> NDArray[np.int64]:
    """Runs of instants one step (``step_ns``) apart: (k, 2) [first, last]."""
    if t_ns.size == 0:
        return np.zeros((0, 2), np.int64)
    cut = np.flatnonzero(np.diff(t_ns) != step_ns) + 1
    starts = np.concatenate([[0], cut])
    ends = np.concatenate([cut - 1, [t_ns.size - 1]])
    return np.stack([t_ns[starts], t_ns[ends]], axis=1)


def _near(t: NDArray[np.int64], spans: NDArray[np.int64], margin: int) -> NDArray[np.bool_]:
    """Which times ``t`` (sorted) lie within ``margin`` of a span."""
    if spans.shape[0] == 0 or t.size == 0:
        return np.zeros(t.size, bool)
    lo = np.searchsorted(t, spans[:, 0] - margin, side='left')
    hi = np.searchsorted(t, spans[:, 1] + margin, side='right')
    mark = np.zeros(t.size + 1, np.int64)
    np.add.at(mark, lo, 1)
    np.add.at(mark, hi, -1)
    return np.cumsum(mark[:-1]) > 0


def _moving_times(signals: Mapping[str, Series], ram_area: float) -> tuple[NDArray[np.int64], int]:
    """The steady-motion instants of ``signals`` and their spacing [ns]."""
    try:
        obs = build_observations(signals, ram_area)
    except EstimateError:
        return np.zeros(0, np.int64), GRID_NS
    return obs.t_ns[obs.moving], obs.step_ns


def _keep(signals: Mapping[str, Series], spans: NDArray[np.int64], before_ns: int | None = None
          ) -> dict[str, Series]:
    """Each input's samples near ``spans`` (its margin); with ``before_ns``, only samples
    older than that less the input's margin are judged, newer ones are all kept (motion that
    starts after ``before_ns`` may need them)."""
    out: dict[str, Series] = {}
    fast = max(FAST_MARGIN_NS, Windows.of(signals).reach_ns)
    for name, ser in signals.items():
        margin = fast if name in FAST_INPUTS else SLOW_MARGIN_NS
        keep = _near(ser.t_ns, spans, margin)
        if before_ns is not None:
            keep |= ser.t_ns >= before_ns - margin
        out[name] = ser if keep.all() else Series(ser.t_ns[keep], ser.value[keep])
    return out


def before(signals: Mapping[str, Series], t_ns: int) -> dict[str, Series]:
    """The samples of ``signals`` older than ``t_ns`` [ns]: the data a node's analysis at
    ``t_ns`` had (a log cut there)."""
    out: dict[str, Series] = {}
    for name, ser in signals.items():
        k = int(np.searchsorted(ser.t_ns, t_ns, side='left'))
        out[name] = ser if k == len(ser.t_ns) else Series(ser.t_ns[:k], ser.value[:k])
    return out


def select(signals: Mapping[str, Series], ram_area: float, motion_s: float = 0.0) -> Window:
    """The window of ``signals``: the last ``motion_s`` seconds of steady motion (0: all of it)
    and the samples near it (see the module docstring)."""
    moving, step = _moving_times(signals, ram_area)
    if motion_s > 0:
        keep = int(round(motion_s * 1e9 / step))
        moving = moving[-keep:] if keep > 0 else moving[:0]
    spans = _spans(moving, step)
    kept = _keep(signals, spans)
    return Window(kept, int(moving[0]) if moving.size else None, moving.size * step / 1e9, spans)


def compact(signals: Mapping[str, Series], ram_area: float, motion_s: float = 0.0) -> dict[str, Series]:
    """The samples a node keeps of ``signals`` for its later windows: those newer than
    ``SETTLE_NS`` before the newest angle sample (their observations are not final yet) and
    the input's margin before that, and of the older ones those :func:`select` would keep now. Any later window of
    the data that
    follow is :func:`select` of these and what comes after, as of the whole data."""
    angle = signals.get('rudder_angle')
    if angle is None or len(angle) == 0:
        return dict(signals)
    settled = int(angle.t_ns[-1]) - max(SETTLE_NS, Windows.of(signals).reach_ns)
    moving, step = _moving_times(signals, ram_area)
    moving = moving[moving < settled]
    if motion_s > 0:
        keep = int(round(motion_s * 1e9 / step))
        moving = moving[-keep:] if keep > 0 else moving[:0]
    return _keep(signals, _spans(moving, step), before_ns=settled)


class WindowBuffer:
    """The samples a node keeps for its analyses: appended as they come, compacted every
    ``compact_every_ns`` of data (:func:`compact`, on the samples taken since the last
    compaction and the margin before them), so memory is bounded by the window's motion.
    :meth:`signals` is what a job hands :func:`select`. Not thread-safe: one caller."""

    def __init__(self, names: tuple[str, ...], ram_area: float, motion_s: float,
                 compact_every_ns: int = 600_000_000_000) -> None:
        self.names = names
        self.ram_area = ram_area
        self.motion_s = motion_s
        self.compact_every_ns = compact_every_ns
        self._kept: dict[str, Series] = {}                 # compacted: arrays
        self._t: dict[str, list[int]] = {n: [] for n in names}
        self._v: dict[str, list[float]] = {n: [] for n in names}
        self._last_compact_ns: int | None = None

    def add(self, name: str, t_ns: int, value: float) -> None:
        """Take one sample of input ``name`` (the others are ignored)."""
        t = self._t.get(name)
        if t is not None:
            t.append(t_ns)
            self._v[name].append(value)

    def extend(self, name: str, times: list[int], values: list[float]) -> None:
        """Take samples of input ``name`` in order: :meth:`add` of each."""
        t = self._t.get(name)
        if t is not None:
            t.extend(times)
            self._v[name].extend(values)

    def signals(self) -> dict[str, Series]:
        """Every sample held, per input, as series."""
        out: dict[str, Series] = {}
        for n in self.names:
            kept = self._kept.get(n)
            new_t, new_v = self._t[n], self._v[n]
            if not new_t:
                if kept is not None and len(kept):
                    out[n] = kept
                continue
            t = np.fromiter(new_t, np.int64, len(new_t))
            v = np.fromiter(new_v, float, len(new_v))
            if kept is not None and len(kept):
                t, v = np.concatenate([kept.t_ns, t]), np.concatenate([kept.value, v])
            out[n] = Series(t, v)
        return out

    def tick(self, now_ns: int) -> bool:
        """At a whole second of data: compact when ``compact_every_ns`` has passed since the
        last compaction. True when it did."""
        if self._last_compact_ns is None:
            self._last_compact_ns = now_ns
            return False
        if now_ns - self._last_compact_ns < self.compact_every_ns:
            return False
        self._last_compact_ns = now_ns
        self.load(compact(self.signals(), self.ram_area, self.motion_s))
        return True

    def load(self, signals: dict[str, Series]) -> None:
        """Hold exactly ``signals`` (a compaction's, or a saved state's)."""
        self._kept = {n: s for n, s in signals.items() if n in self._t and len(s)}
        for n in self.names:
            self._t[n].clear()
            self._v[n].clear()

    def clear(self) -> None:
        self.load({})
        self._last_compact_ns = None

    def __len__(self) -> int:
        return sum(len(s) for s in self._kept.values()) + sum(len(t) for t in self._t.values())
