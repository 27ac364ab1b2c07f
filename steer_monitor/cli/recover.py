"""``steer-monitor recover FILE``: make an MCAP cut short by a crash readable again."""

from __future__ import annotations

import argparse
import dataclasses
import sys
from pathlib import Path
from typing import TextIO

from steer_monitor.cli.output import dump_json
from steer_monitor.record.recover import recover

__all__ = ['register', 'run']


def run(path: str | Path, output: str | Path | None = None, as_json: bool = False,
        out: TextIO | None = None) -> int:
    out = out or sys.stdout
    r = recover(path, output)
    if as_json:
        dump_json(dataclasses.asdict(r), out)
        return 0
    span = '' if r.first_ns is None else f', {(r.last_ns - r.first_ns) / 1e9:.1f} s'
    state = 'the file was complete' if r.complete else f'the file was cut short ({r.stopped_at})'
    out.write(f'recovered {r.messages} messages on {r.channels} channels{span} from {r.source} '
              f'into {r.output}; {state}\n')
    return 0


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser('recover', help='make an MCAP cut short by a crash readable again',
                       description='Copy every intact record of an unfinished MCAP into a new, finished file.')
    p.add_argument('file', help='the MCAP file')
    p.add_argument('--out', help='output file (default: <name>.recovered.mcap)')
    p.add_argument('--json', action='store_true', help='print JSON')
    p.set_defaults(handler=lambda a: run(a.file, a.out, a.json))
