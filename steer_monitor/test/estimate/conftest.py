"""Simulated logs for the estimator tests, decoded once per session."""

from __future__ import annotations

import functools

import pytest

from steer_monitor import sim
from steer_monitor.can.decoder import Decoder
from steer_monitor.model.gear import Gaps


@pytest.fixture(scope='session')
def simulate_signals(r18_params, db, smap):
    """(program, 2Z mm, Z_gb mm, effects, seed, max_s) -> (decoded signals, Simulation)."""
    @functools.lru_cache(maxsize=None)
    def make(program: str = 'voyage', two_z: float = 0.6, z_gb: float = 0.25, effects: tuple[str, ...] = (),
             seed: int = 1, max_s: float = 7200.0):
        cfg = sim.SimConfig(program=program, gaps=Gaps.from_mm(two_z, z_gb),
                            effects=tuple(sim.parse_effect(e) for e in effects), max_duration_s=max_s)
        s = sim.run(r18_params, cfg, db, smap, seed)
        return Decoder(db, smap).decode_arrays(s.frames), s
    return make
