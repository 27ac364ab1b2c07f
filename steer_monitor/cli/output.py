"""Small helpers for CLI output: JSON for scripts, aligned tables for people."""

from __future__ import annotations

import argparse
import datetime
import io
import json
import math
import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any, TextIO

from steer_monitor.texttable import table

__all__ = ['JSON_DIGITS', 'add_date_option', 'any_text', 'check_json_target', 'check_logs', 'date_notes', 'dump_json',
           'emit_json', 'json_to_stdout', 'report_read_errors', 'table', 'text_stream']


def any_text(v: object) -> object:
    """A source address or instance for a table: ``any`` where the parameters and JSON hold -1
    (any address, any instance), else as it is."""
    return 'any' if v == -1 else v


#: significant digits a float keeps in JSON: a computation's last bits are no data (0.115, not
#: 0.11499999999999999); quantities are rounded further where they are made (docs/json.md)
JSON_DIGITS = 9


def _clean(obj: Any) -> Any:
    """Make numpy scalars and non-finite floats JSON-safe (NaN/inf become null), floats kept
    to :data:`JSON_DIGITS` significant digits."""
    if isinstance(obj, dict):
        return {str(k): _clean(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_clean(v) for v in obj]
    if hasattr(obj, 'item') and callable(obj.item):
        obj = obj.item()
    if isinstance(obj, float):
        return float(f'{obj:.{JSON_DIGITS}g}') if math.isfinite(obj) else None
    return obj


def dump_json(obj: Any, out: TextIO) -> None:
    """Write ``obj`` as indented JSON with a trailing newline."""
    json.dump(_clean(obj), out, indent=2, allow_nan=False)
    out.write('\n')


def json_to_stdout(target: str | Path | None) -> bool:
    """Whether ``--json`` asked for stdout (``-``): then the command prints JSON only."""
    return target is not None and str(target) == '-'


def check_json_target(target: str | Path | None, inputs: Sequence[str | Path | None] = ()) -> None:
    """Refuse, before any work, a ``--json`` file that cannot be written or would replace an
    input (:func:`steer_monitor.atomic.check_target`); nothing for stdout or no ``--json``."""
    if target is not None and not json_to_stdout(target):
        from steer_monitor.atomic import check_target
        check_target(target, inputs)


def emit_json(obj: Any, target: str | Path | None, out: TextIO) -> None:
    """The JSON answer to ``--json``'s ``target``: ``-`` is ``out``; a file is written through a
    temporary name and renamed (nothing for None)."""
    if target is None:
        return
    if json_to_stdout(target):
        dump_json(obj, out)
        return
    from steer_monitor.atomic import atomic_write
    with atomic_write(target, 'w', encoding='utf-8') as fh:
        dump_json(obj, fh)


def text_stream(targets: Sequence[str | Path | None], out: TextIO, err: TextIO) -> TextIO:
    """Where a command's words for people go: ``out``, unless one of its output files is
    ``out`` itself (``--out /dev/stdout`` into a pipe), whose bytes they would corrupt:
    then ``err``. ``-`` (``--json -``: the JSON on ``out`` instead of the words) is no file."""
    try:
        here = os.fstat(out.fileno())
    except (OSError, ValueError, AttributeError, io.UnsupportedOperation):
        return out
    for target in targets:
        if target is None or json_to_stdout(target):
            continue
        try:
            there = os.stat(target)
        except (OSError, ValueError):
            continue
        if (there.st_dev, there.st_ino) == (here.st_dev, here.st_ino):
            return err
    return out


def check_logs(paths: Sequence[str | Path]) -> None:
    """:class:`~steer_monitor.errors.ParameterError` naming the first log that is not a file
    (missing, a directory), before any work is done."""
    from steer_monitor.atomic import note_input
    from steer_monitor.errors import ParameterError
    from steer_monitor.logfiles.logs import log_path_problem
    for p in paths:
        note_input(p)
        problem = log_path_problem(Path(p))
        if problem is not None:
            raise ParameterError(problem)


def report_read_errors(command: str, errors: Sequence[str], err: TextIO) -> int:
    """One line on ``err`` per input that broke off or had corrupt parts (the command's
    output was made from what could be read); the exit status: 1 with any, else 0."""
    for e in errors:
        err.write(f'steer-monitor {command}: error: {e}\n')
    return 1 if errors else 0


def _date(text: str) -> datetime.date:
    try:
        return datetime.date.fromisoformat(text)
    except ValueError:
        msg = f'expected a date as YYYY-MM-DD, got {text!r}'
        raise argparse.ArgumentTypeError(msg) from None


def add_date_option(p: argparse.ArgumentParser) -> None:
    """``--date``: the date of a YDWG raw log's first line (it writes the time of day only)."""
    p.add_argument('--date', type=_date, metavar='YYYY-MM-DD',
                   help="date (UTC) of the first line of YDWG raw logs, which hold the time of day only "
                        "(default: a date in the file name, else the file's modification date)")


def date_notes(command: str, paths: Sequence[str | Path], date: datetime.date | None, err: TextIO) -> None:
    """Say, on ``err``, which date each YDWG raw log is read with and where it came from."""
    from steer_monitor.logfiles.gateway import ydwg_date
    from steer_monitor.logfiles.logs import LogError, log_format

    for path in paths:
        try:
            if log_format(path) != 'ydwg':
                continue
            day, source = ydwg_date(path, date)
        except (LogError, OSError):
            continue            # the reader reports it
        hint = '' if source == 'given' else '; give --date if that is wrong'
        err.write(f'steer-monitor {command}: note: {path}: YDWG raw log (time of day only) read as starting on '
                  f'{day.isoformat()} UTC, the date {"given" if source == "given" else "from " + source}{hint}\n')
