"""The analysis of one log and its JSON answer (``steer-monitor analyze``'s, the fleet's per-log
check and the report's model check use it): decode the log, run the residual loop
(:func:`steer_monitor.estimate.analyze.analyze`) on its data (optionally the data before a
time, the last hours of steady motion), and give the answer in the JSON vocabulary of
docs/json.md.

The JSON (units in the key names; intervals are 95 %; a clearance the data bound from below
only is ``{"value": null, "ci95": [lo, null], "bounded": false}``)::

    clearance_2z_mm, clearance_zgb_mm      {"value", "ci95": [lo, hi], "bounded", "level", "note",
                                           "limit_mm"} (final model; level OK | WARN | OVER LIMIT |
                                           NOT ASSESSED, note: why, and what would assess it)
    k_gl_max                               {"value", "ci95": [lo, hi], "bounded"}
    seal_friction_n, mu_bushing, mu_guide  {"value", "ci95": [lo, hi], "bounded"}
    effects                                the adopted effects in order, each {"name", "params",
                                           "rmse_before_bar", "rmse_after_bar", "rmse_before_n",
                                           "rmse_after_n", "systematic_before_bar",
                                           "systematic_after_bar"} (params from the final model)
    effect                                 the first of them ({"name", "params"}) or null
    verdict                                "declared" | "effect" | "unexplained"
    unexplained                            where an unexplained residual lives, or null:
                                           {"variable", "range": [lo, hi] in its "unit",
                                           "either_side", "systematic_bar", "share", "ram",
                                           "direction", "message"}
    message                                one sentence
    rmse_before_n, rmse_after_n            ram-force residual RMS [N], declared / final
    rmse_before_bar, rmse_after_bar        the same in bar of cylinder pressure
    systematic_before_bar, systematic_after_bar, noise_bar   the residual's smooth part and
                                           its sensor-noise part
    declared, final                        each model's estimates
    screening                              every candidate against the declared model
    outlier_instants                       instants set aside before screening
    rams                                   how the rams shared the driving force: {"shares":
                                           [{"ram": 1, "share_pct"}, {"ram": 2, ...}] over the
                                           steady motion kept (null: not judged), "instants",
                                           "uneven": stretches left out, each {"start_utc",
                                           "start_ns", "end_utc", "end_ns", "ram" (the weaker,
                                           1 or 2), "share_pct" (its share), "instants", "idle"}}
    torque_curve                           [{"angle_deg", "torque_knm", "band_knm" (half-width of
                                           the 95 % band)}, ...]
    data                                   log, frames, span, steady-motion rows, max angle
    window                                 the data analysed: {"until_utc" (--until, or null),
                                           "motion_h" (--window-motion-h, null: all),
                                           "motion_s" (the steady motion it held)}

The model check (:func:`model_check`): the clearances a log's page, the fleet and ``analyze``
give, ``analyze`` of its last hours.
"""

from __future__ import annotations

import datetime
import math
import sys
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from steer_monitor.ashore.inspection import rate_notes, timing_json
from steer_monitor.can.busconfig import load_setup
from steer_monitor.can.rejects import RejectCounter
from steer_monitor.estimate.analyze import Analysis, analyze
from steer_monitor.estimate.batch import ClearanceEstimate
from steer_monitor.estimate.intervals import Interval
from steer_monitor.estimate.locate import UNITS
from steer_monitor.estimate.observe import EstimateError
from steer_monitor.estimate.ramscheck import rams_verdict, uneven_json
from steer_monitor.estimate.window import before
from steer_monitor.logfiles.decodelog import clock_steps_json, decode_logs
from steer_monitor.model.reach import Reach
from steer_monitor.monitor.verdict import LABELS, NOT_ASSESSED, assess_hint, clearance_verdict
from steer_monitor.params import gear_from_params, min_clearance_2z_from_params, ram_share_warn_from_params
from steer_monitor.utc import time_json

__all__ = ['ANALYSIS_HOURS', 'NOT_JUDGED', 'Headline', 'analysis_json', 'analyze_log', 'headline_json',
           'headline_text', 'headlines', 'model_check', 'reach_json']


def _quantities(e: ClearanceEstimate) -> dict[str, Any]:
    """The estimated quantities with their intervals, in engineers' units."""
    return {
        'clearance_2z_mm': e.two_z.scaled(1e3),
        'clearance_zgb_mm': e.z_gb.scaled(1e3),
        'k_gl_max': e.k_gl_max.scaled(1.0, 3),
        'seal_friction_n': e.seal_friction.scaled(1.0, 0),
        'mu_bushing': e.mu_bushing.scaled(1.0, 4),
        'mu_guide': e.mu_guide.scaled(1.0, 4),
    }


def _estimate_json(e: ClearanceEstimate) -> dict[str, Any]:
    bar = e.ram_area * 1e5
    return {
        **_quantities(e),
        'rmse_n': round(e.rms, 1),
        'rmse_bar': round(e.rms / bar, 4),
        'systematic_bar': round(e.smooth_rms / bar, 4),
        'noise_bar': round(e.noise_rms / bar, 4),
        'variance_inflation': round(e.inflation, 2),
        'rows': e.rows,
    }


def _params_json(params: dict[str, Any]) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for k, v in params.items():
        if isinstance(v, str):
            out[k] = v
        elif v.lo is None and v.hi is None:
            out[k] = round(v.value, 6)
        else:
            out[k] = v.scaled(1.0, 6)
    return out


def _located_json(a: Analysis) -> dict[str, Any] | None:
    loc = a.located
    if loc is None:
        return None
    bar = a.final.ram_area * 1e5
    digits = 1 if loc.variable in ('time_s', 'pressure_bar') else 2
    return {'variable': loc.variable, 'range': [round(loc.lo, digits), round(loc.hi, digits)],
            'unit': UNITS[loc.variable],
            'either_side': loc.either_side, 'systematic_bar': round(loc.level / bar, 3),
            'share': round(loc.share, 3), 'ram': loc.shape.ram_name, 'direction': loc.shape.direction_name,
            'odd_in_direction': loc.shape.odd and not loc.shape.direction,
            'message': loc.message(a.final.ram_area)}


def analysis_json(a: Analysis) -> dict[str, Any]:
    """The JSON answer (see the module docstring)."""
    d, f = a.declared, a.final
    bar = f.ram_area * 1e5
    effects = [{'name': s.name, 'params': _params_json(s.params),
                'rmse_before_bar': round(s.before.rms / bar, 4), 'rmse_after_bar': round(s.after.rms / bar, 4),
                'rmse_before_n': round(s.before.rms, 1), 'rmse_after_n': round(s.after.rms, 1),
                'systematic_before_bar': round(s.before.smooth_rms / bar, 4),
                'systematic_after_bar': round(s.after.smooth_rms / bar, 4)} for s in a.steps]
    angles, torque, band = f.torque_curve
    return {
        **_quantities(f),
        'effects': effects,
        'effect': {'name': effects[0]['name'], 'params': effects[0]['params']} if effects else None,
        'verdict': a.verdict,
        'message': a.message,
        'unexplained': _located_json(a),
        'rmse_before_n': round(d.rms, 1),
        'rmse_after_n': round(f.rms, 1),
        'rmse_before_bar': round(d.rms / bar, 4),
        'rmse_after_bar': round(f.rms / bar, 4),
        'systematic_before_bar': round(d.smooth_rms / bar, 4),
        'systematic_after_bar': round(f.smooth_rms / bar, 4),
        'noise_bar': round(f.noise_rms / bar, 4),
        'declared': _estimate_json(d),
        'final': _estimate_json(f),
        'screening': [{'name': s.name, 'fixed': s.fixed, 'held_out_gain': round(s.cv_gain, 4),
                       'held_out_deviance': round(s.cv_deviance, 1),
                       'delta_bic': round(s.delta_bic, 1), 'rmse_bar': round(s.rms / bar, 4),
                       'passes': s.passes, 'refused': s.refused} for s in a.screening],
        'outlier_instants': a.outliers,
        'rams': {'shares': None if a.rams is None else [{'ram': k + 1, 'share_pct': round(100 * x, 2)}
                                                         for k, x in enumerate(a.rams.share)],
                 'instants': 0 if a.rams is None else a.rams.instants,
                 'uneven': [uneven_json(sp) for sp in a.uneven],
                 'assessed': a.rams_assessed, 'verdict': rams_verdict(a.uneven, a.rams_assessed)},
        'torque_curve': [{'angle_deg': round(math.degrees(x), 2), 'torque_knm': round(t / 1e3, 2),
                          'band_knm': round(b / 1e3, 2)} for x, t, b in zip(angles, torque, band)],
        'max_angle_seen_deg': round(math.degrees(f.max_angle_seen), 2),
    }


def analyze_log(path: str | Path, config: str | Path | None = None, progress: bool = False,
                date: datetime.date | None = None, until_ns: int | None = None,
                window_motion_s: float = 0.0) -> tuple[Analysis, dict[str, Any]]:
    """The analysis of one log and its JSON. A log that breaks off or holds corrupt chunks is
    analysed on what could be read; ``data.read_errors`` says what was wrong. ``until_ns``:
    only the data before that time [ns]; ``window_motion_s``: only the last that many seconds
    of steady motion (0: all), the window a node analyses (``estimator.window_motion_h``)."""
    config_path, params, db, smap = load_setup(config)
    gear = gear_from_params(params)
    rejects = RejectCounter()
    logs = decode_logs([path], db, smap, rejects, date=date)
    if logs.frames == 0 and not logs.errors:
        raise EstimateError(f'{path} holds no CAN frames: nothing to analyse')
    signals = logs.signals if until_ns is None else before(logs.signals, until_ns)
    say = (lambda msg: print(f'  {msg} ...', file=sys.stderr)) if progress else None
    try:
        a = analyze(gear, signals, min_clearance_2z=min_clearance_2z_from_params(params),
                    ram_share_warn=ram_share_warn_from_params(params), progress=say,
                    window_motion_s=window_motion_s)
    except EstimateError as exc:
        if logs.errors and logs.frames == 0:    # nothing read: the reason is the log, first
            raise EstimateError(f'{logs.errors[0]}: nothing to analyse') from exc
        if logs.errors:      # say why the data are short as well
            raise EstimateError(f'{exc} ({logs.errors[0]})') from exc
        raise
    out = analysis_json(a)
    limit_2z, limit_zgb = params['clearances.limit_2z_mm'] * 1e-3, params['clearances.limit_zgb_mm'] * 1e-3
    for h, key in zip(headlines(a, limit_2z, limit_zgb, params['diagnostics.clearance_warn_share']),
                      ('clearance_2z_mm', 'clearance_zgb_mm')):
        out[key]['level'] = h.level
        out[key]['note'] = h.note
        out[key]['limit_mm'] = round(h.limit * 1e3, 4)
        out[key].update(reach_json(h.reach))
    out['data'] = {'log': str(path), 'frames': logs.frames, 'span_s': logs.span_s,
                   'rejects': dict(sorted(rejects.snapshot().counts.items())),
                   'read_errors': list(logs.errors),
                   'clock_steps': clock_steps_json(logs.clock_steps),
                   'notes': [*logs.notes, *rate_notes(signals)],
                   'inputs': timing_json(signals, {spec.name: spec.rate_hz for spec in smap.specs}),
                   'config': str(config_path)}
    out['window'] = {**time_json('until', until_ns),
                     'motion_h': window_motion_s / 3600.0 if window_motion_s > 0 else None,
                     'motion_s': round(a.window.motion_s, 2) if a.window is not None else None}
    return a, out


#: hours of data at a log's end the check looks at (``report --analysis-hours``)
ANALYSIS_HOURS = 3.0
#: the level of a clearance the data do not assess: no estimate, a lower bound below the warning,
#: an interval reaching from below the warning past the limit, or one from a model that does not
#: explain the data (one word everywhere)
NOT_JUDGED = LABELS[NOT_ASSESSED]


def model_check(paths: Sequence[str | Path], params: Mapping[str, Any], config_path: str | Path,
                end_ns: int, hours: float = ANALYSIS_HOURS, date: datetime.date | None = None
                ) -> tuple[Analysis | None, str]:
    """``analyze`` of the data of ``paths`` from ``hours`` before ``end_ns`` (the last data
    time, ns) on; (None, why) when it cannot be made. Breaks in the logs are the review's to
    report (read here again)."""
    from steer_monitor.can.busconfig import can_setup
    from steer_monitor.can.rejects import RejectCounter
    from steer_monitor.logfiles.decodelog import decode_logs
    from steer_monitor.params import gear_from_params, min_clearance_2z_from_params, ram_share_warn_from_params

    db, smap = can_setup(params, config_path)
    logs = decode_logs(paths, db, smap, RejectCounter(), since_ns=int(end_ns - hours * 3.6e12), date=date)
    if logs.first_ns is None:
        return None, 'no data for the model check'
    try:
        return analyze(gear_from_params(params), logs.signals, min_clearance_2z=min_clearance_2z_from_params(params),
                       ram_share_warn=ram_share_warn_from_params(params)), ''
    except EstimateError as exc:
        return None, f'model check not made: {exc}'


@dataclass(frozen=True)
class Headline:
    """One clearance as the page shows it: its estimate (None: none), the level (``OK``,
    ``WARN``, ``OVER LIMIT`` or ``NOT ASSESSED``), the limit [m], a note ('' or why) and how far
    the clearance can show on the gear (None: not worked out)."""

    name: str
    estimate: Interval | None
    level: str
    limit: float
    note: str
    reach: Reach | None = None


def headlines(analysis: Analysis | None, limit_2z: float, limit_zgb: float, warn_share: float
              ) -> tuple[Headline, Headline]:
    """2Z and Z_gb from the model check: judged as the node's diagnostics judge them
    (:func:`~steer_monitor.monitor.verdict.clearance_verdict`), or not judged when there is
    no check or its model does not explain the data (the clearances then rest on an
    incomplete model)."""
    out = []
    for name, limit, attr in (('2Z', limit_2z, 'two_z'), ('Z_gb', limit_zgb, 'z_gb')):
        if analysis is None:
            out.append(Headline(name, None, NOT_JUDGED, limit,
                                f'not estimated (too little steady motion); {assess_hint(name)}'))
            continue
        iv = getattr(analysis.final, attr)
        k = 0 if attr == 'two_z' else 1
        reach = None if analysis.final.reach is None else analysis.final.reach[k]
        v = clearance_verdict(iv.value, iv.lo, iv.hi, limit, warn_share, name, analysis.final.bound_why[k], reach)
        if analysis.verdict == 'unexplained':
            out.append(Headline(name, iv, NOT_JUDGED, limit, 'the model does not explain the pressures, so the '
                                                             'clearances rest on an incomplete model', reach))
            continue
        out.append(Headline(name, iv, v.label, limit, v.note, reach))
    return out[0], out[1]


def headline_text(h: Headline) -> str:
    """One clearance's line for a terminal: the estimate, its share of the limit, the level and
    why (the words of ``analyze`` and the report's box)."""
    iv = h.estimate
    if iv is None:
        est = 'not estimated'
    elif iv.hi is None:      # a bound below the limit is no share of it: "13 % of the limit" read as reassurance
        est = f'>= {iv.lo * 1e3:.3f} mm (lower bound only)' + (
            f', {iv.lo / h.limit:.0%} of the {h.limit * 1e3:g} mm limit' if iv.lo > h.limit else '')
    else:
        est = (f'{iv.value * 1e3:.3f} mm [{iv.lo * 1e3:.3f} .. {iv.hi * 1e3:.3f}], {iv.value / h.limit:.0%} of the '
               f'{h.limit * 1e3:g} mm limit')
    return f'{h.name:<7} {est}  {h.level}' + (f': {h.note}' if h.note else '')


def headline_json(h: Headline) -> dict[str, object]:
    """``{value, ci95, bounded, level}`` in mm (``value`` and ``ci95`` null without an
    estimate)."""
    if h.estimate is None:
        return {'value': None, 'ci95': [None, None], 'bounded': False, 'level': h.level}
    return {**h.estimate.scaled(1e3), 'level': h.level, **reach_json(h.reach)}


def reach_json(reach: Reach | None) -> dict[str, object]:
    """``{"observable_to_mm": {"loads_seen", "gear", "at_other_mm", "other_lower_bound"}}`` ({} when
    not worked out)."""
    if reach is None:
        return {}
    return {'observable_to_mm': {'loads_seen': round(reach.seen * 1e3, 4), 'gear': round(reach.gear * 1e3, 4),
                                 'at_other_mm': round(reach.other * 1e3, 4), 'other_lower_bound': reach.other_bound}}
