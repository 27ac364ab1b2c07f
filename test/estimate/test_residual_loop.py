"""The residual loop on a ship's operation (the realistic programme) with effects it was not
tuned on: each library effect at a fifth of the simulator's default, two at once, and one
outside the library. Seeds 301-312 and the clearances here are used nowhere else."""

from __future__ import annotations

import pytest

from steer_monitor import sim
from steer_monitor.ashore.loganalysis import analysis_json
from steer_monitor.estimate.analysiswords import skew_equivalent_s
from steer_monitor.estimate.analyze import analyze
from steer_monitor.studies.accuracy import MAGNITUDE, scaled_effect
from test.estimate.conftest import holds

pytestmark = pytest.mark.slow

MIN_2Z = 0.05e-3
# The systematic part a clean realistic voyage keeps (docs/accuracy.md: up to ~0.14 bar): an
# effect is explained when what it added over that floor is gone.
FLOOR_BAR = 0.15


def _bar(est) -> float:
    return est.ram_area * 1e5


def test_every_library_effect_has_a_magnitude_and_the_simulator_has_them_all():
    assert set(MAGNITUDE) | set(sim.OUTSIDE_LIBRARY) | set(sim.FAULTS) | set(sim.SENSOR_FAULTS) == set(sim.EFFECTS)
    assert scaled_effect('viscous', 0.2) == 'viscous:c_ns_per_m=200000'


@pytest.mark.parametrize('name, seed', [(n, 301 + k) for k, n in enumerate(MAGNITUDE)])
def test_each_library_effect_at_a_fifth_is_named(r18, simulate_signals, name, seed):
    """At a fifth of the default the effect is mostly under the sensor noise; what the loop
    must do is name it, take what it added to the systematic part, and nothing else."""
    signals, _ = simulate_signals('realistic:1500', 0.4, 0.2, (scaled_effect(name, 0.2),), seed=seed)
    a = analyze(r18, signals, min_clearance_2z=MIN_2Z)
    names = [s.name for s in a.steps]
    assert names == [name], a.message
    assert a.verdict == 'effect'
    d, f = a.declared.smooth_rms / _bar(a.declared), a.final.smooth_rms / _bar(a.final)
    assert f <= max(0.5 * d, FLOOR_BAR), (d, f)
    assert holds(a.final, 1, 0.2e-3), a.final.z_gb      # within its 99 % set (see conftest.holds)


@pytest.mark.parametrize('effects, seed', [
    (('viscous', 'pressure_offset'), 311),
    (('pressure_friction:k=0.006', 'viscous:c_ns_per_m=2e5'), 312),
])
def test_two_effects_at_once_are_both_named(r18, simulate_signals, effects, seed):
    """Both named. A known third: with the default viscous friction (30 kN at two-pump speed)
    a term proportional to the ram's acceleration remains, about 18 t [12, 25] of apparent
    mass on seed 311, and is taken as ram_inertia. The viscous slope times a misalignment of
    the angle-derived ram speed and the pressures is a mass: the plant's pressure leads its
    angle by half a 10 ms step and the rate window lags 2 ms, which make about 7 t; the rest
    is not found. It takes under 0.01 bar of RMS (docs/residual-loop.md). Anything else is a
    false adoption."""
    signals, _ = simulate_signals('realistic:1500', 0.3, 0.3, effects, seed=seed)
    a = analyze(r18, signals, min_clearance_2z=MIN_2Z)
    simulated = {e.partition(':')[0] for e in effects}
    assert simulated <= {s.name for s in a.steps}, a.message
    for extra in (s for s in a.steps if s.name not in simulated):
        assert extra.name == 'ram_inertia' and 'viscous' in simulated, a.message
        assert extra.before.rms - extra.after.rms < 0.01 * _bar(a.final)
        skew = skew_equivalent_s(a.steps)      # a few ms, as the plant's lead and the rate's lag make
        assert skew is not None and 0.001 < skew < 0.05, skew
        assert f'a skew of {1e3 * skew:.0f} ms between the angle and the pressures' in a.message
    assert a.verdict == 'effect'
    d, f = a.declared.smooth_rms / _bar(a.declared), a.final.smooth_rms / _bar(a.final)
    assert f <= max(0.5 * d, FLOOR_BAR), (d, f)
    for before, after in ((s.before, s.after) for s in a.steps):
        assert after.rms < before.rms
    assert a.steps[0].before is a.declared and a.steps[-1].after is a.final
    assert a.final.z_gb.contains(0.3e-3)
    js = analysis_json(a)
    assert [e['name'] for e in js['effects']] == [s.name for s in a.steps]
    assert js['effect'] == {'name': js['effects'][0]['name'], 'params': js['effects'][0]['params']}
    for e in js['effects']:
        assert set(e) >= {'name', 'params', 'rmse_before_bar', 'rmse_after_bar'}
        assert e['rmse_after_bar'] < e['rmse_before_bar']
    assert js['unexplained'] is None


@pytest.mark.parametrize('seed', [313, 5049])   # 5049: the accuracy study's log whose Z_gb interval
                                                # missed by 0.002 mm with the nuisance alone
def test_an_effect_outside_the_library_is_located_and_the_clearances_stay_honest(r18, simulate_signals, seed):
    signals, _ = simulate_signals('realistic:1500', 0.4, 0.2, ('band_friction',), seed=seed)
    a = analyze(r18, signals, min_clearance_2z=MIN_2Z)
    assert a.verdict == 'unexplained', a.message
    loc = a.located
    assert loc is not None and loc.variable == 'alpha_deg' and loc.either_side
    assert abs(loc.lo - 12.0) < 0.5 and abs(loc.hi - 18.0) < 0.5
    assert loc.shape.ram is None and loc.shape.odd and loc.level > 0
    f = a.final
    assert f.z_gb.contains(0.2e-3) and f.two_z.contains(0.4e-3)
    assert 'incomplete model' in a.message


def test_a_delay_between_the_grid_steps_is_found_to_a_few_milliseconds(r18, simulate_signals):
    """Found by the sensitivity study: a 0.125 s delay, between the 50 ms grid's steps, was
    read as 0.10 or 0.15 s, and the rest of it taken by viscous and pressure friction, which
    then put Z_gb at 0.02 mm (truth 0.1). Refined where the grid's parabola says the optimum
    lies between its points, it is one effect."""
    signals, _ = simulate_signals('realistic:1500', 0.3, 0.3, ('angle_delay:tau_s=0.137',), seed=314)
    a = analyze(r18, signals, min_clearance_2z=MIN_2Z)
    assert [s.name for s in a.steps] == ['angle_delay'], a.message
    assert abs(a.params['tau_s'].value - 0.137) <= 0.003
    assert abs(a.final.z_gb.value - 0.3e-3) <= 0.02e-3       # not the 0.08 mm the half-found delay cost


def test_unexplained_inflation_counts_the_systematic_part_as_noise():
    from types import SimpleNamespace as NS

    from steer_monitor.estimate.analyze import unexplained_inflation
    assert unexplained_inflation(NS(noise_rms=0.35e5, smooth_rms=0.0)) == 1.0
    assert unexplained_inflation(NS(noise_rms=0.35e5, smooth_rms=0.47e5)) == pytest.approx(1 + (0.47 / 0.35) ** 2)
    assert unexplained_inflation(NS(noise_rms=float('nan'), smooth_rms=1.0)) == 1.0


def test_an_adopted_inertia_says_what_its_mass_cannot():
    """The fitted mass reads low (docs/residual-loop.md): the message says so whenever
    ram_inertia is adopted, and says nothing of it otherwise."""
    from types import SimpleNamespace as NS

    from steer_monitor.estimate.analysiswords import CAVEATS, message, skew_equivalent_s
    from steer_monitor.estimate.intervals import Interval
    est = NS(ram_area=0.05, rms=0.35 * 5e3, smooth_rms=0.05 * 5e3)
    visc, inertia = NS(name='viscous', params={}), NS(name='ram_inertia', params={})
    with_it = message('effect', est, est, None, [visc, inertia])
    assert with_it.startswith('added viscous, then ram_inertia: residual 0.35 -> 0.35 bar RMS')
    assert with_it.endswith(f'(ram_inertia: {CAVEATS["ram_inertia"]})') and 'reads low' in with_it
    assert 'apparent' not in message('effect', est, est, None, [visc])
    assert 'apparent' in message('unexplained', est, est, None, [inertia])
    # with both fitted: the skew that would show as that mass beside that viscous friction
    visc = NS(name='viscous', params={'c_ns_per_m': Interval(7.5e5, 7.0e5, 8.0e5)})
    for mass, skew in ((1.8e4, 0.024), (-1.8e4, None), (0.0, None)):
        inertia = NS(name='ram_inertia', params={'mass_kg': Interval(mass, None, None)})
        assert skew_equivalent_s([visc, inertia]) == (None if skew is None else pytest.approx(skew))
        text = message('effect', est, est, None, [visc, inertia])
        assert ('a skew of 24 ms between the angle and the pressures' in text) == (skew is not None), text
    assert skew_equivalent_s([inertia]) is None
