"""The accuracy study of the clearance estimator: simulate, analyze, compare with the truth.

Each case is one simulated log (a helm programme, true clearances 2Z and Z_gb, a seed) run
through the same path as ``steer-monitor analyze`` (decode -> observations -> residual loop);
its estimates and 95 % intervals are compared with what was simulated. Over a grid of cases
the study gives the error of each estimate and the *coverage* of its intervals: the share of
cases whose interval holds the truth, which for honest 95 % intervals is near 0.95.

2Z is only identifiable where the ram clamps at the loads the log holds (its slope reaches
2Z / l_s in the bushing); elsewhere the honest answer is a lower bound. Each case therefore
records how much of the rudder's motion the true ram spent clamped, and the summary
separates "clamped" cases (error of 2Z) from "never clamped" ones (is the lower bound below
the truth).

The *sensitivity* part runs the realistic voyage with one undeclared effect of the analysis
library at a fraction of the simulator's default magnitude (:data:`FRACTIONS`), with two
effects at once, and with an effect outside the library, and records what the residual loop
named (:func:`sensitivity_cases`, :func:`summarize_sensitivity`). Its *hour-long* part
(:func:`long_voyage_cases`) runs each library effect at a fifth of its default, and clean
logs, on the realistic voyage of about an hour (:data:`LONG_PROGRAMMES`): how long a log an
effect at the edge of detection needs, and whether a longer log makes the loop adopt effects
that are not there.

Pure: simulator and estimator only, no ROS, no bus.
"""

from __future__ import annotations

import math
import time
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from steer_monitor import sim
from steer_monitor.can.codec import CanDatabase
from steer_monitor.can.decoder import Decoder
from steer_monitor.can.signals import PRESSURE_INPUTS, SignalMap
from steer_monitor.estimate.analyze import analyze, declared_fit
from steer_monitor.estimate.batch import ClearanceEstimate, k_gl_max
from steer_monitor.estimate.intervals import Interval
from steer_monitor.estimate.locate import UNITS
from steer_monitor.estimate.observe import Observations
from steer_monitor.model.gear import Clearances
from steer_monitor.model.loadshare import STAGE_CLAMPED, load_sharing
from steer_monitor.model.ramforce import ram_forces
from steer_monitor.params import gear_from_params, min_clearance_2z_from_params

__all__ = [
    'FRACTIONS',
    'GRID_2Z_MM',
    'GRID_ZGB_MM',
    'LONG_PROGRAMMES',
    'MAGNITUDE',
    'PAIRS',
    'PROGRAMMES',
    'SIZE',
    'Case',
    'CaseResult',
    'cases',
    'coverage_interval',
    'long_voyage_cases',
    'model_misfit',
    'off_grid_cases',
    'programme_text',
    'run_case',
    'scaled_effect',
    'sensitivity_cases',
    'summarize',
    'summarize_sensitivity',
    'true_forces',
]

GRID_2Z_MM = (0.1, 0.2, 0.3, 0.4, 0.5, 0.6)
GRID_ZGB_MM = (0.05, 0.1, 0.15, 0.2, 0.25, 0.3, 0.35)
# name -> helm programme text; each about 20-25 minutes of data
PROGRAMMES = {
    'voyage': 'voyage',
    'manoeuvres': 'hard_over_2,zigzag_20,zigzag_10,hard_over_1,zigzag_20,hold:60,zigzag_10',
    'autopilot': 'autopilot:1500',
    'realistic': 'realistic:1500',
}
# the sensitivity study's hour-long voyages (not in the clearance grid's default programmes)
LONG_PROGRAMMES = {'realistic_1h': 'realistic:3000'}
LONG_FRACTION = 0.2
LONG_CLEAN_PER_SEED = 4     # clean hour-long logs per seed of the effects
# the parameter that sets each library effect's size, scaled by the sensitivity fractions
MAGNITUDE = {'viscous': 'c_ns_per_m', 'angle_delay': 'tau_s', 'pressure_offset': 'offset_bar',
             'temp_friction': 'k_per_k', 'pressure_friction': 'k', 'stribeck': 'f_st_n', 'ram_inertia': 'mass_kg'}
# ... and of the effects outside the library and the sensor faults (set to 0 in a case's clean twin)
SIZE = {**MAGNITUDE, 'band_friction': 'f_n', 'angle_zero': 'offset_deg', 'angle_span': 'span_pct',
        'pressure_span': 'span_pct', 'pressure_delay': 'tau_s'}
FRACTIONS = (0.2, 0.5, 1.0)
PAIRS = (('viscous', 'pressure_offset'), ('angle_delay', 'temp_friction'),
         ('pressure_friction:k=0.006', 'viscous:c_ns_per_m=2e5'))
SENSITIVITY_CLEARANCES_MM = ((0.4, 0.2), (0.3, 0.3), (0.6, 0.1))
QUANTITIES = ('clearance_2z_mm', 'clearance_zgb_mm', 'k_gl_max', 'seal_friction_n', 'mu_bushing', 'mu_guide')
#: decimals each quantity's errors are given to (docs/json.md: clearances to 0.1 um, K_gl to
#: 1e-4; the seal friction to 0.1 N, the friction coefficients to 1e-4); shares to 1e-4
DECIMALS = {'clearance_2z_mm': 4, 'clearance_zgb_mm': 4, 'k_gl_max': 4, 'seal_friction_n': 1, 'mu_bushing': 4,
            'mu_guide': 4}
SHARE_DECIMALS = 4


@dataclass(frozen=True)
class Case:
    """One simulated log: programme name (a key of :data:`PROGRAMMES` or
    :data:`LONG_PROGRAMMES`), true gaps [mm], seed."""

    programme: str
    two_z_mm: float
    z_gb_mm: float
    seed: int
    effects: tuple[str, ...] = ()      # undeclared effects, as ``--effect`` takes them


@dataclass(frozen=True)
class CaseResult:
    """The outcome of one case, engineers' units.

    ``truth`` and ``estimate`` map each of :data:`QUANTITIES` to a value; ``ci95`` maps them
    to ``(lo, hi)`` (None where unbounded). ``clamped_share`` is the share of moving time the
    true ram spent clamped; ``verdict`` the analysis verdict (on clean data 'declared' is
    right); ``effect`` the first effect adopted, if any, ``adopted`` all of them in order;
    ``systematic_bar`` / ``systematic_after_bar`` the smooth residual of the declared and
    of the final model; ``located`` the variable an unexplained residual was located on;
    ``misfit_bar`` / ``misfit_after_bar`` the declared and the final model's error against the
    truth (:func:`model_misfit`), which only a simulation can give, and ``misfit_clean_bar``
    the declared model's on the same seed's log with every undeclared effect at size 0 (its
    *clean twin*: the same helm, noise and, for a ram's mass, the same lagging rate; NaN for a
    clean case): the declared model's own approximation error, which no effect takes away.
    """

    case: Case
    duration_s: float
    rows: int
    truth: dict[str, float]
    estimate: dict[str, float]
    ci95: dict[str, tuple[float | None, float | None]]
    clamped_share: float
    max_angle_deg: float
    inflation: float
    systematic_bar: float
    verdict: str
    effect: str | None
    seconds: float
    adopted: tuple[str, ...] = ()
    systematic_after_bar: float = math.nan
    located: str | None = None
    located_range: tuple[float, float] | None = None
    misfit_bar: float = math.nan
    misfit_after_bar: float = math.nan
    misfit_clean_bar: float = math.nan

    @property
    def effect_misfit(self) -> tuple[float, float]:
        """The undeclared effects' part of the model error [bar], before and after the
        effects adopted: the misfit in excess of the clean twin's (in quadrature; errors of
        independent origins add so), 0 where it is below."""
        base = self.misfit_clean_bar ** 2
        return (math.sqrt(max(self.misfit_bar**2 - base, 0.0)), math.sqrt(max(self.misfit_after_bar**2 - base, 0.0)))

    def covered(self, quantity: str) -> bool:
        lo, hi = self.ci95[quantity]
        return Interval(self.estimate[quantity], lo, hi).contains(self.truth[quantity])

    def two_sided(self, quantity: str) -> bool:
        lo, hi = self.ci95[quantity]
        return lo is not None and hi is not None

    def to_json(self) -> dict[str, Any]:
        """The case in the JSON vocabulary (docs/json.md): what was simulated, each quantity's
        estimate as ``{value, ci95: [lo, hi], bounded}`` (no point value for a bound), its
        truth and whether the interval holds it, and the residual loop's outcome."""
        c = self.case

        def r(q: str, v: float | None) -> float | None:
            return None if v is None else round(v, DECIMALS[q])

        def estimate(q: str) -> dict[str, Any]:
            lo, hi = self.ci95[q]
            bounded = lo is not None and hi is not None
            return {'value': r(q, self.estimate[q]) if bounded else None, 'ci95': [r(q, lo), r(q, hi)],
                    'bounded': bounded}

        def bar(v: float) -> float | None:
            return round(v, 4) if math.isfinite(v) else None

        return {
            'programme': c.programme, 'seed': c.seed, 'effects': list(c.effects),
            'true_clearance_2z_mm': c.two_z_mm, 'true_clearance_zgb_mm': c.z_gb_mm,
            'duration_s': round(self.duration_s, 2), 'rows': self.rows,
            'clamped_share': round(self.clamped_share, 4), 'max_angle_deg': round(self.max_angle_deg, 2),
            'inflation': round(self.inflation, 3),
            'estimates': {q: estimate(q) for q in QUANTITIES},
            'truth': {q: r(q, self.truth[q]) for q in QUANTITIES},
            'covered': {q: self.covered(q) for q in QUANTITIES},
            'verdict': self.verdict, 'effect': self.effect, 'adopted': list(self.adopted),
            'unexplained': None if self.located is None else {
                'variable': self.located, 'unit': UNITS[self.located],
                'range': None if self.located_range is None else [round(v, 2) for v in self.located_range]},
            'systematic_bar': bar(self.systematic_bar), 'systematic_after_bar': bar(self.systematic_after_bar),
            'misfit_bar': bar(self.misfit_bar), 'misfit_after_bar': bar(self.misfit_after_bar),
            'misfit_clean_bar': bar(self.misfit_clean_bar), 'analysis_s': round(self.seconds, 2),
        }


def cases(programmes: Iterable[str], grid_2z_mm: Sequence[float] = GRID_2Z_MM,
          grid_zgb_mm: Sequence[float] = GRID_ZGB_MM, seeds: int = 1, first_seed: int = 1) -> list[Case]:
    """Every combination, each with its own seed (independent noise and helm sequence)."""
    out: list[Case] = []
    seed = first_seed
    for p in programmes:
        programme_text(p)
        for _ in range(seeds):
            for tz in grid_2z_mm:
                for zg in grid_zgb_mm:
                    out.append(Case(p, float(tz), float(zg), seed))
                    seed += 1
    return out


def off_grid_cases(programmes: Iterable[str], n: int, first_seed: int = 9001,
                   range_2z_mm: tuple[float, float] = (0.1, 0.6),
                   range_zgb_mm: tuple[float, float] = (0.05, 0.35), effects: Sequence[str] = ()) -> list[Case]:
    """``n`` logs per programme whose true clearances are drawn uniformly over the study's
    ranges (to 0.1 um), so they fall between the estimator's grid points as real clearances
    do: the grid study's all lie on them (0.02 mm steps of 2Z, 0.005 mm of Z_gb). The draws
    come from ``first_seed``, 2Z then Z_gb for each log in turn, the log's seed counting on
    from it; each programme draws the same clearances. ``effects`` (``--effect`` texts): log
    k carries the k-th of them, in turn (none: the clean plant)."""
    out: list[Case] = []
    for p in programmes:
        programme_text(p)
        rng = np.random.default_rng(first_seed)
        for k in range(n):
            tz = round(float(rng.uniform(*range_2z_mm)), 4)
            zg = round(float(rng.uniform(*range_zgb_mm)), 4)
            out.append(Case(p, tz, zg, first_seed + k, (effects[k % len(effects)],) if effects else ()))
    return out


def programme_text(name: str) -> str:
    """The helm programme text of a study programme's name."""
    try:
        return {**PROGRAMMES, **LONG_PROGRAMMES}[name]
    except KeyError:
        msg = f'unknown study programme {name!r} (choose from: {", ".join([*PROGRAMMES, *LONG_PROGRAMMES])})'
        raise ValueError(msg) from None


def _scaled(iv: Interval, k: float) -> tuple[float, tuple[float | None, float | None]]:
    return iv.value * k, (None if iv.lo is None else iv.lo * k, None if iv.hi is None else iv.hi * k)


def run_case(params: Mapping[str, Any], db: CanDatabase, smap: SignalMap, case: Case) -> CaseResult:
    """Simulate ``case`` on the gear of ``params`` (with the case's undeclared effects, if
    any), run the analysis on the decoded frames and compare."""
    t0 = time.perf_counter()
    gear = gear_from_params(params)
    cfg = sim.SimConfig(program=programme_text(case.programme), gaps=Clearances.from_mm(case.two_z_mm, case.z_gb_mm),
                        max_duration_s=7200.0, effects=tuple(sim.parse_effect(e) for e in case.effects))
    s = sim.run(params, cfg, db, smap, case.seed)
    signals = Decoder(db, smap).decode_arrays(s.frames, final=True)
    min_2z = min_clearance_2z_from_params(params)
    a = analyze(gear, signals, min_clearance_2z=min_2z)
    f = a.final

    p = s.plant
    moving = p.rate != 0
    ls = load_sharing(gear, p.alpha[moving], p.torque[moving], cfg.gaps.two_z, cfg.gaps.z_gb)
    clamped = float(np.mean((ls.stages & STAGE_CLAMPED) != 0)) if moving.any() else 0.0
    angles = f.torque_curve[0]
    truth = {
        'clearance_2z_mm': case.two_z_mm, 'clearance_zgb_mm': case.z_gb_mm,
        # the estimand: K_gl max of the true gear and torque over the angles the estimate
        # evaluates (0.5 deg steps up to the largest angle of the steady-motion rows)
        # at the service speed, where the estimate's torque curve stands
        'k_gl_max': float(k_gl_max(gear, angles, gear.torque(angles),
                                   cfg.gaps.two_z, cfg.gaps.z_gb)[0]),
        'seal_friction_n': cfg.seal_friction, 'mu_bushing': cfg.mu_bushing, 'mu_guide': cfg.mu_guide,
    }
    temp = cfg.effect('temp_friction')
    if temp is not None:
        # the friction the estimate stands for is the plant's at the oil temperature its temperature
        # term is relative to (the log's mean, as analyze takes it), not at the simulator's t_ref_c
        t_mean_c = float(np.nanmean(a.final_observations.oil_temp)) - 273.15
        scale = 1.0 + float(temp['k_per_k']) * (t_mean_c - float(temp['t_ref_c']))
        for q in ('seal_friction_n', 'mu_bushing', 'mu_guide'):
            truth[q] *= scale
    est: dict[str, float] = {}
    ci: dict[str, tuple[float | None, float | None]] = {}
    for q, iv, k in (
        ('clearance_2z_mm', f.two_z, 1e3),
        ('clearance_zgb_mm', f.z_gb, 1e3),
        ('k_gl_max', f.k_gl_max, 1.0),
        ('seal_friction_n', f.seal_friction, 1.0),
        ('mu_bushing', f.mu_bushing, 1.0),
        ('mu_guide', f.mu_guide, 1.0),
    ):
        est[q], ci[q] = _scaled(iv, k)
    bar = gear.ram_area * 1e5
    model = a.model or f
    loc = a.located

    def misfit(plant: sim.SimResult, c: sim.SimConfig, est: ClearanceEstimate, obs: Observations) -> float:
        return model_misfit(est, obs, true_forces(plant, c, obs.t_ns, gear.ram_area)) / bar

    clean_misfit = math.nan
    if case.effects:      # the clean twin: the same seed (helm, noise), each effect at size 0
        twin_cfg = replace(cfg, effects=tuple(sim.Effect(e.name, {**e.params, SIZE[e.name]: 0.0})
                                              for e in cfg.effects))
        twin = sim.run(params, twin_cfg, db, smap, case.seed)
        t_obs, t_est = declared_fit(gear, Decoder(db, smap).decode_arrays(twin.frames, final=True),
                                    min_clearance_2z=min_2z)
        clean_misfit = misfit(twin.plant, twin_cfg, t_est, t_obs)

    return CaseResult(case=case, duration_s=p.duration, rows=f.rows, truth=truth, estimate=est, ci95=ci,
                      clamped_share=clamped, max_angle_deg=math.degrees(f.max_angle_seen), inflation=f.inflation,
                      systematic_bar=a.declared.smooth_rms / bar, verdict=a.verdict, effect=a.effect,
                      seconds=time.perf_counter() - t0, adopted=tuple(st.name for st in a.steps),
                      systematic_after_bar=model.smooth_rms / bar, located=None if loc is None else loc.variable,
                      located_range=None if loc is None else (loc.lo, loc.hi),
                      misfit_bar=misfit(p, cfg, a.declared, a.observations),
                      misfit_after_bar=misfit(p, cfg, model, a.final_observations), misfit_clean_bar=clean_misfit)


def true_forces(plant: sim.SimResult, cfg: sim.SimConfig, t_ns: NDArray[np.int64], ram_area: float
                ) -> NDArray[np.float64]:
    """The ram forces [N], shape (n, 2), that the pressure transducers would read at ``t_ns``
    without noise, quantisation or sampling: the plant's pressures at those instants (a
    transducer's offset included, it is part of what the sensor reads)."""
    ts = (t_ns - plant.start_ns) / 1e9
    offset = cfg.effect('pressure_offset')
    p = []
    for name in PRESSURE_INPUTS:
        value = np.interp(ts, plant.t, plant.pressures[name])
        if offset is not None and offset['input'] == name:
            value = value + float(offset['offset_bar']) * 1e5
        p.append(value)
    return ram_forces(ram_area, np.stack(p, axis=1))


def model_misfit(est: ClearanceEstimate, obs: Observations, truth: NDArray[np.float64]) -> float:
    """RMS [N] over the instants and rams ``est`` fitted of its prediction of the ram force
    (observed less residual) against the true force ``truth`` (shape (n, 2), at
    ``obs.t_ns``): the part of the residual that is the model's error, not the sensors'
    noise or the 20 Hz sampling of a pressure that steps. On a clean log it is the
    estimation error alone; with an undeclared effect the model lacks, it holds the effect."""
    err = truth - (obs.force - est.residual)
    use = np.isfinite(err)
    return float(np.sqrt(np.mean(err[use] ** 2))) if use.any() else math.nan


def scaled_effect(name: str, fraction: float) -> str:
    """``name`` at ``fraction`` of the simulator's default magnitude, as ``--effect`` text."""
    key = MAGNITUDE[name]
    return f'{name}:{key}={float(sim.EFFECTS[name][key]) * fraction:.6g}'


def sensitivity_cases(seeds: int = 2, first_seed: int = 5001) -> list[Case]:
    """The realistic voyage with each library effect at each of :data:`FRACTIONS`, with each
    pair of :data:`PAIRS`, and with each effect outside the library, ``seeds`` logs each
    (clearances cycling through ``SENSITIVITY_CLEARANCES_MM``)."""
    specs: list[tuple[str, ...]] = [(scaled_effect(n, f),) for n in MAGNITUDE for f in FRACTIONS]
    specs += [tuple(p) for p in PAIRS]
    specs += [(n,) for n in sim.OUTSIDE_LIBRARY]
    out = []
    seed = first_seed
    for spec in specs:
        for _ in range(seeds):
            out.append(_sensitivity_case('realistic', seed, spec))
            seed += 1
    return out


def _sensitivity_case(programme: str, seed: int, effects: tuple[str, ...] = ()) -> Case:
    """A case of the sensitivity study: its clearances cycle through ``SENSITIVITY_CLEARANCES_MM``
    with the seed."""
    tz, zg = SENSITIVITY_CLEARANCES_MM[seed % len(SENSITIVITY_CLEARANCES_MM)]
    return Case(programme, tz, zg, seed, effects)


def long_voyage_cases(seeds: int = 2, first_seed: int = 6001) -> tuple[list[Case], list[Case]]:
    """The hour-long realistic voyage (:data:`LONG_PROGRAMMES`) with each library effect at
    :data:`LONG_FRACTION` of its default, ``seeds`` logs each, and ``LONG_CLEAN_PER_SEED *
    seeds`` clean logs (seeds from ``first_seed + 100``) -> (with effects, clean)."""
    (name,) = LONG_PROGRAMMES
    with_effect = []
    seed = first_seed
    for effect in MAGNITUDE:
        for _ in range(seeds):
            with_effect.append(_sensitivity_case(name, seed, (scaled_effect(effect, LONG_FRACTION),)))
            seed += 1
    clean = [_sensitivity_case(name, seed)
             for seed in range(first_seed + 100, first_seed + 100 + LONG_CLEAN_PER_SEED * seeds)]
    return with_effect, clean


def _effect_name(spec: str) -> str:
    return spec.partition(':')[0]


def summarize_sensitivity(results: Sequence[CaseResult], clean: Sequence[CaseResult] = ()) -> dict[str, Any]:
    """Detection per effect and magnitude: how many logs named every simulated effect, how many
    adopted one that was not simulated, and the systematic residual before and after
    (medians, bar); for effects outside the library, how often the verdict was 'unexplained'
    with the residual located on the right variable and the clearance intervals held the
    truth; and false adoptions on the clean logs ``clean``."""
    groups: dict[tuple[str, ...], list[CaseResult]] = {}
    for r in results:
        groups.setdefault(r.case.effects, []).append(r)
    rows = []
    for spec, rs in groups.items():
        names = {_effect_name(e) for e in spec}
        outside = names & (set(sim.OUTSIDE_LIBRARY) | set(sim.SENSOR_FAULTS))   # no term of the library's
        inside = names - outside
        fraction = None
        if len(spec) == 1 and not outside:
            name = _effect_name(spec[0])
            key = MAGNITUDE[name]
            value = float(sim.parse_effect(spec[0])[key])
            fraction = value / float(sim.EFFECTS[name][key])
        rows.append({
            'effects': list(spec), 'fraction_of_default': fraction, 'logs': len(rs),
            'median_minutes': float(np.median([r.duration_s for r in rs])) / 60.0,
            'named': sum(inside <= set(r.adopted) for r in rs) if inside else None,
            'wrong_adoptions': sum(bool(set(r.adopted) - inside) for r in rs),
            'unexplained': sum(r.verdict == 'unexplained' for r in rs),
            'located_on_angle': sum(r.located == 'alpha_deg' for r in rs) if outside else None,
            'clearances_covered': sum(r.covered('clearance_zgb_mm') and r.covered('clearance_2z_mm') for r in rs),
            'systematic_before_bar': float(np.median([r.systematic_bar for r in rs])),
            'systematic_after_bar': float(np.median([r.systematic_after_bar for r in rs])),
            'effect_misfit_before_bar': float(np.median([r.effect_misfit[0] for r in rs])),
            'effect_misfit_after_bar': float(np.median([r.effect_misfit[1] for r in rs])),
            'effect_misfit_halved': sum(0.0 < r.effect_misfit[0] and r.effect_misfit[1] <= 0.5 * r.effect_misfit[0]
                                        for r in rs),
        })
    return {'rows': rows, 'clean_logs': len(clean),
            'clean_false_adoptions': sum(bool(r.adopted) for r in clean),
            'clean_adopted': sorted({e for r in clean for e in r.adopted})}


def coverage_interval(hits: int, n: int) -> tuple[float, float]:
    """Wilson 95 % interval of a coverage share from ``hits`` of ``n`` cases."""
    if n == 0:
        return (math.nan, math.nan)
    z = 1.959963984540054
    p = hits / n
    den = 1 + z * z / n
    mid = (p + z * z / (2 * n)) / den
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / den
    lo = 0.0 if hits == 0 else max(mid - half, 0.0)     # exact at the ends (rounding otherwise)
    hi = 1.0 if hits == n else min(mid + half, 1.0)
    return (lo, hi)


def _errors(results: Sequence[CaseResult], q: str) -> dict[str, Any]:
    err = np.array([r.estimate[q] - r.truth[q] for r in results])
    hits = sum(r.covered(q) for r in results)
    lo, hi = coverage_interval(hits, len(results))
    d, sd = DECIMALS[q], SHARE_DECIMALS
    two = [r for r in results if r.two_sided(q)]
    two_hits = sum(r.covered(q) for r in two)
    bounds = [r for r in results if r.ci95[q][0] is not None and r.ci95[q][1] is None]
    widths = [r.ci95[q][1] - r.ci95[q][0] for r in two]       # type: ignore[operator]
    return {
        'two_sided': len(two),
        'two_sided_coverage': round(two_hits / len(two), sd) if two else math.nan,
        'two_sided_coverage_ci95': [round(x, sd) for x in coverage_interval(two_hits, len(two))],
        'lower_bounds': len(bounds),
        'lower_bounds_holding': sum(r.covered(q) for r in bounds),
        'not_determined': sum(r.ci95[q][0] is None and r.ci95[q][1] is None for r in results),
        'median_width': round(float(np.median(widths)), d) if widths else math.nan,
        'cases': len(results),
        'bias': round(float(err.mean()), d) if err.size else math.nan,
        'rms_error': round(float(np.sqrt(np.mean(err ** 2))), d) if err.size else math.nan,
        'max_abs_error': round(float(np.abs(err).max()), d) if err.size else math.nan,
        'coverage': round(hits / len(results), sd) if results else math.nan,
        'coverage_ci95': [round(lo, sd), round(hi, sd)],
        'two_sided_share': round(sum(r.two_sided(q) for r in results) / len(results), sd) if results else math.nan,
    }


def summarize(results: Sequence[CaseResult], clamp_threshold: float = 0.05) -> dict[str, Any]:
    """Per programme and over all: error and coverage of every quantity.

    For 2Z the cases are split by ``clamped_share`` at ``clamp_threshold`` (share of moving
    time clamped): "clamped" cases are where 2Z is identifiable; in "not clamped" ones the
    count that matters is how often the lower bound stays at or below the truth.
    """
    groups: dict[str, list[CaseResult]] = {}
    for r in results:
        groups.setdefault(r.case.programme, []).append(r)
    groups['all'] = list(results)
    out: dict[str, Any] = {}
    for name, rs in groups.items():
        declared = sum(r.verdict == 'declared' for r in rs) / len(rs)
        g: dict[str, Any] = {'cases': len(rs), 'declared_share': round(declared, SHARE_DECIMALS),
                             'effects_adopted': sorted({r.effect for r in rs if r.effect}),
                             'median_inflation': round(float(np.median([r.inflation for r in rs])), 3),
                             'max_systematic_bar': round(float(np.max([r.systematic_bar for r in rs])), 3)}
        for q in QUANTITIES:
            g[q] = _errors(rs, q)
        clamped = [r for r in rs if r.clamped_share >= clamp_threshold]
        free = [r for r in rs if r.clamped_share < clamp_threshold]
        g['clearance_2z_mm_clamped'] = _errors(clamped, 'clearance_2z_mm')
        g['clearance_2z_mm_clamped']['within_0.05mm'] = (
            round(sum(abs(r.estimate['clearance_2z_mm'] - r.truth['clearance_2z_mm']) <= 0.05 for r in clamped)
                  / len(clamped), SHARE_DECIMALS) if clamped else math.nan)
        g['clearance_2z_mm_not_clamped'] = _errors(free, 'clearance_2z_mm')
        g['clearance_zgb_mm']['within_0.03mm'] = round(sum(
            abs(r.estimate['clearance_zgb_mm'] - r.truth['clearance_zgb_mm']) <= 0.03 for r in rs) / len(rs),
            SHARE_DECIMALS)
        out[name] = g
    return out
