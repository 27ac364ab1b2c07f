"""The node's analyses: its findings are ``analyze``'s of the log cut at their time, its state
survives a restart, an older or damaged state is refused in one line."""

from __future__ import annotations

import json
import math
from dataclasses import replace

import numpy as np
import pytest

from steer_monitor import sim
from steer_monitor.can import Decoder, RejectCounter
from steer_monitor.can.busconfig import can_setup
from steer_monitor.estimate.analyze import analyze
from steer_monitor.estimate.effects import Effect
from steer_monitor.estimate.finding import Finding, finding_of
from steer_monitor.estimate.intervals import Interval
from steer_monitor.estimate.observe import EstimateError
from steer_monitor.model import Clearances
from steer_monitor.model.inputs import PRESSURE_INPUTS, Series
from steer_monitor.monitor import DiagnosticsBuilder, DiagnosticsConfig, LiveMonitor
from steer_monitor.monitor.analyst import Analyst, AnalystSettings, SyncJobs
from steer_monitor.monitor.pipeline import DiagOut, Pipeline, analyst_from_params
from steer_monitor.params import friction_from_params, gaps_from_params, gear_from_params
from steer_monitor.sim.gateway import forward, parse_gateway
from steer_monitor.utc import parse_utc
from test.conftest import R18_YAML

T0 = 1_767_225_600_000_000_000


class Recording(SyncJobs):
    """The jobs run at once, each job and its outcome kept."""

    def __init__(self, *args, **kwargs) -> None:
        super().__init__(*args, **kwargs)
        self.done: list = []

    def submit(self, job):
        out = super().submit(job)
        self.done.append((job, out))
        return out


def _node_over(params, can_db, frames):
    """The node's pipeline over ``frames``: (its analyst, the jobs and their outcomes, the
    diagnostics)."""
    db, smap = can_db
    gear = gear_from_params(params)
    rejects = RejectCounter()
    mon = LiveMonitor(gear, gaps_from_params(params), 'configured', friction_from_params(params),
                      angle_period_ns=smap.period_ns('rudder_angle'))
    diag = DiagnosticsBuilder(DiagnosticsConfig.from_params(params), smap, gear)
    analyst = analyst_from_params(gear, params)
    jobs = Recording(gear, analyst.settings)
    p = Pipeline(Decoder(db, smap, rejects), rejects, mon, diag, analyst, jobs)
    diags = []
    for f in frames:
        diags += [o for o in p.feed(f) if isinstance(o, DiagOut)]
    diags += [o for o in p.finish() if isinstance(o, DiagOut)]
    return analyst, jobs.done, diags


def _close(a: Finding, b: Finding) -> bool:
    """Equal but for rounding (the same code on the same samples in one process gives the same
    bits; 1e-9 of each value allows for a BLAS that sums in another order)."""
    def near(x, y):
        if isinstance(x, Interval):
            return all(near(p, q) for p, q in zip((x.value, x.lo, x.hi), (y.value, y.lo, y.hi)))
        if x is None or y is None:
            return x is y
        if isinstance(x, float):
            return (math.isnan(x) and math.isnan(y)) or math.isclose(x, y, rel_tol=1e-9, abs_tol=1e-12)
        if isinstance(x, tuple | list):
            return len(x) == len(y) and all(near(p, q) for p, q in zip(x, y))
        if isinstance(x, dict):
            return x.keys() == y.keys() and all(near(x[k], y[k]) for k in x)
        return x == y
    return all(near(getattr(a, f), getattr(b, f)) for f in a.__dataclass_fields__)


@pytest.mark.slow
@pytest.mark.parametrize('program, effects, seed, gateway', [
    ('realistic', (), 41, None),                            # a realistic voyage
    ('realistic', ('angle_delay:tau_s=0.25',), 42, None),   # one with an effect the declared model lacks
    ('autopilot:1500', (), 43, None),                       # autopilot only
    # through a gateway forwarding the angle at 2 Hz and the pressures at 5 Hz, configured so
    ('realistic', (), 44, 'rudder=2,pressure=5,mode=decimate,loss=0.02'),
])
def test_the_nodes_findings_are_analyze_of_the_log_cut_at_their_time(r18_params, can_db, program, effects, seed,
                                                                     gateway):
    """Every analysis the node runs on a voyage (loops and estimates, on its own compacted
    window of the data) equals ``analyze`` of the decoded log cut at the job's second with the
    node's window (and, for an estimate, the model of the loop before it): the clearances with
    their intervals, K_gl max, friction, torque, effects, verdict and message."""
    db, smap = can_db
    cfg = sim.SimConfig(program=program, gaps=Clearances.from_mm(0.33, 0.205), max_duration_s=1500.0,
                        effects=tuple(sim.parse_effect(e) for e in effects))
    s = sim.run(r18_params, cfg, db, smap, seed)
    # loops from 60 s of motion and estimates between them: more analyses to compare
    params = {**r18_params, 'estimator.first_motion_s': 60.0, 'estimator.every_motion_s': 90.0}
    frames = s.frames
    if gateway is not None:
        gw = parse_gateway(gateway)
        frames = forward(frames, gw, db, seed)
        rates = {'rudder_angle': gw.rates_hz[127245], 'rudder_order': gw.rates_hz[127245],
                 **{n: gw.rates_hz[130314] for n in PRESSURE_INPUTS}}
        params.update({f'signals.{n}.rate_hz': r for n, r in rates.items()})
        can_db = can_setup(params, R18_YAML)
    analyst, done, diags = _node_over(params, can_db, frames.frames())
    kinds = [job.kind for job, _ in done]
    assert kinds.count('loop') >= 3 and 'estimate' in kinds, kinds
    signals = Decoder(db, smap).decode_arrays(frames)
    gear = gear_from_params(r18_params)
    settings = analyst.settings
    model: tuple[Effect, ...] = ()
    for job, out in done:
        cut = {n: Series(v.t_ns[v.t_ns < job.t_ns], v.value[v.t_ns < job.t_ns]) for n, v in signals.items()
               if n in job.signals}
        try:
            a = analyze(gear, cut, min_clearance_2z=settings.min_clearance_2z, ram_share_warn=settings.ram_share_warn,
                        window_motion_s=settings.window_motion_s, model=None if job.kind == 'loop' else model)
        except EstimateError as exc:
            assert out.finding is None and out.why == str(exc)
            continue
        assert a.window is not None and a.window.motion_s > 0 and isinstance(a.rams_assessed, bool)
        want = finding_of(a, job.t_ns, job.kind)
        assert out.finding is not None and _close(out.finding, want), (job.kind, job.t_ns, out.finding, want)
        if job.kind == 'loop':
            model = want.model
    # and what the node published at each second is the last finding it applied
    published = [(d.t_ns, d.gaps, d.interval) for d in diags if d.source == 'estimated']
    assert published
    findings = [out.finding for _, out in done if out.finding is not None]
    for _, gaps, interval in published:
        assert any(gaps == Clearances(f.two_z.value, f.z_gb.value)
                   and interval == {'2z': (f.two_z.lo, f.two_z.hi), 'zgb': (f.z_gb.lo, f.z_gb.hi)} for f in findings)


def _finding(t_ns: int = T0) -> Finding:
    return Finding(t_ns, 'loop', Interval(0.3e-3, 0.25e-3, None), Interval(0.2e-3, 0.19e-3, 0.21e-3),
                   Interval(0.5, 0.45, 0.55), (9e3, 0.13, 0.05), (1.0, 2.0, 3.0), 0.6,
                   (Effect('angle_delay', (('tau_s', 0.25),)),), {'tau_s': 0.25}, 'effect', 'added angle_delay', 0.33,
                   0.06, 0.32, 880.0, 35000)


@pytest.fixture
def analyst(r18):
    a = Analyst(r18, AnalystSettings())
    for k in range(50):
        a.add('rudder_angle', T0 + k * 100_000_000, 0.01 * k)
        a.add('pressure_r1_stbd', T0 + k * 50_000_000, 2e5 + k)
    a.finding, a.model = _finding(), _finding().model
    a.schedule.due(45.0)
    return a


def test_the_state_survives_a_restart(r18, analyst, tmp_path):
    path = analyst.save(tmp_path / 'state.npz', motion_s=45.0)
    again = Analyst(r18, AnalystSettings())
    assert again.load(path) == 45.0
    assert again.finding == analyst.finding and again.model == analyst.model
    assert again.schedule.to_dict() == analyst.schedule.to_dict()
    a, b = analyst.buffer.signals(), again.buffer.signals()
    assert a.keys() == b.keys()
    for n in a:
        np.testing.assert_array_equal(a[n].t_ns, b[n].t_ns)
        np.testing.assert_array_equal(a[n].value, b[n].value)
    # the motion counted goes on from there: the schedule sees it with this run's
    assert again.motion_base_s == 45.0


def test_the_last_assessed_clearances_survive_a_restart(r18, analyst, tmp_path):
    """A clearance assessed once (two-sided, from a model that explains the data) is kept when a
    later finding can only bound it, and across a restart: the node says when it last knew."""
    from dataclasses import replace

    from steer_monitor.monitor.analyst import Outcome
    first = _finding(T0)
    analyst.take(Outcome(1, T0, 'loop', first, None, ()))
    later = replace(_finding(T0 + 10**12), z_gb=Interval(0.2e-3, 0.0, None))
    analyst.take(Outcome(2, T0 + 10**12, 'loop', later, None, ()))
    assert analyst.assessed == {'zgb': (0.2e-3, 0.19e-3, 0.21e-3, T0)}          # 2Z was a bound both times
    unexplained = replace(_finding(T0 + 2 * 10**12), verdict='unexplained', z_gb=Interval(0.3e-3, 0.29e-3, 0.31e-3))
    analyst.take(Outcome(3, T0 + 2 * 10**12, 'loop', unexplained, None, ()))
    assert analyst.assessed['zgb'][3] == T0                                     # not from an incomplete model
    path = analyst.save(tmp_path / 'state.npz', motion_s=45.0)
    again = Analyst(r18, AnalystSettings())
    again.load(path)
    assert again.assessed == analyst.assessed


def _write(path, meta, **arrays):
    np.savez(path, meta=np.array(json.dumps(meta)), **arrays)


@pytest.mark.parametrize('change, text', [
    ({'version': 3}, 'format 3, written by the estimator this release replaced (binned moments, no data to analyse); '
                     'this build reads format 4'),
    ({'version': 9}, 'format 9; this build reads format 4'),
    ({'gear': [1.0] * 10}, 'learned on another gear geometry; not used'),
    ({'schedule': {'next_loop_s': -1.0, 'next_estimate_s': 1.0}}, 'damaged (ValueError: analysis schedule: next loop'),
    ({'model': [{'name': 'wobble'}]}, "damaged (ValueError: unknown effect 'wobble'"),
    ({'finding': {'kind': 'loop'}}, 'damaged (KeyError:'),
    ({'motion_s': -5.0}, 'damaged (ValueError: motion counted -5.0 s)'),
])
def test_an_older_or_damaged_state_is_refused_in_one_line(r18, analyst, tmp_path, change, text):
    path = analyst.save(tmp_path / 'state.npz', motion_s=45.0)
    with np.load(path) as d:
        meta = json.loads(str(d['meta']))
        arrays = {k: d[k] for k in d.files if k != 'meta'}
    _write(tmp_path / 'bad.npz', {**meta, **change}, **arrays)
    fresh = Analyst(r18, AnalystSettings())
    with pytest.raises(EstimateError) as err:
        fresh.load(tmp_path / 'bad.npz')
    assert str(err.value).startswith(f'analysis state {tmp_path / "bad.npz"}: ') and text in str(err.value)
    assert '\n' not in str(err.value)
    assert fresh.finding is None and len(fresh.buffer) == 0       # nothing taken


@pytest.mark.parametrize('data', [b'', b'not a zip', b'PK\x03\x04' + bytes(40)])
def test_a_file_that_is_no_state_is_refused_in_one_line(r18, tmp_path, data):
    (tmp_path / 's.npz').write_bytes(data)
    with pytest.raises(EstimateError, match=r'^analysis state .*: cannot read it \('):
        Analyst(r18, AnalystSettings()).load(tmp_path / 's.npz')


def test_samples_out_of_order_in_a_state_are_refused(r18, analyst, tmp_path):
    path = analyst.save(tmp_path / 'state.npz', motion_s=1.0)
    with np.load(path) as d:
        meta = json.loads(str(d['meta']))
        arrays = {k: d[k] for k in d.files if k != 'meta'}
    arrays['t_rudder_angle'] = arrays['t_rudder_angle'][::-1].copy()
    _write(tmp_path / 'bad.npz', meta, **arrays)
    with pytest.raises(EstimateError, match='the samples of rudder_angle are not a time series'):
        Analyst(r18, AnalystSettings()).load(tmp_path / 'bad.npz')


def test_a_finding_round_trips_its_json():
    f = _finding()
    assert Finding.from_json(json.loads(json.dumps(f.to_json()))) == f
    assert not replace(f, verdict='unexplained').explained


@pytest.mark.slow
def test_analyze_of_the_log_until_a_findings_time_gives_what_the_node_published(r18_params, can_db, tmp_path):
    """What a superintendent can check: the clearances status names the data its estimate
    was made of (``estimate_data_until_utc``); ``steer-monitor analyze LOG --until THAT
    --window-motion-h 1`` gives the published values, as the diagnostics print them."""
    from steer_monitor.cli import analyze as A
    from steer_monitor.logfiles.mcapio import McapWriter

    db, smap = can_db
    s = sim.run(r18_params, sim.SimConfig(program='realistic:900', gaps=Clearances.from_mm(0.41, 0.1717)), db, smap, 47)
    log = tmp_path / 'voyage.mcap'
    with McapWriter(log) as w:
        frames = list(s.frames.frames())
        for i in range(0, len(frames), 8192):
            w.write_frames(frames[i:i + 8192])
    _, done, diags = _node_over(r18_params, can_db, s.frames.frames())
    loops = {}
    for d in diags:
        st = next(st for st in d.statuses if st.name.endswith('clearances'))
        if dict(st.values).get('estimate_kind') == 'loop':
            loops[st.value('estimate_data_until_utc')] = st
    assert len(loops) >= 2
    until, st = sorted(loops.items())[-1]
    out = tmp_path / 'a.json'
    assert A.run(log, json_out=out, until_ns=parse_utc(until), window_motion_h=1.0) == 0
    got = json.loads(out.read_text())
    assert got['window']['until_utc'] == until and got['window']['motion_h'] == 1.0
    for key in ('2z', 'zgb'):      # the JSON to 0.0001 mm, the diagnostics to 0.001 mm
        q = got[f'clearance_{key}_mm']
        shown = [
            st.value(f'clearance_{key}_mm'),
            st.value(f'clearance_{key}_lo_mm'),
            st.value(f'clearance_{key}_hi_mm'),
        ]
        if not q['bounded']:        # a bound: the JSON gives no point (docs/json.md); the diagnostics show one
            shown = shown[1:]
        for x, v in zip(q['ci95'] if not q['bounded'] else [q['value'], *q['ci95']], shown):
            assert (x is None and v == 'n/a') or abs(x - float(v)) <= 0.00055, (key, q, shown)


def test_an_analysis_asked_for_comes_at_the_next_second(r18_params):
    """Before the schedule has one due (no motion yet), :meth:`Analyst.request` gives a loop at
    the next whole second, once; the schedule is left as it was."""
    from steer_monitor.monitor.pipeline import analyst_from_params
    from steer_monitor.params import gear_from_params
    a = analyst_from_params(gear_from_params(r18_params), r18_params)
    t = 1_767_225_600_000_000_000
    assert a.due(t, 0.0) is None
    a.request()
    job = a.due(t + 1_000_000_000, 0.0)
    assert job is not None and job.kind == 'loop' and job.t_ns == t + 1_000_000_000
    assert a.due(t + 2_000_000_000, 0.0) is None
