"""``steer-monitor discover`` on real captures, as a new user would: discover, write the
parameters file, inspect with it and see the rudder; and its bad inputs."""

from __future__ import annotations

import json
import shutil

import pytest

from steer_monitor.cli.main import main
from steer_monitor.params import load_params_file
from test.support.captures import MERRIMAC, REALBUS, SUSTERANNA, SUSTERANNA_2020, capture


@pytest.mark.parametrize('path, extra, address, samples', [
    (SUSTERANNA, [], 26, 256), (SUSTERANNA_2020, [], 32, 117), (MERRIMAC, ['--date', '2020-08-22'], 13, 13)],
    ids=lambda x: getattr(x, 'name', str(x)))
def test_discover_then_inspect_sees_the_rudder(tmp_path, capsys, path, extra, address, samples):
    capture(path)
    out = tmp_path / 'vessel.yaml'
    # these buses carry a rudder angle but no ram pressures: the map is written, partial, and said so
    assert main(['discover', str(path), '--write-config', str(out), '--json', '-'] + extra) == 1
    cap = capsys.readouterr()
    d = json.loads(cap.out)
    missing = ['pressure_r1_stbd', 'pressure_r1_port', 'pressure_r2_stbd', 'pressure_r2_port']
    assert d['missing_required'] == missing and not any(d['proposed'][n]['on_bus'] for n in missing)
    assert d['proposed']['rudder_angle']['on_bus']
    assert cap.err.splitlines()[-1] == ('steer-monitor discover: error: the bus lacks inputs the monitor needs: '
                                       f'{", ".join(missing)}; the map written keeps them as the given map has them, '
                                       'so it is partial: find where the gear sends them (a longer log, another bus)')
    assert set(d) >= {'streams', 'devices', 'proposed', 'notes'}
    for s in d['streams']:
        assert set(s) >= {'pgn', 'name', 'source', 'instance', 'frames', 'rate_hz', 'first_ns', 'last_ns', 'fields'}
    assert d['proposed']['rudder_angle']['address'] == address
    for note in d['notes']:                                  # never silently: every note on stderr too
        assert f'steer-monitor discover: note: {note}' in cap.err
    params = load_params_file(out)
    assert params['signals.rudder_angle.address'] == address
    assert main(['inspect', str(path), '--config', str(out), '--json', '-'] + extra) == 0
    s = json.loads(capsys.readouterr().out)
    rudder = s['signals']['rudder_angle']
    assert rudder['samples'] == samples and rudder['min_deg'] is not None
    assert 'rudder' not in ''.join(s['reject_examples'].get('unmapped', ''))
    assert 'multi_frame' not in s['rejects'] or s['rejects']['multi_frame'] > 0


def test_text_output_and_ambiguity_on_stderr(tmp_path, capsys):
    capture(SUSTERANNA)
    assert main(['discover', str(SUSTERANNA), '--pgn-database', str(REALBUS / 'canboat.json')]) == 1
    cap = capsys.readouterr()
    assert 'NO (kept as given)' in cap.out and 'no (left out)' in cap.out     # required and optional inputs not found
    assert 'Rudder' in cap.out and 'Vessel Heading' in cap.out          # named from canboat.json
    assert 'devices (address claims):' in cap.out and 'C0508C002FB89064' in cap.out
    assert 'steer-monitor discover: note: ship_speed: 3 senders of 128259' in cap.err
    assert 'a barometer, never a ram chamber' in cap.err


def test_ydwg_date_is_said(tmp_path, capsys):
    capture(MERRIMAC)
    # the R-18's map finds no rudder angle on this vessel's bus: what it holds is shown, and why
    # it is refused (discover's map finds it: test_discover_then_inspect_sees_the_rudder)
    assert main(['inspect', str(MERRIMAC), '--date', '2020-08-22', '--json', '-']) == 1
    cap = capsys.readouterr()
    assert json.loads(cap.out)['start_utc'].startswith('2020-08-22T00:29:58')
    assert 'YDWG raw log (time of day only) read as starting on 2020-08-22 UTC, the date given' in cap.err
    assert 'no rudder angle in the data (input rudder_angle)' in cap.err
    copy = tmp_path / 'merrimac-2021-03-04.raw'
    shutil.copy(MERRIMAC, copy)
    assert main(['discover', str(copy)]) == 1      # no ram pressures on this bus
    assert 'starting on 2021-03-04 UTC, the date from the file name; give --date if that is wrong' \
        in capsys.readouterr().err


@pytest.mark.parametrize('args, status, message', [
    (['--date', '22/08/2020'], 2, "expected a date as YYYY-MM-DD, got '22/08/2020'"),
    (['--write-config', '/nonexistent/dir/x.yaml'], 1, 'cannot write /nonexistent/dir/x.yaml: no directory'),
    (['--pgn-database', '/nonexistent.json'], 1, 'cannot read PGN database /nonexistent.json'),
    (['--config', '/nonexistent.yaml'], 1, '/nonexistent.yaml'),
])
def test_bad_options_are_one_line(capsys, args, status, message):
    capture(SUSTERANNA)
    with pytest.raises(SystemExit) if status == 2 else _nothing():
        assert main(['discover', str(SUSTERANNA)] + args) == status
    err = capsys.readouterr().err
    assert message in err and 'Traceback' not in err


class _nothing:
    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return False


@pytest.mark.parametrize('content, message', [
    (b'', 'x.raw: empty file: no CAN frames'),
    (b'this is not a log\n', "unsupported log format '.raw'"),
])
def test_bad_logs_are_one_line(tmp_path, capsys, content, message):
    path = tmp_path / 'x.raw'
    path.write_bytes(content)
    assert main(['discover', str(path)]) == 1
    err = capsys.readouterr().err
    assert message in err and err.count('\n') == 1


def test_a_pgn_database_that_is_not_canboats(tmp_path, capsys):
    capture(SUSTERANNA)
    bad = tmp_path / 'x.json'
    bad.write_text('{"PGNs": 3}')
    assert main(['discover', str(SUSTERANNA), '--pgn-database', str(bad)]) == 1
    assert "is not CANboat's canboat.json" in capsys.readouterr().err


def test_a_log_of_no_frames(tmp_path, capsys):
    path = tmp_path / 'x.log'
    path.write_text('garbage\n')
    assert main(['discover', str(path)]) == 1
    err = capsys.readouterr().err
    assert f'no CAN frames in {path}' in err and err.count('\n') == 1


def test_a_bad_device_name_in_the_parameters(tmp_path, capsys):
    capture(SUSTERANNA)
    out = tmp_path / 'vessel.yaml'
    assert main(['discover', str(SUSTERANNA), '--write-config', str(out)]) == 1      # partial: no pressures
    capsys.readouterr()
    out.write_text(out.read_text().replace("device_name: ''", "device_name: not-a-name", 1))
    assert main(['inspect', str(SUSTERANNA), '--config', str(out)]) == 1
    err = capsys.readouterr().err
    assert "device_name: expected a device NAME as 16 hex digits (as discover prints it), got 'not-a-name'" in err


def test_replay_reads_a_gateway_log_with_its_date(tmp_path, capsys):
    capture(MERRIMAC)
    cfg = tmp_path / 'vessel.yaml'
    assert main(['discover', str(MERRIMAC), '--date', '2020-08-22', '--write-config', str(cfg)]) == 1   # partial
    capsys.readouterr()
    assert main(['replay', str(MERRIMAC), '--date', '2020-08-22', '--config', str(cfg), '--out',
                 str(tmp_path / 'r.mcap'), '--json', '-']) == 0
    cap = capsys.readouterr()
    r = json.loads(cap.out)
    assert r['frames'] == 914
    assert 'read as starting on 2020-08-22 UTC, the date given' in cap.err
    from steer_monitor.logfiles.blocks import read_log_fast
    frames = read_log_fast(tmp_path / 'r.mcap')
    assert len(frames) == 914 and str(frames.t_ns[0]).startswith('15980')     # 2020-08-22
    from mcap.reader import make_reader
    with open(tmp_path / 'r.mcap', 'rb') as fh:
        meta = {m.name: m.metadata for m in make_reader(fh).iter_metadata()}
    assert meta['steer_monitor']['writer'] == 'steer-monitor replay'
    assert meta['steer_monitor']['parameters_file'] == str(cfg)
    assert json.loads(meta['steer_monitor.parameters']['signals.rudder_angle.address']) == 13


def test_a_bus_with_every_input_gives_a_whole_map(tmp_path, capsys):
    """The simulator's bus carries every input: each is found, the map is whole, exit 0."""
    log, out = tmp_path / 'sim.log', tmp_path / 'vessel.yaml'
    assert main(['simulate', '--program', 'hard_over_2', '--max-duration', '20', '--out', str(log)]) == 0
    capsys.readouterr()
    assert main(['discover', str(log), '--write-config', str(out), '--json', '-']) == 0
    cap = capsys.readouterr()
    d = json.loads(cap.out)
    assert d['missing_required'] == [] and all(v['on_bus'] for v in d['proposed'].values()), d['proposed']
    assert f"then: steer-monitor inspect {log} --config {out}" in cap.err      # no placeholder


def test_the_written_config_keeps_the_comments_order_and_numbers_of_the_one_adapted(tmp_path, capsys):
    """--write-config once dropped every comment of the file it adapted (the "# H", "# L, bushing
    A to bushing E", "# assumed" hints the README tells the user to check) and wrote 2.1e+11 as
    210000000000.0. Everything but the signals' values is the original, line for line."""
    from test.conftest import R18_YAML
    log, out = tmp_path / 'sim.log', tmp_path / 'vessel.yaml'
    assert main(['simulate', '--program', 'hard_over_2', '--max-duration', '20', '--out', str(log)]) == 0
    assert main(['discover', str(log), '--write-config', str(out)]) == 0
    capsys.readouterr()
    original = R18_YAML.read_text().splitlines()
    written = out.read_text().splitlines()
    assert written[0].startswith('# Written by steer-monitor discover from ')
    body = written[written.index(original[0]):]                   # the original's first line on
    signals = next(k for k, line in enumerate(original) if line.strip() == 'signals:')
    assert body[:signals] == original[:signals]                   # gear, torque, ... as they were
    for hint in ('stock_to_ram_m: 0.600            # H', '# L, bushing A to bushing E', 'youngs_modulus_pa: 2.1e+11',
                 '# assumed'):
        assert any(hint in line for line in written), hint
    from steer_monitor.params import load_params_file
    assert load_params_file(out)['gear.youngs_modulus_pa'] == 2.1e11


def test_the_text_gives_fields_in_the_units_inspect_uses(tmp_path, capsys):
    """discover printed Pa and K where inspect prints bar and degC; the JSON keeps the DBC's units."""
    log = tmp_path / 'sim.log'
    assert main(['simulate', '--program', 'hard_over_2', '--max-duration', '5', '--out', str(log)]) == 0
    capsys.readouterr()
    assert main(['discover', str(log)]) == 0
    text = capsys.readouterr().out
    assert ' bar' in text and ' degC' in text and ' deg' in text and ' kn' in text
    assert ' Pa' not in text and ' K;' not in text and ' rad' not in text and ' m/s' not in text


def test_a_slow_input_is_said_with_how_to_raise_its_rate(tmp_path, capsys):
    """Through a gateway at 2 Hz (angle) and 0.5 Hz (pressures): discover says so per input and
    how to raise the rate (PGN 126208), and writes the rates it saw into the map."""
    log, conf = tmp_path / 'gw.log', tmp_path / 'vessel.yaml'
    assert main(['simulate', '--program', 'zigzag_10', '--seed', '4', '--gateway', 'rudder=2,pressure=0.5',
                 '--out', str(log)]) == 0
    capsys.readouterr()
    assert main(['discover', str(log), '--write-config', str(conf)]) == 0
    err = capsys.readouterr().err
    assert 'rudder_angle: PGN 127245 from address 16 comes at 2 Hz, slower than a direct tap (10 Hz)' in err
    assert 'pressure_r1_stbd: PGN 130314 from address 32 comes at 0.5 Hz, slower than a direct tap (20 Hz)' in err
    assert err.count('PGN 126208') == 5
    p = load_params_file(conf)
    assert p['signals.rudder_angle.rate_hz'] == pytest.approx(2.0, abs=0.1)
    assert p['signals.pressure_r2_port.rate_hz'] == pytest.approx(0.5, abs=0.1)


def test_a_bus_without_address_claims_is_said_once(tmp_path, capsys):
    """The simulator sends no address claim: one note for the log, not one per input."""
    log = tmp_path / 'sim.log'
    assert main(['simulate', '--program', 'hard_over_2', '--max-duration', '20', '--out', str(log)]) == 0
    capsys.readouterr()
    assert main(['discover', str(log)]) == 0
    err = capsys.readouterr().err
    assert err.count('no address claim') == 1
    assert 'no address claim in the log (none sent, or the log began after them): every input mapped by its ' \
        'address only' in err
