"""Study gear B (config/gear_b.yaml), the second gear the checks run on: an invented gear, so
its landmarks are not a paper's but what physics and the rules ask of any such gear, each
checked against a computation of its own (a finite-element contact solution, a closed form)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from steer_monitor.can.busconfig import can_setup
from steer_monitor.model import Clearances
from steer_monitor.model.kinematics import rapson_state
from steer_monitor.model.landmarks import landmarks
from steer_monitor.model.loadshare import compliances, load_sharing_at
from steer_monitor.params import gear_from_params, load_params_file
from test.conftest import PKG
from test.model.beam_fem import contact_solution

GEAR_B = PKG / 'config' / 'gear_b.yaml'


@pytest.fixture(scope='module')
def params() -> dict:
    return load_params_file(GEAR_B)


@pytest.fixture(scope='module')
def gear_b(params):
    return gear_from_params(params)


def test_it_is_a_whole_parameters_file_the_node_and_commands_read(params):
    assert params['gear.name'] == 'study gear B'
    db, smap = can_setup(params, GEAR_B)          # its DBC beside it, its signal map complete
    assert db.message(127245) is not None and len(smap.specs) == 8


def _fe(gear, alpha: float, gaps: Clearances):
    st = rapson_state(gear, alpha, gear.torque(alpha))
    return st, contact_solution(gear.bushing_span, gear.youngs_modulus * gear.ram_inertia, float(st.near),
                                gear.guide_beam_span, gear.youngs_modulus * gear.guide_beam_inertia,
                                float(st.guide_a), float(st.lateral), gaps.two_z / gear.bushing_length, gaps.z_gb)


@pytest.mark.parametrize('gaps_mm', [(0.7, 0.3), (0.3, 0.1), (0.05, 0.05), (0.0, 0.2)])
@pytest.mark.parametrize('alpha_deg', [5.0, 12.0, 21.0, 30.0, 35.0])
def test_its_load_sharing_is_the_finite_element_contact_solution(gear_b, alpha_deg, gaps_mm):
    alpha = math.radians(alpha_deg)
    gaps = Clearances.from_mm(*gaps_mm)
    res = load_sharing_at(gear_b, alpha, gaps)
    st, fe = _fe(gear_b, alpha, gaps)
    scale = float(st.lateral)
    assert float(res.ram_force) == pytest.approx(fe.ram_force, rel=1e-3, abs=1e-3 * scale)
    assert float(res.guide_force) == pytest.approx(fe.guide_force, rel=1e-3, abs=1e-3 * scale)
    assert float(res.deflection) == pytest.approx(fe.deflection, rel=1e-3, abs=1e-9)


def test_the_guide_beam_takes_load_where_the_finite_element_solution_first_touches(gear_b):
    """At its wear limits (0.7 / 0.3 mm): the guide onset of the sweep equals the angle where the
    FE solution's slipper first touches (bisection to 0.01 deg), and the guide then carries a
    real share (as a guide beam is there to)."""
    gaps = Clearances.from_mm(0.7, 0.3)
    alpha = np.radians(np.arange(0.0, 35.0001, 0.05))
    marks = landmarks(alpha, load_sharing_at(gear_b, alpha, gaps))
    lo, hi = 0.0, 35.0
    assert not _fe(gear_b, math.radians(lo + 0.5), gaps)[1].guide_contact
    assert _fe(gear_b, math.radians(hi), gaps)[1].guide_contact
    while hi - lo > 0.01:
        mid = (lo + hi) / 2
        lo, hi = (lo, mid) if _fe(gear_b, math.radians(mid), gaps)[1].guide_contact else (mid, hi)
    assert marks.guide_onset is not None
    assert math.degrees(marks.guide_onset) == pytest.approx(hi, abs=0.06)
    assert 0.3 <= marks.k_gl_max <= 0.9


def test_the_guide_beam_is_stiffer_than_the_ram_over_the_range(gear_b):
    alpha = np.radians(np.arange(0.0, 35.01, 0.5))
    c = compliances(gear_b, rapson_state(gear_b, alpha, 1.0))
    assert np.all(c.pinned / c.guide > 1.0)


def test_its_working_pressure_at_full_torque_is_what_such_a_gear_is_built_for(gear_b):
    """Per ram at 35 deg the axial force T cos^2(alpha) / (n H) (the Rapson slide's lever):
    the chamber pressure it takes lies well inside a ram gear's usual 160-250 bar rating."""
    alpha = math.radians(35.0)
    torque = gear_b.torque(alpha)
    st = rapson_state(gear_b, alpha, torque)
    closed = torque * math.cos(alpha) ** 2 / (gear_b.rams * gear_b.stock_to_ram)
    assert float(st.axial) == pytest.approx(closed, rel=1e-9)
    bar = float(st.axial) / gear_b.ram_area / 1e5
    assert 80.0 <= bar <= 160.0


def test_its_hard_over_meets_solas_with_both_pumps(params, gear_b):
    """35 deg one side to 30 deg the other in 28 s or less (SOLAS II-1/29.3.2) with both pumps:
    the ram's travel H (tan 35 + tan 30) at n pumps' speed."""
    travel = gear_b.stock_to_ram * (math.tan(math.radians(35.0)) + math.tan(math.radians(30.0)))
    seconds = travel / (params['hydraulics.pumps'] * params['hydraulics.ram_speed_per_pump_mm_s'] * 1e-3)
    assert 20.0 <= seconds <= 28.0
