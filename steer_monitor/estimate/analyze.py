"""The residual loop over a whole log: fit the declared model, test the residual against the
library of candidate effects, add the one the data support, refit, and say what is left.

Selection guards against overfitting twice: a candidate must lower the *held-out* error
(two-fold cross-validation over alternate minutes of the log: fit on one half, score on the
other, and back) by at least ``MIN_CV_GAIN`` and lower the Bayesian information criterion
computed with the effective sample size (rows / variance inflation) by at least
``MIN_BIC_DROP``. Among those the largest held-out gain wins. It is then adopted only if it
*explains* the residual: afterwards the residual's smooth part (its autocovariance at 200 ms,
what sensor noise cannot make) is at most ``EXPLAINED_RATIO`` of its noise part; and where
the declared model already explained the data that far, only if it cuts the smooth part by
``1 - MIN_SYSTEMATIC_CUT`` (a column that explains nothing systematic is no effect, however it
scores). Otherwise the answer is "unexplained": the declared estimate stands and the report says which
candidate came closest and what it left.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from steer_monitor.can.decoder import Series
from steer_monitor.can.signals import PRESSURE_INPUTS
from steer_monitor.estimate import fit as F
from steer_monitor.estimate.batch import ClearanceEstimate, Rows, estimate_clearances, make_rows
from steer_monitor.estimate.effects import Candidate, candidates, low_side_offsets, z_columns
from steer_monitor.estimate.intervals import Interval
from steer_monitor.estimate.moments import Moments
from steer_monitor.estimate.observe import Observations, build_observations
from steer_monitor.model.gear import GearParams

__all__ = ['EXPLAINED_RATIO', 'MIN_BIC_DROP', 'MIN_CV_GAIN', 'MIN_SYSTEMATIC_CUT', 'OUTLIER_SIGMAS', 'SIGNS', 'outlier_instants', 'refusal', 'Analysis', 'Screening', 'analyze',
           'grid_2z_from']

MIN_CV_GAIN = 0.10       # held-out mean square must fall by 10 % (RMS by ~5 %)
MIN_BIC_DROP = 10.0      # "very strong" evidence on the effective sample size
EXPLAINED_RATIO = 0.5    # smooth residual RMS at most half the sensor-noise RMS
OUTLIER_SIGMAS = 5.0     # instants set aside before screening (see outlier_instants)
MIN_SYSTEMATIC_CUT = 0.7  # an effect on data the declared model explains must cut its smooth part by 30 %
BLOCK_NS = 60_000_000_000
MIN_SEGMENT_SAMPLES = 20


@dataclass(frozen=True)
class Screening:
    """One candidate's score: held-out gain (1 - MSE_cv / MSE_cv declared), BIC change,
    in-sample RMS [N], the clearances at its optimum [m], its fitted coefficients (SI) and,
    when its coefficients break the physics the effect stands for, why it is refused
    (a refused candidate never passes, however well it fits)."""

    name: str
    fixed: dict[str, float]
    cv_gain: float
    delta_bic: float
    rms: float
    two_z: float
    z_gb: float
    values: dict[str, float] = field(default_factory=dict)
    refused: str | None = None

    @property
    def passes(self) -> bool:
        return self.refused is None and self.cv_gain >= MIN_CV_GAIN and self.delta_bic <= -MIN_BIC_DROP


@dataclass(frozen=True)
class Analysis:
    """The outcome of :func:`analyze`.

    Attributes:
        declared: the estimate under the declared model.
        final: the estimate with the adopted effect (``declared`` when none).
        effect: name of the adopted effect, or None; params: its parameters (engineers'
            units, see :mod:`~steer_monitor.estimate.effects`) with intervals.
        verdict: 'declared' (the declared model explains the data to the sensor noise),
            'effect' (an effect was adopted), 'unexplained' (a systematic residual remains
            that nothing in the library explains).
        message: one plain sentence saying so.
        screening: every candidate's score, best first.
        closest: the candidate that came closest when the verdict is 'unexplained'.
        observations: the aligned data (for reports).
        outliers: instants set aside as outliers before screening (:func:`outlier_instants`).
    """

    declared: ClearanceEstimate
    final: ClearanceEstimate
    effect: str | None
    params: dict[str, Interval | str]
    verdict: str
    message: str
    screening: list[Screening]
    closest: Screening | None
    observations: Observations = field(repr=False)
    final_observations: Observations = field(repr=False)
    outliers: int = 0


def grid_2z_from(min_clearance: float) -> NDArray[np.float64]:
    """The 2Z grid from the new fit's smallest clearance (wear only opens a fit) up."""
    return F.GRID_2Z[F.GRID_2Z >= min_clearance - 1e-12]


def _halves(obs: Observations) -> tuple[NDArray[np.bool_], NDArray[np.bool_]]:
    block = (obs.t_ns // BLOCK_NS) % 2 == 0
    return block, ~block


def _covered(train: Moments, score: Moments, basis: F.TorqueBasis) -> NDArray[np.bool_]:
    """Bins of ``score`` whose torque-spline segment the training half has data in (at least
    ``MIN_SEGMENT_SAMPLES``): held-out rows elsewhere would score the spline's extrapolation
    (a hard-over sits in one minute, so in one half only), not the friction model."""
    step = math.radians(F.KNOT_STEP_DEG)
    seg_train = np.floor(train.abs_alpha / step).astype(np.int64)
    counts = np.bincount(seg_train, train.count, minlength=int(seg_train.max(initial=0)) + 1)
    seg = np.floor(score.abs_alpha / step).astype(np.int64)
    ok = seg < counts.size
    ok[ok] = counts[seg[ok]] >= MIN_SEGMENT_SAMPLES
    return ok


def _cv_mse(gear: GearParams, basis: F.TorqueBasis, parts: tuple[Rows, Rows], coef_torque: NDArray,
            two_z: float, z_gb: float, extra: tuple[F.Column, ...]) -> float:
    """Held-out mean square: fit on each half at the given clearances, score on the other
    (the bins of the other half inside the angles the fitting half covers)."""
    if min(part.moments.samples for part in parts) < 50:
        return math.nan
    total, n = 0.0, 0.0
    for fit_on, score_on in ((0, 1), (1, 0)):
        fmom = parts[fit_on].moments
        xtx, xty, names = F.normal_equations(gear, basis, fmom, two_z, z_gb,
                                             F.axial_load(gear, basis, fmom, coef_torque), extra)
        coef = F.solve_normal_equations(basis, xtx, xty, names)
        mom = parts[score_on].moments
        keep = _covered(fmom, mom, basis)
        if not keep.all():
            mom = mom.subset(keep)
        if not len(mom):
            continue
        cols, zs, _ = F.design_at(gear, basis, mom, two_z, z_gb, F.axial_load(gear, basis, mom, coef_torque), extra)
        total += F.residual_sum_of_squares(mom, cols, zs, coef)
        n += mom.samples
    return total / n if n > 0 else math.nan


def _score(gear: GearParams, basis: F.TorqueBasis, rows: Rows, parts: tuple[Rows, Rows], coef_torque: NDArray,
           extra: tuple[F.Column, ...], grid_2z: NDArray, declared_at: tuple[float, float]
           ) -> tuple[float, float, float, float, float, int, NDArray[np.float64]]:
    """(in-sample RSS, rows, held-out MSE, 2Z, Z_gb, parameters) at the candidate's optimum:
    a coarse pass over the grid, then the full resolution around its best point and around
    the declared model's estimate ``declared_at`` (2Z, Z_gb) [m] (a ram that clamps makes the
    profile in 2Z narrower than the coarse step, so the coarse pass alone can miss it)."""
    mom = rows.moments
    load = F.axial_load(gear, basis, mom, coef_torque)
    pr = F.profile(gear, basis, mom, load, extra, grid_2z[::3], F.GRID_ZGB[::3])
    best: tuple[float, float, float, int, NDArray[np.float64]] = (math.inf, 0.0, 0.0, 0, np.zeros(0))
    centres = dict.fromkeys((int(np.argmin(np.abs(grid_2z - tz0))), int(np.argmin(np.abs(F.GRID_ZGB - zg0))))
                            for tz0, zg0 in ((float(pr.two_z[pr.best[0]]), float(pr.z_gb[pr.best[1]])), declared_at))
    for i0, j0 in centres:      # in order; one fine search when both centres are the same point
        fine = F.profile(gear, basis, mom, load, extra, grid_2z[max(i0 - 3, 0):i0 + 4],
                         F.GRID_ZGB[max(j0 - 3, 0):j0 + 4])
        i, j = fine.best
        if fine.rss[i, j] < best[0]:
            best = (float(fine.rss[i, j]), float(fine.two_z[i]), float(fine.z_gb[j]), fine.p, fine.coef)
    rss, tz, zg, p, coef = best
    cv = _cv_mse(gear, basis, parts, coef_torque, tz, zg, extra)
    return rss, mom.samples, cv, tz, zg, p, coef


def analyze(gear: GearParams, signals: Mapping[str, Series], *, min_clearance_2z: float = 0.0,
            progress: Callable[[str], None] | None = None) -> Analysis:
    """Fit, screen, adopt or not, refit (see the module docstring). Pure."""
    say = progress or (lambda _msg: None)
    grid_2z = grid_2z_from(min_clearance_2z)
    obs = build_observations(signals, gear.ram_area)
    z = z_columns(obs, gear)
    rows = make_rows(obs, z)
    say('declared model')
    declared = estimate_clearances(gear, obs, rows, grid_2z=grid_2z)
    outliers = outlier_instants(declared.residual, obs.direction)
    keep = ~outliers
    n_out = int(outliers.sum())
    if outliers.any():
        say(f'declared model without {n_out} outlying instants')
        rows = make_rows(obs, z, keep)
        declared = estimate_clearances(gear, obs, rows, grid_2z=grid_2z)
    basis = F.TorqueBasis(gear.max_rudder)
    coef_t = declared.fit.coef[:basis.size]
    a_half, b_half = _halves(obs)
    parts = (make_rows(obs, z, a_half & keep), make_rows(obs, z, b_half & keep))
    bad_times = obs.t_ns[outliers]
    at = (declared.two_z.value, declared.z_gb.value)
    nuisance = F.speed_scale_columns(rows.moments)
    rss0, n0, cv0, _, _, p0, _ = _score(gear, basis, rows, parts, coef_t, nuisance, grid_2z, at)
    n_eff = n0 / declared.inflation
    seal, mu_b, mu_g = (declared.fit.get(k) for k in ('seal_friction_n', 'mu_bushing', 'mu_guide'))
    screened: list[tuple[Screening, Candidate]] = []
    delays: list[tuple[float, Candidate, Observations, Rows, Rows, NDArray[np.bool_], NDArray[np.bool_]]] = []
    steady_t = obs.t_ns[obs.moving & keep]
    for cand in candidates(z, (seal, mu_b, mu_g)):
        if cand.angle_shift_s:
            # The shifted angle judges steady motion at other instants. Scored on its own
            # instants against the declared model on all of them, a delay would win or lose
            # by which rows it kept, not by how well it fits: both are scored on the instants
            # steady under either reading.
            o = build_observations(signals, gear.ram_area, angle_shift_s=cand.angle_shift_s)
            o_mask = np.isin(o.t_ns, steady_t)
            base_mask = np.isin(obs.t_ns, o.t_ns[o.moving & o_mask]) & keep
            r = make_rows(o, z_columns(o, gear), o_mask)
            rb = make_rows(obs, z, base_mask)
            if min(r.moments.samples, rb.moments.samples) < 200:
                continue
            f, fb = (F.fit_at(gear, basis, x.moments, declared.two_z.value, declared.z_gb.value,
                              F.axial_load(gear, basis, x.moments, coef_t), nuisance) for x in (r, rb))
            delays.append(((f.rss / f.n) / (fb.rss / fb.n), cand, o, r, rb, o_mask, base_mask))
            continue
        say(f'candidate {cand.name}')
        rss, n, cv, tz, zg, p, coef = _score(gear, basis, rows, parts, coef_t, nuisance + cand.columns, grid_2z, at)
        values = {c.name: float(v) for c, v in zip(cand.columns, coef[coef.size - len(cand.columns):])}
        screened.append((_screening(cand, rss, n, cv, tz, zg, p, rss0, n0, cv0, p0, n_eff, values), cand))
    delay_obs: dict[float, tuple[Observations, Rows]] = {}
    if delays:
        say('candidate angle_delay')
        _, cand, o, r, rb, o_mask, base_mask = min(delays, key=lambda d: d[0])
        o_a, o_b = _halves(o)
        zc = z_columns(o, gear)
        rss, n, cv, tz, zg, p, _ = _score(gear, basis, r, (make_rows(o, zc, o_a & o_mask), make_rows(o, zc, o_b & o_mask)),
                                       coef_t, nuisance, grid_2z, at)
        rss_b, n_b, cv_b, _, _, p_b, _ = _score(gear, basis, rb, (make_rows(obs, z, a_half & base_mask),
                                                                   make_rows(obs, z, b_half & base_mask)),
                                                coef_t, nuisance, grid_2z, at)
        screened.append((_screening(cand, rss, n, cv, tz, zg, p + 1, rss_b, n_b, cv_b, p_b, n_b / declared.inflation),
                         cand))
        delay_obs[cand.angle_shift_s] = (o, r)
    screened = _best_per_name(screened)
    screened.sort(key=lambda sc: -sc[0].cv_gain)
    passing = [sc for sc in screened if sc[0].passes]
    explained0 = declared.smooth_rms <= EXPLAINED_RATIO * declared.noise_rms
    if not passing:
        verdict = 'declared' if explained0 else 'unexplained'
        closest = None if explained0 else (screened[0][0] if screened else None)
        return Analysis(declared, declared, None, {}, verdict, _message(verdict, declared, None, closest),
                        [s for s, _ in screened], closest, obs, obs, n_out)
    best, cand = passing[0]
    say(f'refit with {cand.name}')
    if cand.angle_shift_s:
        o, r = delay_obs[cand.angle_shift_s]
        final = estimate_clearances(gear, o, r, grid_2z=grid_2z)
        final_obs = o
    else:
        final = estimate_clearances(gear, obs, rows, cand.columns, grid_2z=grid_2z)
        final_obs = obs
    if explained0 and final.smooth_rms > MIN_SYSTEMATIC_CUT * declared.smooth_rms:
        # the declared model already explained the data to the noise and the candidate takes
        # none of what is left: a better held-out score from a column that explains nothing
        # systematic is not an effect
        return Analysis(declared, declared, None, {}, 'declared',
                        _message('declared', declared, None, best) + f' ({best.name} passed screening but '
                        f'leaves the systematic part at {final.smooth_rms / (1e5 * declared.ram_area):.2f} bar)',
                        [s for s, _ in screened], None, obs, obs, n_out)
    if final.smooth_rms > EXPLAINED_RATIO * final.noise_rms:
        return Analysis(declared, declared, None, {}, 'unexplained',
                        _message('unexplained', declared, final, best), [s for s, _ in screened], best, obs, obs, n_out)
    params = _effect_params(cand, final, obs, declared)
    return Analysis(declared, final, cand.name, params, 'effect', _message('effect', declared, final, best, cand.name),
                    [s for s, _ in screened], None, obs, final_obs, n_out)


def outlier_instants(resid: NDArray[np.float64], direction: NDArray[np.int8]) -> NDArray[np.bool_]:
    """Instants (n,) where either ram's residual (n, 2) [N] lies more than ``OUTLIER_SIGMAS``
    robust standard deviations (1.4826 x the median absolute residual) *against* the
    direction of motion ``direction`` (n,): the pressure held less friction than the model
    puts there.

    They are instants the steadiness test passed while the rudder stood: 10 Hz angle
    samples cannot resolve a pause of a few tens of ms between an autopilot's steps, and
    there the pressure holds no friction (a residual of the whole friction, 2 to 4 bar,
    against 0.35 bar of sensor noise). Left in, a few hundred of them bias the seal
    friction low by more than its interval. Only that side is cut: friction *above* the
    model (a Stribeck rise at low speed) is an effect to find, not an outlier. Gaussian
    noise passes 5 sigma on one side once in 3.5 million rows."""
    r = np.asarray(resid, float) * np.asarray(direction, float)[:, None]
    fin = np.isfinite(r)
    if fin.sum() < 50:
        return np.zeros(r.shape[0], bool)
    scale = 1.4826 * float(np.median(np.abs(r[fin])))
    if not scale > 0:
        return np.zeros(r.shape[0], bool)
    with np.errstate(invalid='ignore'):
        return np.any(fin & (r < -OUTLIER_SIGMAS * scale), axis=1)


# Coefficients whose sign the physics fixes: (effect, coefficient) -> what a negative value
# would claim. A fit may still find one negative: another misfit leaning on its column.
SIGNS = {
    ('viscous', 'c_ns_per_m'): 'a negative viscous coefficient (friction falling as the ram speeds up)',
    ('stribeck', 'f_st_n'): 'friction below the declared law near zero speed (a negative Stribeck amplitude)',
    ('pressure_friction', 'k'): 'a negative pressure-friction factor (friction falling as the pressure rises)',
    ('ram_inertia', 'mass_kg'): 'a negative moving mass',
}


def refusal(name: str, values: Mapping[str, float]) -> str | None:
    """Why an effect with these fitted coefficients (SI) is unphysical, or None."""
    for (effect, coef), claim in SIGNS.items():
        if effect == name and values.get(coef, 0.0) < 0:
            return f'refused: its fit needs {claim}, {coef} = {values[coef]:.4g}'
    return None


def _screening(cand: Candidate, rss: float, n: float, cv: float, tz: float, zg: float, p: int,
               rss0: float, n0: float, cv0: float, p0: int, n_eff: float,
               values: Mapping[str, float] | None = None) -> Screening:
    mse, mse0 = rss / n, rss0 / n0
    d_bic = n_eff * math.log(max(mse, 1e-300) / mse0) + (p - p0) * math.log(max(n_eff, 2.0))
    gain = 1.0 - cv / cv0 if math.isfinite(cv) and cv0 > 0 else 0.0
    values = dict(values or {})
    return Screening(cand.name, dict(cand.fixed or {}), gain, d_bic, math.sqrt(mse), tz, zg, values,
                     refusal(cand.name, values))


def _best_per_name(scored: list[tuple[Screening, Candidate]]) -> list[tuple[Screening, Candidate]]:
    """Stribeck comes with several v_s: keep each name's best."""
    best: dict[str, tuple[Screening, Candidate]] = {}
    for sc in scored:
        cur = best.get(sc[0].name)
        if cur is None or sc[0].cv_gain > cur[0].cv_gain:
            best[sc[0].name] = sc
    return list(best.values())


def _effect_params(cand: Candidate, final: ClearanceEstimate, obs: Observations,
                   declared: ClearanceEstimate) -> dict[str, Interval | str]:
    out: dict[str, Interval | str] = {}
    for k, v in (cand.fixed or {}).items():
        out[k] = Interval(v, None, None)
    if cand.name == 'pressure_offset':
        offs = low_side_offsets(obs, PRESSURE_INPUTS)
        for ram, key in ((1, 'offset_ram1_n'), (2, 'offset_ram2_n')):
            iv = final.extra[key]
            k = 1.0 / final.ram_area / 1e5
            out[f'offset_ram{ram}_bar'] = Interval(iv.value * k, iv.lo * k if iv.lo is not None else None,
                                                   iv.hi * k if iv.hi is not None else None)
        named = max(offs, key=lambda k: abs(offs[k]) if math.isfinite(offs[k]) else -1.0)
        out['input'] = named
        out['low_side_offset_bar'] = Interval(offs[named] / 1e5, None, None)
        return out
    if cand.name == 'temp_friction':
        t_mean = float(np.nanmean(obs.oil_temp)) - 273.15
        out['t_ref_c'] = Interval(t_mean, None, None)
    for key, iv in final.extra.items():
        out[key] = iv
    return out


def _message(verdict: str, declared: ClearanceEstimate, final: ClearanceEstimate | None,
             best: Screening | None, name: str | None = None) -> str:
    bar = 1e5 * declared.ram_area
    if verdict == 'declared':
        return (f'the declared model explains the data to the sensor noise: residual {declared.rms / bar:.2f} bar '
                f'RMS, of which {declared.smooth_rms / bar:.2f} bar systematic; no effect added')
    if verdict == 'effect' and final is not None:
        return (f'added {name}: residual {declared.rms / bar:.2f} -> {final.rms / bar:.2f} bar RMS '
                f'(systematic part {declared.smooth_rms / bar:.2f} -> {final.smooth_rms / bar:.2f} bar)')
    text = (f'residual not explained: {declared.rms / bar:.2f} bar RMS with a systematic part of '
            f'{declared.smooth_rms / bar:.2f} bar that no effect in the library explains')
    if best is not None:
        text += f' (closest: {best.name}, held-out error -{100 * best.cv_gain:.0f} %)'
    return text
