"""The binned normal equations against an independent per-sample least-squares solution."""

from __future__ import annotations

import numpy as np
import pytest

from steer_monitor.estimate import fit as F
from steer_monitor.estimate.effects import Candidate
from steer_monitor.estimate.fit import Column
from steer_monitor.estimate.moments import Moments, bin_keys
from steer_monitor.model.friction import normal_forces
from steer_monitor.model.loadshare import load_sharing


def _synthetic(r18, n=4000, seed=0, noise=500.0):
    """Rows of the declared model at 2Z 0.6, Z_gb 0.25 mm with the gear's own torque curve."""
    rng = np.random.default_rng(seed)
    alpha = rng.uniform(-0.6, 0.6, n)
    d = rng.choice([-1, 1], n).astype(np.int8)
    speed = np.full(n, np.nan)
    torque = r18.torque(alpha)
    ls = load_sharing(r18, alpha, torque, 0.6e-3, 0.25e-3)
    na, ne = normal_forces(ls.r_a, ls.r_e, ls.m_a, r18.bushing_length)
    y = np.sign(alpha) * ls.axial + d * (9e3 + 0.13 * (na + ne) + 0.05 * np.abs(ls.guide_force))
    y = y + rng.normal(0, noise, n)
    return alpha, d, speed, y, rng.normal(size=n)


def test_torque_basis_is_zero_at_midships_and_spans_the_range(r18):
    b = F.TorqueBasis(r18.max_rudder)
    m = b(np.array([0.0, 0.1, r18.max_rudder]))
    assert np.all(m[0] == 0.0)
    assert np.allclose(m[1:].sum(axis=1), 1.0)   # partition of unity away from 0


def test_binned_fit_equals_per_sample_least_squares(r18):
    """X^T X from the bins' moments equals the per-row design: solve both ways and compare."""
    alpha, d, speed, y, z = _synthetic(r18)
    keys = bin_keys(alpha, d, speed)
    u = np.stack([np.ones_like(y), z, y], axis=1)
    mom = Moments.from_rows(keys, np.abs(alpha), np.zeros_like(y), u, ('z',))
    basis = F.TorqueBasis(r18.max_rudder)
    load = F.axial_load(r18, basis, mom, F.torque_prefit(r18, basis, mom))
    extra = (Column('k', 'z', lambda m, f: m.direction),)
    xtx, xty, yty, names = F.normal_equations(r18, basis, mom, 0.6e-3, 0.25e-3, load, extra)
    # the same design built row by row from each row's bin
    nb, fg = F.friction_features(r18, mom.abs_alpha, F.torque_of_load(r18, mom, load), np.array([0.6e-3]),
                                 np.array([0.25e-3]))
    cols, zs, _ = F.design_columns(r18, basis, mom, {'n_b': nb[:, 0], 'f_gb': fg[:, 0], 'load': load}, extra)
    x = cols[np.searchsorted(mom.keys, keys)] * u[:, zs]
    assert np.allclose(xtx, x.T @ x, rtol=1e-9)
    assert np.allclose(xty, x.T @ y, rtol=1e-9)
    assert yty == pytest.approx(float(y @ y))
    fit = F.fit_at(r18, basis, mom, 0.6e-3, 0.25e-3, load, extra)
    coef, *_ = np.linalg.lstsq(x, y, rcond=None)
    k = basis.size
    assert fit.coef[k:k + 3] == pytest.approx(coef[k:k + 3], rel=1e-3, abs=1.0)
    assert fit.rss == pytest.approx(float(np.sum((y - x @ coef) ** 2)), rel=1e-4)


def test_recovers_declared_friction_and_the_profile_minimum(r18):
    alpha, d, speed, y, _ = _synthetic(r18, n=20000, noise=300.0)
    mom = Moments.from_rows(bin_keys(alpha, d, speed), np.abs(alpha), np.zeros_like(y),
                            np.stack([np.ones_like(y), y], axis=1), ())
    basis = F.TorqueBasis(r18.max_rudder)
    load = F.axial_load(r18, basis, mom, F.torque_prefit(r18, basis, mom))
    pr = F.profile(r18, basis, mom, load)
    i, j = pr.best
    assert pr.z_gb[j] == pytest.approx(0.25e-3, abs=0.01e-3)
    fit = F.fit_at(r18, basis, mom, pr.two_z[i], pr.z_gb[j], load)
    assert fit.get('seal_friction_n') == pytest.approx(9e3, rel=0.05)
    assert fit.get('mu_bushing') == pytest.approx(0.13, rel=0.05)
    assert fit.get('mu_guide') == pytest.approx(0.05, rel=0.1)
    # the vectorized profile agrees with single fits at grid points (it evaluates the friction
    # features once per 0.1 deg cell instead of per bin: 1e-4 of the RSS)
    for a, b in ((i, j), (0, 0), (10, 30)):
        single = F.fit_at(r18, basis, mom, pr.two_z[a], pr.z_gb[b], load)
        assert pr.rss[a, b] == pytest.approx(single.rss, rel=2e-4)


def test_candidate_defaults():
    c = Candidate('viscous')
    assert c.columns == () and c.angle_shift_s == 0.0


def _moments(r18, n=6000, seed=3):
    alpha, d, speed, y, z = _synthetic(r18, n=n, seed=seed)
    return Moments.from_rows(bin_keys(alpha, d, speed), np.abs(alpha), np.zeros_like(y),
                             np.stack([np.ones_like(y), z, y], axis=1), ('z',))


PAIRS = [(0.0, 0.0), (0.6e-3, 0.25e-3), (1.5e-3, 0.6e-3), (0.2e-3, 0.05e-3), (1.0e-3, 0.3e-3)]


def _guide_squared(m, f):
    """An extra column built from the friction features (it changes with the clearances)."""
    return m.direction.reshape((-1,) + (1,) * (np.ndim(f['f_gb']) - 1)) * f['f_gb'] ** 2 * 1e-5


_guide_squared.uses_clearances = True   # type: ignore[attr-defined]


@pytest.mark.parametrize('extra', [(), (Column('k', 'z', lambda m, f: m.direction),),
                                   (Column('g', '', _guide_squared),)])
def test_fits_at_many_pairs_are_single_fits(r18, extra):
    """Per bin, the vectorized fits over pairs equal fit_at at each pair: coefficients, RSS and
    covariance; per cell, the RSS within the cells' 1e-4; the profile is those fits on the grid."""
    mom = _moments(r18)
    basis = F.TorqueBasis(r18.max_rudder)
    load = F.axial_load(r18, basis, mom, F.torque_prefit(r18, basis, mom))
    tz, zg = (np.array(x) for x in zip(*PAIRS))
    fits = F.fit_points(r18, basis, mom, load, tz, zg, extra, per_cell=False, covariance=True)
    cells = F.fit_points(r18, basis, mom, load, tz, zg, extra)
    assert cells.cov_unscaled is None
    for k, (a, b) in enumerate(PAIRS):
        single = F.fit_at(r18, basis, mom, a, b, load, extra)
        got = fits.at(k, single.n)
        assert got.names == single.names
        # X^T X summed in another order: the neighbouring spline coefficients (nearly
        # collinear) move by ~1e-6 of themselves, the RSS by far less
        np.testing.assert_allclose(got.coef, single.coef, rtol=1e-4)
        assert got.rss == pytest.approx(single.rss, rel=1e-9)
        np.testing.assert_allclose(got.cov_unscaled, single.cov_unscaled, rtol=1e-4,
                                   atol=1e-9 * np.abs(single.cov_unscaled).max())
        assert cells.rss[k] == pytest.approx(single.rss, rel=2e-4)
    pr = F.profile(r18, basis, mom, load, extra, np.array([0.2e-3, 1.0e-3]), np.array([0.05e-3, 0.3e-3]))
    on_grid = F.fit_points(r18, basis, mom, load, np.array([0.2e-3, 0.2e-3, 1.0e-3, 1.0e-3]),
                           np.array([0.05e-3, 0.3e-3, 0.05e-3, 0.3e-3]), extra)
    np.testing.assert_array_equal(pr.rss.ravel(), on_grid.rss)
    with pytest.raises(ValueError, match='without their covariance'):
        cells.at(0, 1.0)


def test_pairs_beyond_any_contact_are_one_model(r18):
    """Past the clearance the largest load closes, every pair has the same features to the
    bit; they are fitted once, so the plateau is flat to the bit wherever it falls in the
    batch (what the plateau test and the best point's tie-break rely on)."""
    mom = _moments(r18)
    basis = F.TorqueBasis(r18.max_rudder)
    load = F.axial_load(r18, basis, mom, F.torque_prefit(r18, basis, mom))
    pr = F.profile(r18, basis, mom, load, (), F.GRID_2Z, F.GRID_ZGB[::4])
    last = pr.rss[:, -1]                            # Z_gb 0.6 mm: the slipper never touches
    flat = pr.rss[-5:]                              # 2Z 1.42..1.5 mm
    assert (flat == flat[0]).all() and np.unique(last[-20:]).size == 1
    # the pairs' distinct feature columns: pairs 0 and 2 (both beyond contact) are one
    tz, zg = np.array([1.5e-3, 0.1e-3, 1.4e-3, 0.1e-3]), np.array([0.6e-3, 0.0, 0.6e-3, 0.05e-3])
    nb, fg, first, inverse = F._point_features(r18, np.radians([5.0, 20.0]), np.array([1e5, 5e5]), tz, zg)
    np.testing.assert_array_equal(first, [0, 1, 3])
    np.testing.assert_array_equal(inverse, [0, 1, 0, 2])
    ref_nb, ref_fg = F.friction_features(r18, np.radians([5.0, 20.0]), np.array([1e5, 5e5]), tz[None], zg[None])
    np.testing.assert_array_equal(nb, ref_nb[:, first])
    np.testing.assert_array_equal(fg, ref_fg[:, first])
