"""The tiller torque curve: through its points, monotone, odd, speed squared."""

from __future__ import annotations

import math

import numpy as np
import pytest

from steer_monitor.errors import ParameterError
from steer_monitor.model import TorqueCurve


@pytest.fixture
def curve():
    return TorqueCurve.from_degrees_knm([0, 5, 10, 21, 27.5, 35], [0, 330, 584, 766, 930, 1000], 16.0)


def test_through_points_and_monotone(curve):
    pts = np.radians([0, 5, 10, 21, 27.5, 35])
    assert curve(pts) / 1e3 == pytest.approx([0, 330, 584, 766, 930, 1000])
    dense = curve(np.radians(np.linspace(0, 35, 3501)))
    assert np.all(np.diff(dense) >= -1e-9)


def test_odd_held_beyond_last_point_and_speed_squared(curve):
    a = math.radians(20)
    assert float(curve(-a)) == pytest.approx(-float(curve(a)))
    assert float(curve(math.radians(40))) == pytest.approx(1000e3)
    vs = curve.service_speed
    assert float(curve(a, vs / 2)) == pytest.approx(float(curve(a)) / 4)


@pytest.mark.parametrize('angles,torques,msg', [
    ([0, 5], [0, 1, 2], 'two equal-length lists'),
    ([0, 5, 5], [0, 1, 2], 'strictly increasing'),
    ([0, 5, 10], [0, 2, 1], 'must not decrease'),
    ([0, 5, 10], [1, 2, 3], 'must start at'),
])
def test_bad_curves(angles, torques, msg):
    with pytest.raises(ParameterError, match=msg):
        TorqueCurve.from_degrees_knm(angles, torques, 16.0)


def test_one_sample_is_the_curve_itself(curve):
    """The live model's one-sample torque is the PCHIP curve's value, exactly (one evaluation)."""
    rng = np.random.default_rng(0)
    for a in np.concatenate([rng.uniform(-0.7, 0.7, 2000), [0.0, 1e-9, np.radians(35.0), np.radians(40.0)]]):
        assert curve.scalar(float(a)) == float(curve(a))
        assert curve.scalar(float(a), 5.0) == float(curve(a, 5.0))


def test_table_interpolates_is_odd_and_unknown_beyond_its_last_angle():
    import math

    from steer_monitor.model.torque import TorqueTable

    t = TorqueTable(np.radians([0.0, 10.0, 20.0]), np.array([0.0, 400e3, 600e3]), 7.0)
    assert t.max_angle == pytest.approx(math.radians(20.0))
    assert t.scalar(math.radians(15.0)) == pytest.approx(500e3)
    assert t.scalar(math.radians(-5.0)) == pytest.approx(-200e3)
    assert t.scalar(math.radians(20.0)) == pytest.approx(600e3) and t.scalar(0.0) == 0.0
    assert t.scalar(math.radians(10.0), 14.0) == pytest.approx(4 * 400e3)
    assert math.isnan(t.scalar(math.radians(20.01)))


def test_scalars_are_the_one_sample_lookup_over_arrays(curve):
    """The array lookup (the live monitor re-judging a minute at once) gives each sample's
    one-sample value, to rounding: the curve held beyond its end, the learned table NaN
    beyond its end; speed scaling where the speed is known (NaN: not)."""
    import math

    from steer_monitor.model.torque import TorqueTable
    rng = np.random.default_rng(1)
    alpha = np.concatenate([rng.uniform(-0.7, 0.7, 3000), [0.0, -0.0, 1e-12, np.radians(35.0), np.radians(-40.0)]])
    speed = np.where(rng.random(alpha.size) < 0.3, np.nan, rng.uniform(1.0, 9.0, alpha.size))
    table = TorqueTable(np.radians(np.arange(0.0, 20.01, 0.5)), np.linspace(0.0, 700e3, 41), 7.0)
    for t in (curve, table):
        got = t.scalars(alpha, speed)
        want = [t.scalar(float(a), None if math.isnan(v) else float(v)) for a, v in zip(alpha, speed)]
        np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-6)
        assert np.array_equal(np.isnan(got), np.isnan(want))
    assert np.isnan(table.scalars(alpha, speed)[np.abs(alpha) > np.radians(20.0)]).all()


@pytest.mark.parametrize('alpha, speed', [(np.zeros(3), np.zeros(2)), (np.zeros((2, 2)), np.zeros((2, 2))),
                                          (np.zeros(3), np.zeros(()))])
def test_scalars_need_one_shape(curve, alpha, speed):
    """The array lookup takes (n,) angles and (n,) speeds, nothing broadcast."""
    with pytest.raises(ValueError, match=r'torque lookup needs angles and speeds of one shape \(n,\)'):
        curve.scalars(alpha, speed)


@pytest.mark.parametrize('angles, torques', [([0.0], [0.0]), ([0.1, 0.2], [0.0, 1.0]), ([0.0, 0.2, 0.1], [0, 1, 2]),
                                             ([0.0, 0.1], [0.0, float('nan')])])
def test_bad_tables(angles, torques):
    from steer_monitor.model.torque import TorqueTable

    with pytest.raises(ParameterError, match='torque table needs at least 2 finite points'):
        TorqueTable(np.array(angles), np.array(torques, dtype=float), 7.0)
