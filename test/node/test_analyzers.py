"""The aggregator set-up: the packaged analyzer file reaches the node aggregator_node runs as,
and diagnostic_aggregator's own rules (:mod:`test.support.aggregator`) read the monitor's group
as ERROR only for a fault: not after a normal start, while the clearances and the rams are still
NOT ASSESSED (which stays in their messages and values)."""

from __future__ import annotations

import ast

import pytest
import yaml

from steer_monitor import sim
from steer_monitor.can import Decoder, RejectCounter
from steer_monitor.can.frames import pgn_of
from steer_monitor.model import Clearances
from steer_monitor.monitor import DiagnosticsBuilder, DiagnosticsConfig, LiveMonitor
from steer_monitor.monitor.diagnostics import ASSESSMENT_KEY, NOT_ASSESSED_TEXT
from steer_monitor.monitor.pipeline import DiagOut, Pipeline, analyst_from_params
from steer_monitor.node.analyzers import AGGREGATOR_NODE, ALWAYS, analyzer_file, analyzer_parameters
from steer_monitor.node.statuses import bus_status, recording_status
from steer_monitor.params import friction_from_params, gaps_from_params, gear_from_params
from steer_monitor.record.recorder import RecorderStatus
from test.conftest import PKG
from test.support.aggregator import ERROR, OK, STALE, Aggregator, rcl_parameters

ANALYZERS = PKG / 'config' / 'aggregator' / 'steer_monitor_analyzers.yaml'
GROUP = '/Vessel/Steering gear'


def _launch_aggregator() -> dict[str, ast.expr]:
    """The keywords the launch file gives diagnostic_aggregator's Node."""
    tree = ast.parse((PKG / 'launch' / 'monitor.launch.py').read_text(encoding='utf-8'))
    for n in ast.walk(tree):
        if isinstance(n, ast.Call) and getattr(n.func, 'id', '') == 'Node':
            kw = {k.arg: k.value for k in n.keywords}
            if getattr(kw.get('package'), 'value', None) == 'diagnostic_aggregator':
                return kw
    raise AssertionError('the launch file starts no aggregator')


def test_the_analyzer_file_reaches_the_aggregator_node():
    """The file is keyed by the name aggregator_node runs as, and the launch file does not rename
    it: under the name it gave before (diagnostic_aggregator) the file gave it nothing."""
    doc = yaml.safe_load(ANALYZERS.read_text(encoding='utf-8'))
    assert doc == analyzer_file()
    kw = _launch_aggregator()
    name = kw['name'].value if 'name' in kw else AGGREGATOR_NODE
    assert name == AGGREGATOR_NODE == 'analyzers'
    params = rcl_parameters(doc, f'/{name}')
    assert params['steer_monitor.type'] == 'diagnostic_aggregator/GenericAnalyzer' and params['path'] == 'Vessel'
    assert rcl_parameters(doc, '/diagnostic_aggregator') == {}
    agg = Aggregator(params)
    assert set(agg.analyzers) == {'steer_monitor'}
    assert agg.report(0.0) == ({GROUP: STALE, '/Vessel': STALE}, STALE)    # before the monitor: no knowledge


def test_the_analyzer_for_another_monitor_name():
    port = analyzer_parameters('port_gear')
    assert port['port_gear']['startswith'] == ['port_gear:']
    assert port['port_gear']['path'] == 'Steering gear (port_gear)'
    assert port['port_gear']['expected'] == [f'port_gear: {n}' for n in ALWAYS]


def _statuses(params, can_db, program, seed, drop_after_s=None, gaps_mm=None):
    """[(t_s, statuses)]: each DiagnosticArray the node publishes for a simulated run, its bus's
    and its recording's statuses beside the monitor's; ``drop_after_s``: (PGN, t_s), that
    PGN's frames lost from then on."""
    db, smap = can_db
    gear = gear_from_params(params)
    cfg = sim.SimConfig(program=program) if gaps_mm is None else \
        sim.SimConfig(program=program, gaps=Clearances.from_mm(*gaps_mm))
    s = sim.run(params, cfg, db, smap, seed)
    rejects = RejectCounter()
    mon = LiveMonitor(gear, gaps_from_params(params), 'configured', friction_from_params(params))
    diag = DiagnosticsBuilder(DiagnosticsConfig.from_params(params), smap, gear)
    p = Pipeline(Decoder(db, smap, rejects), rejects, mon, diag, analyst_from_params(gear, params))
    t0 = int(s.frames.t_ns[0])
    own = (bus_status('virtual:x', None, 'virtual: no controller', 'the host clock', 0, '', 'R-18'),
           recording_status(RecorderStatus(True, 'recording', '/rec/a.mcap', 1, 10, 0, 0), 'R-18'))
    out = []
    for f in s.frames.frames():
        if drop_after_s is not None and f.t_ns - t0 > drop_after_s[1] * 1e9 and pgn_of(f.can_id) == drop_after_s[0]:
            continue
        out += [((o.t_ns - t0) / 1e9, (*o.statuses, *own)) for o in p.feed(f) if isinstance(o, DiagOut)]
    out += [((o.t_ns - t0) / 1e9, (*o.statuses, *own)) for o in p.finish() if isinstance(o, DiagOut)]
    return out


def _levels(published, start_s=-1.0):
    """[(t_s, group level, top-level state)] of an aggregator started at ``start_s``, reporting
    after each array (as it does once a second)."""
    agg = Aggregator(rcl_parameters(yaml.safe_load(ANALYZERS.read_text(encoding='utf-8')), f'/{AGGREGATOR_NODE}'),
                     start_s)
    out = []
    for t, statuses in published:
        agg.feed(statuses, t)
        groups, top = agg.report(t + 0.5)
        out.append((t, groups[GROUP], top))
    return out


def test_a_normal_start_is_no_fault_in_the_aggregator(r18_params, can_db):
    """Seed 6701 and a 10-degree zigzag, used for nothing else: from the first diagnostics on,
    neither the gear's group nor the top-level state is ever ERROR (nor STALE), though the rams
    and the clearances are NOT ASSESSED for a while; they say so in their message and values."""
    published = _statuses(r18_params, can_db, 'zigzag_10', 6701)
    assert len(published) > 60
    levels = _levels(published)
    assert all(g == OK and top == OK for _, g, top in levels), [x for x in levels if x[1:] != (OK, OK)][:3]
    first = {st.name: st for st in published[0][1]}
    rams = first['steer_monitor: rams']
    assert (rams.level, rams.value(ASSESSMENT_KEY), rams.label) == (OK, NOT_ASSESSED_TEXT, NOT_ASSESSED_TEXT)
    assert rams.message.startswith('NOT ASSESSED: not judged yet')
    clear = first['steer_monitor: clearances']
    assert (clear.level, clear.value(ASSESSMENT_KEY)) == (OK, NOT_ASSESSED_TEXT) and 'NOT ASSESSED' in clear.message
    # every status but the recording's is expected: a monitor that records nothing is no fault
    assert {st.name for st in published[0][1]} - {'steer_monitor: recording'} == \
        set(analyzer_parameters()['steer_monitor']['expected'])


def test_a_silent_pressure_is_an_error_in_the_aggregator(r18_params, can_db):
    """The pressures' PGN lost 40 s in (seed 6702): the input STALE among fresh statuses, so the
    group and the top-level state ERROR, as a watchkeeper must see it; OK before."""
    _, smap = can_db
    pgn = next(s.pgn for s in smap.specs if s.name.startswith('pressure'))
    levels = _levels(_statuses(r18_params, can_db, 'zigzag_10', 6702, (pgn, 40.0)))
    before = [(g, top) for t, g, top in levels if t < 40]
    after = [(g, top) for t, g, top in levels if t > 52]
    assert before and set(before) == {(OK, OK)}
    assert after and set(after) == {(ERROR, ERROR)}


@pytest.mark.slow
def test_a_worn_slipper_is_an_error_and_the_clearances_status_says_so(r18_params, can_db):
    """Seed 6703, Z_gb worn past its limit: OVER LIMIT is published at ERROR and is assessed."""
    published = _statuses(r18_params, can_db, 'voyage', 6703, gaps_mm=(0.70, 0.30))
    last = {st.name: st for st in published[-1][1]}['steer_monitor: clearances']
    assert (last.level, last.value(ASSESSMENT_KEY)) == (ERROR, 'assessed'), last.message
    assert _levels(published)[-1][1:] == (ERROR, ERROR)


@pytest.mark.parametrize('other', [OK, ERROR])
def test_the_oracle_reads_one_stale_item_among_fresh_ones_as_error(other):
    """The rule that made NOT ASSESSED published as STALE an ERROR."""
    agg = Aggregator({'path': 'Vessel', 'g.type': 'diagnostic_aggregator/GenericAnalyzer', 'g.path': 'G',
                      'g.startswith': ['x:']})

    class S:
        def __init__(self, name, level):
            self.name, self.level, self.message = name, level, ''
    agg.feed([S('x: one', other), S('x: two', STALE)], 0.0)
    assert agg.report(1.0) == ({'/Vessel/G': ERROR, '/Vessel': ERROR}, ERROR)
    agg.feed([S('x: two', OK)], 1.0)
    assert agg.report(1.5)[0]['/Vessel/G'] == other
    assert agg.report(7.0) == ({'/Vessel/G': STALE, '/Vessel': STALE}, STALE)   # all timed out
