"""Simulated logs for the estimator tests, decoded once per session."""

from __future__ import annotations

import functools

import numpy as np
import pytest

from steer_monitor import sim
from steer_monitor.can.decoder import Decoder
from steer_monitor.model.gear import Gaps


@pytest.fixture(scope='session')
def simulate_signals(r18_params, db, smap):
    """(program, 2Z mm, Z_gb mm, effects, seed, max_s) -> (decoded signals, Simulation)."""
    @functools.lru_cache(maxsize=None)
    def make(program: str = 'voyage', two_z: float = 0.6, z_gb: float = 0.25, effects: tuple[str, ...] = (),
             seed: int = 1, max_s: float = 7200.0, perturb=None):
        cfg = sim.SimConfig(program=program, gaps=Gaps.from_mm(two_z, z_gb),
                            effects=tuple(sim.parse_effect(e) for e in effects), max_duration_s=max_s)
        if perturb is None:
            s = sim.run(r18_params, cfg, db, smap, seed)
        else:
            s = perturb(r18_params, cfg, db, smap, seed)
        return Decoder(db, smap).decode_arrays(s.frames), s
    return make


def scored_ram(params, cfg, db, smap, seed):
    """An effect outside the analysis library: a scored stretch of the ram adds 12 kN of friction
    while the rudder moves between 12 and 18 deg (the ram passes a damaged part of its bushing)."""
    from steer_monitor.params import gear_from_params
    from steer_monitor.sim.encode import encode_frames, sensor_streams
    from steer_monitor.sim.plant import simulate

    gear = gear_from_params(params)
    rng = np.random.default_rng(seed)
    plant = simulate(gear, cfg, params['hydraulics.ram_speed_per_pump_mm_s'] * 1e-3, params['hydraulics.pumps'], rng)
    band = (np.abs(plant.alpha) > np.radians(12)) & (np.abs(plant.alpha) < np.radians(18)) & (plant.rate != 0)
    extra = np.where(band, np.sign(plant.rate) * 12e3, 0.0) / gear.ram_area
    for ram in ('r1', 'r2'):
        st, pt = plant.pressures[f'pressure_{ram}_stbd'], plant.pressures[f'pressure_{ram}_port']
        dp = st - pt + extra
        st[:] = cfg.return_pressure + np.maximum(dp, 0.0)
        pt[:] = cfg.return_pressure + np.maximum(-dp, 0.0)
    sensors = sensor_streams(plant, cfg, rng)
    return sim.Simulation(plant, sensors, encode_frames(sensors, db, smap))
