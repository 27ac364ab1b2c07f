"""The steering-gear simulator: declared plant, optional undeclared effects, NMEA 2000 frames.

:func:`run` is the whole chain (plant -> sensors -> frames) for given parameters, a
:class:`SimConfig` and a seed; the same seed gives the same frames.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from steer_monitor.can.codec import CanDatabase
from steer_monitor.can.frames import FrameArrays
from steer_monitor.can.signals import SignalMap
from steer_monitor.params import gear_from_params
from steer_monitor.sim.encode import SensorStreams, encode_frames, sensor_streams
from steer_monitor.sim.plant import DEFAULT_START_NS, SimConfig, SimResult, simulate
from steer_monitor.sim.plant_effects import (
    EFFECTS,
    FAULTS,
    OUTSIDE_LIBRARY,
    SENSOR_FAULTS,
    Effect,
    parse_effect,
    split_effects,
)
from steer_monitor.sim.programs import PROGRAMS, parse_program
from steer_monitor.utc import time_json

__all__ = ['DEFAULT_START_NS', 'EFFECTS', 'FAULTS', 'OUTSIDE_LIBRARY', 'PROGRAMS', 'SENSOR_FAULTS', 'Effect',
           'SimConfig', 'SimResult', 'Simulation', 'parse_effect', 'parse_program', 'run', 'split_effects', 'truth']


@dataclass(frozen=True)
class Simulation:
    plant: SimResult
    sensors: SensorStreams
    frames: FrameArrays


def run(params: Mapping[str, Any], cfg: SimConfig, db: CanDatabase, smap: SignalMap,
        seed: int) -> Simulation:
    """Simulate the gear of ``params`` under ``cfg``; deterministic for a given seed."""
    gear = gear_from_params(params)
    rng = np.random.default_rng(seed)
    plant = simulate(gear, cfg, params['hydraulics.ram_speed_per_pump_mm_s'] * 1e-3,
                     params['hydraulics.pumps'], rng)
    sensors = sensor_streams(plant, cfg, rng)
    return Simulation(plant, sensors, encode_frames(sensors, db, smap))


def truth(params: Mapping[str, Any], cfg: SimConfig, sim: Simulation, seed: int) -> dict[str, Any]:
    """What was simulated, in engineers' units: the truth file beside every output."""
    p = sim.plant
    moving = p.rate != 0
    return {
        'generator': 'steer_monitor simulate',
        'seed': seed,
        'gear': params['gear.name'],
        'program': cfg.program,
        **time_json('start', cfg.start_ns),
        'duration_s': p.duration,
        'clearance_2z_mm': cfg.gaps.two_z * 1e3,
        'clearance_zgb_mm': cfg.gaps.z_gb * 1e3,
        'seal_friction_n': cfg.seal_friction,
        'mu_bushing': cfg.mu_bushing,
        'mu_guide': cfg.mu_guide,
        'return_pressure_bar': cfg.return_pressure / 1e5,
        'angle_noise_rad': cfg.angle_noise if cfg.noise else 0.0,
        'pressure_noise_bar': cfg.pressure_noise / 1e5 if cfg.noise else 0.0,
        'speed_profile': [{'t_s': t, 'speed_kn': kn} for t, kn in cfg.speed_profile],
        'oil_temperature': {'start_c': cfg.oil_temp_start_c, 'end_c': cfg.oil_temp_end_c,
                            'time_constant_s': cfg.oil_temp_tau_s},
        'effects': [{'name': e.name, 'params': dict(e.params)} for e in cfg.effects],
        'frames': len(sim.frames),
        'samples': {name: int(t.size) for name, t in sim.sensors.t_ns.items()},
        'rudder_range_deg': [round(float(np.degrees(p.alpha.min())), 3) if p.alpha.size else 0.0,
                             round(float(np.degrees(p.alpha.max())), 3) if p.alpha.size else 0.0],
        'moving_share': round(float(moving.mean()), 4) if moving.size else 0.0,
        'k_gl_max': round(float(p.k_gl.max()), 4) if p.k_gl.size else 0.0,
    }
