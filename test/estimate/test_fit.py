"""The binned normal equations against an independent per-sample least-squares solution."""

from __future__ import annotations

import numpy as np
import pytest

from steer_monitor.estimate import fit as F
from steer_monitor.estimate import pointfit as PF
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


def _with_z_column(r18, n=4000, seed=0):
    """Synthetic rows with an extra z column binned, and the fit's pieces: (alpha, y, keys,
    u, moments, basis, load, extra columns)."""
    alpha, d, speed, y, z = _synthetic(r18, n=n, seed=seed)
    keys = bin_keys(alpha, d, speed)
    u = np.stack([np.ones_like(y), z, y], axis=1)
    mom = Moments.from_rows(keys, np.abs(alpha), np.zeros_like(y), u, ('z',))
    basis = F.TorqueBasis(r18.max_rudder)
    load = F.axial_load(r18, basis, mom, F.torque_prefit(r18, basis, mom))
    return alpha, y, keys, u, mom, basis, load, (Column('k', 'z', lambda m, f: m.direction),)


def test_torque_basis_is_zero_at_midships_and_spans_the_range(r18):
    b = F.TorqueBasis(r18.max_rudder)
    m = b(np.array([0.0, 0.1, r18.max_rudder]))
    assert np.all(m[0] == 0.0)
    assert np.allclose(m[1:].sum(axis=1), 1.0)   # partition of unity away from 0


def test_binned_fit_equals_per_sample_least_squares(r18):
    """X^T X from the bins' moments equals the per-row design: solve both ways and compare."""
    alpha, y, keys, u, mom, basis, load, extra = _with_z_column(r18)
    xtx, xty, names = F.normal_equations(r18, basis, mom, 0.6e-3, 0.25e-3, load, extra)
    # the same design built row by row from each row's bin
    nb, fg = F.friction_features(r18, mom.abs_alpha, F.torque_of_load(r18, mom, load), np.array([0.6e-3]),
                                 np.array([0.25e-3]))
    cols, zs, _ = F.design_columns(r18, basis, mom, {'n_b': nb[:, 0], 'f_gb': fg[:, 0], 'load': load}, extra)
    x = cols[np.searchsorted(mom.keys, keys)] * u[:, zs]
    assert np.allclose(xtx, x.T @ x, rtol=1e-9)
    assert np.allclose(xty, x.T @ y, rtol=1e-9)
    assert float(mom.m[:, -1, -1].sum()) == pytest.approx(float(y @ y), rel=1e-12)
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
    pr = PF.profile(r18, basis, mom, load)
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


def _rss_shift_bound(r18, basis, mom, load, two_z, z_gb, extra, ref, other):
    """|RSS(b') - RSS(b)| for b the penalized optimum: 2 |(P b) . db| + db^T X^T X db, plus the
    evaluation's bins x epsilon x RSS."""
    xtx, _, names = F.normal_equations(r18, basis, mom, two_z, z_gb, load, extra)
    pen = F.smoothing_penalty(basis.size, len(names), xtx) + np.diag(F.RIDGE * np.diag(xtx))
    db = other.coef - ref.coef
    return 2 * abs(float((pen @ ref.coef) @ db)) + float(db @ xtx @ db) + len(mom) * 2.3e-16 * ref.rss


@pytest.mark.parametrize('extra', [(), (Column('k', 'z', lambda m, f: m.direction),),
                                   (Column('g', '', _guide_squared),)])
def test_fits_at_many_pairs_are_single_fits(r18, extra):
    """Per bin, the vectorized fits over pairs equal fit_at at each pair: coefficients, RSS and
    covariance; per cell, the RSS within the cells' 1e-4; the profile is those fits on the grid."""
    mom = _moments(r18)
    basis = F.TorqueBasis(r18.max_rudder)
    load = F.axial_load(r18, basis, mom, F.torque_prefit(r18, basis, mom))
    tz, zg = (np.array(x) for x in zip(*PAIRS))
    fits = PF.fit_points(r18, basis, mom, load, tz, zg, extra, per_cell=False, covariance=True)
    cells = PF.fit_points(r18, basis, mom, load, tz, zg, extra)
    assert cells.cov_unscaled is None
    for k, (a, b) in enumerate(PAIRS):
        single = F.fit_at(r18, basis, mom, a, b, load, extra)
        got = fits.at(k, single.n)
        assert got.names == single.names
        # X^T X summed in another order: the neighbouring spline coefficients (nearly
        # collinear) move by ~1e-6 of themselves
        np.testing.assert_allclose(got.coef, single.coef, rtol=1e-4)
        # the RSS moves with them only through the penalty's gradient (the penalized optimum
        # is not RSS's stationary point) and the curvature; fit_at's evaluation adds at most
        # bins x epsilon (non-negative per-bin terms); the partitioned solve's (PointFitter:
        # the fixed columns' residual less what the clearances' columns take from it) within
        # 1e-8 of the RSS where those columns are nearly collinear with the others (both
        # clearances 0), 1e-11 elsewhere: a deviance of rows x 1e-8, under 1e-3 on a voyage
        assert abs(got.rss - single.rss) <= (2 * _rss_shift_bound(r18, basis, mom, load, a, b, extra, single, got)
                                             + 1e-8 * single.rss)
        np.testing.assert_allclose(got.cov_unscaled, single.cov_unscaled, rtol=1e-4,
                                   atol=1e-9 * np.abs(single.cov_unscaled).max())
        assert cells.rss[k] == pytest.approx(single.rss, rel=2e-4)
    pr = PF.profile(r18, basis, mom, load, extra, np.array([0.2e-3, 1.0e-3]), np.array([0.05e-3, 0.3e-3]))
    on_grid = PF.fit_points(r18, basis, mom, load, np.array([0.2e-3, 0.2e-3, 1.0e-3, 1.0e-3]),
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
    pr = PF.profile(r18, basis, mom, load, (), F.GRID_2Z, F.GRID_ZGB[::4])
    last = pr.rss[:, -1]                            # Z_gb 0.6 mm: the slipper never touches
    flat = pr.rss[-5:]                              # 2Z 1.42..1.5 mm
    assert (flat == flat[0]).all() and np.unique(last[-20:]).size == 1
    # the pairs' distinct feature columns: pairs 0 and 2 (both beyond contact) are one
    tz, zg = np.array([1.5e-3, 0.1e-3, 1.4e-3, 0.1e-3]), np.array([0.6e-3, 0.0, 0.6e-3, 0.05e-3])
    nb, fg, first, inverse = PF._point_features(r18, np.radians([5.0, 20.0]), np.array([1e5, 5e5]), tz, zg)
    np.testing.assert_array_equal(first, [0, 1, 3])
    np.testing.assert_array_equal(inverse, [0, 1, 0, 2])
    ref_nb, ref_fg = F.friction_features(r18, np.radians([5.0, 20.0]), np.array([1e5, 5e5]), tz[None], zg[None])
    np.testing.assert_array_equal(nb, ref_nb[:, first])
    np.testing.assert_array_equal(fg, ref_fg[:, first])


@pytest.mark.parametrize('seed', [0, 1])
def test_pairs_taken_as_one_model_have_the_same_features_to_the_bit(r18, seed):
    """Every pair of the grid has its class's features, bit for bit (each pair evaluated on its
    own here), on cells of every load: the classes are a saving, never an approximation."""
    rng = np.random.default_rng(seed)
    alpha = rng.uniform(0.0, r18.max_rudder, 300)
    torque = r18.torque(alpha) * rng.uniform(0.2, 1.6, 300)
    tz, zg = np.repeat(F.GRID_2Z, F.GRID_ZGB.size), np.tile(F.GRID_ZGB, F.GRID_2Z.size)
    nb, fg, first, inverse = PF._point_features(r18, alpha, torque, tz, zg)
    assert first.size < 0.6 * tz.size
    each_nb, each_fg = F.friction_features(r18, alpha, torque, tz, zg)
    np.testing.assert_array_equal(each_nb, nb[:, inverse])
    np.testing.assert_array_equal(each_fg, fg[:, inverse])


def test_plateau_is_flat_without_deduplication(r18):
    """The plateau beyond any contact is flat because the residual is computed from centred
    per-bin statistics (order-independent to bins x epsilon), not because equal pairs are
    solved once: solved apart, the plateau's RSS agree to 1e-12 of themselves, a deviance
    of ~1e-7 at most, under the intervals' plateau tolerance."""
    mom = _moments(r18)
    basis = F.TorqueBasis(r18.max_rudder)
    load = F.axial_load(r18, basis, mom, F.torque_prefit(r18, basis, mom))
    tz = np.repeat(F.GRID_2Z[-8:], 3)
    zg = np.tile([0.6e-3, 0.595e-3, 0.59e-3], 8)
    fits = PF.fit_points(r18, basis, mom, load, tz, zg, dedupe=False)
    nb, fg, first, inverse = PF._point_features(r18, mom.abs_alpha, F.torque_of_load(r18, mom, load), tz, zg,
                                               dedupe=False)
    assert first.size == tz.size                         # every pair solved on its own
    model = PF._point_features(r18, mom.abs_alpha, F.torque_of_load(r18, mom, load), tz, zg)[3]
    assert np.unique(model).size < tz.size               # (yet many are one model)
    for k in np.unique(model):
        plateau = fits.rss[model == k]
        np.testing.assert_allclose(plateau, plateau[0], rtol=1e-12)
    deduped = PF.fit_points(r18, basis, mom, load, tz, zg)
    np.testing.assert_allclose(deduped.rss, fits.rss, rtol=1e-12)


@pytest.mark.parametrize('seed', [0, 1, 2])
def test_rss_from_centred_moments_is_the_per_row_sum(r18, seed):
    """The RSS from the bins' centred statistics equals the per-row residual sum (computed
    row by row, an independent path) to 1e-12 of itself, and does not depend on the rows'
    order or on merging halves (Chan's update)."""
    alpha, y, keys, u, mom, basis, load, extra = _with_z_column(r18, n=5000, seed=seed)
    fit = F.fit_at(r18, basis, mom, 0.6e-3, 0.25e-3, load, extra)
    cols, zs, _ = F.design_at(r18, basis, mom, 0.6e-3, 0.25e-3, load, extra)
    x = cols[np.searchsorted(mom.keys, keys)] * u[:, zs]
    per_row = np.sum((y - x @ fit.coef) ** 2)
    assert fit.rss == pytest.approx(float(per_row), rel=1e-12)
    order = np.random.default_rng(seed).permutation(y.size)
    shuffled = Moments.from_rows(keys[order], np.abs(alpha)[order], np.zeros_like(y), u[order], ('z',))
    half = y.size // 2
    a, b = (Moments.from_rows(keys[order[s]], np.abs(alpha)[order[s]], np.zeros(y.size)[order[s]], u[order[s]], ('z',))
            for s in (slice(0, half), slice(half, None)))
    for other in (shuffled, a.merge(b)):
        np.testing.assert_array_equal(other.keys, mom.keys)
        assert F.residual_sum_of_squares(other, cols, zs, fit.coef) == pytest.approx(fit.rss, rel=1e-12)


def test_a_kept_fitter_does_not_keep_its_moments_alive(r18):
    """The fitter kept with its moments referred to them: a cycle that held the fitters' arrays
    (hundreds of MB on a voyage) until Python's cycle collector happened to run, which the
    node's worker reached after many analyses. Freed by reference counts alone now."""
    import gc
    import weakref
    mom = _moments(r18, n=3000)
    basis = F.TorqueBasis(r18.max_rudder)
    load = F.axial_load(r18, basis, mom, F.torque_prefit(r18, basis, mom))
    fitter = PF.PointFitter.of(r18, basis, mom, load)
    assert PF.PointFitter.of(r18, basis, mom, load) is fitter and fitter.mom is mom
    fitter.fit(np.array([0.6e-3]), np.array([0.25e-3]))
    gone_mom, gone_fitter = weakref.ref(mom), weakref.ref(fitter)
    gc.disable()
    try:
        del mom, fitter
        assert gone_mom() is None and gone_fitter() is None
    finally:
        gc.enable()
