"""The ship-like programmes: engine orders (stepped and drifting speed), pump changes, the
dead-band autopilot on solenoid valves (stop-start motion), holds at odd angles, zigzags of
any amplitude, and the ``realistic`` voyage drawn from the seed."""

from __future__ import annotations

import math

import numpy as np
import pytest

from steer_monitor import sim
from steer_monitor.sim.programs import SPEED_TAU_S, realistic_program

DEG = math.pi / 180
KNOT = 1852.0 / 3600.0


def _plant(r18_params, can_db, program, seed=1, **kw):
    db, smap = can_db
    return sim.run(r18_params, sim.SimConfig(program=program, **kw), db, smap, seed).plant


def test_realistic_is_drawn_from_the_seed():
    a, b, c = (realistic_program(np.random.default_rng(s)) for s in (5, 5, 6))
    assert a == b and a != c
    steps = sim.parse_program(a)
    kinds = {s.kind for s in steps}
    assert {'speed', 'autopilot_db'} <= kinds
    speeds = [s.value for s in steps if s.kind == 'speed']
    assert len(speeds) >= 5 and all(8.0 <= v <= 17.0 for v in speeds)


def test_engine_order_steps_then_the_speed_drifts_in(r18_params, can_db):
    """speed:KN sets the engine order; the ship's speed follows with the hull's lag (one
    time constant: 63 % of the way)."""
    p = _plant(r18_params, can_db, 'speed:8,hold:30,speed:16,hold:120')
    k30 = int(round(30.0 / 0.01))
    assert p.speed[k30 - 1] == pytest.approx(16 * KNOT + (8 - 16) * KNOT * (1 - math.exp(-30 / SPEED_TAU_S)), rel=2e-3)
    after = p.speed[k30 + int(SPEED_TAU_S / 0.01)]
    start = p.speed[k30]
    assert (after - start) / (16 * KNOT - start) == pytest.approx(1 - math.exp(-1), abs=0.01)
    assert np.all(np.diff(p.speed[k30:]) >= 0)


def test_dead_band_autopilot_moves_in_steps_with_pauses(r18_params, can_db):
    """On solenoid valves the rudder either moves at the pumps' full rate or stands: no slow
    creep; it stops and starts many times a minute, with pauses from a few tens of ms."""
    p = _plant(r18_params, can_db, 'pumps:1,autopilot_db:300', seed=2)
    gear_rate = 15e-3 * np.cos(p.alpha) ** 2 / 0.6           # one pump [rad/s]
    moving = p.rate != 0
    full = np.isclose(np.abs(p.rate), gear_rate, rtol=1e-9)
    # moving samples run at full rate except the last step into the dead band
    assert np.mean(full[moving]) > 0.9
    starts = np.flatnonzero(np.diff(moving.astype(int)) == 1)
    assert starts.size / 5.0 > 10                              # > 10 starts a minute
    stops = np.flatnonzero(np.diff(moving.astype(int)) == -1)
    pauses = (starts[starts > stops[0]][:stops.size] - stops[:starts[starts > stops[0]].size]) * 0.01
    assert pauses.min() < 0.5


def test_hold_at_an_odd_angle_and_zigzag_of_any_amplitude(r18_params, can_db):
    p = _plant(r18_params, can_db, 'hold_at:-7.3/20,zigzag_5')
    held = np.abs(p.alpha + 7.3 * DEG) < 0.5 * DEG          # HelmProgram.REACHED
    assert held.sum() * 0.01 >= 20.0
    assert np.degrees(p.alpha.max()) == pytest.approx(5.0, abs=0.5)


def test_pump_changes_set_the_rate(r18_params, can_db):
    p = _plant(r18_params, can_db, 'pumps:1,zigzag_10,pumps:2,zigzag_10')
    assert set(np.unique(p.pumps[p.rate != 0])) == {1, 2}


def test_existing_programmes_are_unchanged_by_the_new_steps(r18_params, can_db):
    """Programmes without engine orders keep the time-based speed profile."""
    p = _plant(r18_params, can_db, 'hard_over_2', speed_profile=((0.0, 10.0), (100.0, 14.0)))
    assert p.speed[0] == pytest.approx(10 * KNOT)
    assert p.speed[int(50 / 0.01)] == pytest.approx(12 * KNOT, rel=1e-9)
