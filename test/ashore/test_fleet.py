"""The fleet on a 2-worker Dask LocalCluster: two simulated vessels over a year of monthly
logs, one wearing at a known rate and one not; a worker killed mid-run; kept results reused;
a broken log reported, not fatal."""

from __future__ import annotations

import datetime
import json
import math
import os
import signal
from pathlib import Path

import pytest

from steer_monitor import sim
from steer_monitor.ashore.store import LogResult
from steer_monitor.logfiles.logs import write_candump
from steer_monitor.model import Clearances

pytestmark = pytest.mark.slow

T0_NS = 1_767_225_600_000_000_000          # 2026-01-01
MONTH_NS = int(365.25 / 12 * 86400e9)
ZGB0_MM, ZGB_RATE_MM_YEAR = 0.10, 0.12     # the wearing vessel's guide slipper
PROGRAM = 'hard_over_2,zigzag_20,zigzag_10'


@pytest.fixture(scope='module')
def fleet_dirs(tmp_path_factory, r18_params, can_db):
    db, smap = can_db
    root = tmp_path_factory.mktemp('fleet')
    for name, rate in (('wearing', ZGB_RATE_MM_YEAR), ('steady', 0.0)):
        d = root / name / 'recordings'
        d.mkdir(parents=True)
        for k in range(12):
            zgb = ZGB0_MM + rate * k / 12
            s = sim.run(r18_params, sim.SimConfig(program=PROGRAM, gaps=Clearances.from_mm(0.35, zgb),
                                                  start_ns=T0_NS + k * MONTH_NS), db, smap, 100 + k)
            with open(d / f'{name}_{k:02d}.log', 'wb') as fh:
                write_candump(fh, s.frames)
    return root


@pytest.fixture(scope='module')
def client():
    from steer_monitor.ashore.fleet import make_client
    c, cluster = make_client(2, None)      # the LocalCluster run_fleet makes
    with cluster, c:
        yield c


def test_workers_run_without_dask_malloc_trim(client):
    """Dask's MALLOC_TRIM_THRESHOLD_ made the analysis three times slower on a worker
    (glibc maps and unmaps every large temporary); its other settings stay."""
    env = client.run(lambda: (os.environ.get('MALLOC_TRIM_THRESHOLD_'), os.environ.get('OMP_NUM_THREADS')))
    assert len(env) == 2 and set(env.values()) == {(None, '1')}


def _kill_one_worker(client):
    pids = client.run(os.getpid)
    os.kill(next(iter(pids.values())), signal.SIGKILL)


def test_a_year_of_a_fleet_with_a_worker_killed(tmp_path, fleet_dirs, client):
    from steer_monitor.ashore.fleet import fleet_json, run_fleet

    killed = []

    def progress(done, total):
        if done == 3 and not killed:        # mid-run: its tasks go to the other worker, nothing lost
            _kill_one_worker(client)
            killed.append(done)

    out = tmp_path / 'out'
    out.mkdir()
    run = run_fleet([fleet_dirs / 'wearing', fleet_dirs / 'steady'], out, progress=progress, client=client)
    assert killed and run.analysed == 24 and run.failed == []
    data = fleet_json(run)
    by = {v['name']: v for v in data['vessels']}
    assert [v['name'] for v in data['vessels']] == ['wearing', 'steady']        # the soonest limit first
    wearing = by['wearing']['trend']['clearance_zgb_mm']
    lo, hi = wearing['rate_mm_per_year']['ci95']
    assert lo <= ZGB_RATE_MM_YEAR <= hi and lo > 0
    true_date = (datetime.date(2026, 1, 1)
                 + datetime.timedelta(days=365.25 * (0.25 - ZGB0_MM) / ZGB_RATE_MM_YEAR)).isoformat()
    d_lo, d_hi = wearing['limit_date_ci95']
    assert d_lo <= true_date <= d_hi, (wearing, true_date)
    assert by['steady']['trend']['clearance_zgb_mm']['limit_date_utc'] is None
    assert all(lg['level'] in ('OK', 'WARN', 'OVER LIMIT', 'NOT ASSESSED') for v in data['vessels'] for lg in v['logs'])
    log0 = by['wearing']['logs'][0]
    assert log0['start_utc'].startswith('2026-01-01') and set(log0['clearance_zgb_mm']) == {
        'value',
        'ci95',
        'bounded',
        'level',
        'observable_to_mm',
    }
    assert set(log0['clearance_zgb_mm']['observable_to_mm']) == {'loads_seen', 'gear', 'at_other_mm',
                                                                 'other_lower_bound'}

    # each log's report page, from the same review, whole (written aside and renamed)
    for v in data['vessels']:
        for lg in v['logs']:
            page = out / lg['report']
            assert lg['report'].startswith(f"reports/{v['name']}/") and page.is_file(), lg
            assert os.path.basename(lg['log']) in page.read_text()
            assert (page.parent / 'clearances.png').stat().st_size > 5000
    assert not list(out.glob('reports/*/.*.tmp'))

    # a rerun analyses nothing new: the kept results are used
    again = run_fleet([fleet_dirs / 'wearing', fleet_dirs / 'steady'], out, client=client)
    assert again.analysed == 0 and again.reused == 24
    assert fleet_json(again)['vessels'] == data['vessels']

    # a log whose page went missing is made again, unless pages are not asked for
    import shutil
    page_dir = (out / log0['report']).parent
    shutil.rmtree(page_dir)
    # and what a worker killed while writing that page left beside it goes with the rerun
    debris = page_dir.with_name(f'.{page_dir.name}.99999.tmp')
    (debris / 'half').mkdir(parents=True)
    other = page_dir.with_name('.unrelated.99999.tmp')
    other.mkdir()
    assert run_fleet([fleet_dirs / 'wearing'], out, client=client, reports=False).analysed == 0
    assert debris.is_dir()
    assert run_fleet([fleet_dirs / 'wearing'], out, client=client).analysed == 1
    assert (out / log0['report']).is_file()
    assert not debris.exists() and other.is_dir()


def test_a_ram_that_did_not_carry_its_share_and_results_of_an_earlier_version(tmp_path, r18_params, can_db, client,
                                                                              capsys):
    """A vessel whose second log has ram 2's chambers joined for 400 s: the fleet's JSON and
    page name it. Results kept by an earlier version (no column for it) are made again."""
    import pyarrow.parquet as pq

    from steer_monitor.ashore.fleet import fleet_json, run_fleet
    from steer_monitor.ashore.fleetpage import fleet_page
    from steer_monitor.ashore.store import LATER_COLUMNS, RESULTS_FILE

    db, smap = can_db
    d = tmp_path / 'tanker' / 'recordings'
    d.mkdir(parents=True)
    for k, effects in enumerate(((), (sim.parse_effect('ram_bypass:ram=2,start_s=200,end_s=600'),))):
        s = sim.run(r18_params, sim.SimConfig(program='realistic:900', effects=effects, start_ns=T0_NS + k * MONTH_NS),
                    db, smap, 31 + k)
        with open(d / f'tanker_{k}.log', 'wb') as fh:
            write_candump(fh, s.frames)
    out = tmp_path / 'out'
    out.mkdir()
    run = run_fleet([tmp_path / 'tanker'], out, client=client, reports=False)
    logs = fleet_json(run)['vessels'][0]['logs']
    assert logs[0]['uneven_rams'] == []
    [u] = logs[1]['uneven_rams']
    assert (u['ram'], u['idle']) == (2, True) and u['share_pct'] < 5
    assert u['start_utc'].startswith('2026-01-31T1') and u['end_utc'] > u['start_utc']
    page = fleet_page(run)
    assert '<td>even</td>' in page and f"ram 2 {u['share_pct']:.0f} % " in page and '(left out)' in page

    table = pq.read_table(out / RESULTS_FILE)
    pq.write_table(table.drop_columns(list(LATER_COLUMNS)), out / RESULTS_FILE)
    again = run_fleet([tmp_path / 'tanker'], out, client=client, reports=False)
    assert (again.analysed, again.reused, again.earlier_version) == (2, 0, 2)
    assert fleet_json(again)['earlier_version_results'] == 2
    assert fleet_json(again)['vessels'][0]['logs'] == logs

    from steer_monitor.cli.main import main
    pq.write_table(table.drop_columns(list(LATER_COLUMNS)), out / RESULTS_FILE)
    assert main(['fleet', str(tmp_path / 'tanker'), '--out', str(out), '--workers', '1', '--no-reports']) == 0
    said = capsys.readouterr().out.splitlines()
    assert said[-2:] == ['2 kept results were written by an earlier version of steer_monitor (without the model '
                         "check's clearances and verdict): their logs analysed again",
                         f"2 analysed, 0 kept from earlier runs -> {out / 'index.html'}"]


def test_cli_with_a_broken_log_and_a_vessel_of_its_own_parameters(tmp_path, fleet_dirs, capsys):
    """The command end to end (its own 2-worker LocalCluster): a log that is not a log is
    one line on stderr and exit 1; everything else is in fleet.json and the page."""
    import shutil

    from steer_monitor.cli.main import main
    from test.conftest import R18_YAML

    vessel = tmp_path / 'mv_example'
    shutil.copytree(fleet_dirs / 'wearing', vessel)
    (vessel / 'recordings' / 'broken.log').write_bytes(b'\x00\x01 not a log\n')
    (vessel / 'recordings' / 'moved.log').symlink_to(tmp_path / 'gone.log')    # a log that was moved away
    (vessel / 'recordings' / 'endless.log').symlink_to('/dev/zero')           # read, it would never end
    shutil.copy(R18_YAML, vessel / 'steer_monitor.yaml')
    (vessel / 'voyage.txt').write_text('a note of the crew\n')                  # not a log by its name: said
    out = tmp_path / 'out'
    rc = main(['fleet', str(vessel), '--out', str(out), '--workers', '2', '--json', '-'])
    cap = capsys.readouterr()
    assert rc == 1
    assert 'steer-monitor fleet: error: mv_example:' in cap.err and 'broken.log' in cap.err
    lines = cap.err.splitlines()
    notes = [ln for ln in lines if ln.startswith('steer-monitor fleet: note: ')]
    assert len(notes) == 1 and 'file(s) not logs by their name left out: ' in notes[0], lines
    assert str(vessel / 'voyage.txt') in notes[0] or ' more (a log is named *.log' in notes[0], notes
    assert (f'steer-monitor fleet: error: mv_example: log {vessel / "recordings" / "moved.log"} does not exist '
            '(a broken symbolic link)') in lines, lines
    assert (f'steer-monitor fleet: error: mv_example: log {vessel / "recordings" / "endless.log"} is not a regular '
            'file') in lines, lines
    data = json.loads(cap.out)
    v = data['vessels'][0]
    assert v['name'] == 'mv_example' and v['config'].endswith('steer_monitor.yaml') and len(v['logs']) == 13
    assert v['trend']['clearance_zgb_mm']['limit_date_utc'] is not None
    assert json.loads((out / 'fleet.json').read_text()) == data
    page = (out / 'index.html').read_text()
    assert 'mv_example' in page and 'data:image/png;base64,' in page
    links = [lg['report'] for lg in v['logs'] if lg['report']]
    assert len(links) == 12 and all(f'<a href="{link}">' in page for link in links)   # not the broken log
    assert (out / 'results.parquet').is_file()


@pytest.mark.parametrize('args, message', [
    (['/nonexistent/vessel'], 'vessel directory /nonexistent/vessel does not exist'),
    (['{tmp}', '--workers', '0'], '--workers must be at least 1, got 0'),
])
def test_bad_arguments_are_one_line(tmp_path, capsys, args, message):
    from steer_monitor.cli.main import main
    (tmp_path / 'mv').mkdir()
    (tmp_path / 'mv' / 'a.log').write_text('')
    args = [a.replace('{tmp}', str(tmp_path / 'mv')) for a in args]
    assert main(['fleet', *args, '--out', str(tmp_path / 'out')]) == 1
    err = capsys.readouterr().err
    assert message in err and err.count('\n') == 1
    assert not (tmp_path / 'out').exists()


def test_no_logs_is_an_error_naming_what_is_there_and_leaves_nothing(tmp_path, capsys):
    """An empty directory, or one holding only a voyage.txt, once gave "0 logs" and exit 0."""
    from steer_monitor.cli.main import main
    (tmp_path / 'mv').mkdir()
    assert main(['fleet', str(tmp_path / 'mv'), '--out', str(tmp_path / 'out' / 'fleet')]) == 1
    err = capsys.readouterr().err
    assert err == (f'steer-monitor fleet: error: no logs in {tmp_path / "mv"} (a log is named *.log, *.asc, *.blf, '
                   '*.mcap, *.raw, each also compressed: .gz, .xz, .zst)\n')
    (tmp_path / 'mv' / 'voyage.txt').write_text('(1.0) can0 123#00\n')
    assert main(['fleet', str(tmp_path / 'mv'), '--out', str(tmp_path / 'out' / 'fleet')]) == 1
    assert 'not logs by their name: ' + str(tmp_path / 'mv' / 'voyage.txt') in capsys.readouterr().err
    assert not (tmp_path / 'out').exists()


# --- the trend's logs, pure (no Dask) -----------------------------------------------------------
DAY_NS = 86_400 * 10**9


def _result(log: str, day: float, hours: float, z_gb_mm: float, frames: int = 1000,
            half_width_mm: float = 0.01) -> LogResult:
    start = int(1_767_225_600 * 10**9 + day * DAY_NS)
    z, w = z_gb_mm * 1e-3, half_width_mm * 1e-3
    return LogResult('mv', log, log, 'cfg', start, start + int(hours * 3.6e12), frames, 0.4e-3, 0.39e-3, 0.41e-3,
                     z, z - w, z + w, 0.6, 0.59, 0.61, '[]', '[]', '', '[]')


def _fleet(rs: list[LogResult], r18_params) -> dict:
    from steer_monitor.ashore.fleet import FleetRun, Vessel, fleet_json

    return fleet_json(FleetRun([Vessel('mv', Path('mv'), None, ())], {'mv': rs}, {'mv': dict(r18_params)}))['vessels'][
        0
    ]


def test_a_log_of_the_same_time_is_counted_once_in_the_trend(r18_params):
    """A day's log copied twice (or kept compressed beside the plain one, or recorded by the
    node beside a candump): before, each copy was one more point of the trend, whose rate's
    interval narrowed as if the gear had been measured twice."""
    rs = [_result(f'd{d:03d}.log', d, 24, 0.20 + 0.0004 * d + 0.004 * (-1) ** d) for d in range(0, 360, 30)]
    alone = _fleet(rs, r18_params)['trend']['clearance_zgb_mm']
    copies = [_result(f'copy/{r.log}', (r.start_ns - rs[0].start_ns) / DAY_NS, 24, r.z_gb * 1e3, frames=999)
              for r in rs]
    v = _fleet(sorted(rs + copies, key=lambda r: r.start_ns), r18_params)
    assert v['trend']['clearance_zgb_mm'] == alone
    assert {log['log']: log['same_time_as'] for log in v['logs'] if log['same_time_as']} == \
        {c.log: r.log for c, r in zip(copies, rs)}


@pytest.mark.parametrize('second, twice', [
    ((0.0, 24), True),          # the same day
    ((0.25, 12), True),         # a recording of half of it
    ((0.9, 24), False),         # the next log, overlapping by a rotation's 2.4 h
    ((1.0, 24), False),         # the next day
])
def test_same_time_as_takes_the_fuller_log(second, twice):
    from steer_monitor.ashore.fleet import same_time_as
    rs = [_result('a.log', 0, 24, 0.2), _result('b.log', *second, 0.2, frames=500)]
    assert same_time_as(rs) == ({1: 0} if twice else {})
    assert same_time_as(rs[::-1]) == ({0: 1} if twice else {})
    failed = LogResult.failed('mv', 'c.log', 'c', 'cfg', 'no frame')
    assert same_time_as([failed, *rs]) == ({2: 1} if twice else {})


def test_an_outlier_is_named_by_its_own_log(r18_params):
    """The trend's outliers are indices into its points; they were looked up among all the
    vessel's logs, so a log that failed before it shifted the name onto its neighbour."""
    rs = [_result(f'd{d:03d}.log', d, 24, 0.20 + 0.0004 * d) for d in range(0, 300, 30)]
    rs[6] = _result('bad_day.log', 180, 24, 0.40)
    failed = LogResult.failed('mv', 'broken.log', 'x', 'cfg', 'no frame in broken.log')
    v = _fleet([failed, *rs], r18_params)
    assert v['trend']['clearance_zgb_mm']['outliers'] == ['bad_day.log']


def test_the_page_says_which_log_was_left_out_of_the_trend(r18_params):
    from steer_monitor.ashore.fleet import FleetRun, Vessel
    from steer_monitor.ashore.fleetpage import fleet_page
    rs = [_result(f'd{d:03d}.log', d, 24, 0.20 + 0.0004 * d) for d in range(0, 120, 30)]
    rs.append(_result('d000.log.gz', 0, 24, 0.2, frames=10))
    page = fleet_page(FleetRun([Vessel('mv', Path('mv'), None, ())], {'mv': rs}, {'mv': dict(r18_params)}))
    assert 'd000.log.gz (the time of d000.log: not in the trend)' in page


def test_a_vessel_whose_map_reverses_a_ram_has_its_logs_failed_with_the_reason(tmp_path, r18_params, can_db):
    """Its logs gave no estimate and no word of why (the review's note was not kept)."""
    from steer_monitor.ashore.store import log_result
    from test.conftest import PKG
    db, smap = can_db
    s = sim.run(r18_params, sim.SimConfig(program='autopilot:600'), db, smap, seed=8)
    log = tmp_path / 'a.log'
    with open(log, 'wb') as fh:
        write_candump(fh, s.frames)
    text = (PKG / 'config' / 'r18.yaml').read_text()
    swapped = text.replace('pressure_r2_stbd: {pgn: 130314, field: Pressure, instance: 2',
                           'pressure_r2_stbd: {pgn: 130314, field: Pressure, instance: 9').replace(
        'pressure_r2_port: {pgn: 130314, field: Pressure, instance: 3',
        'pressure_r2_port: {pgn: 130314, field: Pressure, instance: 2').replace('instance: 9', 'instance: 3')
    assert swapped != text
    cfg = tmp_path / 'vessel.yaml'
    cfg.write_text(swapped)
    r = log_result('mv', str(log), str(cfg), 'x', 'y')
    assert r.error.startswith('the rams push against each other') and 'of ram 2 are read the wrong way round' in r.error
    assert r.error.endswith('; nothing estimated') and r.frames == len(s.frames)
    assert log_result('mv', str(log), None, 'x', 'y').error == ''


def test_a_script_without_the_main_guard_is_told_what_to_do(tmp_path):
    """A script that runs the fleet at its top level made every spawned worker start a
    cluster of its own, and ended in "Nanny failed to start": now the error says why."""
    import subprocess
    import sys
    script = tmp_path / 'fleet_script.py'
    script.write_text('from steer_monitor.ashore.fleet import make_client\nmake_client(1, None)\n')
    env = dict(os.environ, ROS_AUTOMATIC_DISCOVERY_RANGE='LOCALHOST')
    done = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, timeout=180, env=env,
                          check=False)
    assert done.returncode != 0
    assert "call the fleet under `if __name__ == '__main__':`" in done.stderr.splitlines()[-1], done.stderr[-2000:]


def test_the_trend_uses_judged_logs_only_and_says_no_wear(r18_params):
    """A year of a steady slipper (0.20 mm): no date, "no wear seen over 11 months". Logs whose
    model did not explain their pressures, reading higher and higher, would have made a wear of
    it: they are shown (NOT ASSESSED) and left out of the trend."""
    from dataclasses import replace
    rs = [_result(f'd{d:03d}.log', d, 24, 0.20 + 0.003 * (-1) ** (d // 30)) for d in range(0, 360, 30)]
    v = _fleet(rs, r18_params)
    tr = v['trend']['clearance_zgb_mm']
    assert tr['limit_date_utc'] is None and tr['wear_seen'] is False
    assert tr['message'].startswith('no wear seen over 11 months (12 logs; rate ')
    bad = [replace(r, verdict='unexplained', z_gb=r.z_gb + 0.01e-3 * k, z_gb_lo=r.z_gb_lo + 0.01e-3 * k,
                   z_gb_hi=r.z_gb_hi + 0.01e-3 * k) if k >= 8 else r for k, r in enumerate(rs)]
    v = _fleet(bad, r18_params)
    tr = v['trend']['clearance_zgb_mm']
    assert tr['estimates_used'] == 8 and tr['limit_date_utc'] is None
    assert [lg['clearance_zgb_mm']['level'] for lg in v['logs']][8:] == ['NOT ASSESSED'] * 4


def test_the_page_shows_each_clearance_with_its_own_level(r18_params):
    """2Z a lower bound (not assessed) beside a Z_gb past its warning share: the page gives each
    clearance its own level, not the log's worst in one column."""
    from steer_monitor.ashore.fleet import FleetRun, Vessel
    from steer_monitor.ashore.fleetpage import fleet_page
    from steer_monitor.ashore.store import LogResult
    warn = 0.9 * r18_params['clearances.limit_zgb_mm'] * 1e-3
    start = int(1_767_225_600 * 10**9)
    r = LogResult('mv', 'a.log', 'a.log', 'cfg', start, start + 3_600 * 10**9, 1000, 0.1e-3, 0.08e-3, math.nan,
                  warn, warn - 1e-5, warn + 1e-5, 0.6, 0.59, 0.61, '[]', '[]', '', '[]')
    page = fleet_page(FleetRun([Vessel('mv', Path('mv'), None, ())], {'mv': [r]}, {'mv': dict(r18_params)}))
    row = next(line for line in page.split('<tr>') if 'a.log' in line)
    cells = row.split('<td>')
    assert 'NOT ASSESSED' in cells[3] and 'WARN' in cells[4] and 'NOT ASSESSED' not in cells[4]


def test_the_fleet_says_when_a_clearance_left_what_the_pressures_can_show(r18_params):
    """2Z assessed in the first logs, then a lower bound past the gear's reach (the bushing worn
    past what clamps at its largest loads): the vessel says since when, and the logs' trend up
    to then; a log's clearance carries its reach."""
    import dataclasses
    reach = json.dumps([[0.2e-3, 0.21e-3, 0.61, 8.23, 0.25e-3], [0.5e-3, 0.6e-3, 0.61, 8.23, 0.2e-3]])
    rs = [dataclasses.replace(_result(f'd{d:03d}.log', d, 24, 0.20), reach_json=reach) for d in range(0, 150, 30)]
    worn = [dataclasses.replace(r, two_z=0.2e-3, two_z_lo=0.2e-3, two_z_hi=math.nan) for r in rs[3:]]
    v = _fleet(rs[:3] + worn, r18_params)
    b = v['beyond_reach']['clearance_2z_mm']
    assert b['log'] == 'd090.log' and b['since_utc'].startswith('2026-04-01') and b['gear_mm'] == 0.21
    assert b['message'].startswith('beyond what the pressures can show on this gear') and 'survey' in b['message']
    assert v['beyond_reach']['clearance_zgb_mm'] is None
    assert v['logs'][0]['clearance_2z_mm']['observable_to_mm'] == {'loads_seen': 0.2, 'gear': 0.21,
                                                                   'at_other_mm': 0.25, 'other_lower_bound': False}
    assert _fleet(rs, r18_params)['beyond_reach']['clearance_2z_mm'] is None
