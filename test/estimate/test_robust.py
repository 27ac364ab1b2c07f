"""The cluster-robust scale of the intervals: about 1 for independent noise, the size theory
gives for a shared shock per block and per angle cell, blocks chosen from the residual's own
correlation, Student's t at few clusters."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats

from steer_monitor.estimate import fit as F
from steer_monitor.estimate.batch import make_rows
from steer_monitor.estimate.observe import GRID_NS, Observations
from steer_monitor.estimate.robust import BLOCK_MAX_S, BLOCK_MIN_S, block_seconds, robust_scales, t2_threshold
from steer_monitor.params import gear_from_params, load_params_file
from steer_monitor.resources import default_config

GEAR = gear_from_params(load_params_file(default_config()))


def _voyage(rng: np.random.Generator, shock_s: float = 0.0, shock_bar: float = 0.0, cell_bar: float = 0.0):
    """A gear swinging +-30 deg at a steady rate under its declared model, pressures with
    0.3 bar of independent noise, plus a shock shared by each ``shock_s`` of time and one
    shared by each 1 deg cell of |alpha| and direction (an error the model lacks that repeats
    where the rudder passes again): (observations, rows, residual per row)."""
    n = 36_000                                   # 30 minutes at 20 Hz
    t = np.arange(n, dtype=np.int64) * GRID_NS
    phase = 2 * np.pi * t / 60e9
    alpha = np.radians(30.0) * np.sin(phase)
    rate = np.radians(30.0) * 2 * np.pi / 60.0 * np.cos(phase)
    direction = np.sign(rate).astype(np.int8)
    area = GEAR.ram_area
    truth = np.sign(alpha) * np.abs(GEAR.torque(alpha)) * np.cos(alpha) ** 2 / (GEAR.rams * GEAR.stock_to_ram)
    truth = truth + direction * 9e3
    noise = rng.normal(0, 0.3e5 * area, (n, 2))
    if shock_s:
        blocks = (t // int(shock_s * 1e9)).astype(int)
        noise += rng.normal(0, shock_bar * 1e5 * area, blocks.max() + 1)[blocks][:, None]
    if cell_bar:
        cell = np.floor(np.degrees(np.abs(alpha))).astype(int) * 2 + (direction > 0)
        noise += rng.normal(0, cell_bar * 1e5 * area, cell.max() + 1)[cell][:, None]
    force = truth[:, None] + noise
    obs = Observations(t, alpha, rate, direction, force, np.full((n, 4), np.nan), np.full(n, np.nan),
                       np.full(n, np.nan))
    rows = make_rows(obs)
    basis = F.TorqueBasis(GEAR.max_rudder)
    mom = rows.moments
    load = F.axial_load(GEAR, basis, mom, F.torque_prefit(GEAR, basis, mom))
    fit = F.fit_at(GEAR, basis, mom, 1.0e-3, 1.0e-3, load)      # no contact: the declared model without kinks
    pred = np.empty(rows.bin_of_row.size)
    cols, zs, _ = F.design_at(GEAR, basis, mom, 1.0e-3, 1.0e-3, load)
    pred[:] = (cols[rows.bin_of_row] * rows.u[:, zs]) @ fit.coef
    resid = rows.u[:, -1] - pred
    return obs, rows, resid, fit, load, basis


def _scales(obs, rows, resid, fit, load, basis, block_s):
    a = obs.alpha[rows.obs_index]
    return robust_scales(GEAR, basis, rows.moments, rows.bin_of_row, rows.u, resid, obs.t_ns[rows.obs_index],
                         np.abs(a), np.sign(a).astype(np.int8), obs.direction[rows.obs_index], fit.coef, fit.names,
                         1.0e-3, 1.0e-3, load, (), (), block_s)


def test_independent_noise_keeps_the_textbook_interval():
    obs, rows, resid, fit, load, basis = _voyage(np.random.default_rng(1))
    s = _scales(obs, rows, resid, fit, load, basis, 60.0)['seal_friction_n']
    assert s.scale == pytest.approx(1.0, abs=0.5)
    assert s.dof > 10


def test_a_shock_shared_over_blocks_of_time_widens_the_seal_frictions_interval():
    """A 0.3 bar shock common to each 20 s (600 rows of each ram) on 0.3 bar of noise: the
    seal friction's variance grows by about 1 + 1200 x (shared variance / noise variance)
    for the part of the shock that changes sign with the motion; a wide margin either way."""
    obs, rows, resid, fit, load, basis = _voyage(np.random.default_rng(2), shock_s=20.0, shock_bar=0.3)
    s = _scales(obs, rows, resid, fit, load, basis, 60.0)['seal_friction_n']
    assert s.by == 'time'
    assert s.scale > 20.0


def test_a_misfit_repeating_by_angle_cell_is_seen_by_the_state_clustering():
    obs, rows, resid, fit, load, basis = _voyage(np.random.default_rng(4), cell_bar=0.15)
    s = _scales(obs, rows, resid, fit, load, basis, 60.0)['seal_friction_n']
    assert s.by == 'state'
    assert s.scale > 5.0


def test_block_length_follows_the_residuals_correlation():
    rng = np.random.default_rng(5)
    n = 40_000
    t = np.arange(n, dtype=np.int64) * GRID_NS
    white = rng.normal(size=(n, 2))
    assert block_seconds(white, t, GRID_NS) == BLOCK_MIN_S
    # an AR(1) with a 5 s time constant: its correlation falls below 0.05 after 3 time constants
    phi = math.exp(-0.05 / 5.0)
    x = np.empty(n)
    x[0] = 0.0
    e = rng.normal(size=n)
    for k in range(1, n):
        x[k] = phi * x[k - 1] + e[k]
    got = block_seconds(np.stack([x, x], axis=1), t, GRID_NS)
    assert 10 * 5.0 * math.log(1 / 0.05) * 0.6 <= got <= BLOCK_MAX_S


def test_t2_threshold():
    assert t2_threshold(math.inf) == pytest.approx(stats.chi2.ppf(0.95, 1))
    assert t2_threshold(5.0) == pytest.approx(stats.t.ppf(0.975, 5) ** 2)
    assert t2_threshold(0.5) == pytest.approx(stats.t.ppf(0.975, 2) ** 2)


def test_a_clock_step_of_years_costs_no_memory():
    rng = np.random.default_rng(6)
    t = np.concatenate([np.arange(2000), np.arange(2000) + 20 * 365 * 86400 * 20]).astype(np.int64) * GRID_NS
    assert block_seconds(rng.normal(size=(4000, 2)), t, GRID_NS) == BLOCK_MIN_S
