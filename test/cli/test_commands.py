"""The steer-monitor subcommands: JSON shapes, text output, and errors as messages."""

from __future__ import annotations

import io
import json

import pytest

from steer_monitor.cli import backlash, fit, loadshare, study
from steer_monitor.cli.main import main
from steer_monitor.studies.tables import ROW_KEYS
from test.conftest import PKG, fill

CHAIN = PKG / 'config' / 'r18_chain.yaml'


def _json(run, *args, **kwargs):
    out = io.StringIO()
    assert run(*args, json_out='-', out=out, **kwargs) == 0
    return json.loads(out.getvalue())


def test_fit_json():
    s = _json(fit.run, '240 H9/f9')
    assert (round(s['clearance_min_mm'], 3), round(s['clearance_max_mm'], 3)) == (0.050, 0.280)
    assert (round(s['probable_min_mm'], 3), round(s['probable_max_mm'], 3)) == (0.084, 0.246)
    assert s['hole_mm'] == {'upper': pytest.approx(0.115), 'lower': 0.0}


def test_loadshare_json_rows_and_plot(tmp_path):
    png = tmp_path / 'fig7.png'
    s = _json(loadshare.run, None, 0.6, 0.25, None, png)
    rows = s['rows']
    assert len(rows) == 71
    assert [r['alpha_deg'] for r in rows[:3]] == [0.0, 0.5, 1.0] and rows[-1]['alpha_deg'] == 35.0
    assert set(rows[0]) == set(ROW_KEYS)
    r275 = next(r for r in rows if r['alpha_deg'] == 27.5)
    assert r275['k_gl'] == pytest.approx(0.59, abs=0.01)
    assert r275['torque_knm'] == pytest.approx(930.0)
    assert r275['f_ram_n'] + r275['f_guide_n'] == pytest.approx(r275['f_lateral_n'])
    assert s['landmarks']['guide_onset_deg'] == pytest.approx(10.0, abs=0.1)
    assert png.stat().st_size > 10_000 and png.read_bytes()[:4] == b'\x89PNG'


def test_loadshare_speed_scales_torque():
    half = _json(loadshare.run, None, 0.6, 0.25, 8.0)
    r = next(r for r in half['rows'] if r['alpha_deg'] == 35.0)
    assert r['torque_knm'] == pytest.approx(250.0)


def test_backlash_json_with_limit():
    s = _json(backlash.run, CHAIN, 10.0, 8.0, 'worst')
    assert len(s['joints']) == 4
    assert s['limit']['coarsest_grade'] == 9
    assert s['at_worst_angle_arcmin']['worst_max'] > s['at_angle_arcmin']['worst_max']


@pytest.mark.parametrize('argv,msg', [
    (['fit', '240 X9/f9'], "only hole-basis fits (hole H) are supported, got hole 'X'"),
    (['loadshare', '--gap-2z', '-1'], '--gap-2z must be a clearance of at least 0 mm, got -1 mm'),  # its words
    # 20 times its limit: refused, not a table of a gear that cannot be in service
    (['loadshare', '--gap-zgb', '5'], '--gap-zgb 5 mm is 20 times the 0.25 mm wear limit (clearances.limit_zgb_mm): '
                                      'a gear worn so far is out of service; give at most 1 mm'),
    (['simulate', '--gap-2z', '3', '--out', 'x.log'], '--gap-2z 3 mm is 5 times the 0.6 mm wear limit'),
    (['loadshare', '--speed-kn', '99'], '--speed-kn must lie in [0, 60] kn'),
    (['loadshare', '--config', 'nope.yaml'], 'cannot read parameters file nope.yaml'),
    (['backlash', str(CHAIN), '--angle-deg', '50'], "--angle-deg 50 is outside the chain's range"),
])
def test_errors_are_messages_not_tracebacks(capsys, argv, msg):
    assert main(argv) == 1
    err = capsys.readouterr().err
    assert err.startswith(f'steer-monitor {argv[0]}: error: ')
    assert msg in err
    assert 'Traceback' not in err


@pytest.mark.parametrize(
    'text,msg',
    [
        ('chain: {stock_to_ram_m: 0.6, joints: []}', 'chain.joints: expected a non-empty list'),
        ('chain: {stock_to_ram_m: 0.6, joints: [{name: a, fit: 180 H7/q7}]}', "chain.joints[0].fit: fit '180 H7/q7'"),
        (
            'chain: {stock_to_ram_m: 0.6, joints: [{name: a, nominal_mm: 50.0, hole_mm: [0.1]}]}',
            'chain.joints[0]: missing shaft_mm',
        ),
        (
            'chain: {stock_to_ram_m: 0.6, joints: [{name: a, fit: 50 H7/g6, colour: red}]}',
            "chain.joints[0]: unknown key 'colour'",
        ),
        ('chain: {joints: [{name: a, fit: 50 H7/g6}]}', 'chain.stock_to_ram_m: missing'),
        (
            'chain: {stock_to_ram_m: 0.6, joints: [{name: a, nominal_mm: 50.0, hole_mm: [0.0, 0.1], '
            'shaft_mm: [0.0, -0.1]}]}',
            'upper deviation 0.0000 mm is below lower deviation 0.1000 mm',
        ),
    ],
)
def test_bad_chain_files(tmp_path, capsys, text, msg):
    path = tmp_path / 'c.yaml'
    path.write_text(text)
    assert main(['backlash', str(path)]) == 1
    assert msg in capsys.readouterr().err


def test_study_writes_plots_and_summary(tmp_path):
    out = io.StringIO()
    assert study.run(tmp_path, None, out) == 0
    text = out.getvalue()
    assert "The paper's claim" in text and 'The model disagrees' in text
    summary = json.loads((tmp_path / 'summary.json').read_text())
    assert summary['loadshare_at_limits']['landmarks']['crossover_deg'] == pytest.approx(21.0, abs=1.0)
    gap = summary['gap_study']
    j = gap['z_gb_mm'].index(0.25)
    kmax = [row[j] for row in gap['k_gl_max']]
    # The physics answer to the paper: K_gl never grows as 2Z shrinks.
    assert all(a <= b + 1e-12 for a, b in zip(kmax, kmax[1:]))
    for name in ('fig7_load_sharing.png', 'gap_study.png'):
        assert (tmp_path / name).read_bytes()[:4] == b'\x89PNG'


def test_study_writes_its_three_files_or_none_on_a_disk_that_fills_midway(tmp_path, small_tmpfs, capsys):
    # room for the largest plot alone, not for it and the rest: the first files written one
    # by one would have been left without the summary that lists them
    assert study.run(tmp_path, None, io.StringIO()) == 0
    sizes = {p.name: p.stat().st_size for p in tmp_path.iterdir()}
    fill(small_tmpfs)
    filler = small_tmpfs / 'filler.bin'
    with open(filler, 'r+b') as fh:
        fh.truncate(max(0, filler.stat().st_size - (sizes['fig7_load_sharing.png'] + 16384)))
    out = small_tmpfs / 'study'
    out.mkdir()
    assert main(['study', '--out', str(out)]) == 1
    err = capsys.readouterr().err
    assert 'No space left on device' in err and err.count('\n') == 1 and 'Traceback' not in err
    assert sorted(p.name for p in out.iterdir()) == []


def test_console_script_help(capsys):
    with pytest.raises(SystemExit) as exc:
        main(['--help'])
    assert exc.value.code == 0
    out = capsys.readouterr().out
    for command in ('fit', 'backlash', 'loadshare', 'simulate', 'inspect', 'run', 'recover', 'study', 'demo'):
        assert command in out


@pytest.mark.parametrize(('values', 'text'), [
    ({'residual_rms_bar': '0.68', 'residual_instants_not_judged': '3'}, '0.68 bar'),
    ({'residual_rms_bar': 'n/a', 'residual_instants_not_judged': '412'},
     'n/a (412 instants not judged: a clearance known from below only)'),
    ({'residual_rms_bar': 'n/a', 'residual_instants_not_judged': '0'}, 'n/a'),
    ({}, 'n/a'),
])
def test_the_demo_says_why_the_residual_is_missing(values, text):
    from steer_monitor.cli.demo import residual_text
    assert residual_text(values) == text


@pytest.mark.parametrize('argv', [['fit', '240 H9/f9'], ['loadshare', '--gap-2z', '0.6'],
                                  ['backlash', str(CHAIN), '--angle-deg', '20']])
def test_json_to_a_file_is_what_stdout_gets_and_the_text_still_prints(tmp_path, capsys, argv):
    """`--json OUT` means the same on every command: `-` prints JSON instead of the text, a
    file name gets the same JSON while the text still goes to stdout."""
    assert main([*argv, '--json', '-']) == 0
    to_stdout = json.loads(capsys.readouterr().out)
    target = tmp_path / 'answer.json'
    assert main([*argv, '--json', str(target)]) == 0
    text = capsys.readouterr().out
    assert json.loads(target.read_text()) == to_stdout
    assert text.strip() and not text.lstrip().startswith('{'), text


def test_every_json_option_takes_a_file_or_dash():
    """No command's --json is a bare flag where another's takes a file: one spelling, OUT."""
    from steer_monitor.cli.main import build_parser
    parser = build_parser()
    subs = next(a for a in parser._actions if a.choices and 'fit' in a.choices).choices
    found = {}
    for name, p in subs.items():
        for a in p._actions:
            if '--json' in a.option_strings:
                found[name] = (a.nargs, a.metavar, a.dest)
    assert len(found) >= 12, found
    assert set(found.values()) == {(None, 'OUT', 'json_out')}, found


def test_replay_and_report_say_the_verdict_or_why_there_is_none(tmp_path, capsys):
    """A replay of 70 s says no analysis ran and what motion it wanted; a report ends with one
    line per clearance (value or bound, share of the limit, level), the rams check and the model
    check."""
    from steer_monitor.cli.main import main
    log = tmp_path / 'h.log'
    assert main(['simulate', '--program', 'hard_over_2', '--max-duration', '80', '--out', str(log)]) == 0
    capsys.readouterr()
    assert main(['replay', str(log), '--out', str(tmp_path / 'r.mcap'), '--no-frames']) == 0
    out = capsys.readouterr().out
    assert 'no analysis ran: ' in out and 's of steady rudder motion seen, 240 s needed for the first' in out, out
    assert main(['report', str(log), '--out', str(tmp_path / 'rep')]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].startswith('report of ') and lines[1].startswith('2Z      >= ') and 'NOT ASSESSED' in lines[1]
    assert lines[2].startswith('Z_gb    ') and '% of the 0.25 mm limit  ' in lines[2]
    assert lines[3] == 'rams    OK: the rams shared the driving force evenly wherever it was judged'
    assert lines[4].startswith('model check: ')


def test_loadshare_words_agree_with_its_table(capsys):
    """A slipper without clearance: K_gl > 0 from the first step, and the summary once said the
    guide beam carried load "from not reached"."""
    from steer_monitor.cli.main import main
    assert main(['loadshare', '--gap-zgb', '0']) == 0
    last = capsys.readouterr().out.splitlines()[-1]
    assert last.startswith('the guide beam carries load from 0.0 deg; the guide beam carries more than the rams')
    assert last.endswith('the ram never clamps in its bushing')
    assert 'not reached' not in last


def test_fit_says_what_a_negative_clearance_is(capsys):
    from steer_monitor.cli.main import main
    assert main(['fit', '240 H7/k6']) == 0
    assert capsys.readouterr().out.splitlines()[-1] == (
        '  a negative clearance is interference (the shaft larger than the hole): a transition fit: from '
        'interference to clearance')
    assert main(['fit', '240 H9/f9']) == 0
    assert 'interference' not in capsys.readouterr().out


def test_loadshare_says_what_carries_the_load_in_words(capsys):
    """The table's last column once read "2" and "4": the paper's case numbers alone."""
    from steer_monitor.cli.main import main
    assert main(['loadshare']) == 0
    rows = capsys.readouterr().out.splitlines()
    assert 'carried by (paper 004)' in rows[1]
    assert rows[3].endswith('ram, pinned (case 2)')
    assert any(r.endswith('ram + guide beam (case 4)') for r in rows)
