"""What the live monitor has heard of each input: its newest sample and its arrival times. Pure.

The diagnostics judge each input's rate and silence from these (:meth:`InputLog.rate_hz`,
:meth:`InputLog.silent_for`); the live model reads the newest values.
Times are integer ns; values SI.
"""

from __future__ import annotations

import bisect
import math
from dataclasses import dataclass, field

import numpy as np

from steer_monitor.estimate.sampling import SignalTiming, signal_timing
from steer_monitor.model.inputs import INPUTS

__all__ = ['ARRIVALS_KEPT_NS', 'RATE_WINDOW_NS', 'Arrivals', 'InputLog']

RATE_WINDOW_NS = 5_000_000_000      # the shortest window a rate is judged over
ARRIVALS_KEPT_NS = 30_000_000_000   # arrivals kept per input: five periods down to 0.17 Hz


@dataclass
class Arrivals:
    """An input's newest sample and its arrival times: those of the last
    :data:`ARRIVALS_KEPT_NS` kept, in the order they came (``times`` from ``start`` on; the
    list is cut down as it grows, so dropping the oldest costs no per-sample work)."""

    last_t_ns: int | None = None
    last_value: float = math.nan
    times: list[int] = field(default_factory=list)
    start: int = 0
    ordered: bool = True        # arrivals in time order (a clock step back can break it)
    #: arrivals ever (those dropped from ``times`` too)
    total: int = 0
    #: frames lost, silences and the last of them, as counted so far (:meth:`count_gaps`)
    lost: int = 0
    gaps: int = 0
    last_gap: tuple[int, int] | None = None
    counted_to: int | None = None      # the last arrival counted

    @property
    def arrivals(self) -> list[int]:
        """The arrival times kept [ns], as they came (a copy)."""
        return self.times[self.start:]

    def kept(self) -> int:
        """How many arrival times are kept."""
        return len(self.times) - self.start

    def arrive(self, t_ns: int) -> None:
        """One arrival at ``t_ns``: kept, those older than :data:`ARRIVALS_KEPT_NS` dropped."""
        times = self.times
        if len(times) > self.start and t_ns < times[-1]:
            self.ordered = False
        times.append(t_ns)
        self.total += 1
        self._drop(t_ns - ARRIVALS_KEPT_NS)

    def arrive_many(self, t_ns: list[int]) -> None:
        """Arrivals in time order, none before the last kept, :meth:`arrive` of each at once."""
        self.times += t_ns
        self.total += len(t_ns)
        self._drop(t_ns[-1] - ARRIVALS_KEPT_NS)

    def silent_for(self, now_ns: int) -> float | None:
        """Seconds since the input was last heard at ``now_ns`` (None: never)."""
        t = self.last_t_ns
        return None if t is None else (now_ns - t) / 1e9

    def timing(self) -> SignalTiming:
        """How the input came over the arrivals kept (its own period, whatever it was configured
        at: :func:`~steer_monitor.estimate.sampling.signal_timing`; no period out of order)."""
        if not self.ordered:
            return SignalTiming(None, None, 0, ())
        return signal_timing(np.asarray(self.times[self.start:], np.int64), 2 ** 62)

    def count_gaps(self, period_ns: int, gap_ns: int) -> None:
        """Count what came since the last count: the frames lost (an interval of k periods of
        ``period_ns`` has k - 1 missing) into :attr:`lost`, the silences over ``gap_ns`` into
        :attr:`gaps` and the last of them into :attr:`last_gap` (start, end [ns]). Arrivals
        out of order are not counted."""
        times = self.times
        if not self.ordered or len(times) <= self.start:
            return
        i = self.start if self.counted_to is None else max(bisect.bisect_left(times, self.counted_to, self.start),
                                                             self.start)
        if len(times) - i >= 2:
            d = np.diff(np.asarray(times[i:], np.int64))
            self.lost += int(np.maximum(np.rint(d / period_ns) - 1, 0).sum())
            at = np.flatnonzero(d > gap_ns)
            if at.size:
                self.gaps += int(at.size)
                self.last_gap = (int(times[i + at[-1]]), int(times[i + at[-1] + 1]))
        self.counted_to = times[-1]

    def rate_hz(self, now_ns: int, window_ns: int) -> float:
        """:meth:`InputLog.rate_hz` of this input (``window_ns`` at most the time kept)."""
        if self.ordered:
            times = self.times
            i = bisect.bisect_left(times, now_ns - window_ns, self.start)
            n = len(times) - i
            first, last = (times[i], times[-1]) if n else (0, 0)
        else:
            recent = [t for t in self.arrivals if t >= now_ns - window_ns]
            n, first, last = len(recent), recent[0] if recent else 0, recent[-1] if recent else 0
        if n < 2 or last == first:
            return 0.0
        return (n - 1) / ((last - first) / 1e9)

    def _drop(self, cut: int) -> None:
        """The oldest dropped while the first kept is before ``cut`` [ns]."""
        times, i = self.times, self.start
        if self.ordered:
            i = bisect.bisect_left(times, cut, i)
        else:
            n = len(times)
            while i < n and times[i] < cut:
                i += 1
        if i > 1024 and 2 * i > len(times):
            del times[:i]
            i = 0
        self.start = i


class InputLog:
    """Every input's :class:`Arrivals` (``signals``, by the input's name)."""

    def __init__(self) -> None:
        self.signals: dict[str, Arrivals] = {name: Arrivals() for name in INPUTS}

    def heard(self, name: str, t_ns: int, value: float) -> None:
        """One sample of ``name`` at ``t_ns`` [ns] of ``value`` [SI]: the newest, its arrival kept."""
        sig = self.signals[name]
        sig.last_t_ns, sig.last_value = t_ns, value
        sig.arrive(t_ns)

    def record(self, name: str, times: list[int], values: list[float], ordered: bool) -> None:
        """Samples of ``name`` [ns, SI] as :meth:`heard` of each in turn takes them.
        ``ordered``: the times are in order (else they are taken one by one)."""
        if not times:
            return
        sig = self.signals[name]
        if ordered and sig.ordered and (not sig.kept() or times[0] >= sig.times[-1]):
            sig.arrive_many(times)
        else:
            for t in times:
                sig.arrive(t)
        sig.last_t_ns, sig.last_value = times[-1], values[-1]

    def rate_hz(self, name: str, now_ns: int, window_ns: int = RATE_WINDOW_NS) -> float:
        """Arrival rate of an input (Hz) from the spacing of its arrivals in the last
        ``window_ns`` (at most :data:`ARRIVALS_KEPT_NS`), so it is right from the second
        sample on; silence is judged by :meth:`silent_for`. A slow input needs a window of
        several of its periods: with two periods in it, one late frame reads as rate 0."""
        if window_ns > ARRIVALS_KEPT_NS:
            msg = f'rate window {window_ns / 1e9:g} s is longer than the {ARRIVALS_KEPT_NS / 1e9:g} s of arrivals kept'
            raise ValueError(msg)
        return self.signals[name].rate_hz(now_ns, window_ns)

    def silent_for(self, name: str, now_ns: int) -> float | None:
        """Seconds since the input was last heard (None: never)."""
        return self.signals[name].silent_for(now_ns)
