"""One rams check: the node (as a replay publishes it), analyze and report judge the same log
alike, name the ram and its UTC stretch, and say so for a bypass over the whole log."""

from __future__ import annotations

import json

import pytest

from steer_monitor.cli.main import main
from steer_monitor.utc import parse_utc

BYPASS = ('ram_bypass:ram=2,start_s=150,end_s=330')
T0 = 1_767_225_600_000_000_000          # the simulator's start


def _statuses(path):
    from rosbags.highlevel import AnyReader
    out = []
    with AnyReader([path]) as r:
        for conn, t, raw in r.messages():
            if conn.topic == '/diagnostics':
                msg = r.deserialize(raw, conn.msgtype)
                out += [(t, st) for st in msg.status if st.name.endswith('rams')]
    return out


@pytest.fixture(scope='module')
def bypassed(tmp_path_factory):
    d = tmp_path_factory.mktemp('rams')
    log = d / 'bypass.log'
    assert main(['simulate', '--program', 'realistic:600', '--effect', BYPASS, '--seed', '41', '--out', str(log)]) == 0
    return log


def test_node_analyze_and_report_agree_on_the_stretch(bypassed, tmp_path, capsys):
    assert main(['analyze', str(bypassed), '--json', str(tmp_path / 'a.json')]) == 0
    assert main(['report', str(bypassed), '--out', str(tmp_path / 'rep'), '--json', str(tmp_path / 'r.json')]) == 0
    assert main(['replay', str(bypassed), '--out', str(tmp_path / 'r.mcap')]) == 0
    capsys.readouterr()
    a = json.loads((tmp_path / 'a.json').read_text())['rams']
    r = json.loads((tmp_path / 'r.json').read_text())['rams']
    assert [sp['ram'] for sp in a['uneven']] == [sp['ram'] for sp in r['uneven']] == [2]
    sa, sr = a['uneven'][0], r['uneven'][0]
    assert abs(sa['start_ns'] - sr['start_ns']) <= 3e9 and abs(sa['end_ns'] - sr['end_ns']) <= 3e9
    assert 140 <= (sa['start_ns'] - T0) / 1e9 <= 160 and 320 <= (sa['end_ns'] - T0) / 1e9 <= 345, sa
    assert a['verdict'] == r['verdict'] and a['verdict'].startswith('rams    ERROR: ram 2 carried ')
    rams = _statuses(tmp_path / 'r.mcap')
    bad = [(t - T0) / 1e9 for t, st in rams if st.level in (b'\x01', b'\x02', 1, 2)]
    assert bad and sa['start_ns'] <= T0 + bad[0] * 1e9 and bad[-1] * 1e9 + T0 <= sa['end_ns'] + 60e9, (bad[0], bad[-1])
    for _, st in rams:            # OK follows its own band: an even window's share lies inside 35-65 %
        values = {kv.key: kv.value for kv in st.values}
        if values['ram_share_window_said'] == 'even':
            assert 35.0 <= float(values['ram_1_share_pct']) <= 65.0, st.message
        if st.level in (b'\x01', b'\x02', 1, 2):
            assert 'ram 2 ' in st.message and ' since ' in st.message
    last = {kv.key: kv.value for kv in rams[-1][1].values}
    assert abs(parse_utc(last['ram_uneven_last_start_utc']) - sa['start_ns']) <= 30e9     # the node's own stretch
    assert abs(parse_utc(last['ram_uneven_last_end_utc']) - sa['end_ns']) <= 30e9


def test_a_bypass_over_the_whole_log_names_the_ram_and_its_times(tmp_path, capsys):
    log = tmp_path / 'whole.log'
    assert main(['simulate', '--program', 'realistic:300', '--effect', 'ram_bypass:ram=1', '--seed', '43',
                 '--out', str(log)]) == 0
    capsys.readouterr()
    assert main(['analyze', str(log)]) == 1
    err = capsys.readouterr().err.strip()
    assert err.startswith('steer-monitor analyze: error: too little steady rudder motion to estimate the clearances')
    assert 'ram 1 carried 0 % of the driving force from 2026-01-01 00:00:' in err and ' UTC (' in err
    assert 'next to no work' in err and '\n' not in err
    assert main(['report', str(log), '--out', str(tmp_path / 'rep')]) == 0
    out = capsys.readouterr().out
    assert 'rams    ERROR: ram 1 carried 0 % of the driving force from 2026-01-01 00:00:' in out
