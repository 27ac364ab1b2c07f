"""The Rapson slide's lever: the tiller torque and the rams' axial force, against virtual work."""

from __future__ import annotations

import math

import numpy as np
import pytest

from steer_monitor.model.kinematics import axial_of_torque, rapson_state, torque_of_axial


def test_the_lever_is_virtual_work_on_the_slide(r18):
    """n rams pushing Fa along x = H tan(alpha) do the work the torque does turning the stock:
    M d(alpha) = n Fa dx, dx/d(alpha) by a central difference of x(alpha)."""
    alpha = np.radians(np.array([-35.0, -20.0, -3.0, 0.0, 7.5, 22.0, 35.0]))
    fa = 4.0e5
    h = 1e-6
    dx = r18.stock_to_ram * (np.tan(alpha + h) - np.tan(alpha - h)) / (2 * h)
    np.testing.assert_allclose(torque_of_axial(r18, fa, np.cos(alpha)), r18.rams * fa * dx, rtol=1e-8)
    torque = torque_of_axial(r18, fa, np.cos(alpha))
    np.testing.assert_allclose(axial_of_torque(r18, torque, np.cos(alpha)), fa, rtol=1e-14)
    np.testing.assert_allclose(rapson_state(r18, alpha, torque).axial, fa, rtol=1e-14)


def test_floats_and_arrays_alike(r18):
    a = math.radians(25.0)
    one = torque_of_axial(r18, 3.0e5, math.cos(a))
    assert isinstance(one, float)
    assert one == pytest.approx(torque_of_axial(r18, np.array([3.0e5]), np.cos(np.array([a])))[0], rel=1e-15)
