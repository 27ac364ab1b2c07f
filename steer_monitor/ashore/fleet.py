"""The fleet: vessels' log directories in, every log estimated on Dask distributed, results
kept, trends and limit dates out.

A vessel is a directory (its name is the vessel's): its logs in any format the tool reads,
found recursively, and optionally its own parameters file ``steer_monitor.yaml`` at its top.
Each log is one task, :func:`~steer_monitor.ashore.store.log_result`, on an in-process
``LocalCluster`` (worker processes on this machine, scheduler on the loopback address) or an
existing cluster (``scheduler``). A task whose worker dies is run again by Dask; a log that
fails for good is reported with its error, never fatal for the fleet.
"""

from __future__ import annotations

import datetime
import json
import math
import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from steer_monitor.ashore.loganalysis import NOT_JUDGED, reach_json
from steer_monitor.ashore.store import LogResult, file_digest, load_results, log_result, save_results
from steer_monitor.atomic import os_reason
from steer_monitor.errors import InputError, SteerMonitorError
from steer_monitor.estimate.intervals import Interval
from steer_monitor.estimate.trend import NO_WEAR, YEAR_S, Trend, TrendPoint, fit_trend
from steer_monitor.logfiles.compressed import plain_suffix
from steer_monitor.logfiles.logs import log_path_problem
from steer_monitor.monitor.verdict import MARGIN, beyond_words, clearance_verdict
from steer_monitor.params import load_config
from steer_monitor.record.provenance import parameters_digest
from steer_monitor.utc import utc_json

__all__ = ['LOG_SUFFIXES', 'REPORTS_DIR', 'SAME_TIME_SHARE', 'VESSEL_CONFIG', 'WORKER_ENVIRON', 'FleetRun', 'Vessel',
           'find_vessels', 'fleet_json', 'make_client', 'report_path', 'run_fleet', 'same_time_as', 'worker_environ']

#: a vessel's logs, by suffix (each also compressed: ``.log.gz``, ...)
LOG_SUFFIXES = ('.log', '.asc', '.blf', '.mcap', '.raw')
VESSEL_CONFIG = 'steer_monitor.yaml'
REPORTS_DIR = 'reports'
TASK_RETRIES = 2


@dataclass(frozen=True)
class Vessel:
    """One vessel: name, directory, parameters file (None: the fleet's), logs in path order."""

    name: str
    path: Path
    config: Path | None
    logs: tuple[Path, ...]
    skipped: tuple[Path, ...] = ()       # files beside the logs that are not logs by their name


@dataclass
class FleetRun:
    """What a run did: per vessel its results (in time order) and params; counts."""

    vessels: list[Vessel]
    results: dict[str, list[LogResult]]
    params: dict[str, dict[str, Any]]
    analysed: int = 0
    reused: int = 0
    failed: list[str] = field(default_factory=list)
    out: Path | None = None          # the output directory (report pages are looked for there)
    earlier_version: int = 0         # kept results an earlier version wrote, not kept (made again)


def find_vessels(dirs: Sequence[str | Path], config: str | Path | None = None) -> list[Vessel]:
    """The vessels of ``dirs``; :class:`InputError` naming a directory that is not one."""
    out = []
    names: dict[str, Path] = {}
    for d in dirs:
        path = Path(d)
        if not path.is_dir():
            msg = f'vessel directory {path} does not exist or is not a directory'
            raise InputError(msg)
        name = path.resolve().name
        if name in names:
            msg = f'two vessels named {name!r}: {names[name]} and {path} (a vessel is named by its directory)'
            raise InputError(msg)
        names[name] = path
        own = path / VESSEL_CONFIG
        # a link that leads nowhere is a log that cannot be read, said as such, not left out
        files = sorted(p for p in path.rglob('*') if (p.is_file() or p.is_symlink() and not p.is_dir())
                       and not any(part.startswith('.') for part in p.relative_to(path).parts))
        logs = tuple(p for p in files if plain_suffix(p) in LOG_SUFFIXES)
        skipped = tuple(p for p in files if plain_suffix(p) not in LOG_SUFFIXES and p != own)
        out.append(Vessel(name, path, own if own.is_file() else (Path(config) if config else None), logs, skipped))
    if not any(v.logs for v in out):
        others = [str(p) for v in out for p in v.skipped]
        msg = (f'no logs in {", ".join(str(d) for d in dirs)} (a log is named *' + ', *'.join(LOG_SUFFIXES)
               + ', each also compressed: .gz, .xz, .zst' + (f'; not logs by their name: {", ".join(others[:5])}'
                                                             + (' ...' if len(others) > 5 else '') if others else '')
               + ')')
        raise InputError(msg)
    return out


def make_client(workers: int | None, scheduler: str | None) -> tuple[Any, Any]:
    """(client, cluster or None): an existing scheduler, or a LocalCluster on loopback."""
    import dask
    from distributed import Client, LocalCluster

    if scheduler:
        try:
            return Client(scheduler, timeout='20s'), None
        except (OSError, TimeoutError) as exc:
            msg = f'cannot reach the Dask scheduler {scheduler}: {exc}'
            raise InputError(msg) from exc
    n = workers or os.cpu_count() or 1
    with dask.config.set({WORKER_ENVIRON: worker_environ()}):   # read once per worker's nanny
        try:
            cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True, host='127.0.0.1',
                                   dashboard_address='127.0.0.1:0', silence_logs=50)
        except RuntimeError as exc:   # a spawned worker re-ran a script's top level, which started a cluster
            msg = (f"cannot start the fleet's {n} worker process(es) ({exc}); from a script, call the fleet "
                   "under `if __name__ == '__main__':`")
            raise SteerMonitorError(msg) from exc
    return Client(cluster), cluster


WORKER_ENVIRON = 'distributed.nanny.pre-spawn-environ'


def worker_environ() -> dict[str, Any]:
    """What Dask sets in a worker's environment before it starts, less
    ``MALLOC_TRIM_THRESHOLD_``: glibc then keeps a fixed threshold for serving large blocks
    by mmap, so every large numpy temporary is mapped and unmapped afresh; the analysis of a
    log ran three times slower on a worker than in one process (0.72 against 0.24 s on a
    four-minute log, and the same in one process with that variable set). A scheduler of
    your own starts its workers with its own setting (docs/benchmarks.md)."""
    import dask

    return {k: v for k, v in dask.config.get(WORKER_ENVIRON, {}).items() if k != 'MALLOC_TRIM_THRESHOLD_'}


def report_path(vessel: str, log_sha256: str, config_sha256: str) -> Path:
    """Where a log's report page lies under the fleet's output directory (relative): one per
    log content and parameters, like the kept results."""
    return Path(REPORTS_DIR, vessel, f'{log_sha256[:16]}-{config_sha256[:8]}', 'index.html')


def run_fleet(dirs: Sequence[str | Path], out: str | Path, *, workers: int | None = None,
              scheduler: str | None = None, config: str | Path | None = None,
              progress: Callable[[int, int], None] | None = None, client: Any = None,
              reports: bool = True) -> FleetRun:
    """Estimate every log not kept yet, keep all results under ``out``; ``progress`` hears
    (tasks done, tasks in all). ``client``: a Dask client to use as it is (left open).
    ``reports``: each log's report page too (:func:`report_path`; the workers write it, so
    on a cluster ``out`` must be on a file system they share, as the logs are); a kept result
    whose page is missing is made again."""
    from distributed import as_completed

    vessels = find_vessels(dirs, config)
    out = Path(out)
    kept, earlier = load_results(out)
    run = FleetRun(vessels, {}, {}, out=out, earlier_version=earlier)
    todo: list[tuple[Vessel, Path, str, str]] = []
    for v in vessels:
        path, params = load_config(v.config)
        run.params[v.name] = params
        cfg_sha = parameters_digest(params)
        run.results[v.name] = []
        for log in v.logs:
            problem = log_path_problem(log)          # e.g. a link to nowhere, or to a device
            if problem is None:
                try:
                    sha = file_digest(log)
                except OSError as exc:
                    problem = f'{log}: {os_reason(exc)}'
            if problem is not None:
                run.failed.append(f'{v.name}: {problem}')
                continue
            r = kept.get((sha, cfg_sha))
            page_kept = not reports or (out / report_path(v.name, sha, cfg_sha)).is_file()
            if r is not None and not r.error and page_kept:
                run.results[v.name].append(r if r.log == str(log) else _moved(r, v.name, log))
                run.reused += 1
            else:
                todo.append((v, log, sha, cfg_sha))
    if todo:
        own = client is None
        cluster = None
        if own:
            client, cluster = make_client(workers, scheduler)
        try:
            def page_dir(v: Vessel, sha: str, cfg_sha: str) -> str | None:
                return str((out / report_path(v.name, sha, cfg_sha)).parent.resolve()) if reports else None
            futures = {client.submit(log_result, v.name, str(log), None if v.config is None else str(v.config),
                                     sha, cfg_sha, page_dir(v, sha, cfg_sha),
                                     key=f'steer_monitor-log-{v.name}-{sha[:16]}-{cfg_sha[:8]}',
                                     retries=TASK_RETRIES, pure=False): (v, log, sha, cfg_sha)
                       for v, log, sha, cfg_sha in todo}
            done = 0
            for fut in as_completed(futures):
                v, log, sha, cfg_sha = futures[fut]
                try:
                    r = fut.result()
                except Exception as exc:      # failed for good (after Dask's retries)
                    r = LogResult.failed(v.name, str(log), sha, cfg_sha, f'task failed: {type(exc).__name__}: {exc}')
                run.results[v.name].append(r)
                run.analysed += 1
                done += 1
                if progress is not None:
                    progress(done, len(futures))
            if reports:        # every task has ended: what a killed worker left half-written goes
                from steer_monitor.ashore.report.reviewpage import remove_report_debris
                for v, _log, sha, cfg_sha in todo:
                    remove_report_debris((out / report_path(v.name, sha, cfg_sha)).parent)
        finally:
            if own:
                client.close()
            if cluster is not None:
                cluster.close()
    for name, rs in run.results.items():
        rs.sort(key=lambda r: (r.start_ns, r.log))
        run.failed += [f'{name}: {r.log}: {r.error}' for r in rs if r.error]
    # keep what was kept for other vessels or logs too: a rerun of part of the fleet loses nothing
    current = {(r.log_sha256, r.config_sha256): r for rs in run.results.values() for r in rs}
    save_results(out, list({**kept, **current}.values()))
    return run


def _moved(r: LogResult, vessel: str, log: Path) -> LogResult:
    from dataclasses import replace
    return replace(r, vessel=vessel, log=str(log))


def _utc(t_s: float | None) -> str | None:
    if t_s is None or not math.isfinite(t_s):
        return None
    try:
        return datetime.datetime.fromtimestamp(t_s, tz=datetime.UTC).date().isoformat()
    except (OverflowError, OSError, ValueError):
        return None


def _interval(r: LogResult, attr: str) -> Interval | None:
    """A result's estimate ``attr`` (``two_z``, ``z_gb``, ``k_gl_max``) as an Interval (NaN
    ends: open); None when there is none."""
    value, lo, hi = getattr(r, attr), getattr(r, attr + '_lo'), getattr(r, attr + '_hi')
    if not math.isfinite(value):
        return None
    return Interval(value, None if math.isnan(lo) else lo, None if math.isnan(hi) else hi)


def _est(r: LogResult, attr: str, k: float = 1e3) -> dict[str, Any] | None:
    iv = _interval(r, attr)
    return None if iv is None else iv.scaled(k)


def _clearance(r: LogResult, attr: str, limit: float, warn_share: float) -> dict[str, Any]:
    """A clearance of a log as the fleet page and ``fleet.json`` give it: ``{value, ci95,
    bounded, level}`` in mm, judged as the report judges it (not judged without an estimate
    or when the model check's model does not explain the data)."""
    iv = _interval(r, attr)
    if iv is None:
        return {'value': None, 'ci95': [None, None], 'bounded': False, 'level': NOT_JUDGED}
    label = clearance_verdict(iv.value, iv.lo, iv.hi, limit, warn_share).label
    level = NOT_JUDGED if r.verdict == 'unexplained' else label
    return {**iv.scaled(1e3), 'level': level, **reach_json(r.reach(0 if attr == 'two_z' else 1))}


def beyond_reach(rs: Sequence[LogResult]) -> dict[str, dict[str, Any] | None]:
    """Per clearance, the first log (in time) where it lay beyond what the pressures can show
    on the gear (a lower bound past the gear's reach, :meth:`~steer_monitor.model.reach.Reach.beyond`):
    ``{"since_utc", "log", "lower_bound_mm", "gear_mm", "message"}``, None when none did. From then
    on the logs can only say it is at least that: a measurement tells the rest, and a trend is
    what the logs before it imply."""
    out: dict[str, dict[str, Any] | None] = {}
    for key, attr, k, name in (('clearance_2z_mm', 'two_z', 0, '2Z'), ('clearance_zgb_mm', 'z_gb', 1, 'Z_gb')):
        out[key] = None
        for r in sorted((r for r in rs if not r.error and r.start_ns), key=lambda r: r.start_ns):
            iv, reach = _interval(r, attr), r.reach(k)
            if (iv is not None and iv.hi is None and iv.lo is not None and reach is not None
                    and reach.beyond(iv.lo, MARGIN[name])):
                out[key] = {'since_utc': _iso(r.start_ns), 'log': r.log, 'lower_bound_mm': round(iv.lo * 1e3, 4),
                            'gear_mm': round(reach.gear * 1e3, 4), 'message': beyond_words(name, reach)}
                break
    return out


#: levels from the least to the most serious (a log's level is its worst clearance's): a
#: clearance not assessed is worse than one known fine, never worse than one known worn
_LEVELS = ('OK', NOT_JUDGED, 'WARN', 'OVER LIMIT')


def _worst(levels: Any) -> str:
    return max(levels, key=_LEVELS.index)


#: a log whose span lies this much (fraction of its own) within a fuller log's is the same data
SAME_TIME_SHARE = 0.5


def same_time_as(rs: Sequence[LogResult]) -> dict[int, int]:
    """Logs that hold the same stretch of time as another (the same log copied twice, a
    recording beside a candump of the same hours, a log and its compressed copy): index ->
    index of the log kept in its place. Of logs whose spans overlap by at least
    :data:`SAME_TIME_SHARE` of the shorter one's, the one with the most frames is kept (then
    the first); counted twice, one stretch of data would narrow a wear trend's interval as
    if it were two."""
    usable = [i for i, r in enumerate(rs) if not r.error and r.end_ns > r.start_ns > 0]
    kept: list[int] = []
    out: dict[int, int] = {}
    for i in sorted(usable, key=lambda i: (-rs[i].frames, i)):
        r = rs[i]
        for k in kept:
            common = min(r.end_ns, rs[k].end_ns) - max(r.start_ns, rs[k].start_ns)
            if common >= SAME_TIME_SHARE * (r.end_ns - r.start_ns):
                out[i] = k
                break
        else:
            kept.append(i)
    return out


def _points(rs: list[LogResult], attr: str) -> tuple[list[TrendPoint], list[int]]:
    """The trend's points of estimate ``attr`` and the index in ``rs`` of each: judged logs
    only (a log whose model does not explain its pressures gives no clearance to trend), a
    log of the same time as another left out."""
    pts, index = [], []
    twice = same_time_as(rs)
    for i, r in enumerate(rs):
        iv = _interval(r, attr)
        if r.error or iv is None or not r.end_ns or i in twice or r.verdict == 'unexplained':
            continue
        pts.append(TrendPoint((r.start_ns + r.end_ns) / 2e9, iv.value, iv.lo, iv.hi))
        index.append(i)
    return pts, index


def vessel_trends(rs: list[LogResult], params: dict[str, Any]
                  ) -> dict[str, tuple[Trend | None, list[TrendPoint], list[int]]]:
    """Per clearance (JSON key): its trend (None: too few estimates), the points and the
    index in ``rs`` of each point's log."""
    out = {}
    for key, attr, limit in (('clearance_2z_mm', 'two_z', params['clearances.limit_2z_mm'] * 1e-3),
                             ('clearance_zgb_mm', 'z_gb', params['clearances.limit_zgb_mm'] * 1e-3)):
        pts, index = _points(rs, attr)
        out[key] = (fit_trend(pts, limit), pts, index)
    return out


def _trend_json(tr: Trend | None, limit: float, logs: list[str]) -> dict[str, Any] | None:
    """A trend as JSON; ``logs``: the log of each of its points."""
    if tr is None:
        return None
    r = tr.rate
    k = YEAR_S * 1e3
    return {'rate_mm_per_year': {'value': round(r.value * k, 5),
                                 'ci95': [round(r.lo * k, 5), round(r.hi * k, 5)]},  # type: ignore[operator]
            'wear_seen': tr.wear_seen,
            'verdict': tr.verdict,
            'message': tr.message(),
            'limit_date_earliest_utc': _utc(tr.earliest_t) if tr.verdict != NO_WEAR else None,
            'months_to_tell': None if tr.months_to_tell is None else round(tr.months_to_tell, 1),
            'limit_mm': round(limit * 1e3, 4),
            'limit_date_utc': _utc(tr.limit_t),
            'limit_date_ci95': [_utc(tr.limit_t_lo), _utc(tr.limit_t_hi)] if tr.limit_t is not None else None,
            'estimates_used': tr.used, 'lower_bounds_used': tr.bounds,
            'between_logs_mm': round(tr.between * 1e3, 5),
            'outliers': [logs[i] for i in tr.outliers]}


def fleet_json(run: FleetRun) -> dict[str, Any]:
    """The fleet as ``fleet.json`` holds it."""
    vessels = []
    for v in run.vessels:
        p = run.params[v.name]
        rs = run.results[v.name]
        share = p['diagnostics.clearance_warn_share']
        logs = []
        for r in rs:
            clearances = {}
            for key, attr, limit in (('clearance_2z_mm', 'two_z', p['clearances.limit_2z_mm'] * 1e-3),
                                     ('clearance_zgb_mm', 'z_gb', p['clearances.limit_zgb_mm'] * 1e-3)):
                clearances[key] = _clearance(r, attr, limit, share)
            logs.append({'log': r.log, 'start_utc': _iso(r.start_ns), 'start_ns': r.start_ns or None,
                         'end_utc': _iso(r.end_ns), 'end_ns': r.end_ns or None, 'frames': r.frames,
                         **clearances, 'k_gl_max': _est(r, 'k_gl_max', 1.0),
                         'level': _worst(c['level'] for c in clearances.values()),
                         'model_check': ({'verdict': r.verdict, 'effects': [e for e in r.effects.split(',') if e]}
                                         if r.verdict else None),
                         'hard_overs_s': [round(h['seconds'], 2) for h in json.loads(r.hard_overs_json)],
                         'report': _report(run, v.name, r),
                         'read_errors': json.loads(r.read_errors_json),
                         'uneven_rams': [{'start_utc': _iso(u['start_ns']), 'start_ns': u['start_ns'],
                                          'end_utc': _iso(u['end_ns']), 'end_ns': u['end_ns'],
                                          'ram': u['ram'], 'share_pct': round(100 * u['share'], 1), 'idle': u['idle']}
                                         for u in json.loads(r.uneven_json)],
                         'same_time_as': None,
                         'error': r.error or None})
        trends = vessel_trends(rs, p)
        for i, k in same_time_as(rs).items():
            logs[i]['same_time_as'] = rs[k].log
        vessels.append({'name': v.name, 'config': None if v.config is None else str(v.config),
                        'logs': logs, 'beyond_reach': beyond_reach(rs),
                        'trend': {key: _trend_json(tr, p[f'clearances.limit_{key.split("_")[1]}_mm'] * 1e-3,
                                                   [rs[i].log for i in index])
                                  for key, (tr, _, index) in trends.items()}})
    vessels.sort(key=_soonest)
    return {'vessels': vessels, 'analysed': run.analysed, 'reused': run.reused,
            'earlier_version_results': run.earlier_version, 'failed': run.failed}


def _report(run: FleetRun, vessel: str, r: LogResult) -> str | None:
    """The log's report page relative to the output directory, None when there is none."""
    rel = report_path(vessel, r.log_sha256, r.config_sha256)
    return str(rel) if run.out is not None and (run.out / rel).is_file() else None


def _soonest(v: dict[str, Any]) -> str:
    dates = [t['limit_date_utc'] for t in v['trend'].values() if t is not None and t['limit_date_utc']]
    return min(dates) if dates else '9999-12-31'


def _iso(t_ns: int) -> str | None:
    return utc_json(t_ns) if t_ns else None     # 0: a log with no time

