"""``steer-monitor analyze LOG --config CFG --json OUT [--report OUT.html]``: estimate the
clearances from a log, find what the declared model lacks, and say how sure that is. What it
computes and its JSON: :mod:`steer_monitor.ashore.loganalysis`."""

from __future__ import annotations

import argparse
import datetime
import math
import sys
import time
from pathlib import Path
from typing import Any, TextIO

from steer_monitor.ashore.loganalysis import analyze_log
from steer_monitor.atomic import check_target
from steer_monitor.cli.options import LOG_FORMATS, add_config_option, add_force_option, add_json_option
from steer_monitor.cli.output import (
    add_date_option,
    check_json_target,
    check_logs,
    date_notes,
    emit_json,
    json_to_stdout,
    report_read_errors,
    text_stream,
)
from steer_monitor.errors import ParameterError
from steer_monitor.jsonvocab import estimate_text
from steer_monitor.utc import parse_utc

__all__ = ['register', 'run']


def run(path: str | Path, config: str | Path | None = None, json_out: str | Path | None = None,
        report: str | Path | None = None, out: TextIO | None = None, err: TextIO | None = None,
        date: datetime.date | None = None, until_ns: int | None = None, window_motion_h: float = 0.0) -> int:
    """Analyse ``path`` (the data before ``until_ns``, the last ``window_motion_h`` hours of
    steady motion of them: 0 for all); 0 when it was read whole, 1 when it broke off or had
    corrupt parts (the outputs are still written, from what could be read; one line per
    problem on ``err``)."""
    if not (math.isfinite(window_motion_h) and window_motion_h >= 0):
        raise ParameterError(f'--window-motion-h must be a number of hours >= 0 (0: all the motion), '
                             f'not {window_motion_h:g}')
    out = out or sys.stdout
    err = err or sys.stderr
    out = text_stream([json_out, report], out, err)
    check_logs([path])
    check_json_target(json_out, [path, config])     # before minutes of work, not after
    if report is not None:
        check_target(report, [path, config])
    t0 = time.perf_counter()
    date_notes('analyze', [path], date, err)
    a, result = analyze_log(path, config, progress=sys.stderr.isatty(), date=date, until_ns=until_ns,
                            window_motion_s=window_motion_h * 3600.0)
    result['analysis_s'] = round(time.perf_counter() - t0, 2)
    for note in result['data']['notes']:
        err.write(f'steer-monitor analyze: note: {path}: {note}\n')
    emit_json(result, json_out, out)
    if report is not None:
        from steer_monitor.ashore.report.analysispage import write_analysis_report
        write_analysis_report(a, result, report)
    if not json_to_stdout(json_out):
        _summary(result, out)
    return report_read_errors('analyze', result['data']['read_errors'], err)


def _fmt(d: dict[str, Any], unit: str) -> str:
    # a bound from below only is said as one: the profile's best point on its plateau is no
    # estimate, and printed first it read as one (2Z 0.3 mm for a true 0.7 mm)
    edge = d.get('at_range_edge')
    return estimate_text(d, unit) + (f' (at the {edge} end of its physical range)' if edge else '')


def _verdict(name: str, d: dict[str, Any]) -> str:
    """One clearance's line: the estimate, its share of the limit, the level and why."""
    lo, hi = d['ci95']
    ref = d['value'] if d['value'] is not None else lo
    # a lower bound below the limit is no share of it ("13 % of the limit" read as reassurance)
    share = (f", {ref / d['limit_mm']:.0%} of the {d['limit_mm']:g} mm limit"
             if ref is not None and (hi is not None or ref > d['limit_mm']) else '')
    note = f": {d['note']}" if d.get('note') else ''
    return f"{name:<7} {_fmt(d, 'mm')}{share}  {d['level']}{note}\n"


def _summary(r: dict[str, Any], out: TextIO) -> None:
    out.write(_verdict('2Z', r['clearance_2z_mm']))
    out.write(_verdict('Z_gb', r['clearance_zgb_mm']))
    out.write(f"K_gl max {_fmt(r['k_gl_max'], '')}\n")
    out.write(f"F_s {_fmt(r['seal_friction_n'], 'N')};  mu_b {_fmt(r['mu_bushing'], '')};  "
              f"mu_g {_fmt(r['mu_guide'], '')}\n")
    out.write(r['rams']['verdict'] + '\n')
    out.write(f"model check: {r['verdict']}: {r['message']}\n")


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        'analyze',
        help='estimate the clearances from a log and test the residual',
        description='Fit the declared model to a CAN log (any log inspect reads: ' + LOG_FORMATS + '), profile '
        'the clearances with 95 % intervals, test the residual against the '
        'library of candidate effects and refit with the one the data support.',
    )
    p.add_argument('log', help='the log file')
    add_config_option(p)
    add_json_option(p, 'the analysis')
    p.add_argument('--report', metavar='OUT.html', help='write a self-contained HTML report')
    p.add_argument('--until', type=_utc_arg, metavar='UTC',
                   help='analyse only the data before this time (ISO 8601, e.g. 2026-11-26T14:03:00Z): '
                        'what the node had then')
    p.add_argument('--window-motion-h', type=float, default=0.0, metavar='H',
                   help='analyse only the last H hours of steady rudder motion, as the node does '
                        '(its estimator.window_motion_h; default 0: all of it)')
    add_date_option(p)
    add_force_option(p)
    p.set_defaults(handler=lambda a: run(a.log, a.config, a.json_out, a.report, date=a.date, until_ns=a.until,
                                         window_motion_h=a.window_motion_h))


def _utc_arg(text: str) -> int:
    try:
        return parse_utc(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None
