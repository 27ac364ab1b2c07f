"""simulate -> file -> inspect gives back the sample counts; inspect reports rejects and gaps."""

from __future__ import annotations

import io
import json

import pytest

from steer_monitor.cli import inspect, simulate
from steer_monitor.cli.main import main


@pytest.mark.parametrize('suffix', ['.log', '.blf', '.mcap'])
def test_round_trip_sample_counts(tmp_path, suffix):
    path = tmp_path / f'voyage{suffix}'
    out = io.StringIO()
    assert simulate.run(None, 'hard_over_2,hold:20', path, seed=3, json_out='-', out=out) == 0
    truth = json.loads(out.getvalue())
    report = inspect.inspect_log(path)
    assert report['frames'] == truth['frames']
    sig = report['signals']
    assert sig['rudder_angle']['samples'] == truth['samples']['rudder']
    assert sig['rudder_order']['samples'] == truth['samples']['rudder']
    for name in ('pressure_r1_stbd', 'pressure_r1_port', 'pressure_r2_stbd', 'pressure_r2_port',
                 'ship_speed', 'oil_temperature'):
        assert sig[name]['samples'] == truth['samples'][name], name
        assert sig[name]['gaps_over_1s'] == 0
    assert report['rejects'] == {}
    assert report['span_s'] == pytest.approx(truth['duration_s'], abs=0.1)


def test_inspect_reports_gaps_and_rejects(tmp_path, capsys):
    src = tmp_path / 'a.log'
    simulate.run(None, 'hold:10', src, seed=1, out=io.StringIO())
    lines = src.read_text().splitlines()
    # Silence the pressure transducers for 3 s, add a bad line and an unknown PGN.
    t_cut = (1767225600 + 3, 1767225600 + 6)
    kept = [ln for ln in lines if not ('15FD0A2' in ln and t_cut[0] <= float(ln[1:18]) < t_cut[1])]
    kept.insert(5, 'not a frame')
    kept.insert(6, '(1767225600.050000) can0 0DF80105#0000000000000000')
    bad = tmp_path / 'b.log'
    bad.write_text('\n'.join(kept) + '\n')
    assert main(['inspect', str(bad), '--json', '-']) == 0
    report = json.loads(capsys.readouterr().out)
    assert report['rejects'] == {'malformed_record': 1, 'unknown_id': 1}
    assert report['reject_reasons']['unknown_id'] == 'unknown identifier: PGN not in the DBC'
    for name in ('pressure_r1_stbd', 'pressure_r2_port'):
        gaps = report['signals'][name]['gaps']
        assert len(gaps) == 1 and gaps[0]['length_s'] == pytest.approx(3.0, abs=0.06)
    assert report['signals']['rudder_angle']['gaps_over_1s'] == 0


def test_simulate_needs_one_target(capsys):
    with pytest.raises(SystemExit):
        main(['simulate'])
    assert 'one of the arguments --out --bus is required' in capsys.readouterr().err


def test_simulate_bad_bus(capsys):
    assert main(['simulate', '--bus', 'virtual']) == 1
    assert "--bus 'virtual': expected INTERFACE:CHANNEL" in capsys.readouterr().err


def test_simulate_starts_at_the_time_given(tmp_path, capsys):
    """A simulated fleet needs logs at their own dates: --start sets the log's clock."""
    out = tmp_path / 'march.log'
    assert main(['simulate', '--max-duration', '3', '--start', '2026-03-01T08:00:00Z', '--out', str(out)]) == 0
    first = float(out.read_text().split()[0].strip('()'))
    assert 1772352000.0 <= first < 1772352001.0
    truth = json.loads((tmp_path / 'march.truth.json').read_text())
    assert truth['start_utc'] == '2026-03-01T08:00:00.000Z'
    capsys.readouterr()
    with pytest.raises(SystemExit) as exc:
        main(['simulate', '--max-duration', '3', '--start', 'yesterday', '--out', str(tmp_path / 'y.log')])
    assert exc.value.code == 2
    assert "argument --start: 'yesterday' is not an ISO 8601 time" in capsys.readouterr().err


def test_inspect_says_any_where_the_map_takes_any_address(tmp_path, capsys):
    """The table printed "-1" for an address the signals map leaves open (the JSON's -1)."""
    src = tmp_path / 'a.log'
    simulate.run(None, 'hold:5', src, seed=1, out=io.StringIO())
    assert main(['inspect', str(src)]) == 0
    rows = capsys.readouterr().out.splitlines()
    angle = next(r for r in rows if r.startswith('rudder_angle '))
    assert angle.split()[3] == 'any' and ' -1 ' not in angle
