"""Closed-form beam compliances, slopes, reactions and the Euler force against FE solutions."""

from __future__ import annotations

import math

import numpy as np
import pytest

from steer_monitor.model import (
    clamped_clamped_compliance,
    clamped_pinned_compliance,
    clamped_pinned_reactions,
    euler_force,
    pinned_pinned_compliance,
    pinned_pinned_reactions,
    pinned_pinned_slope_at_a,
    rapson_state,
)
from test.model.beam_fem import Beam, buckling_force

ANGLES_DEG = np.arange(0.0, 35.01, 2.5)
REL = 1e-3  # 0.1 %: what a beam's closed form must hold to against the finite elements


@pytest.fixture(params=ANGLES_DEG, ids=lambda a: f'{a:g}deg')
def geometry(request, r18):
    st = rapson_state(r18, math.radians(request.param), 1.0)
    return r18, float(st.near), float(st.far), float(st.guide_a), float(st.guide_b)


def test_pinned_pinned_against_fe(geometry):
    gear, a, b, _, _ = geometry
    ei = gear.youngs_modulus * gear.ram_inertia
    beam = Beam(a + b, ei, a)
    u, reactions = beam.solve(1.0, 'pinned', 'pinned')
    assert pinned_pinned_compliance(a, b, ei) == pytest.approx(u[beam.w_dof(beam.load_node)], rel=REL)
    assert pinned_pinned_slope_at_a(a, b, ei) == pytest.approx(u[beam.slope_dof(0)], rel=REL)
    r_a, r_e = pinned_pinned_reactions(a, b)
    assert r_a == pytest.approx(reactions[beam.w_dof(0)], rel=REL)
    assert r_e == pytest.approx(reactions[beam.w_dof(beam.last)], rel=REL)


def test_clamped_pinned_against_fe(geometry):
    gear, a, b, _, _ = geometry
    ei = gear.youngs_modulus * gear.ram_inertia
    beam = Beam(a + b, ei, a)
    u, reactions = beam.solve(1.0, 'clamped', 'pinned')
    assert clamped_pinned_compliance(a, b, ei) == pytest.approx(u[beam.w_dof(beam.load_node)], rel=REL)
    r_a, r_e, m_a = clamped_pinned_reactions(a, b)
    assert r_a == pytest.approx(reactions[beam.w_dof(0)], rel=REL)
    assert r_e == pytest.approx(reactions[beam.w_dof(beam.last)], rel=REL)
    assert m_a == pytest.approx(reactions[beam.slope_dof(0)], rel=REL)


def test_guide_beam_clamped_clamped_against_fe(geometry):
    gear, _, _, ag, bg = geometry
    ei = gear.youngs_modulus * gear.guide_beam_inertia
    beam = Beam(ag + bg, ei, ag)
    u, _ = beam.solve(1.0, 'clamped', 'clamped')
    assert clamped_clamped_compliance(ag, bg, ei) == pytest.approx(u[beam.w_dof(beam.load_node)], rel=REL)


@pytest.mark.parametrize('span', [0.8, 1.22, 1.6])
def test_euler_force_against_fe_eigenvalue(r18, span):
    ei = r18.youngs_modulus * r18.ram_inertia
    assert euler_force(ei, span) == pytest.approx(buckling_force(span, ei), rel=REL)


def test_euler_amplification_against_fe_beam_column(r18):
    """Deflection of the axially loaded ram (FE with geometric stiffness) over the linear one
    equals 1 / (1 - Fa / F_Eu) at 35 deg and 1000 kN m."""
    st = rapson_state(r18, math.radians(35.0), 1.0e6)
    a, b = float(st.near), float(st.far)
    ei = r18.youngs_modulus * r18.ram_inertia
    # The compressed segment is B..E (length L1 = b), loaded laterally at its end B, as the
    # paper's F_Eu with L1 assumes: a column pinned at both ends of L1 with a mid-load.
    beam = Beam(b, ei, b / 2, elements=40)
    lin, _ = beam.solve(1.0, 'pinned', 'pinned')
    col, _ = beam.solve(1.0, 'pinned', 'pinned', axial=float(st.axial))
    ratio = col[beam.w_dof(beam.load_node)] / lin[beam.w_dof(beam.load_node)]
    assert float(st.amplification) == pytest.approx(ratio, rel=1e-4)
    assert round(float(st.amplification), 4) == 1.0031  # the paper's 0.31 %
    assert a > 0
