"""The friction's intervals over the lags a slow log's stamps allow: widened to hold the fits with
the angle read at either end of the span, nothing done at the design rates, and on a voyage
through a gateway that holds its values the seal friction's interval holds the truth."""

from __future__ import annotations

import numpy as np
import pytest

from steer_monitor import sim
from steer_monitor.can import Decoder
from steer_monitor.estimate.analyze import analyze
from steer_monitor.estimate.batch import estimate_clearances, make_rows
from steer_monitor.estimate.effects import z_columns
from steer_monitor.estimate.intervals import Interval
from steer_monitor.estimate.observe import build_observations, in_sorted
from steer_monitor.estimate.ranges import DECLARED
from steer_monitor.estimate.sampling import Windows
from steer_monitor.estimate.stamplags import over_stamp_lags, spanning
from steer_monitor.model.gear import Clearances
from steer_monitor.params import gear_from_params
from steer_monitor.sim.gateway import Gateway, forward

RUDDER, PRESSURE = 127245, 130314
SEAL_N = 9000.0          # the simulator's seal friction


def test_an_interval_spanning_others_holds_each_and_keeps_its_value():
    iv = spanning('seal_friction_n', Interval(9000.0, 8800.0, 9300.0), [Interval(8000.0, 7500.0, 8600.0),
                                                                       Interval(9900.0, 9400.0, 10400.0)])
    assert (iv.value, iv.lo, iv.hi) == (9000.0, 7500.0, 10400.0)
    # an interval not determined leaves the span not determined
    iv = spanning('seal_friction_n', Interval(9000.0, 8800.0, 9300.0), [Interval(8000.0, None, None)])
    assert (iv.lo, iv.hi) == (None, None)
    # held to the physical range: past it, the range's end
    rng = DECLARED['mu_guide']
    iv = spanning('mu_guide', Interval(rng.hi * 0.9, rng.hi * 0.8, rng.hi * 0.95), [Interval(rng.hi, rng.hi * 0.9,
                                                                                             rng.hi * 2)])
    assert iv.lo == pytest.approx(rng.hi * 0.8) and iv.hi == pytest.approx(rng.hi)


@pytest.fixture(scope='module')
def held_voyage(r18_params, can_db):
    """25 minutes of realistic steering through a gateway holding each value and sending it at
    5 Hz (angle sensor 10 Hz, pressures 20 Hz), 2 % of the time lost in bursts. The seed is
    used for no choice."""
    db, smap = can_db
    cfg = sim.SimConfig(program='realistic:1500', gaps=Clearances.from_mm(0.3, 0.15))
    s = sim.run(r18_params, cfg, db, smap, 31)
    gw = Gateway({RUDDER: 5.0, PRESSURE: 5.0}, mode='hold', loss=0.02, burst_s=0.2)
    return Decoder(db, smap).decode_arrays(forward(s.frames, gw, db, 32), final=True), s


def test_at_the_design_rates_nothing_is_widened(simulate_signals, r18_params):
    signals, _ = simulate_signals('voyage', 0.3, 0.15, max_s=600.0)
    gear = gear_from_params(r18_params)
    obs = build_observations(signals, gear.ram_area)
    est = estimate_clearances(gear, obs, make_rows(obs, z_columns(obs, gear)))
    assert Windows.of(signals).lag_span_ns == (0, 0)
    assert over_stamp_lags(gear, signals, est, obs, obs.moving, (), 0.0, np.array([0.3e-3])) is est


def test_through_a_holding_gateway_the_seal_friction_s_interval_holds_the_truth(held_voyage, r18_params):
    """The analysis's friction intervals hold those of the fits with the angle read at either end
    of the lags the stamps allow (on the same instants), and the seal friction's the truth."""
    signals, _ = held_voyage
    gear = gear_from_params(r18_params)
    a = analyze(gear, signals)
    assert a.verdict == 'declared' and not a.steps
    f = a.final
    assert f.seal_friction.lo <= SEAL_N <= f.seal_friction.hi, f.seal_friction
    obs = a.final_observations
    for lag_ns in Windows.of(signals).lag_span_ns:
        o = build_observations(signals, gear.ram_area, angle_shift_s=lag_ns / 1e9)
        keep = in_sorted(o.t_ns, obs.t_ns[obs.moving])
        alt = estimate_clearances(gear, o, make_rows(o, z_columns(o, gear), keep))
        for field in ('seal_friction', 'mu_bushing', 'mu_guide'):
            mine, theirs = getattr(f, field), getattr(alt, field)
            if theirs.lo is not None and mine.lo is not None:
                assert mine.lo <= theirs.lo * (1 + 1e-9) and theirs.hi <= mine.hi * (1 + 1e-9), (field, lag_ns)
