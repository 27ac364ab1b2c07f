"""``steer-monitor inspect LOG``: what a log holds (:mod:`steer_monitor.ashore.inspection`
computes it): frames, samples per signal, rejects per reason, time span and gaps per signal."""

from __future__ import annotations

import argparse
import datetime
import sys
from pathlib import Path
from typing import Any, TextIO

from steer_monitor.ashore.inspection import inspect_log, range_text
from steer_monitor.cli.options import add_config_option, add_force_option, add_json_option
from steer_monitor.cli.output import (
    add_date_option,
    any_text,
    check_json_target,
    check_logs,
    date_notes,
    emit_json,
    json_to_stdout,
    report_read_errors,
    table,
    text_stream,
)

__all__ = ['register', 'run']


def run(path: str | Path, config: str | Path | None = None, json_out: str | Path | None = None,
        out: TextIO | None = None, err: TextIO | None = None, date: datetime.date | None = None) -> int:
    """Print what ``path`` holds; 1 (with one line on ``err``) when it broke off or had
    corrupt parts, whose readable frames are counted, or held no frame at all."""
    out = out or sys.stdout
    err = err or sys.stderr
    out = text_stream([json_out], out, err)
    check_logs([path])
    check_json_target(json_out, [path, config])
    date_notes('inspect', [path], date, err)
    s = inspect_log(path, config, date)
    emit_json(s, json_out, out)
    if not json_to_stdout(json_out):
        out.write(f"{s['log']}: {s['frames']} frames, {s['span_s']:.1f} s"
                  + (f" ({s['start_utc']} .. {s['end_utc']})" if s['start_utc'] else '') + '\n')
        table(['signal', 'PGN', 'inst', 'addr', 'samples', 'rate Hz', 'expected', 'period s', 'jitter ms', 'lost',
               'gaps>1s', 'range'],
              [[name, v['pgn'], any_text(v['instance']), any_text(v['address']), v['samples'],
                '-' if v['rate_hz'] is None else f"{v['rate_hz']:.2f}", f"{v['expected_rate_hz']:g}",
                '-' if v['period_s'] is None else f"{v['period_s']:.3f}",
                '-' if v['jitter_s'] is None else f"{v['jitter_s'] * 1e3:.1f}", v['frames_lost'],
                v['gaps_over_1s'], range_text(name, v)] for name, v in s['signals'].items()], out)
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
    """What makes the log a bad input: what broke off or was corrupt, no frame at all (an
    empty file, or nothing in it read as a frame: the rejects say what it held instead), or no
    rudder angle (nothing of the gear to judge, in the words every command refuses with; the
    table still shows what the log holds)."""
    if s['read_error']:
        return [s['read_error']]
    if s['frames'] == 0:
        held = ', '.join(f'{n} {reason}' for reason, n in s['rejects'].items())
        return [f"no frame in {s['log']}" + (f' (rejected: {held})' if held else '')]
    from steer_monitor.estimate.sampling import missing_steering
    missing = missing_steering({name: v['samples'] for name, v in s['signals'].items()}, pressures=False)
    return [] if missing is None else [f"{s['log']}: {missing}"]


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser('inspect', help='what a CAN log holds',
                       description='Frames, samples per signal, rejects per reason, time span and '
                                   'gaps over 1 s of a CAN log (candump, ASC, BLF, MCAP, CANboat plain, YDWG raw).')
    p.add_argument('log', help='the log file')
    add_config_option(p, role='its DBC and signal map decode the log')
    add_date_option(p)
    add_json_option(p, 'what the log holds')
    add_force_option(p)
    p.set_defaults(handler=lambda a: run(a.log, a.config, a.json_out, date=a.date))
