"""Alignment of the streams on the grid: validity, motion, missing inputs."""

from __future__ import annotations

import numpy as np
import pytest

from steer_monitor.can.decoder import Series
from steer_monitor.estimate.observe import GRID_NS, EstimateError, build_observations, grid_times


def _series(t_s, v):
    return Series((np.asarray(t_s) * 1e9).astype(np.int64), np.asarray(v, float))


def _signals(rate=0.05, gap=None):
    t_a = np.arange(0, 10, 0.1)
    a = rate * t_a
    t_p = np.arange(0.013, 10, 0.05)
    sig = {'rudder_angle': _series(t_a, a)}
    for k, name in enumerate(('pressure_r1_stbd', 'pressure_r1_port', 'pressure_r2_stbd', 'pressure_r2_port')):
        t = t_p + 0.004 * k
        v = np.full(t.size, 50e5 if k % 2 == 0 else 2e5)
        if gap is not None:
            keep = (t < gap[0]) | (t > gap[1])
            t, v = t[keep], v[keep]
        sig[name] = _series(t, v)
    return sig


def test_grid_is_anchored_at_the_epoch():
    t = grid_times(1_234_567_891, 1_600_000_000)
    assert t[0] % GRID_NS == 0 and t[0] >= 1_234_567_891 and np.all(np.diff(t) == GRID_NS)


def test_steady_motion_and_force():
    obs = build_observations(_signals(), 0.045)
    inner = obs.moving
    assert inner.sum() > 150 and np.all(obs.direction[inner] == 1)
    assert np.nanmax(np.abs(obs.rate[inner] - 0.05)) < 1e-9
    assert np.allclose(obs.force[inner], 0.045 * 48e5)


def test_rest_and_missing_samples_carry_no_information():
    obs = build_observations(_signals(rate=0.0), 0.045)
    assert not obs.moving.any()
    obs = build_observations(_signals(gap=(4.0, 5.0)), 0.045)
    t = (obs.t_ns - obs.t_ns[0]) / 1e9
    assert np.all(np.isnan(obs.force[(t > 4.2) & (t < 4.8)]))


@pytest.mark.parametrize('drop, match', [
    (('rudder_angle',), 'no rudder angle'),
    (('pressure_r1_stbd', 'pressure_r1_port', 'pressure_r2_stbd', 'pressure_r2_port'), 'no cylinder pressure'),
])
def test_missing_inputs_are_named(drop, match):
    sig = _signals()
    for k in drop:
        del sig[k]
    with pytest.raises(EstimateError, match=match):
        build_observations(sig, 0.045)
