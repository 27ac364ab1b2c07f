"""Kept results: a Parquet file read back as written, refused when damaged, never half-written."""

from __future__ import annotations

import math

import pytest

from steer_monitor.ashore.store import LATER_COLUMNS, RESULTS_FILE, LogResult, load_results, save_results
from steer_monitor.errors import InputError, OutputError


def _rows(n: int) -> list[LogResult]:
    return [LogResult('vessel', f'log{i}.log', f'{i:064x}', 'c' * 64, i * 10**9, (i + 1) * 10**9, 1000 + i,
                      0.3e-3, 0.25e-3, math.nan, 0.2e-3, 0.18e-3, 0.22e-3, 0.6, 0.55, 0.65, '[]', '[]', '',
                      '[{"start_ns": 5, "end_ns": 9, "ram": 2, "share": 0.01, "idle": true}]' if i == 1 else '[]')
            for i in range(n)]


def test_results_read_back_as_written(tmp_path):
    rows = _rows(3) + [LogResult.failed('vessel', 'bad.log', 'f' * 64, 'c' * 64, 'no rudder angle')]
    save_results(tmp_path, rows)
    back, earlier = load_results(tmp_path)
    assert earlier == 0 and set(back) == {(r.log_sha256, r.config_sha256) for r in rows}
    for r in rows:
        got = back[(r.log_sha256, r.config_sha256)].as_dict()
        assert all(got[k] == v or (isinstance(v, float) and math.isnan(v) and math.isnan(got[k]))
                   for k, v in r.as_dict().items()), (got, r)


def test_no_results_yet_and_a_damaged_file(tmp_path):
    assert load_results(tmp_path) == ({}, 0)
    (tmp_path / RESULTS_FILE).write_bytes(b'PAR1 not really')
    with pytest.raises(InputError, match=r'cannot read kept results .*results\.parquet: .*\(remove it to start '
                                         r'again\)'):
        load_results(tmp_path)


def test_results_of_an_earlier_version_are_made_again_and_a_foreign_table_refused(tmp_path):
    """A file without the columns added since (LATER_COLUMNS: the stretches of uneven rams) was
    written by an earlier version: none of it is kept, and the count says so. A table
    lacking any other column is not ours."""
    import pyarrow.parquet as pq

    save_results(tmp_path, _rows(3))
    path = tmp_path / RESULTS_FILE
    table = pq.read_table(path)
    pq.write_table(table.drop_columns(list(LATER_COLUMNS)), path)
    assert load_results(tmp_path) == ({}, 3)
    pq.write_table(table.drop_columns(['z_gb_lo', *LATER_COLUMNS]), path)
    with pytest.raises(
        InputError,
        match=r'kept results .*results\.parquet lack columns z_gb_lo, uneven_json, verdict, effects, reach_json '
        r'\(written by another version\? remove it\)',
    ):
        load_results(tmp_path)


def test_a_full_disk_gives_the_system_s_words_and_keeps_the_old_results(small_tmpfs):
    from test.conftest import fill
    save_results(small_tmpfs, _rows(2))
    before = (small_tmpfs / RESULTS_FILE).read_bytes()
    fill(small_tmpfs)
    # pyarrow says 'Error writing bytes to file. Detail: [errno 28] ...': the line gives the system's words
    with pytest.raises(OutputError, match=r'^cannot write .*results\.parquet: No space left on device$'):
        save_results(small_tmpfs, _rows(5000))
    assert (small_tmpfs / RESULTS_FILE).read_bytes() == before
    assert sorted(p.name for p in small_tmpfs.iterdir()) == ['filler.bin', RESULTS_FILE]
