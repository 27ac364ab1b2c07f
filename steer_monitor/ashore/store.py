"""Kept results: one Parquet file of :class:`~steer_monitor.ashore.logresult.LogResult` rows
under the fleet's output directory, keyed by (log content SHA-256, parameters SHA-256), so a
rerun analyses only logs that are new or changed or were taken with other parameters.

Why Parquet (pyarrow) rather than DuckDB: the results are one small table read whole and
rewritten whole after each run (a few rows per vessel-day); a columnar file any tool reads
(pandas, DuckDB itself, Spark) needs no database engine in the environment or on a cluster.
Written to a temporary name and renamed, like every output here.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import fields
from pathlib import Path

from steer_monitor.ashore.logresult import LogResult
from steer_monitor.atomic import atomic_path
from steer_monitor.errors import InputError

__all__ = ['LATER_COLUMNS', 'RESULTS_FILE', 'load_results', 'save_results']

RESULTS_FILE = 'results.parquet'
#: columns added since the file was first written: a file without them was written by an
#: earlier version, whose results are not kept but made again (that version's estimates
#: took in stretches where the rams did not share the force evenly; then the declared
#: model's, where the clearances now are the model check's)
LATER_COLUMNS = ('uneven_json', 'verdict', 'effects')


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
