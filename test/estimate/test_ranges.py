"""Physics as constraints: the bounded least-squares solve against an independent solver, the
declared friction held to its ranges in every fit, the effects' ranges."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import lsq_linear

from steer_monitor.estimate import fit as F
from steer_monitor.estimate.plausible import refusal
from steer_monitor.estimate.ranges import DECLARED, EFFECT_RANGES, Range, at_edge, effect_range


def test_bounded_quadratic_against_scipys_bounded_least_squares():
    """x' A x - 2 b' x with A = X'X, b = X'y is ||X x - y||^2 less a constant: the enumeration
    of active sets must land where scipy's trust-region bounded least squares does."""
    rng = np.random.default_rng(3)
    for _ in range(200):
        n = int(rng.integers(2, 6))
        x = rng.normal(size=(40, n))
        y = rng.normal(size=40) * 3
        lo = np.where(rng.random(n) < 0.6, rng.uniform(-1, 0, n), -np.inf)
        hi = np.where(rng.random(n) < 0.6, rng.uniform(0, 1, n), np.inf)
        a, b = x.T @ x, x.T @ y
        start = np.linalg.solve(a, b)
        got = F.bounded_quadratic(a[None], b[None], lo, hi, start[None])[0]
        ref = lsq_linear(x, y, bounds=(lo, hi), method='trf', tol=1e-12, lsmr_tol='auto').x
        assert np.all(got >= lo - 1e-12) and np.all(got <= hi + 1e-12)
        obj = float(np.sum((x @ got - y) ** 2))
        obj_ref = float(np.sum((x @ ref - y) ** 2))
        assert obj <= obj_ref + 1e-9 * max(obj_ref, 1.0)
        assert got == pytest.approx(ref, abs=1e-6)


def test_bounded_quadratic_keeps_a_feasible_start_and_fails_with_a_mutation():
    a = np.array([[[2.0, 0.3], [0.3, 1.0]]])
    b = np.array([[1.0, -4.0]])
    lo, hi = np.array([0.0, 0.0]), np.array([0.3, 0.3])
    start = np.linalg.solve(a[0], b[0])[None]
    got = F.bounded_quadratic(a, b, lo, hi, start)[0]
    assert got[1] == 0.0                      # the unconstrained -4.x is held at the lower bound
    # with x2 at 0, x1 minimizes 2 x1^2 - 2 x1: 0.5, past its upper bound 0.3
    assert got[0] == pytest.approx(0.3)
    inside = np.array([[0.1, 0.2]])
    assert F.bounded_quadratic(a, b, lo, hi, inside)[0] == pytest.approx(inside[0])


def test_declared_bounds_name_the_friction_only():
    lo, hi = F.declared_bounds(['torque_0', 'seal_friction_n', 'mu_bushing', 'mu_guide', 'c_ns_per_m'], 5)
    assert lo.tolist() == [-math.inf, 0.0, 0.0, 0.0, -math.inf]
    assert hi.tolist() == [math.inf, math.inf, DECLARED['mu_bushing'].hi, DECLARED['mu_guide'].hi, math.inf]


def test_every_range_states_its_reason_and_holds_the_simulators_default():
    from steer_monitor import sim
    for rng in DECLARED.values():
        assert len(rng.reason) > 40
    assert DECLARED['mu_bushing'].contains(0.13) and DECLARED['mu_guide'].contains(0.05)
    f_s, f_r = 9e3, 559e3
    defaults = {('viscous', 'c_ns_per_m'): sim.EFFECTS['viscous']['c_ns_per_m'],
                ('stribeck', 'f_st_n'): sim.EFFECTS['stribeck']['f_st_n'],
                ('pressure_friction', 'k'): sim.EFFECTS['pressure_friction']['k'],
                ('temp_friction', 'k_per_k'): sim.EFFECTS['temp_friction']['k_per_k'],
                ('pressure_offset', 'offset_ram1_n'): 3e5 * 0.045239,
                ('ram_inertia', 'mass_kg'): sim.EFFECTS['ram_inertia']['mass_kg']}
    for key in EFFECT_RANGES:
        r = effect_range(*key, f_s, f_r)
        assert r is not None and r.reason
        if key in defaults:
            assert r.contains(float(defaults[key])), key


def test_a_stribeck_excess_of_meganewtons_is_refused():
    assert refusal('stribeck', {'f_st_n': 3.57e6}, 9e3, 559e3) is not None
    assert 'range' in refusal('stribeck', {'f_st_n': 3.57e6}, 9e3, 559e3)
    assert refusal('stribeck', {'f_st_n': 15e3}, 9e3, 559e3) is None
    assert refusal('viscous', {'c_ns_per_m': -1.0}, 9e3, 559e3) is not None


def test_at_edge():
    r = Range(0.0, 0.3, 'x')
    assert at_edge(0.0, r) == 'low' and at_edge(0.3, r) == 'high' and at_edge(0.1, r) is None
    assert at_edge(5.0, Range(0.0, math.inf, 'x')) is None
