"""Fixtures the log readers' tests share."""

from __future__ import annotations

import pytest

from steer_monitor import sim


@pytest.fixture(scope='module')
def simulated(r18_params, can_db):
    db, smap = can_db
    return sim.run(r18_params, sim.SimConfig(program='hard_over_2', max_duration_s=20.0), db, smap, seed=12).frames
