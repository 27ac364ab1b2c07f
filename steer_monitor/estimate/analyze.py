"""The residual loop over a whole log: fit the declared model, test the residual against the
library of candidate effects, add the one the data support, refit, screen the rest again on
the new residual, and so on until nothing passes (forward selection); then say what is
left, and where it lives.

Selection guards against overfitting twice: a candidate must lower the *held-out* error
(two-fold cross-validation over alternate minutes of the log, shorter blocks on a log of
under eight minutes (:mod:`~steer_monitor.estimate.heldout`): fit on one half, score on the
other, and back) and the Bayesian information criterion, both on the effective sample size
n_eff (rows / variance inflation): the held-out deviance n_eff ln(MSE_cv before / after) must
reach ``MIN_CV_DEVIANCE`` and the BIC fall by ``MIN_BIC_DROP`` ("very strong" evidence, 10,
plus 2 ln 10 for the ten or so candidates each round tests: at 10, one clean log in 168
adopted a 34 t ram inertia at a BIC drop of 10.2). The best delay of the 50 ms grid is
refined to 5 ms where the parabola through it and its neighbours puts the optimum more
than 10 ms away. A fixed share of the error would not do: an effect at a fifth of the simulator's
defaults takes 1 % of it, far above the noise on a log's 40 000 rows. An effect whose
coefficients break its physics is refused. Among those passing, the largest held-out gain is
refitted and adopted if what it takes from the residual is systematic: the residual's
autocovariance at the next instant (50 ms) must fall by at least ``MIN_SYSTEMATIC_SHARE`` of
the fall of its mean square (a column that fits the noise, or the instants a shifted angle
keeps, explains nothing systematic and is no effect, however it scores); else the next one is tried (at most
``MAX_TRIED``). temp_friction's column scales a friction law, screened with the law of the fit
without it and refitted with that of its own fit until the law settles (``SHAPE_RTOL``). An
adopted effect stays even when a residual remains.

The model explains the data when its smooth part is at most ``EXPLAINED_RATIO`` of its noise
part: the verdict is then "declared" (nothing adopted) or "effect". Otherwise it is
"unexplained": :func:`~steer_monitor.estimate.locate.locate` finds the observed variable,
range, ram and direction that carry the rest, and the clearances are refitted with that
term as a nuisance (so they do not lean on the misfit), where it was found and beside it
(:mod:`~steer_monitor.estimate.placements`: the intervals span the places it fits as well),
saying they rest on an incomplete model.

Before all that, stretches where the two rams did not share the force evenly
(:class:`~steer_monitor.estimate.ramscheck.RamsCheck`: a bypass or isolating valve open, a
transducer not reading) are left out, and the message says when and which ram: the declared
model has each ram carry half.

The parts live beside it: the held-out scoring (:mod:`~steer_monitor.estimate.heldout`), what a
screening records and the outliers set aside (:mod:`~steer_monitor.estimate.screening`), whether
a fit is physical (:mod:`~steer_monitor.estimate.plausible`) and the verdict's words
(:mod:`~steer_monitor.estimate.analysiswords`), whether an adopted column takes something systematic
(:func:`~steer_monitor.estimate.screening.takes_systematic`) and the friction over a slow log's stamp
lags (:mod:`~steer_monitor.estimate.stamplags`). What stays here, some 660 lines, is one room:
the loop (:func:`analyze`), a run under a given model (``_given``) and the verdict they share
(``_conclude``, its specification check) all work on one ``_Base`` (observations, rows, the
adopted columns, the fit) and hand it on; split, each would reach into the others' state.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import NDArray

from steer_monitor.estimate import fit as F
from steer_monitor.estimate import window as W
from steer_monitor.estimate.analysiswords import message, uneven_note
from steer_monitor.estimate.batch import (
    MIN_MOTION_SAMPLES,
    ClearanceEstimate,
    Rows,
    estimate_clearances,
    make_rows,
)
from steer_monitor.estimate.effects import (
    Candidate,
    Effect,
    candidate_of,
    candidates,
    iter_z_columns,
    low_side_offsets,
    z_columns,
)
from steer_monitor.estimate.heldout import candidate_score, halves
from steer_monitor.estimate.intervals import Interval
from steer_monitor.estimate.locate import UNITS, Located, locate
from steer_monitor.estimate.moments import Moments
from steer_monitor.estimate.observe import (
    EstimateError,
    Observations,
    build_observations,
    in_sorted,
    too_little_motion,
)
from steer_monitor.estimate.placements import moved_off, placements, spanned
from steer_monitor.estimate.plausible import rated_force
from steer_monitor.estimate.rams import OPPOSED, RamShare, judge, opposed_cause, ram_share, working_against
from steer_monitor.estimate.ramscheck import RamsCheck, UnevenSpan, within
from steer_monitor.estimate.screening import (
    Screening,
    Step,
    best_per_name,
    outlier_instants,
    screening_record,
    takes_systematic,
)
from steer_monitor.estimate.stamplags import over_stamp_lags
from steer_monitor.model.gear import GearParams
from steer_monitor.model.inputs import PRESSURE_INPUTS, Series

__all__ = [
    'DELAY_KEEP_S',
    'DELAY_STEP_S',
    'DELAY_VERTEX_S',
    'EXPLAINED_RATIO',
    'MAX_TRIED',
    'MIN_SYSTEMATIC_SHARE',
    'SYSTEMATIC_LAG_STEPS',
    'Analysis',
    'analyze',
    'declared_fit',
    'grid_2z_from',
]

EXPLAINED_RATIO = 0.5    # smooth residual RMS at most half the sensor-noise RMS
MIN_SYSTEMATIC_SHARE = 0.5  # of what an adopted effect takes from the mean square, the lag-1 part's share
SYSTEMATIC_LAG_STEPS = 1
MAX_TRIED = 3            # passing candidates refitted per round, best held-out gain first
DELAY_STEP_S = 0.05      # the delay grid's step (effects.DELAYS_S)
DELAY_KEEP_S = 0.01      # a grid point stands unless the parabola's vertex lies further off
DELAY_VERTEX_S = 0.005   # the vertex, and its neighbours, to 5 ms
SHAPE_RTOL = 0.01        # temp_friction's friction law settled: each part moved less than this share of itself
SHAPE_ROUNDS = 4         # refits at most to settle it


@dataclass(frozen=True)
class Analysis:
    """The outcome of :func:`analyze`.

    Attributes:
        declared: the estimate under the declared model.
        final: the estimate the answer rests on: with the adopted effects, and when the
            verdict is 'unexplained' with the located term as a nuisance.
        effect: name of the first adopted effect, or None; params: its parameters (engineers'
            units, see :mod:`~steer_monitor.estimate.effects`) with intervals.
        verdict: 'declared' (the declared model explains the data to the sensor noise),
            'effect' (effects were adopted and the model then explains the data),
            'unexplained' (a systematic residual remains that nothing in the library explains;
            effects may have been adopted before).
        message: one plain sentence saying so.
        screening: every candidate's score against the declared model, best first.
        closest: the candidate of the last round that came closest when 'unexplained'.
        observations: the aligned data (for reports); final_observations: those of the
            final model (the angle read later when a delay was adopted).
        outliers: instants set aside as outliers before screening
            (:func:`~steer_monitor.estimate.screening.outlier_instants`).
        steps: the adopted effects in order.
        located: where the unexplained residual lives (None unless 'unexplained' and found).
        model: the estimate with the adopted effects, before any located nuisance (its
            residual is the one ``located`` describes).
        uneven: stretches where the rams did not share the force evenly, left out of it all.
        rams: how the rams shared the force over the instants of steady motion kept.
        given: True for a run under a given model (``analyze(..., model=...)``: no screening,
            ``screening`` empty, ``declared`` is that model's own fit).
        window: the data analysed (:func:`~steer_monitor.estimate.window.select`), when a
            window was asked for.
        rams_assessed: a window of the rams check said even or uneven (False: it could judge
            none: too little steady motion, or a load that hardly varied).
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
    steps: tuple[Step, ...] = ()
    located: Located | None = None
    model: ClearanceEstimate | None = field(default=None, repr=False)
    uneven: tuple[UnevenSpan, ...] = ()
    rams: RamShare | None = None
    given: bool = False
    window: W.Window | None = field(default=None, repr=False)
    rams_assessed: bool = False

    @property
    def adopted(self) -> tuple[Effect, ...]:
        """The effects adopted, in order, as a run under this model applies them
        (``analyze(..., model=a.adopted)``)."""
        return tuple(s.effect for s in self.steps)


def grid_2z_from(min_clearance: float) -> NDArray[np.float64]:
    """The 2Z grid from the new fit's smallest clearance (wear only opens a fit) up."""
    return F.GRID_2Z[F.GRID_2Z >= min_clearance - 1e-12]


@dataclass(frozen=True)
class _Base:
    """The model the next round screens against: its observations (the angle read later once
    a delay is adopted), the instants it keeps, its rows, their two halves' moments, the
    adopted effects' columns and its estimate. Its z columns are not kept (tens of MB on a
    long log): :func:`_z_subset` makes again those a step needs."""

    obs: Observations
    keep: NDArray[np.bool_]
    rows: Rows
    parts: tuple[Moments, Moments]       # the two halves' moments (their rows are not kept)
    extra: tuple[F.Column, ...]
    est: ClearanceEstimate


def _base(gear: GearParams, obs: Observations, keep: NDArray[np.bool_], extra: tuple[F.Column, ...],
          grid_2z: NDArray, est: ClearanceEstimate | None = None) -> _Base:
    z = z_columns(obs, gear)
    rows = make_rows(obs, z, keep)
    a_half, b_half = halves(obs)
    parts = (make_rows(obs, z, a_half & keep).moments, make_rows(obs, z, b_half & keep).moments)
    est = est or estimate_clearances(gear, obs, rows, extra, grid_2z=grid_2z)
    return _Base(obs, keep, rows, parts, extra, est)


def _z_subset(obs: Observations, gear: GearParams, names: set[str]
              ) -> tuple[dict[str, NDArray[np.float64]], NDArray[np.bool_], tuple[str, ...]]:
    """The z columns ``names`` of ``obs``, the instants where every z column is finite (with
    them as a mask, rows built from the subset are the rows built from all columns), and the
    names of all columns."""
    kept: dict[str, NDArray[np.float64]] = {}
    valid = np.ones(len(obs), bool)
    all_names = []
    for name, arr in iter_z_columns(obs, gear):     # one column at a time: tens of MB each on a long log
        valid &= np.all(np.isfinite(arr), axis=1) if arr.ndim == 2 else np.isfinite(arr)
        all_names.append(name)
        if name in names:
            kept[name] = arr
    return kept, valid, tuple(all_names)


def unexplained_inflation(est: ClearanceEstimate) -> float:
    """The factor on the residual variance for intervals from a model known to be incomplete:
    (noise² + systematic²) / noise² of the residual that nothing explained, i.e. its
    systematic part counted as noise. The located nuisance takes the misfit's place in the
    fit, but not its whole effect on the clearances (on the simulator's angle-band friction
    a Z_gb interval missed the truth by 0.002 mm with the nuisance alone)."""
    if not (math.isfinite(est.noise_rms) and math.isfinite(est.smooth_rms)) or est.noise_rms <= 0:
        return 1.0
    return 1.0 + (est.smooth_rms / est.noise_rms) ** 2


def _screen(
    gear: GearParams,
    signals: Mapping[str, Series],
    base: _Base,
    grid_2z: NDArray,
    adopted: set[str],
    say: Callable[[str], None],
) -> tuple[list[tuple[Screening, Candidate]], dict[float, tuple[Observations, NDArray[np.bool_]]]]:
    """Every candidate not yet adopted, scored against ``base`` (best held-out gain first),
    and the shifted observations of the best delay (with the instants it keeps)."""
    basis = F.TorqueBasis(gear.max_rudder)
    est, obs, rows, parts, keep = base.est, base.obs, base.rows, base.parts, base.keep
    # the trials fit only the adopted columns: their rows carry those z columns alone
    needed = {c.z for c in base.extra if c.z}
    z, z_valid, z_names = _z_subset(obs, gear, needed)
    coef_t = est.fit.coef[:basis.size]
    at = (est.two_z.value, est.z_gb.value)
    nuisance = F.speed_scale_columns(rows.moments) + base.extra
    rss0, n0, cv0, _, _, p0, _ = candidate_score(gear, basis, rows.moments, parts, coef_t, nuisance, grid_2z, at)
    n_eff = n0 / est.inflation
    seal, mu_b, mu_g = _friction_of(est)
    screened: list[tuple[Screening, Candidate]] = []
    # every delay's score; its observations and rows are rebuilt for the best one only (each
    # trial's are tens of MB on a long log, and a dozen are tried)
    score: dict[float, float] = {}
    steady_t = obs.t_ns[obs.moving & keep]
    a_half, b_half = halves(obs)

    def shifted(tau: float) -> tuple[Observations, NDArray[np.bool_], NDArray[np.bool_]]:
        # The shifted angle judges steady motion at other instants. Scored on its own
        # instants against the base model on all of them, a delay would win or lose by
        # which rows it kept, not by how well it fits: both are scored on the instants
        # steady under either reading.
        o = build_observations(signals, gear.ram_area, angle_shift_s=tau)
        o_mask = in_sorted(o.t_ns, steady_t)
        base_mask = in_sorted(obs.t_ns, o.t_ns[o.moving & o_mask]) & keep
        return o, o_mask, base_mask

    def delay_trial(cand: Candidate) -> None:
        o, o_mask, base_mask = shifted(cand.angle_shift_s)
        zo, o_valid, _ = _z_subset(o, gear, needed)
        m = make_rows(o, zo, o_mask & o_valid).moments
        del o, zo
        mb = make_rows(obs, z, base_mask & z_valid).moments
        if min(m.samples, mb.samples) < 200:
            return
        f, fb = (F.fit_at(gear, basis, x, at[0], at[1], F.axial_load(gear, basis, x, coef_t),
                          F.speed_scale_columns(x) + base.extra) for x in (m, mb))
        score[cand.angle_shift_s] = (f.rss / f.n) / (fb.rss / fb.n)

    for cand in candidates(dict.fromkeys(z_names), (seal, mu_b, mu_g)):  # type: ignore[arg-type]
        if cand.name in adopted:
            continue
        if cand.angle_shift_s:
            delay_trial(cand)
            continue
        say(f'candidate {cand.name}')
        rss, n, cv, tz, zg, p, coef = candidate_score(gear, basis, rows.moments, parts, coef_t,
                                                      nuisance + cand.columns, grid_2z, at)
        values = {c.name: float(v) for c, v in zip(cand.columns, coef[coef.size - len(cand.columns):])}
        screened.append((screening_record(cand, rss, n, cv, tz, zg, p, rss0, n0, cv0, p0, n_eff, values,
                                    (seal, rated_force(gear))), cand))
    delay_obs: dict[float, tuple[Observations, NDArray[np.bool_]]] = {}
    if score:
        # The grid's steps are 50 ms: a delay between two of them leaves up to half a step,
        # which weak candidates then take (and lean on the clearances: a 0.125 s delay read
        # as 0.10 or 0.15 s put Z_gb 0.08 mm off). The vertex of the parabola through the
        # best grid point and its neighbours says where the optimum lies; when it is more
        # than DELAY_KEEP_S from the grid point, the vertex (to DELAY_VERTEX_S) and its
        # neighbours are tried. Nearer, the grid point stands: finer steps scored on the
        # quick ratio follow its noise (a clean 0.25 s delay moved by 5-10 ms and left a
        # small viscous column something to take).
        tau1 = min(score, key=score.__getitem__)      # the first tried of the best, as scanned
        lo, hi = round(tau1 - DELAY_STEP_S, 3), round(tau1 + DELAY_STEP_S, 3)
        if lo in score and hi in score:
            curv = score[lo] - 2 * score[tau1] + score[hi]
            if curv > 0:
                step = 0.5 * DELAY_STEP_S * (score[lo] - score[hi]) / curv
                step = max(-0.5 * DELAY_STEP_S, min(0.5 * DELAY_STEP_S, step))
                if abs(step) > DELAY_KEEP_S:
                    centre = round((tau1 + step) / DELAY_VERTEX_S) * DELAY_VERTEX_S
                    for k in (-1, 0, 1):
                        tau = round(centre + k * DELAY_VERTEX_S, 3)
                        if tau > 0 and tau not in score:
                            delay_trial(Candidate('angle_delay', fixed={'tau_s': tau}, angle_shift_s=tau))
        say('candidate angle_delay')
        tau = min(score, key=score.__getitem__)
        cand = Candidate('angle_delay', fixed={'tau_s': tau}, angle_shift_s=tau)
        o, o_mask, base_mask = shifted(tau)
        o_a, o_b = halves(o)
        zc, o_valid, _ = _z_subset(o, gear, needed)
        o_keep = o_mask & o_valid
        m = make_rows(o, zc, o_keep).moments
        two = (make_rows(o, zc, o_a & o_keep).moments, make_rows(o, zc, o_b & o_keep).moments)
        del zc
        rss, n, cv, tz, zg, p, _ = candidate_score(gear, basis, m, two, coef_t,
                                                   F.speed_scale_columns(m) + base.extra, grid_2z, at)
        b_keep = base_mask & z_valid
        mb = make_rows(obs, z, b_keep).moments
        two = (make_rows(obs, z, a_half & b_keep).moments, make_rows(obs, z, b_half & b_keep).moments)
        rss_b, n_b, cv_b, _, _, p_b, _ = candidate_score(gear, basis, mb, two, coef_t,
                                                         F.speed_scale_columns(mb) + base.extra, grid_2z, at)
        screened.append((screening_record(cand, rss, n, cv, tz, zg, p + 1, rss_b, n_b, cv_b, p_b, n_b / est.inflation),
                         cand))
        delay_obs[cand.angle_shift_s] = (o, o_mask)
    screened = best_per_name(screened)
    screened.sort(key=lambda sc: -sc[0].cv_gain)
    return screened, delay_obs


def _declared(gear: GearParams, obs: Observations, grid_2z: NDArray, say: Callable[[str], None]) -> tuple[_Base, int]:
    """The declared model fitted to ``obs`` without its outlying instants -> (it, how many)."""
    say('declared model')
    first = estimate_clearances(gear, obs, make_rows(obs, z_columns(obs, gear)), grid_2z=grid_2z)
    outliers = outlier_instants(first.residual, obs.direction)
    n_out = int(outliers.sum())
    if outliers.any():
        say(f'declared model without {n_out} outlying instants')
    return _base(gear, obs, ~outliers, (), grid_2z, est=None if outliers.any() else first), n_out


def declared_fit(gear: GearParams, signals: Mapping[str, Series], *, min_clearance_2z: float = 0.0
                 ) -> tuple[Observations, ClearanceEstimate]:
    """The first step of :func:`analyze` alone: the observations and the declared model's
    fit (no screening). Pure."""
    obs = build_observations(signals, gear.ram_area)
    return obs, _declared(gear, obs, grid_2z_from(min_clearance_2z), lambda _msg: None)[0].est


def analyze(gear: GearParams, signals: Mapping[str, Series], *, min_clearance_2z: float = 0.0,
            ram_share_warn: float = 0.15, progress: Callable[[str], None] | None = None,
            window_motion_s: float = 0.0, model: Sequence[Effect] | None = None) -> Analysis:
    """Fit, screen, adopt effect after effect, locate what is left, refit (see the module
    docstring). ``ram_share_warn``: a stretch where a ram's share of the force departs from an
    even half by more than this is left out. ``window_motion_s`` (> 0): only the window of the
    last that many seconds of steady motion (:func:`~steer_monitor.estimate.window.select`),
    as the node keeps it. ``model``: no screening, the clearances estimated with these effects
    applied as they are (a delay reads the angle later, the others add their columns; their
    coefficients refitted), the verdict and the location of a misfit as in a loop: what the
    node does between two runs of the loop. Pure."""
    say = progress or (lambda _msg: None)
    grid_2z = grid_2z_from(min_clearance_2z)
    win = None
    if window_motion_s > 0:
        win = W.select(signals, gear.ram_area, window_motion_s)
        signals = win.signals
    obs = build_observations(signals, gear.ram_area)
    rows = int(np.isfinite(obs.force[obs.moving]).sum())
    if rows < MIN_MOTION_SAMPLES:            # the cause said: the motion missing, or the rates that hide it
        raise EstimateError(too_little_motion(signals, obs, rows, MIN_MOTION_SAMPLES))
    whole = ram_share(obs.force[obs.moving])
    if whole is not None and judge(whole, ram_share_warn, gear.ram_area) == OPPOSED:   # a ram reversed: nothing holds
        ram = working_against(obs.force[obs.moving], obs.rate[obs.moving])
        raise EstimateError(opposed_cause(whole, ram, PRESSURE_INPUTS) + '; nothing estimated')
    check = RamsCheck(ram_share_warn, gear.ram_area)        # the one rams check, as the node's
    check.feed(obs.t_ns[obs.moving], obs.force[obs.moving])
    uneven = tuple(check.finish())
    note = uneven_note(uneven)
    try:
        if uneven:
            say(f'{len(uneven)} stretch(es) where the rams did not share the force evenly: left out')
            signals = _without_pressures(signals, uneven)
            obs = build_observations(signals, gear.ram_area)
        rams = ram_share(obs.force[obs.moving])
        if model is not None:
            return replace(_given(gear, signals, obs, tuple(model), grid_2z, say, note, uneven, rams, win),
                           rams_assessed=check.assessed)
        base, n_out = _declared(gear, obs, grid_2z, say)
    except EstimateError as exc:      # what was left out is why: the ram and its times said
        if not uneven:
            raise
        raise EstimateError(f'{exc}{note}') from exc
    declared = base.est
    steps: list[Step] = []
    rounds: list[list[Screening]] = []
    unkept: list[str] = []          # candidates that passed screening and cut nothing systematic
    adopted: set[str] = set()
    while True:
        screened, delay_obs = _screen(gear, signals, base, grid_2z, adopted, say)
        rounds.append([s for s, _ in screened])
        new = None
        for sc, cand in [x for x in screened if x[0].passes][:MAX_TRIED]:
            say(f'refit with {cand.name}')
            if cand.angle_shift_s:
                o, o_mask = delay_obs[cand.angle_shift_s]
                trial = _base(gear, o, o_mask, base.extra, grid_2z)
            else:
                trial = _refit(gear, base, cand.columns, grid_2z)
                if cand.shape is not None:
                    cand, trial = _shaped(gear, base, cand, trial, grid_2z, say)
            if _systematic(base, trial):
                new = (sc, cand, trial)
                break
            # a better score from a column that explains nothing systematic is no effect
            unkept.append(f'{sc.name} passed screening but takes nothing systematic from the residual '
                          f'(systematic part {trial.est.smooth_rms / (1e5 * gear.ram_area):.2f} bar with it)')
        if new is None:
            break
        sc, cand, trial = new
        steps.append(Step(cand.name, {}, sc, base.est, trial.est, cand))
        adopted.add(cand.name)
        base = trial
    steps = [replace(s, params=_effect_params(s.candidate, base.est, base.obs)) for s in steps]
    closest = next((s for s in rounds[-1]), None)
    return replace(_conclude(gear, signals, obs, base, declared, steps, rounds[0], closest, unkept, n_out, note,
                             uneven, rams, grid_2z, say, False, win), rams_assessed=check.assessed)


def _refit(gear: GearParams, base: _Base, columns: tuple[F.Column, ...], grid_2z: NDArray) -> _Base:
    """``base`` with ``columns`` fitted beside its own, on its rows (a candidate's trial)."""
    extra = base.extra + columns
    return replace(base, extra=extra, est=estimate_clearances(gear, base.obs, base.rows, extra, grid_2z=grid_2z))


def _friction_of(est: ClearanceEstimate) -> tuple[float, float, float]:
    """The friction law a fit found: (F_s [N], mu_b, mu_g)."""
    return tuple(est.fit.get(k) for k in ('seal_friction_n', 'mu_bushing', 'mu_guide'))  # type: ignore[return-value]


def _shaped(gear: GearParams, base: _Base, cand: Candidate, trial: _Base, grid_2z: NDArray,
            say: Callable[[str], None]) -> tuple[Candidate, _Base]:
    """temp_friction with the friction law it scales taken from its own fit. Its column is the
    law of the fit without it (the declared one, at screening), and friction that changes with
    the oil's temperature distorts that fit: an effect twice the simulator's default put the
    guide's friction at its limit (0.3) there, and the column scaling that law bought Z_gb >=
    0.42 mm for a true 0.086 mm. The law is taken again from the fit with the column until it
    moves less than ``SHAPE_RTOL`` of itself (at most ``SHAPE_ROUNDS`` refits; it settles in two
    or three)."""
    for _ in range(SHAPE_ROUNDS):
        shape, law = _friction_of(trial.est), cand.shape
        assert law is not None
        if all(abs(a - b) <= SHAPE_RTOL * max(abs(a), abs(b)) for a, b in zip(shape, law)):
            break
        say(f'refit with {cand.name}, the friction law it scales taken from its fit')
        cand = candidate_of(Effect(cand.name, shape=shape))
        trial = _refit(gear, base, cand.columns, grid_2z)
    return cand, trial


def _given(gear: GearParams, signals: Mapping[str, Series], obs: Observations, model: tuple[Effect, ...],
           grid_2z: NDArray, say: Callable[[str], None], note: str, uneven: tuple[UnevenSpan, ...],
           rams: RamShare | None, win: W.Window | None) -> Analysis:
    """:func:`analyze` under a given model: its delay applied to the angle, its other effects'
    columns fitted with the declared model, the outlying instants of that fit set aside."""
    say('the model given: ' + (', '.join(e.name for e in model) or 'declared'))
    cands = [candidate_of(e) for e in model]
    delay = sum(c.angle_shift_s for c in cands)
    m_obs = build_observations(signals, gear.ram_area, angle_shift_s=delay) if delay else obs
    extra: tuple[F.Column, ...] = tuple(col for c in cands for col in c.columns)
    first = estimate_clearances(gear, m_obs, make_rows(m_obs, z_columns(m_obs, gear)), extra, grid_2z=grid_2z)
    outliers = outlier_instants(first.residual, m_obs.direction)
    n_out = int(outliers.sum())
    base = _base(gear, m_obs, ~outliers, extra, grid_2z, est=None if outliers.any() else first)
    steps = [Step(c.name, _effect_params(c, base.est, base.obs), None, base.est, base.est, c) for c in cands]
    return _conclude(gear, signals, obs, base, base.est, steps, [], None, [], n_out, note, uneven, rams, grid_2z, say,
                     True, win)


def _conclude(gear: GearParams, signals: Mapping[str, Series], obs: Observations, base: _Base,
              declared: ClearanceEstimate, steps: list[Step], screening: list[Screening], closest: Screening | None,
              unkept: list[str], n_out: int, note: str, uneven: tuple[UnevenSpan, ...], rams: RamShare | None,
              grid_2z: NDArray, say: Callable[[str], None], given: bool, win: W.Window | None) -> Analysis:
    """The verdict on ``base`` (the model the loop chose, or the one given), and when it does not
    explain the data, where the misfit lives and the clearances refitted with it as a nuisance.
    From a slow log, the friction's intervals span the lags its stamps allow
    (:mod:`~steer_monitor.estimate.stamplags`)."""
    final_obs = base.obs
    shift_s = sum(s.candidate.angle_shift_s for s in steps)
    explained = base.est.smooth_rms <= EXPLAINED_RATIO * base.est.noise_rms
    names = [s.name for s in steps]
    if explained:
        verdict = 'effect' if steps else 'declared'
        msg = message(verdict, declared, base.est, None, steps, given)
        if not steps and unkept:
            msg += f' ({"; ".join(unkept)})'
        est, said = _specification_check(gear, base, grid_2z, say)
        est = over_stamp_lags(gear, signals, est, base.obs, base.keep, base.extra, shift_s, grid_2z, say=say)
        return Analysis(declared, est, names[0] if names else None, steps[0].params if steps else {}, verdict,
                        msg + said + note, screening, None, obs, final_obs, n_out, tuple(steps), None, base.est,
                        uneven, rams, given=given, window=win)
    say('locating the unexplained residual')
    located = locate(base.obs, base.est.residual, base.est.inflation)
    final = base.est
    nuisance = False
    spread = ''
    if located is not None:
        say('refit with the located term as a nuisance, where it sits and beside it')
        placed = placements(gear, base.obs, base.keep, base.extra, located, grid_2z, unexplained_inflation(base.est))
        if placed:                      # else too little motion left outside the term: keep the model's
            final, nuisance = spanned(placed), True
            alike = [p.where for p in placed if p.fits]
            unit = UNITS[located.variable]
            own = next(p.where for p in placed if p.shift == 0.0)
            if (own.lo, own.hi) != (located.lo, located.hi):
                spread = (f'; fitted beside the clearances, the term reaches {own.lo:.3g} to {own.hi:.3g} {unit} '
                          '(the fit with the clearances free pays for each piece added)')
            if moved_off(placed):
                best = placed[0].where
                spread += (f'; fitted beside the clearances, the term fits best at {best.lo:.3g} to {best.hi:.3g} '
                           f'{unit}, not where the residual put it: where it sits is not known, and the intervals '
                           f'span the clearances of every place tried '
                           f'({", ".join(f"{p.where.lo:.3g} to {p.where.hi:.3g}" for p in placed)} {unit})')
            elif len(alike) > 1:
                spread += (f'; it fits as well at {", ".join(f"{w.lo:.3g} to {w.hi:.3g}" for w in alike[1:])} {unit}, '
                           f'and the intervals span the clearances of each place')
    if not nuisance:                    # the model's own fit, its intervals counting the misfit as noise
        final = estimate_clearances(gear, base.obs, base.rows, base.extra, grid_2z=grid_2z,
                                    model_inflation=unexplained_inflation(base.est))
    final = over_stamp_lags(gear, signals, final, base.obs, base.keep, base.extra, shift_s, grid_2z,
                            unexplained_inflation(base.est), say)

    msg = message('unexplained', declared, base.est, closest, steps, given)
    msg += f'; {located.message(gear.ram_area)}' if located is not None else '; no observed variable carries it'
    if nuisance:                        # the term as the clearances were fitted with it
        located = placed[0].where
    msg += ('; the clearances are fitted with that term as a nuisance and rest on an incomplete model' + spread
            if nuisance else '; the clearances rest on an incomplete model')
    return Analysis(declared, final, names[0] if names else None, steps[0].params if steps else {}, 'unexplained',
                    msg + note, screening, closest, obs, final_obs, n_out, tuple(steps), located, base.est, uneven,
                    rams, given=given, window=win)


def _specification_check(gear: GearParams, base: _Base, grid_2z: NDArray, say: Callable[[str], None]
                         ) -> tuple[ClearanceEstimate, str]:
    """The locator on an explained verdict too: a misfit the model lacks, smaller than half the
    sensor noise, can still sit where a clearance shows and move it (friction between 12 and 18
    deg of rudder read as the guide beam's: Z_gb 0.000 [0.000, 0.000] mm for 0.096). Where the
    locator finds a term (:func:`~steer_monitor.estimate.locate.locate`), the clearances are fitted
    again with it taken out as a nuisance; a clearance whose two answers do not overlap rests on
    that misfit and is given as a lower bound (the lower of the two lows), saying why; a lower
    bound the fit without the misfit puts lower is lowered to it (a band of friction masking the
    guide beam's contact put Z_gb >= 0.175 mm for 0.151). -> (the estimate, '' or what the
    message adds)."""
    est = base.est
    located = locate(base.obs, est.residual, est.inflation)
    if located is None:
        return est, ''
    zl, cols = located.columns(base.obs)
    if not cols:
        return est, ''
    say('checking the clearances against the misfit the locator finds')
    rows = make_rows(base.obs, {**z_columns(base.obs, gear), **zl}, base.keep & ~located.near_ends(base.obs))
    try:
        alt = estimate_clearances(gear, base.obs, rows, base.extra + cols, grid_2z=grid_2z)
    except EstimateError:
        return est, ''
    ivs, why, said = [est.two_z, est.z_gb], list(est.bound_why), []
    where = located.message(gear.ram_area)
    for k, (name, a, b) in enumerate((('2Z', est.two_z, alt.two_z), ('Z_gb', est.z_gb, alt.z_gb))):
        if a.lo is None or b.lo is None:
            continue
        apart = (b.hi is not None and b.hi < a.lo) or (a.hi is not None and b.lo > a.hi)
        if a.hi is None and b.lo < a.lo:     # a bound the misfit holds up
            apart = True
        if not apart:
            continue
        ivs[k] = Interval(a.value, min(a.lo, b.lo), None)
        alt_text = f'{1e3 * b.value:.3f}' if b.hi is not None else f'>= {1e3 * b.lo:.3f}'
        why[k] = (f'a misfit the model lacks moves it: {1e3 * a.value:.3f} mm with it, {alt_text} mm with it '
                  f'taken out ({where})')
        said.append(f'{name} {why[k]}')
    if not said:
        return est, ''
    return replace(est, two_z=ivs[0], z_gb=ivs[1], bound_why=(why[0], why[1])), '; ' + '; '.join(said)


def _without_pressures(signals: Mapping[str, Series], spans: Sequence[UnevenSpan]) -> dict[str, Series]:
    """``signals`` with the pressures' samples within ``spans`` taken out (a gap there)."""
    out = dict(signals)
    for name in PRESSURE_INPUTS:
        ser = signals.get(name)
        if ser is not None:
            keep = ~within(ser.t_ns, spans)
            out[name] = Series(ser.t_ns[keep], ser.value[keep])
    return out


def _systematic(before: _Base, after: _Base) -> bool:
    """True when the positive part of the residual's autocovariance at one grid step
    (``SYSTEMATIC_LAG_STEPS``, 50 ms) falls from ``before`` to ``after`` by at least
    ``MIN_SYSTEMATIC_SHARE`` of the fall of its mean square
    (:func:`~steer_monitor.estimate.screening.takes_systematic`). A systematic term is as
    large at the next instant; what a column takes from noise (or a shifted angle from the
    instants it keeps) is not. One step, not the 200 ms of the smooth part: a Stribeck rise or
    an inertia force lasts a fraction of a second, and at 200 ms only a third of it shows."""
    return takes_systematic((before.est.residual, before.obs.t_ns, before.obs.step_ns),
                            (after.est.residual, after.obs.t_ns, after.obs.step_ns),
                            SYSTEMATIC_LAG_STEPS, MIN_SYSTEMATIC_SHARE)


def _effect_params(cand: Candidate, final: ClearanceEstimate, obs: Observations) -> dict[str, Interval | str]:
    """The candidate's parameters from the final model's coefficients (with intervals)."""
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
    for col in cand.columns:
        out[col.name] = final.extra[col.name]
    return out


