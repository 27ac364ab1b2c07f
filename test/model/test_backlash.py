"""Backlash of a kinematic chain (paper 000): sums, RSS, reduction to the rudder angle, and the
inverse grade question, each against an independent computation."""

from __future__ import annotations

import math

import numpy as np
import pytest

from steer_monitor.errors import ParameterError
from steer_monitor.model import ChainJoint, chain_backlash, grade_for_limit, parse_fit, rapson_arm

UM = 1e-6
ARCMIN = math.radians(1 / 60)


@pytest.fixture
def chain():
    return [
        ChainJoint.from_fit('crosshead pin', parse_fit('180 H7/f7'), 1.0),
        ChainJoint.from_fit('swivel block', parse_fit('180 H8/f7'), 1.0),
        ChainJoint.from_deviations('tiller slot', 0.300, (130 * UM, 0.0), (-56 * UM, -186 * UM), 0.5),
    ]


def test_sums_and_rss(chain):
    res = chain_backlash(chain, actuator_mean=50 * UM, actuator_dev=20 * UM)
    c = [j.coefficient for j in chain]
    mean = 50 * UM + sum(ci * j.clearance.mean for ci, j in zip(c, chain))
    rss = math.sqrt((20 * UM) ** 2 + sum((ci * j.clearance.probable_dev) ** 2 for ci, j in zip(c, chain)))
    worst = 20 * UM + sum(ci * j.clearance.worst_dev for ci, j in zip(c, chain))
    assert res.mean == pytest.approx(mean)
    assert res.probable_dev == pytest.approx(rss)
    assert res.worst_dev == pytest.approx(worst)


def test_worst_case_from_limit_deviations(chain):
    """Worst-case max = actuator max + sum c_i (hole upper - shaft lower), read straight off
    the limit deviations rather than through means and half-tolerances."""
    res = chain_backlash(chain, actuator_mean=50 * UM, actuator_dev=20 * UM)
    expected = 70 * UM
    expected += 1.0 * (parse_fit('180 H7/f7').hole.upper - parse_fit('180 H7/f7').shaft.lower)
    expected += 1.0 * (parse_fit('180 H8/f7').hole.upper - parse_fit('180 H8/f7').shaft.lower)
    expected += 0.5 * (130 * UM - (-186 * UM))
    assert res.mean + res.worst_dev == pytest.approx(expected)


def test_rapson_arm_against_numerical_derivative():
    """Rod travel x = H tan(alpha): dx/dalpha is the arm H / cos^2(alpha)."""
    h = 0.6
    for a in np.radians([0.0, 10.0, 20.0, 35.0]):
        eps = 1e-7
        numeric = (h * math.tan(a + eps) - h * math.tan(a - eps)) / (2 * eps)
        assert float(rapson_arm(h, a)) == pytest.approx(numeric, rel=1e-6)


def test_angle_reduction_worst_at_midships(chain):
    res = chain_backlash(chain)
    at_0 = res.angle(rapson_arm(0.6, 0.0))['worst_max']
    at_35 = res.angle(rapson_arm(0.6, math.radians(35)))['worst_max']
    assert at_0 > at_35
    assert float(at_0) == pytest.approx((res.mean + res.worst_dev) / 0.6)


def test_grade_for_limit_picks_the_coarsest_passing(chain):
    arm = 0.6
    grade, checks = grade_for_limit(chain, 3 * ARCMIN, arm)
    assert [c.grade for c in checks] == [5, 6, 7, 8, 9, 10, 11]
    worst = [c.worst_max for c in checks]
    assert worst == sorted(worst)  # coarser grade, more backlash
    assert grade is not None
    assert checks[[c.grade for c in checks].index(grade)].worst_max <= 3 * ARCMIN
    if grade < 11:
        assert checks[[c.grade for c in checks].index(grade + 1)].worst_max > 3 * ARCMIN


def test_grade_for_limit_none_when_unreachable(chain):
    grade, checks = grade_for_limit(chain, 0.01 * ARCMIN, 0.6)
    assert grade is None
    assert not any(c.within for c in checks)


@pytest.mark.parametrize('kwargs,msg', [
    (dict(limit=-1.0, arm=0.6), 'backlash limit must be a positive angle'),
    (dict(limit=1e-3, arm=0.6, basis='median'), "basis must be 'worst' or 'probable'"),
])
def test_grade_for_limit_bad_args(chain, kwargs, msg):
    with pytest.raises(ParameterError, match=msg):
        grade_for_limit(chain, **kwargs)


def test_bad_joint_and_actuator():
    with pytest.raises(ParameterError, match="joint 'x': transmission coefficient must be >= 0"):
        ChainJoint.from_fit('x', parse_fit('50 H7/g6'), -1.0)
    with pytest.raises(ParameterError, match='actuator backlash must be finite'):
        chain_backlash([], actuator_mean=0.0, actuator_dev=-1.0)
