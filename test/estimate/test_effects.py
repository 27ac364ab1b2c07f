"""The library's effects: an adopted effect made again from its plain description, and its
terms sample by sample (the live residual's) as its columns predict them (the fit's)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from steer_monitor.estimate.effects import NAMES, Effect, InstantTerms, candidate_of, candidates, live_term, z_columns
from steer_monitor.estimate.moments import Moments, rows_from_observations
from steer_monitor.estimate.observe import build_observations
from steer_monitor.model.friction import FrictionParams, friction_force
from steer_monitor.model.loadshare import load_sharing


def test_an_effect_is_its_candidate_again():
    for c in candidates({'dtemp': np.zeros(1)}, (9e3, 0.13, 0.05)):
        if c.name == 'angle_delay' and c.angle_shift_s != 0.25:
            continue
        e = Effect(c.name, tuple(sorted((c.fixed or {}).items())), c.shape)
        again = candidate_of(Effect.from_json(e.to_json()))
        assert (again.name, again.fixed or {}, again.angle_shift_s, again.shape) == \
            (c.name, c.fixed or {}, c.angle_shift_s, c.shape)
        assert [(col.name, col.z) for col in again.columns] == [(col.name, col.z) for col in c.columns]
    with pytest.raises(ValueError, match="unknown effect 'wobble'"):
        Effect('wobble')


@pytest.mark.parametrize('name, fixed, coefficients', [
    ('viscous', (), {'c_ns_per_m': 2.0e5}),
    ('stribeck', (('v_s_mm_s', 3.0),), {'f_st_n': 4.0e3}),
    ('pressure_friction', (), {'k': 0.02}),
    ('temp_friction', (), {'k_per_k': 0.01}),
    ('pressure_offset', (), {'offset_ram1_n': 3.0e3, 'offset_ram2_n': -1.5e3}),
])
def test_a_term_sample_by_sample_is_what_its_columns_predict(r18, simulate_signals, name, fixed, coefficients):
    """On a simulated voyage's rows: the live residual's term of an effect (its coefficients,
    each row's ram speed, |force|, oil temperature and the friction law's loads) equals its
    columns times the coefficients, computed per row at the row's own angle."""
    signals, _ = simulate_signals('voyage', 0.4, 0.2)
    obs = build_observations(signals, r18.ram_area)
    z = z_columns(obs, r18)
    shape = (9e3, 0.13, 0.05)
    effect = Effect(name, fixed, shape if name == 'temp_friction' else None)
    cand = candidate_of(effect)
    keys, aa, v2, u, idx, ram = rows_from_observations(obs, z)
    zn = ('speed_ratio', *z)
    t_ref = float(np.nanmean(obs.oil_temp))
    # per row, as a bin of its own (the live monitor sees the instant, not a bin)
    torque = np.abs(r18.torque(obs.alpha[idx], obs.speed[idx]))
    ls = load_sharing(r18, obs.alpha[idx], torque, 0.4e-3, 0.2e-3)
    fr = friction_force(FrictionParams(*shape), ls.r_a, ls.r_e, ls.m_a, ls.guide_force, r18.bushing_length)
    n_a = np.maximum(np.abs(ls.r_a), 2 * np.abs(ls.m_a) / r18.bushing_length)
    feats = {'n_b': n_a + np.abs(ls.r_e), 'f_gb': np.abs(ls.guide_force), 'load': np.abs(ls.axial)}
    rows = slice(0, 400)
    mom = Moments.from_rows(
        np.arange(keys.size)[rows] * 4 + (obs.direction[idx][rows] > 0) + 2 * (obs.alpha[idx][rows] >= 0),
        aa[rows],
        v2[rows],
        u[rows],
        zn,
    )
    predicted = np.zeros(mom.keys.size)
    for col in cand.columns:
        feature = col.feature(mom, {k: v[rows] for k, v in feats.items()})
        zcol = u[rows][:, 1 + zn.index(col.z)] if col.z else np.ones(mom.keys.size)
        predicted += coefficients[col.name] * feature * zcol
    terms = dict(coefficients, t_ref_k=t_ref)
    cos2 = np.cos(obs.alpha[idx]) ** 2
    v_ram = r18.stock_to_ram / cos2 * np.abs(obs.rate[idx])
    live = np.array([live_term((effect,), terms, float(obs.direction[idx][r]), float(v_ram[r]),
                               abs(float(u[r, -1])), float(obs.oil_temp[idx][r]), float(fr[r]), int(ram[r]))
                     for r in range(400)])
    np.testing.assert_allclose(live, predicted, rtol=1e-9, atol=1e-6)


def test_a_delay_and_a_mass_are_no_terms():
    for name in ('angle_delay', 'ram_inertia'):
        assert name in NAMES
        assert live_term((Effect(name, (('tau_s', 0.2),) if name == 'angle_delay' else ()),),
                         {'tau_s': 0.2, 'mass_kg': 5e4}, 1.0, 0.01, 1e5, 300.0, 1e4, 0) == 0.0
    assert math.isfinite(live_term((), {}, 1.0, 0.0, 0.0, math.nan, 0.0, 1))


def test_every_column_of_the_library_has_its_value_at_an_instant():
    """The live residual evaluates the fits' own columns: each candidate's, bar the ram's
    acceleration, has a per-instant value (a new column without one fails here, not at sea)."""
    for c in candidates({'dtemp': np.zeros(1)}, (9e3, 0.13, 0.05)):
        effect = Effect(c.name, tuple(sorted((c.fixed or {}).items())), c.shape)
        terms = {col.name: 1.0 for col in c.columns} | {'t_ref_k': 300.0}
        term = InstantTerms((effect,), terms)
        assert [col.name for _, col in term.columns] == [col.name for col in c.columns if col.z != 'accel']
        assert math.isfinite(term(1.0, 0.01, 1e5, 301.0, 1e4, 0))
    with pytest.raises(KeyError, match='c_ns_per_m'):
        InstantTerms((Effect('viscous'),), {})
