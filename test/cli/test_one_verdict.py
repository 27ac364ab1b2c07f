"""One verdict everywhere: on the same data, `analyze`, `report` and the node (its clearances
status, given the analysis it would run on those data) give each clearance the same level."""

from __future__ import annotations

import json

import pytest

from steer_monitor import sim
from steer_monitor.can import Decoder
from steer_monitor.cli.main import main
from steer_monitor.estimate.analyze import analyze
from steer_monitor.estimate.finding import finding_of
from steer_monitor.logfiles.logs import LogWriter
from steer_monitor.model.gear import Clearances
from steer_monitor.monitor import DiagnosticsBuilder, DiagnosticsConfig, LiveMonitor
from steer_monitor.params import gear_from_params, min_clearance_2z_from_params


@pytest.mark.slow
@pytest.mark.parametrize('two_z, z_gb, seed', [(0.40, 0.24, 61), (0.08, 0.15, 62), (0.45, 0.28, 63)])
def test_analyze_report_and_the_node_give_each_clearance_one_level(tmp_path, capsys, r18_params, can_db, two_z,
                                                                   z_gb, seed):
    """A worn slipper at 96 % of its limit beside a ram bushing past what the pressures show,
    both clearances small, and a slipper past its limit: the level of each clearance is the
    same in `analyze --json`, `report --json` and the node's clearances status."""
    db, smap = can_db
    s = sim.run(r18_params, sim.SimConfig(program='hard_over_2,zigzag_20,zigzag_10',
                                          gaps=Clearances.from_mm(two_z, z_gb)), db, smap, seed)
    log = tmp_path / 'v.log'
    with LogWriter(log) as w:
        for f in s.frames.frames():
            w.write(f)
    levels = {}
    for cmd, extra in (('analyze', []), ('report', ['--out', str(tmp_path / 'rep')])):
        assert main([cmd, str(log), '--json', '-', *extra]) == 0
        d = json.loads(capsys.readouterr().out)
        d = d.get('clearances', d)
        levels[cmd] = (d['clearance_2z_mm']['level'], d['clearance_zgb_mm']['level'])
    gear = gear_from_params(r18_params)
    signals = Decoder(db, smap).decode_arrays(s.frames, final=True)
    a = analyze(gear, signals, min_clearance_2z=min_clearance_2z_from_params(r18_params))
    mon = LiveMonitor(gear, Clearances.from_mm(0.6, 0.25))
    mon.set_finding(finding_of(a, int(s.frames.t_ns[-1]) + 1, 'loop'))
    st = DiagnosticsBuilder(DiagnosticsConfig.from_params(r18_params), smap, gear).clearances(mon)
    levels['node'] = (st.value('clearance_2z_level'), st.value('clearance_zgb_level'))
    assert levels['analyze'] == levels['report'] == levels['node'], levels
