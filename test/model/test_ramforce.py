"""The ram's force from its chambers' pressures: one formula, compiled and not, the same bits."""

from __future__ import annotations

import math

import numpy as np

from steer_monitor.model.ramforce import ram_force, ram_force_compiled, ram_forces
from steer_monitor.params import gear_from_params


def test_the_force_is_the_piston_area_times_the_pressure_difference(r18_params):
    """The R-18's 240 mm ram with 100 bar across it: 452 kN (pi 0.24^2 / 4 x 1e7 Pa)."""
    gear = gear_from_params(r18_params)
    assert math.isclose(ram_force(gear.ram_area, 150e5, 50e5), 452_389.3421169302, rel_tol=1e-12)
    assert ram_force(gear.ram_area, 50e5, 150e5) < 0          # the port chamber pushes the other way


def test_compiled_arrays_and_floats_give_the_same_bits():
    rng = np.random.default_rng(5)
    area = 0.0415
    p = rng.uniform(-1e5, 300e5, (1000, 4))
    forces = ram_forces(area, p)
    one = [(ram_force(area, a, b), ram_force(area, c, d)) for a, b, c, d in p.tolist()]
    compiled = [(ram_force_compiled(area, a, b), ram_force_compiled(area, c, d)) for a, b, c, d in p.tolist()]
    assert forces.tobytes() == np.array(one).tobytes() == np.array(compiled).tobytes()
