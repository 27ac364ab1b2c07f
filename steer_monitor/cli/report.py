"""``steer-monitor report LOG_OR_MCAP... --out DIR``: a page engineers read (``DIR/index.html``,
self-contained, with its PNG plots beside it) from a CAN log, a node recording or a replay.

The review runs on the batch path over the whole log (:mod:`steer_monitor.ashore.reviewlogs`): the
plots and the clearances over time. The clearances the page and ``--json`` give, with their
levels, are the model check's (:mod:`steer_monitor.ashore.loganalysis`: ``analyze`` of the last
``--analysis-hours`` of data, default 3, which is ``steer-monitor analyze`` of a shorter log).

``--json`` prints::

    page, frames, errors, notes, estimates (windows reviewed), hard_overs_s
    clearance_2z_mm, clearance_zgb_mm   {"value", "ci95": [lo, hi], "bounded",
                                         "level": "OK" | "WARN" | "OVER LIMIT" | "NOT ASSESSED"}
    k_gl_max                            {"value", "ci95", "bounded"} or null
    model_check                         {"verdict", "effects", "message"} or null
    model_check_note                    why there is none, or null
"""

from __future__ import annotations

import argparse
import datetime
import math
import sys
import time
from pathlib import Path
from typing import Any, TextIO

from steer_monitor.ashore.loganalysis import ANALYSIS_HOURS
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
from steer_monitor.logfiles.same import distinct_logs

__all__ = ['register', 'run']


def run(logs: list[str], out_dir: str | Path, config: str | Path | None = None, analysis_hours: float = ANALYSIS_HOURS,
        json_out: str | Path | None = None, out: TextIO | None = None, err: TextIO | None = None,
        date: datetime.date | None = None) -> int:
    """Review ``logs`` into ``out_dir``; 1 (one line per log on ``err``) when a log broke off
    or had corrupt parts (the page is made from what could be read and says so). A report that
    fails leaves no output directory it made."""
    from steer_monitor.atomic import output_dir
    from steer_monitor.errors import ParameterError
    from steer_monitor.params import load_config

    out = out or sys.stdout
    err = err or sys.stderr
    if not (math.isfinite(analysis_hours) and analysis_hours >= 0):
        msg = f'--analysis-hours must be a finite number >= 0, got {analysis_hours}'
        raise ParameterError(msg)
    paths = [Path(p) for p in logs]
    out = text_stream([json_out], out, err)
    check_logs(paths)
    paths, same = distinct_logs(paths)
    for note in same:
        err.write(f'steer-monitor report: note: {note}\n')
    from steer_monitor.ashore.report.reviewpage import NOT_READABLE_NOTE, PUBLISHED_READABLE
    if any(p.suffix.lower() == '.mcap' for p in paths) and not PUBLISHED_READABLE:
        err.write(f'steer-monitor report: note: {NOT_READABLE_NOTE}\n')
    check_json_target(json_out, [*paths, config])
    config_path, params = load_config(config)
    # made before the review (a directory that cannot be made fails now, not after minutes of
    # work), and removed again when the report fails before writing into it
    with output_dir(out_dir):
        return _run(paths, out_dir, config_path, params, analysis_hours, json_out, out, err, date)


def _run(paths: list[Path], out_dir: str | Path, config_path: str | Path, params: dict[str, Any],
         analysis_hours: float, json_out: str | Path | None, out: TextIO, err: TextIO,
         date: datetime.date | None) -> int:
    from tqdm import tqdm

    from steer_monitor.ashore.loganalysis import headline_json, headline_text, headlines, model_check
    from steer_monitor.ashore.report.reviewpage import report_input, write_review_report
    from steer_monitor.ashore.reviewlogs import refit_windows, review_logs
    from steer_monitor.ashore.windowmodel import window_model
    from steer_monitor.estimate.ramscheck import rams_verdict, uneven_json
    from steer_monitor.estimate.sampling import missing_steering
    from steer_monitor.logfiles.logs import LogError

    date_notes('report', paths, date, err)
    t0 = time.perf_counter()
    with tqdm(unit='frame', unit_scale=True, disable=not sys.stderr.isatty(), file=sys.stderr, desc='review') as bar:
        batch = review_logs(paths, config_path, progress=bar.update, date=date)
    if batch.frames == 0:           # nothing to show: no page rather than an empty one
        msg = batch.errors[0] if batch.errors else 'no frame in ' + ', '.join(str(p) for p in paths)
        raise LogError(msg)
    missing = missing_steering(batch.samples, pressures=False)
    if missing is not None:         # a page of a bus without the gear would say nothing of it
        raise LogError(f"{', '.join(str(p) for p in paths)}: {missing}")
    r = batch.review
    analysis, note = None, 'no data'
    if len(r.t_ns) and analysis_hours > 0:
        analysis, note = model_check(paths, params, config_path, int(r.t_ns[-1]), analysis_hours, date)
    elif analysis_hours == 0:
        note = 'model check not asked for (--analysis-hours 0)'
    model, nuisance = window_model(analysis) if analysis is not None else ((), None)
    if model or nuisance is not None:     # the windows under the model the page's clearances rest on
        with tqdm(unit='frame', unit_scale=True, disable=not sys.stderr.isatty(), file=sys.stderr,
                  desc='windows refitted') as bar:
            batch = refit_windows(batch, model, config_path, nuisance=nuisance, progress=bar.update, date=date)
        r = batch.review
    inp = report_input(paths, batch, params, config_path, analysis, note)
    page = write_review_report(inp, out_dir)
    elapsed = time.perf_counter() - t0
    if json_out is not None:
        h2z, hzgb = headlines(analysis, inp.limit_2z, inp.limit_zgb, inp.warn_share)
        emit_json({'page': str(page), 'frames': batch.frames, 'errors': batch.errors, 'notes': r.notes,
                   'estimates': len(r.estimates), 'hard_overs_s': [round(h.seconds, 2) for h in r.hard_overs],
                   'clearance_2z_mm': headline_json(h2z), 'clearance_zgb_mm': headline_json(hzgb),
                   'k_gl_max': None if analysis is None else analysis.final.k_gl_max.scaled(1.0, 3),
                   'model_check': None if analysis is None else {
                       'verdict': analysis.verdict, 'effects': [s.name for s in analysis.steps],
                       'message': analysis.message},
                   'model_check_note': note or None,
                   'rams': {'uneven': [uneven_json(sp) for sp in r.uneven], 'assessed': r.rams_assessed,
                            'verdict': rams_verdict(r.uneven, r.rams_assessed)},
                   'elapsed_s': round(elapsed, 2)}, json_out, out)
    if not json_to_stdout(json_out):
        out.write(f'report of {batch.frames} frames written to {page} ({elapsed:.1f} s)\n')
        for h in headlines(analysis, inp.limit_2z, inp.limit_zgb, inp.warn_share):
            out.write(headline_text(h) + '\n')
        out.write(rams_verdict(r.uneven, r.rams_assessed) + '\n')
        out.write(f"model check: {analysis.verdict}: {analysis.message}\n" if analysis is not None
                  else f'model check: none ({note})\n')
    return report_read_errors('report', batch.errors, err)


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        'report',
        help='an HTML page with plots from a log, a recording or a replay',
        description='Review logs (any log inspect reads: ' + LOG_FORMATS + '; including node recordings and '
        'replays) on the batch path and write DIR/index.html with PNG plots: '
        'angle and pressures, load sharing against angle, clearance estimates '
        'over time, the model residual, hard-over times against SOLAS.',
    )
    p.add_argument('logs', nargs='+', metavar='LOG_OR_MCAP', help='log files (taken in order of their first frame)')
    p.add_argument('--out', required=True, metavar='DIR', help='directory for index.html and the PNGs')
    add_config_option(p)
    p.add_argument('--analysis-hours', type=float, default=3.0,
                   help='hours of data at the end for the model check (0: none; default 3)')
    add_json_option(p, 'a summary')
    add_date_option(p)
    add_force_option(p)
    p.set_defaults(handler=lambda a: run(a.logs, a.out, a.config, a.analysis_hours, a.json_out, date=a.date))
