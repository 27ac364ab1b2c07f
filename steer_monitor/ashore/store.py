"""Kept results: one Parquet file of :class:`~steer_monitor.ashore.store.LogResult` rows
under the fleet's output directory, keyed by (log content SHA-256, parameters SHA-256), so a
rerun analyses only logs that are new or changed or were taken with other parameters.

Why Parquet (pyarrow) rather than DuckDB: the results are one small table read whole and
rewritten whole after each run (a few rows per vessel-day); a columnar file any tool reads
(pandas, DuckDB itself, Spark) needs no database engine in the environment or on a cluster.
Written to a temporary name and renamed, like every output here.

One log's result on the batch path as a flat record (:class:`LogResult`, :func:`log_result`):
what a fleet task returns and the store keeps; it runs inside a Dask worker (one process, no
subprocess of its own).
"""

from __future__ import annotations

import hashlib
import json
import traceback
from collections.abc import Iterable
from dataclasses import asdict, dataclass, fields
from pathlib import Path
from typing import Any

from steer_monitor.atomic import atomic_path
from steer_monitor.errors import InputError
from steer_monitor.model.reach import Reach

__all__ = ['LATER_COLUMNS', 'RESULTS_FILE', 'LogResult', 'file_digest', 'load_results', 'log_result', 'save_results']


RESULTS_FILE = 'results.parquet'
#: columns added since the file was first written: a file without them was written by an
#: earlier version, whose results are not kept but made again (that version's estimates
#: took in stretches where the rams did not share the force evenly; then the declared
#: model's, where the clearances now are the model check's)
LATER_COLUMNS = ('uneven_json', 'verdict', 'effects', 'reach_json')


def load_results(directory: str | Path) -> tuple[dict[tuple[str, str], LogResult], int]:
    """Kept results by (log SHA-256, parameters SHA-256), empty when there are none yet; and
    how many results an earlier version wrote, which are not kept (:data:`LATER_COLUMNS`)."""
    import pyarrow.parquet as pq

    path = Path(directory) / RESULTS_FILE
    if not path.is_file():
        return {}, 0
    try:
        table = pq.read_table(path)
    except Exception as exc:     # pyarrow's own errors: a damaged file
        msg = f'cannot read kept results {path}: {exc} (remove it to start again)'
        raise InputError(msg) from exc
    names = [f.name for f in fields(LogResult)]
    missing = [n for n in names if n not in table.column_names]
    if missing and set(missing) <= set(LATER_COLUMNS):
        return {}, table.num_rows
    if missing:
        msg = f'kept results {path} lack columns {", ".join(missing)} (written by another version? remove it)'
        raise InputError(msg)
    rows = table.select(names).to_pylist()
    return {(r['log_sha256'], r['config_sha256']): LogResult(**r) for r in rows}, 0


def save_results(directory: str | Path, results: Iterable[LogResult]) -> Path:
    """Write every result (atomically); returns the file's path."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    rows = [r.as_dict() for r in results]
    names = [f.name for f in fields(LogResult)]
    table = pa.Table.from_pylist(rows, schema=_schema()) if rows else _schema().empty_table()
    path = Path(directory) / RESULTS_FILE
    with atomic_path(path) as tmp:
        pq.write_table(table.select(names), tmp)
    return path


def _schema():  # type: ignore[no-untyped-def]
    """The table's columns, from the record's fields (annotations are strings here)."""
    import pyarrow as pa
    kinds = {'int': pa.int64(), 'float': pa.float64(), 'str': pa.string()}
    return pa.schema([(f.name, kinds[f.type]) for f in fields(LogResult)])


_CHUNK = 1 << 20


def file_digest(path: str | Path) -> str:
    """SHA-256 (hex) of a file's content, read in 1 MiB pieces."""
    h = hashlib.sha256()
    with open(path, 'rb') as fh:
        while piece := fh.read(_CHUNK):
            h.update(piece)
    return h.hexdigest()


@dataclass(frozen=True)
class LogResult:
    """A log's clearances and K_gl max in SI (NaN where none; ``*_hi`` NaN also for a lower
    bound only): the model check's (:mod:`~steer_monitor.ashore.loganalysis`: ``analyze`` of
    its last hours, ``steer-monitor analyze`` of a shorter log), with its ``verdict``
    ('declared', 'effect', 'unexplained'; '' when none could be made) and the ``effects`` it
    adopted (comma-separated); its span [ns], hard-over times [s] and the stretches of uneven
    rams as JSON (from the review on the batch path), and ``error`` ('' when it was read)."""

    vessel: str
    log: str
    log_sha256: str
    config_sha256: str
    start_ns: int
    end_ns: int
    frames: int
    two_z: float
    two_z_lo: float
    two_z_hi: float
    z_gb: float
    z_gb_lo: float
    z_gb_hi: float
    k_gl_max: float
    k_gl_max_lo: float
    k_gl_max_hi: float
    hard_overs_json: str
    read_errors_json: str
    error: str
    #: stretches where the rams did not share the force evenly, left out of the estimate: JSON
    #: list of {"start_ns", "end_ns", "ram" (the weaker, 1 or 2), "share", "idle"}
    uneven_json: str = '[]'
    verdict: str = ''
    effects: str = ''
    #: how far 2Z and Z_gb can show on the gear at this log (:mod:`~steer_monitor.model.reach`):
    #: JSON ``[Reach.as_list(), ...]`` in SI, '' when not worked out
    reach_json: str = ''

    def reach(self, k: int) -> Reach | None:
        """Clearance ``k``'s reach (0: 2Z, 1: Z_gb), None when not worked out."""
        if not self.reach_json:
            return None
        return Reach.of_list(json.loads(self.reach_json)[k])

    def as_dict(self) -> dict[str, Any]:
        return asdict(self)

    @classmethod
    def failed(cls, vessel: str, log: str, log_sha256: str, config_sha256: str, error: str) -> LogResult:
        """The result of a log that could not be estimated at all: ``error`` says why."""
        nan = float('nan')
        return cls(vessel, log, log_sha256, config_sha256, 0, 0, 0, *(nan,) * 9, '[]', '[]', error)


def _iv(iv: Any) -> tuple[float, float, float]:
    nan = float('nan')
    if iv is None:
        return nan, nan, nan
    return (float(iv.value), nan if iv.lo is None else float(iv.lo), nan if iv.hi is None else float(iv.hi))


def log_result(vessel: str, log: str, config: str | None, log_sha256: str, config_sha256: str,
               report_dir: str | None = None) -> LogResult:
    """One log's result: reviewed on the batch path (in this process: its span, hard-overs,
    uneven rams) and its clearances from the model check, as ``steer-monitor report`` gives
    them; with ``report_dir``, its report page written there too (from the same review and
    check). A log that cannot be read at all is a result with ``error`` set, not an
    exception: the fleet goes on, and says so; a page that cannot be written is said in the
    result's read errors."""
    from steer_monitor.ashore.loganalysis import model_check
    from steer_monitor.ashore.reviewlogs import review_logs
    from steer_monitor.errors import SteerMonitorError
    from steer_monitor.params import load_config
    from steer_monitor.runtime import single_blas_thread

    single_blas_thread()
    analysis, note = None, ''
    try:
        run = review_logs([log], config, jobs=1)
        if len(run.review.t_ns):
            config_path, params = load_config(config)
            analysis, note = model_check([log], params, config_path, int(run.review.t_ns[-1]))
    except SteerMonitorError as exc:
        return LogResult.failed(vessel, log, log_sha256, config_sha256, str(exc))
    except (OSError, MemoryError) as exc:
        return LogResult.failed(vessel, log, log_sha256, config_sha256, f'{type(exc).__name__}: {exc}')
    except Exception as exc:   # a defect of ours: kept as this log's error, with where it happened
        where = traceback.extract_tb(exc.__traceback__)[-1]
        return LogResult.failed(vessel, log, log_sha256, config_sha256,
                                f'internal error, please report it: {type(exc).__name__}: {exc} '
                                f'({Path(where.filename).name}:{where.lineno})')
    errors = list(run.errors)
    if report_dir is not None and run.frames:
        try:
            _write_report(log, config, run, report_dir, analysis, note)
        except SteerMonitorError as exc:
            errors.append(f'report not written: {exc}')
    r = run.review
    e = analysis.final if analysis is not None else None
    start = int(r.t_ns[0]) if len(r.t_ns) else 0
    end = int(r.t_ns[-1]) if len(r.t_ns) else 0
    hard = [{'t_leave_ns': int(h.t_leave_ns), 'seconds': float(h.seconds)} for h in r.hard_overs]
    return LogResult(vessel, log, log_sha256, config_sha256, start, end, int(run.frames),
                     *_iv(None if e is None else e.two_z), *_iv(None if e is None else e.z_gb),
                     *_iv(None if e is None else e.k_gl_max), json.dumps(hard), json.dumps(errors),
                     _why_none(e, r.opposed, run),
                     json.dumps([{'start_ns': sp.start_ns, 'end_ns': sp.end_ns, 'ram': sp.ram + 1, 'share': sp.share,
                                  'idle': sp.idle} for sp in r.uneven]),
                     '' if analysis is None else analysis.verdict,
                     '' if analysis is None else ','.join(st.name for st in analysis.steps),
                     '' if e is None or e.reach is None else json.dumps([r.as_list() for r in e.reach]))


def _why_none(estimate: Any, opposed: str, run: Any) -> str:
    """A result's ``error``: '' when there is an estimate, or when the log was read and
    simply held too little motion; else why there is none."""
    if estimate is not None:
        return ''
    if opposed:                 # a ram read the wrong way round: the vessel's map, not the log
        return opposed + '; nothing estimated'
    if run.frames:
        return ''
    return run.errors[0] if run.errors else 'no frames'


def _write_report(log: str, config: str | None, run: Any, report_dir: str, analysis: Any, note: str) -> None:
    from steer_monitor.ashore.report.reviewpage import report_input, write_report_dir
    from steer_monitor.params import load_config

    config_path, params = load_config(config)
    write_report_dir(report_input([Path(log)], run, params, config_path, analysis, note), report_dir)
