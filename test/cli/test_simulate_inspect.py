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


def test_inspect_gives_each_signal_its_own_timing_and_what_a_slow_rate_limits(tmp_path, capsys):
    """Through a gateway at 2 Hz (angle) and 0.5 Hz (pressures), 2 % of frames lost: each
    signal's own period, its jitter and the frames lost; gaps judged against its own period
    (the outage of 5 s, none for the 2 s between pressure frames); the note on what the rates
    limit and how to raise them."""
    path = tmp_path / 'gw.log'
    out = io.StringIO()
    assert simulate.run(None, 'zigzag_10', path, seed=3, json_out='-', out=out,
                        gateway='rudder=2,pressure=0.5,loss=0.02,outage=60+5') == 0
    report = inspect.inspect_log(path)
    angle, p = report['signals']['rudder_angle'], report['signals']['pressure_r1_stbd']
    assert angle['period_s'] == pytest.approx(0.5, abs=0.005) and p['period_s'] == pytest.approx(2.0, abs=0.02)
    assert angle['jitter_s'] <= 0.011 and 0 < angle['frames_lost'] < 0.1 * angle['samples']
    assert any(g['length_s'] > 5 for g in angle['gaps']) and all(g['length_s'] > 1.5 for g in angle['gaps'])
    assert all(g['length_s'] > 3.0 for g in p['gaps'])
    note = next(n for n in report['notes'] if n.startswith('rates: '))
    assert note.startswith('rates: the rudder angle every 0.50 s (2 Hz) and the pressures every 2.00 s (0.5 Hz), '
                           'slower than a direct tap')
    assert 'PGN 126208' in note
    assert inspect.run(path, out=io.StringIO()) == 0
    full = tmp_path / 'full.log'
    simulate.run(None, 'zigzag_10', full, seed=3, out=io.StringIO())
    assert not [n for n in inspect.inspect_log(full)['notes'] if n.startswith('rates: ')]
