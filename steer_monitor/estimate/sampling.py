"""How the inputs came, and the windows the observations are judged over at their rates. Pure,
numpy only (no compiled code: ``inspect`` reads it without loading the estimator's solver).

The observation model (:mod:`~steer_monitor.estimate.observe`) is made for the rudder angle at
10 Hz and the pressures at 20 Hz (a direct tap on the steering bus). A gateway may forward them
far slower (NMEA 2000's default interval for Actual Pressure is 2 s). Each input's own period is
measured from its samples (:func:`median_period_ns`); an input more than :data:`SLOWER` times
slower than its design period has its windows scaled to its period (:class:`Windows`), on a
ladder of quarter octaves so that a log and a window of it (the node's) get the same windows.
:func:`signal_timing` says how an input came: its period, jitter, frames lost and gaps.

Times are integer ns.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from steer_monitor.model.inputs import PRESSURE_INPUTS, Series

__all__ = ['DESIGN_ANGLE_PERIOD_NS', 'DESIGN_PRESSURE_PERIOD_NS', 'GRID_NS', 'HALF_WINDOW_NS', 'MAX_GAP_NS',
           'SEGMENT_NS', 'SLOWER', 'SignalTiming', 'Windows', 'median_period_ns', 'missing_steering', 'signal_timing']

GRID_NS = 50_000_000
HALF_WINDOW_NS = 300_000_000
SEGMENT_NS = 100_000_000              # the five segments of the steadiness test
MAX_GAP_NS = 250_000_000              # angle and pressures: up to 2.5 of the slower period
DESIGN_ANGLE_PERIOD_NS = 100_000_000      # the rates the constants above are made for: the angle at 10 Hz,
DESIGN_PRESSURE_PERIOD_NS = 50_000_000    # the pressures at 20 Hz
SLOWER = 1.2                              # an input this much slower has its windows scaled (Windows)


def median_period_ns(series: Series | None) -> int | None:
    """An input's own period [ns]: the median interval between its samples (times in any order;
    samples at one time count once); :class:`Windows` takes it on a ladder of quarter octaves
    (:func:`_rung`). None with fewer than three distinct times."""
    if series is None or len(series) < 3:
        return None
    d = np.diff(np.unique(series.t_ns))
    return int(np.median(d)) if d.size >= 2 else None


@dataclass(frozen=True)
class SignalTiming:
    """How an input came: its period (the median interval), the jitter about it (the 95th
    percentile of the intervals' distance from it, lost frames aside) [ns], the frames lost
    (an interval of k periods has k - 1 missing) and its gaps: the intervals over
    ``gap_ns`` (start, end [ns]). Period and jitter None with fewer than three samples."""

    period_ns: int | None
    jitter_ns: int | None
    frames_lost: int
    gaps: tuple[tuple[int, int], ...]


def signal_timing(t_ns: NDArray[np.int64], gap_ns: int) -> SignalTiming:
    """:class:`SignalTiming` of sample times ``t_ns`` (any order) with gaps over ``gap_ns``."""
    t = np.unique(np.asarray(t_ns, np.int64))
    d = np.diff(t)
    if d.size < 2:
        return SignalTiming(None, None, 0, ())
    period = int(np.median(d))
    whole = np.rint(d / period) if period > 0 else np.ones_like(d, dtype=float)
    regular = whole <= 1
    jitter = int(np.percentile(np.abs(d[regular] - period), 95)) if regular.any() else None
    lost = int(np.maximum(whole - 1, 0).sum())
    at = np.flatnonzero(d > gap_ns)
    return SignalTiming(period, jitter, lost, tuple((int(t[i]), int(t[i + 1])) for i in at))


def _rung(period: int | None, design: int) -> int | None:
    """``period`` [ns] raised to the next rung of the ladder ``design`` x 2^((k + 1/2) / 4) (at
    most a fifth more): the windows of a log and of a part of it (the node's window) are the
    same though their medians differ by a jitter, and the rungs fall between the common rates
    (a gateway's 0.5, 1, 2, 5 Hz: 4 log2 of their ratios to the design periods are whole or
    .3, never near a half). At or below ``SLOWER`` times the design: the period as it is."""
    if period is None or period <= SLOWER * design:
        return period
    k = math.ceil(4.0 * math.log2(period / design) - 0.5)
    return int(round(design * 2.0 ** ((k + 0.5) / 4.0)))


def _scaled(period: int | None, design: int, const: int, periods: float) -> int:
    """``const`` at the design period (and up to ``SLOWER`` times it), else at least
    ``periods`` of the input's own ``period``."""
    if period is None or period <= SLOWER * design:
        return const
    return max(const, int(round(periods * period)))


@dataclass(frozen=True)
class Windows:
    """What the observations are judged over, from the inputs' own periods (see the module):
    the angle's and the pressures' periods [ns] (the slowest pressure's, each on its ladder of
    quarter octaves), the interpolation
    brackets, the slopes' half window and the steadiness segments [ns], the grid points either
    side a steady one needs steady too, and the rows' spacing in grid points."""

    angle_period_ns: int | None
    pressure_period_ns: int | None
    angle_gap_ns: int = MAX_GAP_NS
    pressure_gap_ns: int = MAX_GAP_NS
    half_window_ns: int = HALF_WINDOW_NS
    segment_ns: int = SEGMENT_NS
    erode: int = 1
    row_step: int = 1

    @classmethod
    def of(cls, signals: Mapping[str, Series]) -> Windows:
        """The windows for ``signals``' own periods."""
        periods = [p for p in (median_period_ns(signals.get(n)) for n in PRESSURE_INPUTS) if p is not None]
        return cls.of_periods(median_period_ns(signals.get('rudder_angle')), max(periods) if periods else None)

    @classmethod
    def of_periods(cls, pa: int | None, pp: int | None) -> Windows:
        """The windows for the angle's period ``pa`` and the slowest pressure's ``pp`` [ns]
        (None: not known, as at the design rate), each taken on its ladder (:func:`_rung`)."""
        pa, pp = _rung(pa, DESIGN_ANGLE_PERIOD_NS), _rung(pp, DESIGN_PRESSURE_PERIOD_NS)
        slow_p = pp is not None and pp > SLOWER * DESIGN_PRESSURE_PERIOD_NS
        return cls(pa, pp,
                   angle_gap_ns=_scaled(pa, DESIGN_ANGLE_PERIOD_NS, MAX_GAP_NS, 2.5),
                   pressure_gap_ns=_scaled(pp, DESIGN_PRESSURE_PERIOD_NS, MAX_GAP_NS, 2.5),
                   half_window_ns=_scaled(pa, DESIGN_ANGLE_PERIOD_NS, HALF_WINDOW_NS, 3.0),
                   segment_ns=_scaled(pa, DESIGN_ANGLE_PERIOD_NS, SEGMENT_NS, 1.0),
                   erode=max(1, math.ceil(pp / GRID_NS)) if slow_p and pp is not None else 1,
                   row_step=max(1, round(pp / GRID_NS)) if slow_p and pp is not None else 1)

    @property
    def step_ns(self) -> int:
        """The rows' spacing [ns]."""
        return self.row_step * GRID_NS

    @property
    def shared_ns(self) -> int:
        """The longest of the inputs' periods where one comes slower than the design's, the
        grid's at the design rates [ns]: rows closer than this may be interpolated from the same
        sample of it, so their errors from that sample (its noise, its timing) correlate."""
        if self.design:
            return GRID_NS
        return max(self.step_ns, self.angle_period_ns or 0, self.pressure_period_ns or 0)

    @property
    def reach_ns(self) -> int:
        """How far from a row the samples its judgement reads reach [ns]: the slopes' half
        window or the steadiness segments, an interpolation bracket beyond, and the erosion."""
        return (max(self.half_window_ns, 5 * self.segment_ns // 2) + max(self.angle_gap_ns, self.pressure_gap_ns)
                + self.erode * GRID_NS)

    @property
    def lag_span_ns(self) -> tuple[int, int]:
        """How much later the angle's stamps may read than the pressures' (lo, hi) [ns]: (0, 0)
        at the design rates (a direct tap stamps each frame as it comes). Through a gateway
        a value is stamped when the gateway sends it: one that holds the last value and sends
        it on its own timer sends it up to one period of the sensor old, or of its own timer
        where that is faster; one that forwards every n-th frame as it comes, about fresh.
        Neither can be told from the stamps, so the angle may lag the pressures by up to its
        period and lead them by up to theirs, each at most the design period (the sensor's)."""
        if self.design:
            return 0, 0
        pa = min(self.angle_period_ns or DESIGN_ANGLE_PERIOD_NS, DESIGN_ANGLE_PERIOD_NS)
        pp = min(self.pressure_period_ns or DESIGN_PRESSURE_PERIOD_NS, DESIGN_PRESSURE_PERIOD_NS)
        return -pp, pa

    @property
    def design(self) -> bool:
        """Both at the rates the constants are made for: nothing scaled."""
        return self == Windows(self.angle_period_ns, self.pressure_period_ns)




def missing_steering(samples: Mapping[str, int], pressures: bool = True) -> str | None:
    """Why data holding ``samples`` per input cannot tell anything of the gear, in the words
    every command refuses with (None: they can): no rudder angle (no motion, no response, no
    hard-over: nothing to judge), or, where the clearances are asked for (``pressures``), no
    cylinder pressure at all. A bus with the rudder and no pressures still shows the steering
    performance: ``inspect``, ``replay`` and ``report`` take it."""
    if samples.get('rudder_angle', 0) < 2:
        return 'no rudder angle in the data (input rudder_angle): nothing to estimate from'
    if pressures and not any(samples.get(n, 0) for n in PRESSURE_INPUTS):
        return 'no cylinder pressure in the data (inputs ' + ', '.join(PRESSURE_INPUTS) + ')'
    return None
