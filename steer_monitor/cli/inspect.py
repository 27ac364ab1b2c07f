"""``steer-monitor inspect LOG``: what a log holds: frames, samples per signal, rejects per
reason, time span and gaps per signal.

A gap is a silence more than 1 s longer than the signal's expected period (so a 20 Hz
pressure silent for over 1.05 s, a 0.5 Hz temperature silent for over 3 s).
"""

from __future__ import annotations

import argparse
import datetime
import math
import sys
from datetime import datetime as _datetime
from pathlib import Path
from typing import Any, TextIO

import numpy as np

from steer_monitor.can.busconfig import load_setup
from steer_monitor.can.devices import format_name
from steer_monitor.can.rejects import REASONS, RejectCounter
from steer_monitor.cli.options import add_config_option
from steer_monitor.cli.output import add_date_option, check_logs, date_notes, dump_json, report_read_errors, table
from steer_monitor.logfiles.decodelog import clock_steps_json, decode_logs

__all__ = ['inspect_log', 'register', 'run']

GAP_NS = 1_000_000_000
MAX_GAPS_LISTED = 50


def _iso(t_ns: int) -> str:
    try:
        return _datetime.fromtimestamp(t_ns / 1e9, tz=datetime.UTC).isoformat(timespec='milliseconds')
    except (ValueError, OverflowError, OSError):   # beyond what datetime holds (year 9999)
        return f'{t_ns} ns since 1970'


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
            'min': float(s.value.min()) if len(s) else None,     # SI: rad, Pa, m/s, K
            'max': float(s.value.max()) if len(s) else None,
            'first_ns': int(t[0]) if t.size else None,
            'last_ns': int(t[-1]) if t.size else None,
            'rate_hz': (float((t.size - 1) / ((t[-1] - t[0]) / 1e9)) if t.size > 1 and t[-1] > t[0] else None),
            'expected_rate_hz': spec.rate_hz,
            'gaps_over_1s': len(gap_idx),  # beyond the expected period
            'gaps': [{'start_ns': int(t[i]), 'end_ns': int(t[i + 1]), 'length_s': float(d[i] / 1e9)}
                     for i in gap_idx[:MAX_GAPS_LISTED]],
            'rejects': {reason: n for (reason, name), n in snap.by_signal.items() if name == spec.name},
        }
    first, last = logs.first_ns, logs.last_ns
    return {
        'log': str(path),
        'frames': logs.frames,
        'start_ns': first,
        'end_ns': last,
        'start': _iso(first) if first is not None else None,
        'end': _iso(last) if last is not None else None,
        'span_s': logs.span_s,
        'signals': signals,
        'rejects': dict(sorted(snap.counts.items())),
        'reject_reasons': {k: REASONS[k] for k in sorted(snap.counts)},
        'reject_examples': dict(sorted(snap.last.items())),
        'read_error': '; '.join(logs.errors) or None,
        'clock_steps': clock_steps_json(logs.clock_steps),
        'notes': list(logs.notes),
    }


def _range(name: str, lo: float | None, hi: float | None) -> str:
    """A signal's range in the units engineers read: degrees, bar, knots... at this edge only."""
    if lo is None or hi is None:
        return '-'
    if name.startswith('rudder'):
        return f'{math.degrees(lo):+.1f}..{math.degrees(hi):+.1f} deg'
    if name.startswith('pressure'):
        return f'{lo / 1e5:.1f}..{hi / 1e5:.1f} bar'
    if name == 'oil_temperature':
        return f'{lo - 273.15:.1f}..{hi - 273.15:.1f} degC'
    return f'{lo:.2f}..{hi:.2f} m/s'


def run(path: str | Path, config: str | Path | None = None, as_json: bool = False,
        out: TextIO | None = None, err: TextIO | None = None, date: datetime.date | None = None) -> int:
    """Print what ``path`` holds; 1 (with one line on ``err``) when it broke off or had
    corrupt parts, whose readable frames are counted, or held no frame at all."""
    out = out or sys.stdout
    err = err or sys.stderr
    check_logs([path])
    date_notes('inspect', [path], date, err)
    s = inspect_log(path, config, date)
    if as_json:
        dump_json(s, out)
    else:
        out.write(f"{s['log']}: {s['frames']} frames, {s['span_s']:.1f} s"
                  + (f" ({s['start']} .. {s['end']})" if s['start'] else '') + '\n')
        table(['signal', 'PGN', 'inst', 'addr', 'samples', 'rate Hz', 'expected', 'gaps>1s', 'range'],
              [[name, v['pgn'], v['instance'], v['address'], v['samples'],
                '-' if v['rate_hz'] is None else f"{v['rate_hz']:.2f}", f"{v['expected_rate_hz']:g}",
                v['gaps_over_1s'], _range(name, v['min'], v['max'])] for name, v in s['signals'].items()], out)
        if s['rejects']:
            out.write('\nrejects:\n')
            table(['reason', 'count', 'latest'], [[k, n, s['reject_examples'].get(k, '')]
                                                   for k, n in s['rejects'].items()], out)
        else:
            out.write('\nno rejects\n')
        for note in s['notes']:
            out.write(f'\n{note}\n')
    return report_read_errors('inspect', _problems(s), err)


def _problems(s: dict[str, Any]) -> list[str]:
    """What makes the log a bad input: what broke off or was corrupt, or no frame at all (an
    empty file, or nothing in it read as a frame: the rejects say what it held instead)."""
    if s['read_error']:
        return [s['read_error']]
    if s['frames'] == 0:
        held = ', '.join(f'{n} {reason}' for reason, n in s['rejects'].items())
        return [f"no frame in {s['log']}" + (f' (rejected: {held})' if held else '')]
    return []


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser('inspect', help='what a CAN log holds',
                       description='Frames, samples per signal, rejects per reason, time span and '
                                   'gaps over 1 s of a CAN log (candump, ASC, BLF, MCAP, CANboat plain, YDWG raw).')
    p.add_argument('log', help='the log file')
    add_config_option(p, role='its DBC and signal map decode the log')
    add_date_option(p)
    p.add_argument('--json', action='store_true', help='print JSON')
    p.set_defaults(handler=lambda a: run(a.log, a.config, a.json, date=a.date))
