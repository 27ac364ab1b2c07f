"""``steer-monitor replay LOG... --out OUT.mcap [--config CFG]``: the live pipeline run
offline over logs, as fast as the machine allows, writing the topics the node publishes.

Deterministic: the same logs give the same file byte for byte, and the values the node
published live for the same frames (see :mod:`steer_monitor.ashore.replay`).
"""

from __future__ import annotations

import argparse
import datetime
import math
import sys
import time
from pathlib import Path
from typing import TextIO

from steer_monitor.cli.options import LOG_FORMATS, add_config_option, add_force_option, add_json_option
from steer_monitor.cli.output import (
    add_date_option,
    check_json_target,
    date_notes,
    emit_json,
    json_to_stdout,
    report_read_errors,
    text_stream,
)
from steer_monitor.logfiles.same import distinct_logs

__all__ = ['register', 'run']


def run(logs: list[str], out_path: str | Path, config: str | Path | None = None, frames: bool = True,
        json_out: str | Path | None = None, out: TextIO | None = None, err: TextIO | None = None,
        date: datetime.date | None = None, progress: bool = False) -> int:
    """Replay ``logs`` into ``out_path``; 1 (one line per log on ``err``) when a log broke
    off or had corrupt parts, whose readable frames were replayed. A progress bar (data
    time, percentage, ETA) on a terminal, or anywhere with ``progress``."""
    from steer_monitor.ashore.replay import replay, summary_json
    from steer_monitor.cli.progress import DataTimeProgress, log_spans

    out = out or sys.stdout
    err = err or sys.stderr
    out = text_stream([out_path, json_out], out, err)
    kept, same = distinct_logs(logs)
    for note in same:
        err.write(f'steer-monitor replay: note: {note}\n')
    logs = [str(p) for p in kept]
    check_json_target(json_out, [*logs, config, out_path])
    date_notes('replay', logs, date, err)
    t0 = time.perf_counter()
    show = progress or sys.stderr.isatty()
    with DataTimeProgress(log_spans(logs, date) if show else None, 'replay', sys.stderr, force=progress) as bar:
        summary = replay(logs, out_path, config, frames=frames, progress=bar, date=date)
    result = summary_json(summary)
    for note in summary.notes:
        err.write(f'steer-monitor replay: note: {note}\n')
    elapsed = time.perf_counter() - t0
    result['elapsed_s'] = round(elapsed, 2)
    result['frames_per_s'] = round(summary.frames / elapsed) if elapsed > 0 else None
    emit_json(result, json_out, out)
    if not json_to_stdout(json_out):
        out.write(f"replayed {summary.frames} frames ({result['span_s']:.0f} s of data) from "
                  f"{len(summary.logs)} log(s) in {elapsed:.1f} s: {summary.states} states, "
                  f"{summary.diagnostics} diagnostics -> {summary.output}\n")
        if summary.finding is not None:
            from steer_monitor.monitor.analyst import describe
            out.write(f"the node's last analysis: {describe(summary.finding)}; {summary.analyses} analyses over "
                      f"{summary.motion_s:.0f} s of motion\n")
        elif not math.isfinite(summary.first_motion_s):
            out.write('no analysis ran: the analyses were not asked for\n')
        else:
            out.write(f"no analysis ran: {summary.motion_s:.0f} s of steady rudder motion seen, "
                      f"{summary.first_motion_s:.0f} s needed for the first (estimator.first_motion_s)\n"
                      if summary.analyses == 0 else
                      f"{summary.analyses} analyses ran and none gave a finding: {summary.why}\n")
        status = result['clearances_status']
        if status is not None:
            out.write(f"the node's clearances status at the end: {status['level']} {status['message']}\n")
        if summary.rejects:
            out.write('rejected: ' + ', '.join(f'{k} {v}' for k, v in summary.rejects.items()) + '\n')
    return report_read_errors('replay', summary.errors, err)


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        'replay',
        help='run the live pipeline offline over logs into an MCAP',
        description='Replay CAN logs (any log inspect reads: ' + LOG_FORMATS + ') through the monitor\'s live '
        'pipeline (decode, model, analyses, diagnostics) as fast as the '
        'machine allows, writing the topics the node publishes. Deterministic.',
    )
    p.add_argument('logs', nargs='+', metavar='LOG', help='log files (taken in order of their first frame)')
    p.add_argument('--out', required=True, metavar='OUT.mcap', help='the MCAP to write')
    add_config_option(p, default='the parameters a recording was made with, else the packaged R-18')
    p.add_argument('--no-frames', dest='frames', action='store_false',
                   help='do not copy the raw frames into the output')
    add_json_option(p, 'the summary')
    p.add_argument('--progress', action='store_true',
                   help='show the progress bar on stderr even when it is not a terminal')
    add_date_option(p)
    add_force_option(p)
    p.set_defaults(handler=lambda a: run(a.logs, a.out, a.config, a.frames, a.json_out, date=a.date,
                                         progress=a.progress))
