"""What a log holds: frames, samples per signal with their range, rate and gaps, rejects per
reason, its time span and clock steps (``steer-monitor inspect``).

Each signal's own timing is measured: its period (the median interval between its samples,
whatever the parameters say it comes at), the jitter about it, the frames lost (an interval
of k periods has k - 1 missing). A gap is a silence more than 1 s longer than its own period
(so a 20 Hz pressure silent for over 1.05 s, a pressure a gateway forwards at 0.5 Hz silent
for over 3 s), listed with its UTC times. Values are given
in the units engineers read, named in the keys (docs/json.md): the decoder's SI values are
converted here, at the edge.
"""

from __future__ import annotations

import datetime
import math
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from steer_monitor.can.busconfig import load_setup
from steer_monitor.can.devices import format_name
from steer_monitor.can.rejects import REASONS, RejectCounter
from steer_monitor.estimate.sampling import (
    DESIGN_ANGLE_PERIOD_NS,
    DESIGN_PRESSURE_PERIOD_NS,
    SLOWER,
    SignalTiming,
    Windows,
    median_period_ns,
    signal_timing,
)
from steer_monitor.logfiles.decodelog import clock_steps_json, decode_logs
from steer_monitor.model.inputs import PRESSURE_INPUTS, Series
from steer_monitor.utc import time_json

__all__ = ['DISPLAY', 'GAP_NS', 'inspect_log', 'range_text', 'rate_notes', 'timing_json']

KNOT = 1852.0 / 3600.0      # m/s

#: per input: (unit in the key names, conversion from SI, decimals kept)
DISPLAY: dict[str, tuple[str, Callable[[float], float], int]] = {
    'rudder_angle': ('deg', math.degrees, 3),
    'rudder_order': ('deg', math.degrees, 3),
    'pressure_r1_stbd': ('bar', lambda pa: pa / 1e5, 3),
    'pressure_r1_port': ('bar', lambda pa: pa / 1e5, 3),
    'pressure_r2_stbd': ('bar', lambda pa: pa / 1e5, 3),
    'pressure_r2_port': ('bar', lambda pa: pa / 1e5, 3),
    'ship_speed': ('kn', lambda ms: ms / KNOT, 2),
    'oil_temperature': ('c', lambda k: k - 273.15, 2),
}
UNIT_WORDS = {'deg': 'deg', 'bar': 'bar', 'kn': 'kn', 'c': 'degC'}


GAP_NS = 1_000_000_000
MAX_GAPS_LISTED = 50


def inspect_log(path: str | Path, config: str | Path | None = None, date: datetime.date | None = None
                ) -> dict[str, Any]:
    """What a log holds (streamed through the column readers: memory is one block of frames
    and the decoded samples). ``read_error``: what broke off or was corrupt, else None."""
    _, _, db, smap = load_setup(config)
    rejects = RejectCounter()
    logs = decode_logs([path], db, smap, rejects, date=date)
    series = logs.signals
    snap = rejects.snapshot()
    signals: dict[str, Any] = {}
    for spec in smap.specs:
        s = series[spec.name]
        t = np.sort(s.t_ns)
        timing = _timing(t, spec.rate_hz)
        signals[spec.name] = {
            'pgn': spec.pgn, 'instance': spec.instance, 'source': spec.source, 'address': spec.address,
            'device_name': format_name(spec.device_name) if spec.device_name is not None else None,
            'samples': len(s),
            **_range_json(spec.name, s.value),
            **time_json('first', int(t[0]) if t.size else None),
            **time_json('last', int(t[-1]) if t.size else None),
            'rate_hz': (round(float((t.size - 1) / ((t[-1] - t[0]) / 1e9)), 4) if t.size > 1 and t[-1] > t[0]
                        else None),
            'expected_rate_hz': spec.rate_hz,
            **_timing_words(timing),
            'gaps_over_1s': len(timing.gaps),  # beyond its own period
            'gaps': [{**time_json('start', a), **time_json('end', b), 'length_s': round((b - a) / 1e9, 3)}
                     for a, b in timing.gaps[:MAX_GAPS_LISTED]],
            'rejects': {reason: n for (reason, name), n in snap.by_signal.items() if name == spec.name},
        }
    first, last = logs.first_ns, logs.last_ns
    return {
        'log': str(path),
        'frames': logs.frames,
        **time_json('start', first),
        **time_json('end', last),
        'span_s': logs.span_s,
        'signals': signals,
        'rejects': dict(sorted(snap.counts.items())),
        'reject_reasons': {k: REASONS[k] for k in sorted(snap.counts)},
        'reject_examples': dict(sorted(snap.last.items())),
        'read_error': '; '.join(logs.errors) or None,
        'clock_steps': clock_steps_json(logs.clock_steps),
        'notes': [*logs.notes, *rate_notes(series)],
    }


def _timing(t_ns: NDArray[np.int64], rate_hz: float) -> SignalTiming:
    """A signal's timing, its gaps those more than :data:`GAP_NS` longer than its own period
    (the configured ``rate_hz``'s where it has too few samples for one)."""
    own = signal_timing(t_ns, 0)
    period = own.period_ns if own.period_ns is not None else 1e9 / rate_hz
    return signal_timing(t_ns, int(GAP_NS + period))


def _timing_words(timing: SignalTiming) -> dict[str, Any]:
    return {'period_s': None if timing.period_ns is None else round(timing.period_ns / 1e9, 4),
            'jitter_s': None if timing.jitter_ns is None else round(timing.jitter_ns / 1e9, 4),
            'frames_lost': timing.frames_lost}


def timing_json(series: Mapping[str, Series], rates_hz: Mapping[str, float]) -> dict[str, Any]:
    """Per input of ``rates_hz`` (its configured rate), how it came: its period, jitter and
    frames lost, and its gaps counted (docs/json.md)."""
    out = {}
    for name, rate in rates_hz.items():
        s = series.get(name)
        timing = _timing(np.sort(s.t_ns) if s is not None else np.zeros(0, np.int64), rate)
        out[name] = {'samples': 0 if s is None else len(s), **_timing_words(timing), 'expected_rate_hz': rate,
                     'gaps_over_1s': len(timing.gaps)}
    return out


def rate_notes(series: Mapping[str, Series]) -> list[str]:
    """Where the angle or the pressures come slower than a direct tap: what that limits in the
    analyses (:class:`~steer_monitor.estimate.observe.Windows`) and how to raise the rate."""
    win = Windows.of(series)
    if win.design:
        return []
    pressures = [p for p in (median_period_ns(series.get(n)) for n in PRESSURE_INPUTS) if p is not None]
    said = [f'the {what} every {p / 1e9:.2f} s ({1e9 / p:.2g} Hz)'
            for what, p, design in (('rudder angle', median_period_ns(series.get('rudder_angle')),
                                     DESIGN_ANGLE_PERIOD_NS),
                                    ('pressures', max(pressures) if pressures else None, DESIGN_PRESSURE_PERIOD_NS))
            if p is not None and p > SLOWER * design]
    return [f'rates: {" and ".join(said)}, slower than a direct tap (the angle at 10 Hz, the pressures at 20 Hz): '
            f'the analyses take one row per ram every {win.step_ns / 1e9:.2g} s and count motion only where the '
            f'rudder moved steadily for {2 * win.half_window_ns / 1e9:.2g} s, so they need more steering to assess '
            'the clearances; raise the rates on the gateway, or through NMEA 2000\'s group function (PGN 126208, '
            'a request to change a PGN\'s transmission interval) where the device supports it, and set the '
            'parameters\' rate_hz to what comes']


def _range_json(name: str, value: NDArray[np.float64]) -> dict[str, Any]:
    """A signal's least and greatest value in the unit engineers read (:data:`DISPLAY`),
    the unit in the key names (``min_deg``, ``max_bar``, ...)."""
    unit, convert, digits = DISPLAY[name]
    has = len(value) > 0
    return {f'min_{unit}': round(convert(float(value.min())), digits) if has else None,
            f'max_{unit}': round(convert(float(value.max())), digits) if has else None}


def range_text(name: str, v: Mapping[str, Any]) -> str:
    """A signal's range of :func:`inspect_log` as a person reads it, e.g. ``-30.0..+35.0 deg``."""
    unit = DISPLAY[name][0]
    lo, hi = v[f'min_{unit}'], v[f'max_{unit}']
    if lo is None or hi is None:
        return '-'
    return f'{lo:+.1f}..{hi:+.1f} {UNIT_WORDS[unit]}'


