"""``steer-monitor analyze``: the JSON contract and the report on a short simulated log."""

from __future__ import annotations

import json

import pytest

from steer_monitor.cli.main import main

pytestmark = pytest.mark.slow


def test_analyze_writes_the_documented_json_and_a_report(tmp_path, capsys):
    log = tmp_path / 'h.log'
    assert main(['simulate', '--program', 'hard_over_2,zigzag_20', '--max-duration', '150', '--out', str(log)]) == 0
    out, html = tmp_path / 'a.json', tmp_path / 'a.html'
    capsys.readouterr()
    assert main(['analyze', str(log), '--json', str(out), '--report', str(html)]) == 0
    d = json.loads(out.read_text())
    # a 2Z the data bound from below only is printed as that bound, not as the profile's
    # best point on its plateau (it read as an estimate: 2Z 0.3 mm for a true 0.7 mm)
    text = capsys.readouterr().out
    first = text.splitlines()[0]
    lo = d['clearance_2z_mm']['ci95'][0]
    # two hard-overs at service speed held the gear's largest loads: no manoeuvre can show more,
    # and a bound below the limit is given no share of it
    reach = d['clearance_2z_mm']['observable_to_mm']
    assert reach['loads_seen'] == pytest.approx(reach['gear'], abs=0.02) and lo > 0
    assert first.startswith(f"2Z      >= {lo} mm (lower bound only)  NOT ASSESSED: "
                            'lower bound only (no clamping of the ram in its bushing shows at the loads seen); '
                            'beyond what the pressures can show on this gear: at Z_gb '), first
    assert first.endswith(f"the ram clamps in its bushing only for 2Z up to {reach['gear']:.3f} mm, even at a "
                          'hard-over to 35 deg at 16 kn; measure it at the next survey'), first
    # the verdict on the terminal: one line per clearance with its level, and the model check
    assert text.splitlines()[1].startswith('Z_gb    ') and ' of the 0.25 mm limit  ' in text.splitlines()[1]
    assert any(line.startswith('model check: declared: ') for line in text.splitlines())
    for key in ('clearance_2z_mm', 'clearance_zgb_mm'):
        assert set(d[key]) == {'value', 'ci95', 'bounded', 'level', 'note', 'limit_mm', 'observable_to_mm'}
        assert len(d[key]['ci95']) == 2
        assert d[key]['bounded'] == (None not in d[key]['ci95'])
    assert d['clearance_2z_mm']['ci95'][1] is None          # the ram never clamps at 0.6 mm
    assert d['clearance_zgb_mm']['ci95'][0] <= 0.25 <= d['clearance_zgb_mm']['ci95'][1]
    assert {'k_gl_max', 'effect', 'effects', 'unexplained', 'rmse_before_n', 'rmse_after_n', 'verdict',
            'message'} <= set(d)
    assert d['effect'] is None and d['effects'] == [] and d['unexplained'] is None
    assert d['rmse_after_n'] == d['rmse_before_n']
    page = html.read_text()
    assert page.count('<img') == 3 and 'data:image/png;base64,' in page


def test_analyze_of_a_log_without_motion_says_why(tmp_path, capsys):
    log = tmp_path / 'hold.log'
    assert main(['simulate', '--program', 'hold:20', '--out', str(log)]) == 0
    assert main(['analyze', str(log), '--json', '-']) == 1
    assert 'too little steady rudder motion' in capsys.readouterr().err


def test_analyze_of_a_slowly_sampled_log_with_too_little_motion_names_the_rates(tmp_path, capsys):
    """Ten minutes through a gateway at NMEA 2000's slow default (0.5 Hz): refused with the
    rates, what they limit, the minutes of steering at this pace that would be enough and how to
    raise the rates; not 'N ram samples' as if the data came at the design rate."""
    log = tmp_path / 'slow.log'
    assert main(['simulate', '--program', 'realistic:600', '--seed', '3', '--gateway', 'rudder=0.5,pressure=0.5',
                 '--out', str(log)]) == 0
    capsys.readouterr()
    assert main(['analyze', str(log)]) == 1
    err = capsys.readouterr().err
    assert err.count('\n') == 1 and 'Traceback' not in err
    assert 'rows of steady motion, need 200: this log has the rudder angle every 2.00 s (0.5 Hz) and the pressures ' \
        'every 2.00 s (0.5 Hz), slower than a direct tap' in err
    assert 'minutes of steering would be enough' in err and 'PGN 126208' in err


def test_an_unexplained_residual_is_located_in_the_json_and_plotted(tmp_path):
    """The band of extra friction outside the library: ``unexplained`` names the angle band,
    the ram and the direction, and the report plots the residual against the angle."""
    log = tmp_path / 'band.log'
    assert main(['simulate', '--program', 'voyage', '--effect', 'band_friction:lo_deg=8,hi_deg=14', '--seed', '21',
                 '--out', str(log)]) == 0
    out, html = tmp_path / 'a.json', tmp_path / 'a.html'
    assert main(['analyze', str(log), '--json', str(out), '--report', str(html)]) == 0
    d = json.loads(out.read_text())
    assert d['verdict'] == 'unexplained'
    u = d['unexplained']
    assert set(u) >= {'variable', 'range', 'systematic_bar', 'ram', 'direction', 'message'}
    assert u['variable'] == 'alpha_deg' and u['either_side'] and u['ram'] == 'both' and u['direction'] == 'both'
    assert abs(u['range'][0] - 8) < 0.5 and abs(u['range'][1] - 14) < 0.5 and u['systematic_bar'] > 0.3
    assert u['message'] in d['message'] and 'incomplete model' in d['message']
    assert d['clearance_zgb_mm']['ci95'][0] <= 0.25 <= d['clearance_zgb_mm']['ci95'][1]
    page = html.read_text()
    assert page.count('<img') == 4 and 'Where the unexplained residual lives' in page
