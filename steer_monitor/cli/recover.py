"""``steer-monitor recover FILE``: make an MCAP cut short by a crash readable again."""

from __future__ import annotations

import argparse
import dataclasses
import sys
from pathlib import Path
from typing import TextIO

from steer_monitor.cli.options import add_force_option, add_json_option
from steer_monitor.cli.output import check_json_target, emit_json, json_to_stdout, report_read_errors, text_stream
from steer_monitor.record.recover import recover
from steer_monitor.utc import time_json

__all__ = ['register', 'run']


def run(path: str | Path, output: str | Path | None = None, json_out: str | Path | None = None,
        out: TextIO | None = None, err: TextIO | None = None) -> int:
    """Recover ``path``. 0 when everything readable was copied (a file cut short is what this
    is for); 1 when corrupt chunks were dropped, with one line on ``err`` saying which."""
    out = out or sys.stdout
    err = err or sys.stderr
    out = text_stream([output, json_out], out, err)
    check_json_target(json_out, [path, output])
    r = recover(path, output)
    d = dataclasses.asdict(r)
    emit_json({**d, **time_json('first', r.first_ns), **time_json('last', r.last_ns)}, json_out, out)
    if not json_to_stdout(json_out):
        span = '' if r.first_ns is None or r.last_ns is None else f', {(r.last_ns - r.first_ns) / 1e9:.1f} s'
        if r.complete:
            state = 'the file was complete'
        elif r.stopped_at is not None:
            state = f'the file was cut short ({r.stopped_at})'
        else:
            state = 'the file ended normally'
        out.write(f'recovered {r.messages} messages on {r.channels} channels{span} from {r.source} '
                  f'into {r.output}; {state}\n')
    if r.dropped:
        return report_read_errors('recover', [f'{r.source}: {len(r.dropped)} corrupt chunk(s) dropped ('
                                              + r.dropped[0] + (', ...' if len(r.dropped) > 1 else '') + ')'], err)
    return 0


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser('recover', help='make an MCAP cut short by a crash readable again',
                       description='Copy every intact record of an unfinished MCAP into a new, finished file.')
    p.add_argument('file', help='the MCAP file')
    p.add_argument('--out', help='output file (default: <name>.recovered.mcap)')
    add_json_option(p, 'what was recovered')
    add_force_option(p)
    p.set_defaults(handler=lambda a: run(a.file, a.out, a.json_out))
