"""``steer-monitor fleet VESSEL_DIR... --out DIR``: every vessel's logs estimated on Dask
distributed, results kept in ``DIR/results.parquet`` (a rerun analyses only new or changed
logs), ``DIR/fleet.json`` and ``DIR/index.html`` with each clearance's wear trend and the
date it reaches its limit."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import TextIO

from steer_monitor.atomic import output_dir, write_files
from steer_monitor.cli.options import add_config_option, add_force_option, add_json_option
from steer_monitor.cli.output import check_json_target, emit_json, json_to_stdout, report_read_errors, text_stream

__all__ = ['register', 'run']


def run(dirs: Sequence[str | Path], out_dir: str | Path, workers: int | None = None, scheduler: str | None = None,
        config: str | Path | None = None, json_out: str | Path | None = None, out: TextIO | None = None,
        err: TextIO | None = None, reports: bool = True) -> int:
    """Run the fleet; 1 (one line per log on ``err``) when some log failed for good, whose
    vessel's other logs are in the results. ``reports``: each log's report page too. No logs
    at all is an error (one line, no output directory made); files that are not logs by their
    name are named on ``err``."""
    from steer_monitor.ashore.fleet import LOG_SUFFIXES, find_vessels

    out = out or sys.stdout
    err = err or sys.stderr
    if workers is not None and workers < 1:
        from steer_monitor.errors import ParameterError
        raise ParameterError(f'--workers must be at least 1, got {workers}')
    out = text_stream([json_out], out, err)
    check_json_target(json_out, [*dirs, config])
    skipped = [str(p) for v in find_vessels(dirs, config) for p in v.skipped]
    if skipped:                 # one line, however many: a simulator's truth files sit beside each log
        shown = ', '.join(skipped[:3]) + (f' and {len(skipped) - 3} more' if len(skipped) > 3 else '')
        err.write(f'steer-monitor fleet: note: {len(skipped)} file(s) not logs by their name left out: {shown} '
                  f'(a log is named *{", *".join(LOG_SUFFIXES)}, each also compressed)\n')
    with output_dir(out_dir) as made:
        return _run(dirs, made, workers, scheduler, config, json_out, out, err, reports)


def _run(dirs: Sequence[str | Path], out_dir: Path, workers: int | None, scheduler: str | None,
         config: str | Path | None, json_out: str | Path | None, out: TextIO, err: TextIO, reports: bool) -> int:
    import json

    from tqdm import tqdm

    from steer_monitor.ashore.fleet import fleet_json, run_fleet
    from steer_monitor.ashore.fleetpage import fleet_page
    with tqdm(unit='log', disable=not sys.stderr.isatty(), file=sys.stderr, desc='fleet') as bar:
        def progress(done: int, total: int) -> None:
            bar.total = total
            bar.update(done - bar.n)
        fleet = run_fleet(dirs, out_dir, workers=workers, scheduler=scheduler, config=config, progress=progress,
                          reports=reports)
    data = fleet_json(fleet)
    page = out_dir / 'index.html'
    # the two together or neither (a full disk does not leave a new fleet.json beside an old page)
    write_files({page: fleet_page(fleet).encode('utf-8'),
                 out_dir / 'fleet.json': (json.dumps(data, indent=2, allow_nan=False) + '\n').encode('utf-8')})
    emit_json(data, json_out, out)
    if not json_to_stdout(json_out):
        for v in data['vessels']:
            dates = {k: t['limit_date_utc'] for k, t in v['trend'].items() if t is not None}
            soon = min((d for d in dates.values() if d), default=None)
            twice = [log for log in v['logs'] if log['same_time_as']]
            out.write(f"{v['name']}: {len(v['logs'])} logs; " +
                      (f'first limit reached {soon}' if soon else 'no limit date') + '\n')
            for key, t in v['trend'].items():
                name = '2Z' if '2z' in key else 'Z_gb'
                trend = 'too few judged estimates for a trend' if t is None else t['message']
                b = v['beyond_reach'][key]
                if b is not None:     # the logs from then on say only "at least": the trend is the logs' before
                    trend = f"since {b['since_utc']} ({b['log']}) {b['message']}; the logs up to then: {trend}"
                out.write(f"  {name}: {trend}\n")
            for log in twice:
                out.write(f"  {log['log']} holds the time of {log['same_time_as']}: counted once in the trend\n")
        if data['earlier_version_results']:
            out.write(f"{data['earlier_version_results']} kept results were written by an earlier version of "
                      'steer_monitor (without the model check\'s clearances and verdict): their logs analysed again\n')
        out.write(f"{data['analysed']} analysed, {data['reused']} kept from earlier runs -> {page}\n")
    return report_read_errors('fleet', data['failed'], err)


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser('fleet', help="every vessel's logs on Dask: wear trends and limit dates",
                       description='Estimate every log of each vessel directory (its name is the vessel\'s; its '
                                   'own parameters in steer_monitor.yaml if present) as tasks on Dask distributed, '
                                   'keep the results, and fit each clearance\'s wear trend and limit date.')
    p.add_argument('vessels', nargs='+', metavar='VESSEL_DIR', help='one directory per vessel')
    p.add_argument('--out', required=True, metavar='DIR', help='results.parquet, fleet.json and index.html')
    g = p.add_mutually_exclusive_group()
    g.add_argument('--workers', type=int, help='worker processes of a local cluster (default: the cores)')
    g.add_argument('--scheduler', metavar='ADDRESS', help='an existing Dask scheduler, e.g. tcp://host:8786')
    add_config_option(p, default='the packaged R-18', role='for vessels without their own steer_monitor.yaml')
    add_json_option(p, 'fleet.json')
    p.add_argument('--no-reports', dest='reports', action='store_false',
                   help="do not write each log's report page (DIR/reports/VESSEL/...; about a second a log)")
    add_force_option(p)
    p.set_defaults(handler=lambda a: run(a.vessels, a.out, a.workers, a.scheduler, a.config, a.json_out,
                                         reports=a.reports))
