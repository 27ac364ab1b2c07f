"""The clearance estimate over a whole log: the declared model (plus optional extra columns)
fitted with the clearances profiled, honest 95 % intervals, residuals per sample.

Steps: bin the steady-motion samples (:mod:`~steer_monitor.estimate.moments`); fit the
torque curve with friction free in shape; profile the clearances with the friction features
from that load; refit the load from the best fit and profile again (the load moves by well
under 1 %); intervals from the profile (:mod:`~steer_monitor.estimate.intervals`) with the
residuals' inflation factor; the friction parameters' intervals are the union, over the
joint 95 % region of the clearances, of their conditional intervals.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.special import fdtri

from steer_monitor.estimate import fit as F
from steer_monitor.estimate import pointfit as PF
from steer_monitor.estimate.intervals import (
    CHI2_1_95,
    CHI2_2_95,
    PLATEAU_THRESHOLD,
    Interval,
    inflation,
    plateau_interval,
)
from steer_monitor.estimate.moments import SPEED_Z, Moments, rows_from_observations
from steer_monitor.estimate.observe import GRID_NS, EstimateError, Observations
from steer_monitor.estimate.plausible import guide_contact_at_friction_limit
from steer_monitor.estimate.ranges import DECLARED, at_edge
from steer_monitor.estimate.refine import Marginal, Refined, refine_profile, widen_to
from steer_monitor.estimate.robust import CLEARANCES, MODEL_ERROR_FLOOR, RobustScale, block_seconds, robust_scales
from steer_monitor.model.gear import GearParams
from steer_monitor.model.loadshare import STAGE_CLAMPED, load_sharing
from steer_monitor.model.reach import Reach, gear_reach

__all__ = ['MIN_MOTION_SAMPLES', 'ClearanceEstimate', 'Rows', 'Spread', 'box_holds', 'coarse_profile',
           'estimate_clearances', 'estimate_in_box', 'k_gl_max', 'lag_moments', 'make_rows',
           'predict_rows', 'residual_parts', 'residuals_and_inflation', 'sample_spread', 'search_box',
           'within_range']

MIN_MOTION_SAMPLES = 200     # rows (ram x instant) of steady motion: 5 s of moving rudder
SMOOTH_LAG_STEPS = 4         # 200 ms: sensor noise is uncorrelated this far apart
PREDICT_CHUNK = 1 << 16      # rows per step of predict_rows


@dataclass(frozen=True)
class Rows:
    """Steady-motion rows (one per ram and instant) and their bins.

    Attributes:
        moments: the binned statistics.
        bin_of_row: (r,) index into the moments' bins; u: (r, q) = [1, z.., y];
        obs_index: (r,) the observation each row came from; ram: (r,) 0 or 1.
    """

    moments: Moments
    bin_of_row: NDArray[np.intp]
    u: NDArray[np.float64]
    obs_index: NDArray[np.intp]
    ram: NDArray[np.intp]


def make_rows(obs: Observations, z: Mapping[str, NDArray[np.float64]] | None = None,
              mask: NDArray[np.bool_] | None = None) -> Rows:
    """Rows of the observations (optionally only where ``mask``), with z columns."""
    z = dict(z or {})
    speed_on_bus = bool(np.isfinite(obs.speed).any())
    keep = obs.moving.copy()
    if speed_on_bus:
        keep &= np.isfinite(obs.speed)    # speed on the bus but missing here: skip the instant
    for arr in z.values():
        keep &= np.all(np.isfinite(arr), axis=1) if arr.ndim == 2 else np.isfinite(arr)
    if mask is not None:
        keep &= mask
    keys, aa, v2, u, idx, ram = rows_from_observations(obs, z, keep)
    mom = Moments.from_rows(keys, aa, v2, u, (SPEED_Z, *z))
    return Rows(mom, np.searchsorted(mom.keys, keys), u, idx, ram)


@dataclass(frozen=True)
class ClearanceEstimate:
    """What the data say about the gear under one model.

    Attributes (SI units):
        two_z, z_gb: clearance intervals [m].
        seal_friction [N], mu_bushing, mu_guide: friction parameters with intervals.
        extra: extra-column coefficients with intervals, by name.
        torque_curve: (angles [rad], torque [N m], half-width of its 95 % band [N m]) at the
            service speed, over the observed angles.
        k_gl_max: largest K_gl over the observed angles at the estimate (and its range over the
            clearances' 95 % region).
        rms: residual RMS per row [N]; rows: rows fitted; inflation: variance inflation.
        noise_rms, smooth_rms: the residual split into sensor noise and its smooth
            (systematic) part [N].
        residual: (n, 2) per observation and ram [N], NaN where not fitted.
        profile: the clearance profile on the grid; deviance: its likelihood-ratio statistic
            there, (RSS - RSS_min) / (sigma^2 x inflation), shape of ``profile.rss``, with
            RSS_min the least of the refined profile.
        marginals: each clearance's profile (2Z, Z_gb): least RSS over the other clearance,
            on the grid and, where the grid could not resolve it, between its points
            (:mod:`~steer_monitor.estimate.refine`); the intervals come from these.
        steps: (2Z, Z_gb) [m]: the spacing each was profiled at near its estimate.
        rss_floor: the least RSS of the profile [N^2] (deviance 0).
    """

    two_z: Interval
    z_gb: Interval
    seal_friction: Interval
    mu_bushing: Interval
    mu_guide: Interval
    extra: dict[str, Interval]
    torque_curve: tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]
    k_gl_max: Interval
    rms: float
    rows: int
    inflation: float
    noise_rms: float
    smooth_rms: float
    residual: NDArray[np.float64] = field(repr=False)
    profile: PF.Profile = field(repr=False)
    fit: F.FitAt = field(repr=False)
    max_angle_seen: float = 0.0
    ram_area: float = 1.0
    deviance: NDArray[np.float64] = field(default_factory=lambda: np.zeros((0, 0)), repr=False)
    marginals: tuple[Marginal, Marginal] | None = field(default=None, repr=False)
    steps: tuple[float, float] = (0.0, 0.0)
    rss_floor: float = math.nan      # the least RSS of the profile [N^2]: deviance 0
    scales: tuple[float, float] = (math.nan, math.nan)       # (2Z, Z_gb): the variance scale of each deviance
    thresholds: tuple[float, float] = (CHI2_1_95, CHI2_1_95)  # ... and the 95 % point it was read against
    robust: dict[str, RobustScale] = field(default_factory=dict, repr=False)   # every parameter's scale, by name
    #: (2Z, Z_gb): why an interval the profile closed is given as a lower bound only ('' when it is not)
    bound_why: tuple[str, str] = ('', '')
    sigma2: float = math.nan         # the residual variance per row [N^2] the deviances are in units of
    #: (2Z, Z_gb): how far each can show, at the other's estimate, under the loads the rows
    #: held and under the gear's largest (:mod:`~steer_monitor.model.reach`); None: not worked out
    reach: tuple[Reach, Reach] | None = None

    def marginal_deviance(self, axis: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """(values [m], deviance) of clearance ``axis`` (0: 2Z, 1: Z_gb): the profile its
        interval was read from (against ``thresholds[axis]``)."""
        if self.marginals is None:
            return (self.profile.two_z if axis == 0 else self.profile.z_gb), self.deviance.min(axis=1 - axis)
        scale = self.scales[axis] if math.isfinite(self.scales[axis]) else self.inflation
        unit = self.fit.rss / max(self.fit.n - self.fit.coef.size, 1.0) * scale
        m = self.marginals[axis]
        return m.axis, (m.rss - self.rss_floor) / unit


def lag_moments(
    resid: NDArray[np.float64], t_ns: NDArray[np.int64], lag: int = SMOOTH_LAG_STEPS, step_ns: int = GRID_NS
) -> tuple[float, float]:
    """(mean square, autocovariance at ``lag`` grid steps, 200 ms by default) of residuals
    (n, 2) [N^2], the latter over the pairs of the same ram with both instants fitted,
    unclamped (it may come out negative where the smooth part is nil); NaN when there is
    nothing to average. Rows further apart than the grid (``step_ns``: a slow pressure's
    period) are each interpolated between two of its samples, so two rows one period apart
    share one and their sensor noise correlates: the lag is then at least two periods."""
    c0 = c4 = 0.0
    n0 = n4 = 0
    if step_ns > GRID_NS:
        lag = max(lag, 2 * (step_ns // GRID_NS))
    step = np.round((t_ns - (t_ns[0] if t_ns.size else 0)) / GRID_NS).astype(np.int64)
    for k in range(resid.shape[1]):
        r = resid[:, k]
        ok = np.isfinite(r)
        c0 += float(np.sum(r[ok] ** 2))
        n0 += int(ok.sum())
        j = np.searchsorted(step, step + lag)
        j = np.minimum(j, step.size - 1)
        pair = ok & (step[j] == step + lag) & ok[j]
        c4 += float(np.sum(r[pair] * r[j[pair]]))
        n4 += int(pair.sum())
    return (c0 / n0 if n0 else math.nan), (c4 / n4 if n4 else math.nan)


def residual_parts(resid: NDArray[np.float64], t_ns: NDArray[np.int64], step_ns: int = GRID_NS,
                   shared_ns: int = GRID_NS) -> tuple[float, float]:
    """(noise RMS, smooth RMS) of residuals (n, 2): the autocovariance at 200 ms (same ram,
    both instants fitted, :func:`lag_moments`) is the smooth part's variance, clamped to
    [0, mean square]; the rest is sensor noise. Rows closer than ``shared_ns`` may be read
    from one sample of a slow input (:attr:`~steer_monitor.estimate.observe.Observations.shared_ns`):
    the autocovariance is then read at least two of it apart, so what that sample's noise and
    timing put into both rows counts as noise, not as something the model misses."""
    var, c4 = lag_moments(resid, t_ns, step_ns=max(step_ns, shared_ns))
    if not math.isfinite(var):
        return math.nan, math.nan
    smooth = min(max(c4, 0.0) if math.isfinite(c4) else 0.0, var)
    return math.sqrt(var - smooth), math.sqrt(smooth)


def predict_rows(gear: GearParams, basis: F.TorqueBasis, rows: Rows, coef: NDArray[np.float64], two_z: float,
                 z_gb: float, load: NDArray[np.float64], extra: Sequence[F.Column] = ()) -> NDArray[np.float64]:
    """Predicted y per row [N] with coefficients ``coef`` at the given clearances. In chunks
    of ``PREDICT_CHUNK`` rows: the design per row is (rows, columns), hundreds of MB on a
    day's log, where the prediction is one number per row."""
    cols, zs, _ = F.design_at(gear, basis, rows.moments, two_z, z_gb, load, extra)
    out = np.empty(rows.bin_of_row.size)
    for i in range(0, out.size, PREDICT_CHUNK):
        sl = slice(i, i + PREDICT_CHUNK)
        out[sl] = (cols[rows.bin_of_row[sl]] * rows.u[sl][:, zs]) @ coef
    return out


def residuals_and_inflation(gear: GearParams, basis: F.TorqueBasis, rows: Rows, t_ns: NDArray[np.int64],
                            coef: NDArray[np.float64], two_z: float, z_gb: float, load: NDArray[np.float64],
                            extra: Sequence[F.Column] = (), step_ns: int = GRID_NS
                            ) -> tuple[NDArray[np.float64], float]:
    """The ram-force residual per observation and ram, shape (len(t_ns), 2) [N] (NaN where no
    row), at a fit, and the variance inflation of its autocorrelation (its lags in the rows'
    spacing ``step_ns``: :attr:`~steer_monitor.estimate.observe.Observations.step_ns`)."""
    pred = predict_rows(gear, basis, rows, coef, two_z, z_gb, load, extra)
    resid = np.full((t_ns.size, 2), np.nan)
    resid[rows.obs_index, rows.ram] = rows.u[:, -1] - pred
    return resid, inflation(resid[rows.obs_index], t_ns[rows.obs_index], step_ns)


def _profile_fit(gear: GearParams, basis: F.TorqueBasis, mom: Moments, extra: Sequence[F.Column],
                 grid_2z: NDArray, grid_zgb: NDArray, load: NDArray[np.float64] | None
                 ) -> tuple[PF.Profile, Refined, F.FitAt, float, float, NDArray[np.float64]]:
    """The load (from a prefit and a coarse profile when not given), the profile over the
    whole grid and its refinement, the fit at the refined optimum. The whole grid: a ram that
    clamps pins 2Z in a valley narrower than a coarse profile's step, which a search box
    drawn round a coarse profile's best point can miss (a true 2Z of 0.10 mm was read 0.18)."""
    if mom.samples < MIN_MOTION_SAMPLES:
        msg = (f'too little steady rudder motion to estimate the clearances: {int(mom.samples)} '
               f'ram samples, need {MIN_MOTION_SAMPLES} (about 5 s of moving rudder)')
        raise EstimateError(msg)
    if load is None:
        load = F.axial_load(gear, basis, mom, F.torque_prefit(gear, basis, mom))
        pr = PF.profile(gear, basis, mom, load, extra, grid_2z[::3], grid_zgb[::3])
        i, j = pr.best
        first = F.fit_at(gear, basis, mom, pr.two_z[i], pr.z_gb[j], load, extra)
        load = F.axial_load(gear, basis, mom, first.coef)
    pr = PF.profile(gear, basis, mom, load, extra, grid_2z, grid_zgb)
    ref = refine_profile(gear, basis, mom, load, extra, pr)
    tz, zg = ref.best
    return pr, ref, F.fit_at(gear, basis, mom, tz, zg, load, extra), tz, zg, load


def _bound(gear: GearParams, basis: F.TorqueBasis, mom: Moments, pr: PF.Profile, ref: Refined, best: F.FitAt,
           tz: float, zg: float, load: NDArray[np.float64], extra: Sequence[F.Column], vif: float, max_seen: float,
           resid: NDArray[np.float64], noise: float, smooth: float,
           scales: dict[str, RobustScale] | None = None) -> ClearanceEstimate:
    """The intervals. With ``scales`` (:func:`_robust`) each parameter's deviance and standard
    error are scaled by its own cluster-robust factor and read against Student's t at its
    effective clusters; without (a moments-only estimate), by ``vif`` against the normal."""
    dof = max(best.n - best.coef.size, 1.0)
    sigma2 = best.rss / dof
    flat = RobustScale(vif, math.inf)

    def scale_of(name: str) -> RobustScale:
        # a parameter the rows could not measure (its column empty there, or too few clusters)
        # is read as one not differentiated: never narrower than the correlation in time gives
        r = None if scales is None else scales.get(name)
        return flat if r is None else r if r.by else RobustScale(max(r.scale, vif), math.inf)

    rs = [scale_of(name) for name in CLEARANCES]
    units = [sigma2 * r.scale * (MODEL_ERROR_FLOOR if scales is not None else 1.0) for r in rs]
    unit = max(units)
    # the refinement judged its sets without these scales: where an interval reaches past the
    # values it profiled, profiled further, so that it does not end at a grid value that reads high
    ref = widen_to(ref, (units[0] * rs[0].threshold_1, units[1] * rs[1].threshold_1))
    # relative to the profile's own minimum: the profile evaluates the friction features per
    # angle cell and ``best`` per bin, which differ by ~1e-4 of the RSS (a deviance of ~1)
    floor = float(ref.rss.min())
    delta = (pr.rss - floor) / unit
    two_z = plateau_interval(ref.two_z.axis, (ref.two_z.rss - floor) / units[0], rs[0].threshold_1,
                             PLATEAU_THRESHOLD * rs[0].threshold_1 / CHI2_1_95)
    z_gb = plateau_interval(ref.z_gb.axis, (ref.z_gb.rss - floor) / units[1], rs[1].threshold_1,
                            PLATEAU_THRESHOLD * rs[1].threshold_1 / CHI2_1_95)
    two_z, z_gb, why = _evidence(gear, mom, load, two_z, z_gb, pr)
    joint_dof = min(r.dof for r in rs)
    joint = CHI2_2_95 if not math.isfinite(joint_dof) else 2.0 * float(fdtri(2.0, max(joint_dof, 2.0), 0.95))
    region_all = np.unique(ref.pairs[(ref.rss - floor) / unit <= joint], axis=0)
    region = region_all
    if region.shape[0] > 60:
        region = region[np.linspace(0, region.shape[0] - 1, 60).round().astype(int)]
    fits = PF.fit_points(gear, basis, mom, load, region[:, 0], region[:, 1], extra, per_cell=False, covariance=True)
    region_fits = [(float(a), float(b), fits.at(k, best.n)) for k, (a, b) in enumerate(region.tolist())]
    region_fits.append((tz, zg, best))
    coefs = {}
    for name in best.names[basis.size:]:
        k = best.names.index(name)
        c = np.array([f.coef[k] for _, _, f in region_fits])
        r = scale_of(name)
        z = math.sqrt(r.threshold_1)
        with np.errstate(over='ignore', invalid='ignore'):   # ill-posed fits in a wide region
            se = np.sqrt(np.maximum(np.array([f.cov_unscaled[k, k] for _, _, f in region_fits]), 0.0) * sigma2
                         * r.scale)
        ok = np.isfinite(c) & np.isfinite(se)
        coefs[name] = within_range(name, float(best.coef[k]), float(np.min((c - z * se)[ok])) if ok.any() else None,
                                   float(np.max((c + z * se)[ok])) if ok.any() else None)
    z_gb, why_guide = guide_contact_at_friction_limit(z_gb, coefs['mu_guide'])
    if why_guide:
        why = (why[0], why_guide)
    angles = np.union1d(np.radians(np.arange(0.0, math.degrees(max_seen), 0.5)), [max_seen])
    bmat = basis(angles)
    tq = bmat @ best.coef[:basis.size]
    cov_t = best.cov_unscaled[:basis.size, :basis.size] * sigma2 * vif
    band = 1.96 * np.sqrt(np.maximum(np.einsum('ij,jk,ik->i', bmat, cov_t, bmat), 0.0))
    fit_tz, fit_zg, fit_torque = (np.array(x) for x in zip(*((a, b, f.coef[:basis.size]) for a, b, f in region_fits)))
    kgl = k_gl_max(gear, angles, bmat @ fit_torque.T, fit_tz, fit_zg).tolist()
    # every point of the region (the extremes of K_gl sit at its edges; the subsample above
    # carries each fit's own torque curve) with the best torque curve and with the curve at
    # either edge of its band (K_gl grows with the load). A slipper clearance bounded only from
    # below may lie anywhere past its bound, as far as the data tell, up to one where the beam
    # never carries, where the joint region (read against the two-sided threshold) does not
    # reach: then every pair of the profile's grid within both intervals as well
    pairs = region_all
    if z_gb.hi is None:
        pairs = np.vstack([region_all, _within_box(pr.two_z, pr.z_gb, two_z, z_gb)])
    for t in (tq - band, tq, tq + band):
        kgl += k_gl_max(gear, angles, t, pairs[:, 0], pairs[:, 1]).tolist()
    k_best = float(k_gl_max(gear, angles, tq, tz, zg)[0])
    return ClearanceEstimate(
        two_z=two_z, z_gb=z_gb,
        seal_friction=coefs['seal_friction_n'], mu_bushing=coefs['mu_bushing'], mu_guide=coefs['mu_guide'],
        extra={c.name: coefs[c.name] for c in extra if not F.is_nuisance(c)},
        torque_curve=(angles, tq, band), k_gl_max=Interval(k_best, min(kgl + [k_best]), max(kgl + [k_best])),
        rms=math.sqrt(best.rss / best.n), rows=int(best.n), inflation=vif, noise_rms=noise, smooth_rms=smooth,
        residual=resid, profile=pr, fit=best, max_angle_seen=max_seen, ram_area=gear.ram_area, deviance=delta,
        marginals=(ref.two_z, ref.z_gb), steps=ref.steps, rss_floor=floor,
        scales=(units[0] / sigma2, units[1] / sigma2), thresholds=(rs[0].threshold_1, rs[1].threshold_1),
        bound_why=why,
        robust=dict(scales or {}), sigma2=sigma2, reach=_reach(gear, mom, load, two_z, z_gb))


def _reach(gear: GearParams, mom: Moments, load: NDArray[np.float64], two_z: Interval, z_gb: Interval
           ) -> tuple[Reach, Reach]:
    """How far 2Z and Z_gb can show, each at the other's estimate (at its lower bound where it
    has no other): under the loads of the rows' bins (their angles and the torque the fitted
    load gives there) and the gear's largest."""
    held = mom.count > 0
    alpha, torque = mom.abs_alpha[held], F.torque_of_load(gear, mom, load)[held]

    def of(which: int, other: Interval) -> Reach:
        bound = other.hi is None and other.lo is not None
        return gear_reach(gear, which, other.lo if bound else other.value, alpha, torque, bound)  # type: ignore[arg-type]

    return of(0, z_gb), of(1, two_z)


MIN_CONTACT_SHARE = 0.02    # of the steady-motion rows, where a clearance's contact must show to be assessed
MIN_CONTACT_ROWS = 200


def _evidence(gear: GearParams, mom: Moments, load: NDArray[np.float64], two_z: Interval, z_gb: Interval,
              pr: PF.Profile) -> tuple[Interval, Interval, tuple[str, str]]:
    """Each clearance's interval, kept where its evidence lies where that clearance shows, else
    a lower bound only, and why.

    A clearance shows only past a contact: Z_gb where the guide beam carries, 2Z where the ram
    clamps in its bushing. A contact the estimate puts in fewer than ``MIN_CONTACT_SHARE`` of the
    rows (or ``MIN_CONTACT_ROWS``) is the data's edge, not a kink: any misfit at the highest
    loads is taken up by a contact placed there (a clamped ram's gear read Z_gb 0.265 [0.258,
    0.270] mm, a guide friction of 0.25-0.3 touching in 1 % of the rows, where the slipper
    never touched: Z_gb 0.34 mm). As a change point needs data on both sides of it (the
    trimming of Andrews' test), such an answer is a lower bound: the clearance is at least
    the interval's low end. A Z_gb estimate at the grid's first value, 0 (a slipper touching
    from no load at all, the model's edge, where friction from elsewhere was read as the guide
    beam's: 0.000 [0.000, 0.000] mm for 0.096), is likewise only a lower bound; a 2Z at its
    grid's first value is the new fit's smallest clearance, a place a gear can be."""
    out = [two_z, z_gb]
    why = ['', '']
    if two_z.hi is None and z_gb.hi is None:
        return two_z, z_gb, ('', '')
    ls = load_sharing(gear, mom.abs_alpha, F.torque_of_load(gear, mom, load), two_z.value, z_gb.value)
    total = float(mom.count.sum())
    if total <= 0:
        return two_z, z_gb, ('', '')
    shows = ((ls.stages & STAGE_CLAMPED) != 0, ls.guide_force > 0)
    grids = (pr.two_z, pr.z_gb)
    what = ('the ram clamped in its bushing', 'the guide beam carried load')
    for k in (0, 1):
        iv = out[k]
        if iv.hi is None or iv.lo is None:
            continue
        rows = float(mom.count[shows[k]].sum())
        if k == 1 and iv.value <= float(grids[k][0]) + 1e-12 and grids[k].size > 1:
            out[k] = Interval(iv.value, float(grids[k][0]), None)
            why[k] = "at the model's edge (a contact from no load at all)"
        elif rows < max(MIN_CONTACT_SHARE * total, MIN_CONTACT_ROWS):
            out[k] = Interval(iv.value, iv.lo, None)
            why[k] = (f'{what[k]} in {rows / total:.1%} of the steady motion at the estimate, too little to place '
                      f'a contact')
    return out[0], out[1], (why[0], why[1])


def within_range(name: str, value: float, lo: float | None, hi: float | None) -> Interval:
    """A coefficient's interval held to its physical range (the declared friction's,
    :data:`~steer_monitor.estimate.ranges.DECLARED`): clipped to it, with the end its fit
    stopped on; not determined (both ends None) where the data do not narrow the range at all
    (no row loads that friction: a guide beam never loaded leaves mu_g free) or the interval
    is not finite."""
    rng = DECLARED.get(name)
    if lo is None or hi is None or not (math.isfinite(lo) and math.isfinite(hi)):
        return Interval(value, None, None)
    if rng is None:
        return Interval(value, lo, hi)
    if lo <= rng.lo and hi >= rng.hi:
        return Interval(value, None, None)
    lo, hi = max(lo, rng.lo), min(hi, rng.hi)
    return Interval(value, min(lo, value), max(hi, value), at_edge(value, rng))


def estimate_clearances(gear: GearParams, obs: Observations, rows: Rows, extra: Sequence[F.Column] = (),
                        grid_2z: NDArray = F.GRID_2Z, grid_zgb: NDArray = F.GRID_ZGB,
                        load: NDArray[np.float64] | None = None, model_inflation: float = 1.0) -> ClearanceEstimate:
    """Fit, profile and bound (see the module docstring). The load scale per speed group
    (:func:`~steer_monitor.estimate.fit.speed_scale_columns`) is fitted with the model.
    ``model_inflation`` (>= 1) multiplies the residual variance's inflation: what a model
    known to be incomplete cannot explain, counted as noise in the intervals."""
    basis = F.TorqueBasis(gear.max_rudder)
    mom = rows.moments
    extra = tuple(extra) + F.speed_scale_columns(mom)
    pr, ref, best, tz, zg, load = _profile_fit(gear, basis, mom, extra, grid_2z, grid_zgb, load)
    resid, vif = residuals_and_inflation(gear, basis, rows, obs.t_ns, best.coef, tz, zg, load, extra, obs.step_ns)
    noise, smooth = residual_parts(resid, obs.t_ns, obs.step_ns, obs.shared_ns)
    max_seen = float(np.nanmax(np.abs(obs.alpha[rows.obs_index])))
    scales = _robust(gear, basis, obs, rows, resid, best, tz, zg, load, extra, ref, max(model_inflation, 1.0))
    return _bound(gear, basis, mom, pr, ref, best, tz, zg, load, extra, vif, max_seen, resid, noise, smooth, scales)


def _robust(gear: GearParams, basis: F.TorqueBasis, obs: Observations, rows: Rows, resid: NDArray[np.float64],
            best: F.FitAt, tz: float, zg: float, load: NDArray[np.float64], extra: Sequence[F.Column], ref: Refined,
            model_inflation: float) -> dict[str, RobustScale]:
    """Each parameter's cluster-robust scale (:mod:`~steer_monitor.estimate.robust`) at the
    best fit; a clearance is differentiated where its profile has a minimum inside the data
    (not on a plateau). At least ``model_inflation`` each (a model known to be incomplete)."""
    r = resid[rows.obs_index, rows.ram]
    alpha = obs.alpha[rows.obs_index]
    moving = [axis for axis, m in enumerate((ref.two_z, ref.z_gb))
              if m.rss.size > 2 and float(np.ptp(m.rss)) > 0 and int(np.argmin(m.rss)) < m.rss.size - 1]
    block = block_seconds(resid[rows.obs_index], obs.t_ns[rows.obs_index], obs.step_ns)
    scales = robust_scales(gear, basis, rows.moments, rows.bin_of_row, rows.u, r, obs.t_ns[rows.obs_index],
                           np.abs(alpha), np.sign(alpha).astype(np.int8), obs.direction[rows.obs_index], best.coef,
                           best.names, tz, zg, load, extra, moving, block)
    if model_inflation > 1.0:
        scales = {k: RobustScale(max(v.scale, model_inflation), v.dof, v.by) for k, v in scales.items()}
    return scales


#: what an estimate from the binned statistics is told of its residuals at its best fit
#: (``two_z``, ``z_gb``, the fit, the refined profile, the fit's extra columns): (the variance
#: inflation, each parameter's cluster-robust scale or None)
Spread = Callable[[float, float, F.FitAt, Refined, Sequence[F.Column]], tuple[float, 'dict[str, RobustScale] | None']]


def estimate_in_box(gear: GearParams, mom: Moments, grid_2z: NDArray, grid_zgb: NDArray,
                    spread_at: Spread, extra: Sequence[F.Column] = ()) -> ClearanceEstimate:
    """The estimate from the binned statistics on a part of the grid (a box an earlier
    estimate found, or the whole grid): the declared model with the load scale per speed group
    (:func:`~steer_monitor.estimate.fit.speed_scale_columns`) and ``extra`` columns (an
    adopted effect's, their z in ``mom``), as :func:`estimate_clearances` fits it, its
    intervals scaled by what ``spread_at`` measures of the residuals at the box's best fit
    (:func:`sample_spread`: the cluster-robust scales of a sample of the rows, as the whole
    log's estimate is scaled by all of its rows); no per-sample residuals (``residual`` empty,
    noise/smooth NaN). Whether the box served is :func:`box_holds`'s to say."""
    basis = F.TorqueBasis(gear.max_rudder)
    extra = F.speed_scale_columns(mom) + tuple(extra)
    pr, ref, best, tz, zg, load = _profile_fit(gear, basis, mom, extra, grid_2z, grid_zgb, None)
    vif, scales = spread_at(tz, zg, best, ref, extra)
    max_seen = float(np.max(mom.abs_alpha)) if len(mom) else 0.0
    return _bound(gear, basis, mom, pr, ref, best, tz, zg, load, extra, vif, max_seen, np.zeros((0, 2)), math.nan,
                  math.nan, scales)


def sample_spread(gear: GearParams, obs: Observations, two_z: float, z_gb: float, best: F.FitAt,
                  ref: Refined, extra: Sequence[F.Column] = (), z: Mapping[str, NDArray[np.float64]] | None = None,
                  model_inflation: float = 1.0) -> tuple[float, dict[str, RobustScale] | None]:
    """The residuals' spread at the fit ``best`` (clearances ``two_z``, ``z_gb`` [m], profile
    ``ref``, with its ``extra`` columns) over the steady-motion observations ``obs``
    (a sample of the estimate's rows: the review's :class:`~steer_monitor.ashore.rowsample.RowSample`): the
    variance inflation of their correlation in time and each parameter's cluster-robust scale
    (:func:`~steer_monitor.estimate.robust.robust_scales`, as :func:`estimate_clearances` has
    them of all its rows). ``z``: the per-observation columns the ``extra`` columns read, as
    the fit had them; ``model_inflation`` as :func:`estimate_clearances` takes it. (1.0, None)
    with fewer than :data:`MIN_MOTION_SAMPLES` rows."""
    rows = make_rows(obs, z)
    if rows.u.shape[0] < MIN_MOTION_SAMPLES:
        return 1.0, None
    basis = F.TorqueBasis(gear.max_rudder)
    load = F.axial_load(gear, basis, rows.moments, best.coef)
    resid, vif = residuals_and_inflation(gear, basis, rows, obs.t_ns, best.coef, two_z, z_gb, load, extra,
                                         obs.step_ns)
    return vif, _robust(gear, basis, obs, rows, resid, best, two_z, z_gb, load, extra, ref, max(model_inflation, 1.0))


def box_holds(est: ClearanceEstimate, grid_2z: NDArray, grid_zgb: NDArray) -> bool:
    """True when the box ``est`` was profiled on held its answer: on each side where the box
    stops short of the whole grid (``grid_2z``, ``grid_zgb``), the best point lies inside and
    the 95 % interval ends before the box's edge. Otherwise the interval (or the minimum) may
    run on beyond the box, and only a profile of the whole grid can say."""
    for box, grid, iv in ((est.profile.two_z, grid_2z, est.two_z), (est.profile.z_gb, grid_zgb, est.z_gb)):
        if box[0] > grid[0] + 1e-12 and (iv.value <= box[0] + 1e-12 or iv.lo is None or iv.lo <= box[0] + 1e-12):
            return False
        if box[-1] < grid[-1] - 1e-12 and (iv.value >= box[-1] - 1e-12 or iv.hi is None or iv.hi >= box[-1] - 1e-12):
            return False
    return True


def coarse_profile(gear: GearParams, mom: Moments, grid_2z: NDArray, grid_zgb: NDArray,
                   coef: NDArray[np.float64] | None = None, extra: Sequence[F.Column] = ()
                   ) -> tuple[PF.Profile, NDArray, NDArray]:
    """The profile on every other grid point, the declared model with ``extra`` columns:
    (profile, its 2Z axis, its Z_gb axis)."""
    basis = F.TorqueBasis(gear.max_rudder)
    coef = F.torque_prefit(gear, basis, mom) if coef is None else coef
    load = F.axial_load(gear, basis, mom, coef)
    g2, gz = grid_2z[::2], grid_zgb[::2]
    return PF.profile(gear, basis, mom, load, tuple(extra), g2, gz), g2, gz


def search_box(gear: GearParams, mom: Moments, grid_2z: NDArray, grid_zgb: NDArray, vif: float = 1.0,
               coef: NDArray[np.float64] | None = None,
               coarse: tuple[PF.Profile, NDArray, NDArray] | None = None) -> tuple[NDArray, NDArray]:
    """The part of the grid worth a fine profile: a profile on every other point first
    (:func:`coarse_profile`, or ``coarse`` when already made), then the box around the points
    within ten times the 95 % threshold of it (one coarse step wider on each side, so the
    box's edges lie outside the interval). A quarter of the cost where the data pin the
    clearances down; the whole grid where they do not."""
    pr, g2, gz = coarse or coarse_profile(gear, mom, grid_2z, grid_zgb, coef)
    best = float(pr.rss.min())
    sigma2 = best / max(pr.n - pr.p, 1.0)
    near = np.argwhere((pr.rss - best) / (sigma2 * max(vif, 1.0)) <= 10 * CHI2_1_95)
    i0, j0 = max(near[:, 0].min() - 1, 0) * 2, max(near[:, 1].min() - 1, 0) * 2
    # a box that reaches the last coarse point runs to the grid's end (with an even number
    # of points the grid's last one is not a coarse point)
    i1 = grid_2z.size - 1 if near[:, 0].max() + 1 >= g2.size - 1 else (near[:, 0].max() + 1) * 2
    j1 = grid_zgb.size - 1 if near[:, 1].max() + 1 >= gz.size - 1 else (near[:, 1].max() + 1) * 2
    return grid_2z[i0:i1 + 1], grid_zgb[j0:j1 + 1]


def _within_box(axis_2z: NDArray, axis_zgb: NDArray, two_z: Interval, z_gb: Interval) -> NDArray[np.float64]:
    """The pairs (P, 2) of grid values of 2Z and Z_gb [m] that lie within both intervals (an
    open end reaching to the grid's last value)."""
    def within(axis: NDArray, iv: Interval) -> NDArray:
        return axis[np.array([iv.contains(float(x)) for x in axis], bool)]
    a, b = np.meshgrid(within(axis_2z, two_z), within(axis_zgb, z_gb), indexing='ij')
    return np.column_stack([a.ravel(), b.ravel()])


def k_gl_max(gear: GearParams, angles: NDArray, torque: NDArray, two_z: ArrayLike, z_gb: ArrayLike) -> NDArray:
    """K_gl max over ``angles`` (A,) [rad] at ``torque`` [N m], one curve (A,) or one per pair
    (A, R), for each clearance pair ``two_z``, ``z_gb`` (R,) [m] (scalars are one pair):
    shape (R,)."""
    two_z, z_gb = np.atleast_1d(np.asarray(two_z, float)), np.atleast_1d(np.asarray(z_gb, float))
    if angles.size == 0 or two_z.size == 0:
        return np.zeros(two_z.size)
    torque = np.maximum(torque, 0.0)
    ls = load_sharing(gear, angles[:, None], torque if torque.ndim == 2 else torque[:, None], two_z[None, :],
                      z_gb[None, :])
    return np.max(ls.k_gl, axis=0)
