"""What a log holds: frames, samples per signal with their range, rate and gaps, rejects per
reason, its time span and clock steps (``steer-monitor inspect``).

A gap is a silence more than 1 s longer than the signal's expected period (so a 20 Hz
pressure silent for over 1.05 s, a 0.5 Hz temperature silent for over 3 s). Values are given
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
from steer_monitor.logfiles.decodelog import clock_steps_json, decode_logs
from steer_monitor.utc import time_json

__all__ = ['DISPLAY', 'GAP_NS', 'inspect_log', 'range_text']

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
        d = np.diff(t)
        gap_idx = np.nonzero(d > GAP_NS + 1e9 / spec.rate_hz)[0]
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
            'gaps_over_1s': len(gap_idx),  # beyond the expected period
            'gaps': [{**time_json('start', int(t[i])), **time_json('end', int(t[i + 1])),
                      'length_s': round(float(d[i] / 1e9), 3)}
                     for i in gap_idx[:MAX_GAPS_LISTED]],
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
        'notes': list(logs.notes),
    }


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


