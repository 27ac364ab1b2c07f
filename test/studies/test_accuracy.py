"""The accuracy study: case grid, coverage arithmetic, one real case, the CLI's table."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from steer_monitor.cli import accuracy as cli
from steer_monitor.cli.main import main
from steer_monitor.studies import accuracy as A


def _result(programme: str, tz: float, zg: float, est_zg: float, ci_zg: tuple, clamped: float = 0.0,
            est_tz: float = 0.3, ci_tz: tuple = (0.2, None), effects: tuple = (), adopted: tuple = (),
            verdict: str = 'declared', located: str | None = None) -> A.CaseResult:
    truth = {q: 1.0 for q in A.QUANTITIES} | {'clearance_2z_mm': tz, 'clearance_zgb_mm': zg}
    est = {q: 1.0 for q in A.QUANTITIES} | {'clearance_2z_mm': est_tz, 'clearance_zgb_mm': est_zg}
    ci = {q: (0.5, 1.5) for q in A.QUANTITIES} | {'clearance_2z_mm': ci_tz, 'clearance_zgb_mm': ci_zg}
    return A.CaseResult(A.Case(programme, tz, zg, 1, effects), 1500.0, 10000, truth, est, ci, clamped, 35.0, 1.5,
                        0.05, verdict, adopted[0] if adopted else None, 5.0, adopted, 0.04, located)


def test_cases_grid_and_seeds():
    cs = A.cases(['voyage', 'autopilot'], (0.1, 0.6), (0.05,), seeds=2, first_seed=10)
    assert len(cs) == 8
    assert [c.seed for c in cs] == list(range(10, 18))            # every log its own seed
    assert {(c.programme, c.two_z_mm) for c in cs} == {(p, t) for p in ('voyage', 'autopilot') for t in (0.1, 0.6)}
    with pytest.raises(ValueError, match="unknown study programme 'sea_trial'"):
        A.cases(['sea_trial'])


@pytest.mark.parametrize(('hits', 'n'), [(0, 10), (5, 10), (10, 10), (95, 100), (1, 1)])
def test_wilson_interval_against_the_exact_score_equation(hits, n):
    lo, hi = A.coverage_interval(hits, n)
    z = 1.959963984540054
    p = hits / n
    for bound in (lo, hi):   # the Wilson bounds solve (p - b)^2 = z^2 b (1 - b) / n
        assert (p - bound) ** 2 == pytest.approx(z * z * bound * (1 - bound) / n, abs=1e-12)
    assert 0.0 <= lo <= p <= hi <= 1.0
    assert all(math.isnan(x) for x in A.coverage_interval(0, 0))


def test_summary_counts_coverage_and_splits_2z_by_clamping():
    rs = [_result('voyage', 0.1, 0.05, 0.06, (0.04, 0.07), clamped=0.3, est_tz=0.11, ci_tz=(0.09, 0.12)),
          _result('voyage', 0.6, 0.25, 0.20, (0.18, 0.22)),                    # Z_gb missed
          _result('autopilot', 0.6, 0.35, 0.01, (0.0, None), est_tz=0.1, ci_tz=(0.7, None))]  # 2Z bound wrong
    s = A.summarize(rs)
    assert s['voyage']['clearance_zgb_mm']['coverage'] == 0.5
    assert s['all']['clearance_zgb_mm']['coverage'] == 0.6667     # shares to 1e-4 (docs/json.md)
    assert s['all']['clearance_zgb_mm']['coverage_ci95'] == [round(x, 4) for x in A.coverage_interval(2, 3)]
    assert s['voyage']['clearance_zgb_mm']['max_abs_error'] == pytest.approx(0.05)
    assert s['voyage']['clearance_zgb_mm']['within_0.03mm'] == 0.5
    assert s['all']['clearance_2z_mm_clamped']['cases'] == 1
    assert s['all']['clearance_2z_mm_clamped']['within_0.05mm'] == 1.0
    assert s['all']['clearance_2z_mm_not_clamped']['coverage'] == 0.5
    assert s['autopilot']['clearance_zgb_mm']['two_sided_share'] == 0.0
    doc = cli.markdown(rs, s, 'steer-monitor accuracy', 'R-18')
    # the legend's **x** and the two misses
    assert doc.count('**x**') == 1 + 2 and '>= 0.70' in doc and '| all | 3 |' in doc


@pytest.mark.slow
def test_one_case_end_to_end(r18_params, db, smap):
    r = A.run_case(r18_params, db, smap, A.Case('voyage', 0.6, 0.25, 3))
    assert r.verdict == 'declared' and r.effect is None
    assert abs(r.estimate['clearance_zgb_mm'] - 0.25) <= 0.03 and r.covered('clearance_zgb_mm')
    assert r.covered('clearance_2z_mm') and r.ci95['clearance_2z_mm'][1] is None   # never clamps: bound only
    assert r.clamped_share == 0.0 and r.truth['k_gl_max'] > 0.5 and r.covered('k_gl_max')


@pytest.mark.slow
def test_cli_writes_table_and_json(tmp_path, capsys):
    md, js = tmp_path / 'acc.md', tmp_path / 'acc.json'
    assert main(['accuracy', '--programmes', 'manoeuvres', '--grid-2z-mm', '0.1', '--grid-zgb-mm', '0.2',
                 '--jobs', '1', '--out', str(md), '--json', str(js)]) == 0
    assert '1 logs: Z_gb coverage' in capsys.readouterr().out
    text = md.read_text()
    assert text.startswith('# Accuracy of the clearance estimator') and '### manoeuvres' in text
    data = json.loads(js.read_text())
    assert len(data['cases']) == 1 and set(data['summary']) == {'manoeuvres', 'all'}
    assert data['cases'][0]['covered']['clearance_zgb_mm'] is True


@pytest.mark.parametrize(('argv', 'message'), [
    (['--seeds', '0'], '--seeds must be at least 1, got 0'),
    (['--sensitivity-seeds', '-1'], '--sensitivity-seeds must be 0 or more, got -1'),
    (['--long-seeds', '-2'], '--long-seeds must be 0 or more, got -2'),
    (['--jobs', '0'], '--jobs must be at least 1, got 0'),
    (['--programmes', 'sea_trial'], "unknown study programme 'sea_trial'"),
    (['--grid-2z-mm', '0.1,x'], '--grid-2z-mm: expected a comma-separated list of positive millimetres'),
    (['--grid-zgb-mm', '-0.1'], '--grid-zgb-mm: expected a comma-separated list of positive millimetres'),
    (['--out', '/nonexistent/dir/acc.md'], 'cannot write /nonexistent/dir/acc.md: no directory /nonexistent/dir'),
])
def test_bad_arguments_are_named(argv, message, capsys):
    assert main(['accuracy', *argv]) == 1
    assert message in capsys.readouterr().err


def test_the_study_runs_the_realistic_voyages_and_reports_the_systematic_part():
    assert A.PROGRAMMES['realistic'].startswith('realistic')
    rs = [_result('realistic', 0.6, 0.25, 0.25, (0.24, 0.26)), _result('voyage', 0.6, 0.25, 0.25, (0.24, 0.26))]
    summary = A.summarize(rs)
    assert summary['realistic']['max_systematic_bar'] == pytest.approx(0.05)
    assert set(summary) == {'realistic', 'voyage', 'all'}


def test_every_effect_of_the_simulator_has_a_size_its_clean_twin_sets_to_nothing():
    """A study of any effect makes its clean twin (the same seed, the effect at size 0): the
    faults of the gear aside, every effect says which parameter is its size, and at 0 it is none."""
    from steer_monitor import sim
    from steer_monitor.studies.accuracy import SIZE
    assert set(SIZE) == set(sim.EFFECTS) - set(sim.FAULTS)
    for name, key in SIZE.items():
        assert key in sim.EFFECTS[name], name


def test_sensitivity_cases_cover_every_library_effect_pairs_and_the_outside_one():
    cs = A.sensitivity_cases(seeds=2)
    specs = {c.effects for c in cs}
    assert len(cs) == 2 * len(specs)
    assert len(specs) == len(A.MAGNITUDE) * len(A.FRACTIONS) + len(A.PAIRS) + 1
    assert ('viscous:c_ns_per_m=200000',) in specs and ('band_friction',) in specs
    assert all(c.programme == 'realistic' for c in cs) and len({c.seed for c in cs}) == len(cs)


def test_long_voyage_cases_take_every_library_effect_at_a_fifth_and_clean_logs():
    with_effect, clean = A.long_voyage_cases(seeds=2)
    assert len(with_effect) == 2 * len(A.MAGNITUDE) and len(clean) == 2 * A.LONG_CLEAN_PER_SEED
    assert {c.effects for c in with_effect} == {(A.scaled_effect(n, 0.2),) for n in A.MAGNITUDE}
    assert ('ram_inertia:mass_kg=12000',) in {c.effects for c in with_effect}
    assert all(c.effects == () for c in clean)
    seeds = [c.seed for c in with_effect + clean]
    assert len(set(seeds)) == len(seeds)                                  # every log its own seed
    assert not set(seeds) & {c.seed for c in A.sensitivity_cases(seeds=2)}   # not the short study's logs
    assert {c.programme for c in with_effect + clean} == set(A.LONG_PROGRAMMES)
    assert A.programme_text('realistic_1h') == 'realistic:3000'
    with pytest.raises(ValueError, match="unknown study programme 'x' .*realistic_1h"):
        A.programme_text('x')


def test_the_hour_long_table_names_minutes_and_what_clean_logs_adopted():
    v = ('ram_inertia:mass_kg=12000',)
    rs = [_result('realistic_1h', 0.4, 0.2, 0.2, (0.19, 0.21), effects=v, adopted=('ram_inertia',), verdict='effect'),
          _result('realistic_1h', 0.4, 0.2, 0.2, (0.19, 0.21), effects=v, adopted=('ram_inertia', 'viscous'))]
    clean = [_result('realistic_1h', 0.6, 0.25, 0.25, (0.24, 0.26)),
             _result('realistic_1h', 0.6, 0.25, 0.25, (0.24, 0.26), adopted=('stribeck',), verdict='effect')]
    s = A.summarize_sensitivity(rs, clean)
    assert s['rows'][0]['median_minutes'] == pytest.approx(25.0) and s['clean_adopted'] == ['stribeck']
    doc = '\n'.join(cli._long_markdown(s))
    assert '| `ram_inertia:mass_kg=12000` | 25 | 2 | 2/2 | 1 | 2/2 | 0.05 -> 0.04 |' in doc
    assert 'False adoption on the clean hour-long logs: 1 of 2 (adopted: `stribeck`).' in doc
    assert '`realistic:3000`' in doc


def test_sensitivity_summary_counts_named_wrong_and_located():
    v = ('viscous:c_ns_per_m=200000',)
    rs = [_result('realistic', 0.4, 0.2, 0.2, (0.19, 0.21), effects=v, adopted=('viscous',), verdict='effect'),
          _result('realistic', 0.4, 0.2, 0.2, (0.19, 0.21), effects=v, adopted=()),
          _result('realistic', 0.4, 0.2, 0.2, (0.19, 0.21), effects=('band_friction',), verdict='unexplained',
                  located='alpha_deg'),
          _result('realistic', 0.4, 0.2, 0.3, (0.25, 0.35), effects=('band_friction',), adopted=('stribeck',),
                  verdict='unexplained', located='time_s')]
    clean = [_result('voyage', 0.6, 0.25, 0.25, (0.24, 0.26)),
             _result('voyage', 0.6, 0.25, 0.25, (0.24, 0.26), adopted=('angle_delay',), verdict='effect')]
    s = A.summarize_sensitivity(rs, clean)
    by = {tuple(r['effects']): r for r in s['rows']}
    assert by[v]['named'] == 1 and by[v]['wrong_adoptions'] == 0 and by[v]['fraction_of_default'] == pytest.approx(0.2)
    b = by[('band_friction',)]
    assert b['named'] is None and b['wrong_adoptions'] == 1 and b['unexplained'] == 2 and b['located_on_angle'] == 1
    assert b['clearances_covered'] == 1 and b['fraction_of_default'] is None
    assert s['clean_logs'] == 2 and s['clean_false_adoptions'] == 1
    doc = cli.markdown(clean, A.summarize(clean), 'steer-monitor accuracy', 'R-18', s)
    assert '## Sensitivity of the residual loop' in doc and 'False adoption on the clean logs above: 1 of 2.' in doc
    assert '| `viscous:c_ns_per_m=200000` | 0.2 | 2 | 1/2 | 0 |' in doc


def _noise_free(r18_params, db, smap, effects=()):
    from steer_monitor import sim
    from steer_monitor.can.decoder import Decoder
    from steer_monitor.estimate.observe import build_observations
    from steer_monitor.model.gear import Clearances
    from steer_monitor.params import gear_from_params
    gear = gear_from_params(r18_params)
    cfg = sim.SimConfig(program='hard_over_2', gaps=Clearances.from_mm(0.3, 0.2), noise=False,
                        effects=tuple(sim.parse_effect(e) for e in effects))
    s = sim.run(r18_params, cfg, db, smap, 4)
    obs = build_observations(Decoder(db, smap).decode_arrays(s.frames, final=True), gear.ram_area)
    return gear, cfg, s, obs


@pytest.mark.parametrize('effects', [(), ('pressure_offset:offset_bar=2',)])
def test_true_forces_are_what_noise_free_transducers_read(r18_params, db, smap, effects):
    """Independently of true_forces: the observations of a noise-free simulation (frames,
    decoder, 20 Hz samples interpolated to the grid) agree with it in steady motion, to the
    transducers' quantisation and the linear interpolation of 20 Hz samples where the load
    bends (a few mbar, 0.05 bar at a kink of the load-sharing stages), an offset included."""
    gear, cfg, s, obs = _noise_free(r18_params, db, smap, effects)
    bar = gear.ram_area * 1e5
    truth = A.true_forces(s.plant, cfg, obs.t_ns, gear.ram_area)
    steady = obs.moving & np.roll(obs.moving, 1) & np.roll(obs.moving, -1)
    err = (obs.force - truth)[steady] / bar
    assert steady.sum() > 1000 and np.nanmedian(np.abs(err)) < 0.005 and np.nanmax(np.abs(err)) < 0.1
    if effects:     # the offset on ram 1's starboard transducer is in ram 1's force
        from dataclasses import replace
        without = A.true_forces(s.plant, replace(cfg, effects=()), obs.t_ns, gear.ram_area)
        assert np.allclose((truth - without)[:, 0] / bar, 2.0, atol=1e-9) and np.all(truth[:, 1] == without[:, 1])


def test_model_misfit_is_the_rms_of_prediction_against_truth_over_fitted_instants():
    from steer_monitor.estimate.observe import Observations
    rng = np.random.default_rng(3)
    n = 400
    truth = rng.normal(0, 1e5, (n, 2))
    model_error = rng.normal(0, 2e3, (n, 2))
    noise = rng.normal(0, 5e3, (n, 2))
    force = truth + noise
    residual = force - (truth + model_error)          # observed less the prediction
    residual[:50] = np.nan                             # instants the fit left out
    obs = Observations(np.arange(n, dtype=np.int64), np.zeros(n), np.zeros(n), np.ones(n, np.int8), force,
                       np.zeros((n, 4)), np.zeros(n), np.zeros(n))

    class Est:
        pass
    est = Est()
    est.residual = residual
    expected = math.sqrt(np.mean(model_error[50:] ** 2))
    assert A.model_misfit(est, obs, truth) == pytest.approx(expected, rel=1e-12)


@pytest.mark.parametrize(('misfit', 'after', 'clean', 'expected'), [
    (0.30, 0.20, 0.20, (math.sqrt(0.05), 0.0)),
    (0.25, 0.21, 0.20, (0.15, math.sqrt(0.21 ** 2 - 0.04))),
    (0.19, 0.19, 0.20, (0.0, 0.0)),                  # under the twin's: nothing of the effect shows
])
def test_the_effects_misfit_is_the_excess_over_the_clean_twin(misfit, after, clean, expected):
    r = _result('realistic', 0.4, 0.2, 0.2, (0.19, 0.21))
    from dataclasses import replace
    r = replace(r, misfit_bar=misfit, misfit_after_bar=after, misfit_clean_bar=clean)
    assert r.effect_misfit == pytest.approx(expected, abs=1e-12)


def test_halved_counts_only_an_effect_that_showed():
    from dataclasses import replace
    v = ('stribeck:f_st_n=3000',)
    base = _result('realistic', 0.4, 0.2, 0.2, (0.19, 0.21), effects=v, adopted=('stribeck',))
    rs = [replace(base, misfit_bar=0.25, misfit_after_bar=0.205, misfit_clean_bar=0.2),   # 0.15 -> 0.04
          replace(base, misfit_bar=0.25, misfit_after_bar=0.24, misfit_clean_bar=0.2),    # 0.15 -> 0.13
          replace(base, misfit_bar=0.19, misfit_after_bar=0.19, misfit_clean_bar=0.2)]    # nothing showed
    (row,) = A.summarize_sensitivity(rs)['rows']
    assert row['effect_misfit_halved'] == 1
    assert row['effect_misfit_before_bar'] == pytest.approx(0.15)
