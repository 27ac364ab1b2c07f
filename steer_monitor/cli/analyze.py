"""``steer-monitor analyze LOG --config CFG --json OUT [--report OUT.html]``: estimate the
clearances from a log, find what the declared model lacks, and say how sure that is.

The JSON (units in the key names; intervals are 95 %, ``hi`` null when the data only bound
a value from below)::

    clearance_2z_mm, clearance_zgb_mm      {"value", "ci95": [lo, hi], "bounded"}   (final model)
    k_gl_max                               {"value", "ci95": [lo, hi], "bounded"}
    seal_friction_n, mu_bushing, mu_guide  {"value", "ci95": [lo, hi], "bounded"}
    effects                                the adopted effects in order, each {"name", "params",
                                           "rmse_before_bar", "rmse_after_bar", "rmse_before_kn",
                                           "rmse_after_kn", "systematic_before_bar",
                                           "systematic_after_bar"} (params from the final model)
    effect                                 the first of them ({"name", "params"}) or null
    verdict                                "declared" | "effect" | "unexplained"
    unexplained                            where an unexplained residual lives, or null:
                                           {"variable", "range": [lo, hi] in its unit,
                                           "either_side", "systematic_bar", "share", "ram",
                                           "direction", "message"}
    message                                one sentence
    rmse_before_kn, rmse_after_kn          ram-force residual RMS, declared / final
    rmse_before_bar, rmse_after_bar        the same in bar of cylinder pressure
    systematic_before_bar, systematic_after_bar, noise_bar   the residual's smooth part and
                                           its sensor-noise part
    declared                               the declared model's estimates (before the effect)
    screening                              every candidate against the declared model
    outlier_instants                       instants set aside before screening
    rams                                   how the rams shared the driving force: {"share_pct":
                                           [ram 1, ram 2] over the steady motion kept,
                                           "instants", "uneven": stretches left out, each
                                           {"start_ns", "end_ns", "ram" (the weaker, 1 or 2),
                                           "share_pct" (its share), "instants", "idle"}}
    torque_curve_knm                       [[deg, kN m, half-width of the 95 % band], ...]
    data                                   log, frames, span, steady-motion rows, max angle
    window                                 the data analysed: {"until_utc" (--until, or null),
                                           "motion_h" (--window-motion-h, null: all),
                                           "motion_s" (the steady motion it held)}
"""

from __future__ import annotations

import argparse
import datetime
import math
import sys
import time
from pathlib import Path
from typing import Any, TextIO

from steer_monitor.atomic import atomic_write, check_target
from steer_monitor.can.busconfig import load_setup
from steer_monitor.can.rejects import RejectCounter
from steer_monitor.cli.options import add_config_option, add_force_option
from steer_monitor.cli.output import add_date_option, check_logs, date_notes, dump_json, report_read_errors, text_stream
from steer_monitor.errors import ParameterError
from steer_monitor.estimate.analyze import Analysis, analyze
from steer_monitor.estimate.batch import ClearanceEstimate
from steer_monitor.estimate.observe import EstimateError
from steer_monitor.estimate.window import before
from steer_monitor.logfiles.decodelog import clock_steps_json, decode_logs
from steer_monitor.params import gear_from_params, min_clearance_2z_from_params, ram_share_warn_from_params
from steer_monitor.utc import parse_utc, utc_text

__all__ = ['analysis_json', 'analyze_log', 'register', 'run']


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
        'rmse_kn': round(e.rms / 1e3, 4),
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
                'rmse_before_kn': round(s.before.rms / 1e3, 4), 'rmse_after_kn': round(s.after.rms / 1e3, 4),
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
        'rmse_before_kn': round(d.rms / 1e3, 4),
        'rmse_after_kn': round(f.rms / 1e3, 4),
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
        'rams': {'share_pct': None if a.rams is None else [round(100 * x, 2) for x in a.rams.share],
                 'instants': 0 if a.rams is None else a.rams.instants,
                 'uneven': [{'start_ns': sp.start_ns, 'end_ns': sp.end_ns, 'ram': sp.ram + 1,
                             'share_pct': round(100 * sp.share, 2), 'instants': sp.instants, 'idle': sp.idle}
                            for sp in a.uneven]},
        'torque_curve_knm': [[round(math.degrees(x), 2), round(t / 1e3, 2), round(b / 1e3, 2)]
                             for x, t, b in zip(angles, torque, band)],
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
    out['data'] = {'log': str(path), 'frames': logs.frames, 'span_s': logs.span_s,
                   'rejects': dict(sorted(rejects.snapshot().counts.items())),
                   'read_errors': list(logs.errors),
                   'clock_steps': clock_steps_json(logs.clock_steps), 'notes': list(logs.notes),
                   'config': str(config_path)}
    out['window'] = {'until_utc': None if until_ns is None else utc_text(until_ns),
                     'motion_h': window_motion_s / 3600.0 if window_motion_s > 0 else None,
                     'motion_s': round(a.window.motion_s, 2) if a.window is not None else None}
    return a, out


def run(path: str | Path, config: str | Path | None = None, json_out: str | Path | None = None,
        report: str | Path | None = None, out: TextIO | None = None, err: TextIO | None = None,
        date: datetime.date | None = None, until_ns: int | None = None, window_motion_h: float = 0.0) -> int:
    """Analyse ``path`` (the data before ``until_ns``, the last ``window_motion_h`` hours of
    steady motion of them: 0 for all); 0 when it was read whole, 1 when it broke off or had
    corrupt parts (the outputs are still written, from what could be read; one line per
    problem on ``err``)."""
    if not (math.isfinite(window_motion_h) and window_motion_h >= 0):
        raise ParameterError(f'--window-motion-h must be a number of hours >= 0 (0: all the motion), '
                             f'not {window_motion_h:g}')
    out = out or sys.stdout
    err = err or sys.stderr
    out = text_stream([None if str(json_out) == '-' else json_out, report], out, err)
    check_logs([path])
    for target in (json_out, report):     # before minutes of work, not after
        if target is not None and str(target) != '-':
            check_target(target, [path, config])
    t0 = time.perf_counter()
    date_notes('analyze', [path], date, err)
    a, result = analyze_log(path, config, progress=sys.stderr.isatty(), date=date, until_ns=until_ns,
                            window_motion_s=window_motion_h * 3600.0)
    result['analysis_s'] = round(time.perf_counter() - t0, 2)
    for note in result['data']['notes']:
        err.write(f'steer-monitor analyze: note: {path}: {note}\n')
    if json_out is not None:
        if str(json_out) == '-':
            dump_json(result, out)
        else:
            with atomic_write(json_out, 'w', encoding='utf-8') as fh:
                dump_json(result, fh)
    if report is not None:
        from steer_monitor.ashore.report.analysis import write_analysis_report
        write_analysis_report(a, result, report)
    if json_out is None or str(json_out) != '-':
        _summary(result, out)
    return report_read_errors('analyze', result['data']['read_errors'], err)


def _fmt(d: dict[str, Any], unit: str) -> str:
    lo, hi = d['ci95']
    if hi is None and lo is not None:
        # the data bound it from below only: the profile's best point on its plateau is
        # no estimate, and printed first it read as one (2Z 0.3 mm for a true 0.7 mm)
        return f">= {lo} {unit}  (lower bound only)"
    return (f"{d['value']} {unit}  [{'-' if lo is None else lo} .. "
            f"{'unbounded' if hi is None else hi}]")


def _summary(r: dict[str, Any], out: TextIO) -> None:
    out.write(f"2Z      {_fmt(r['clearance_2z_mm'], 'mm')}\n")
    out.write(f"Z_gb    {_fmt(r['clearance_zgb_mm'], 'mm')}\n")
    out.write(f"K_gl max {_fmt(r['k_gl_max'], '')}\n")
    out.write(f"F_s {_fmt(r['seal_friction_n'], 'N')};  mu_b {_fmt(r['mu_bushing'], '')};  "
              f"mu_g {_fmt(r['mu_guide'], '')}\n")
    out.write(f"{r['message']}\n")
    if r['clearance_2z_mm']['ci95'][1] is None:
        out.write('2Z: the ram never clamped in its bushing at the loads seen; the data only bound it from below\n')


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser('analyze', help='estimate the clearances from a log and test the residual',
                       description='Fit the declared model to a CAN log (.log, .asc, .blf, .mcap), profile '
                                   'the clearances with 95 % intervals, test the residual against the '
                                   'library of candidate effects and refit with the one the data support.')
    p.add_argument('log', help='the log file')
    add_config_option(p)
    p.add_argument('--json', dest='json_out', metavar='OUT', help="write the JSON answer here ('-': stdout)")
    p.add_argument('--report', metavar='OUT.html', help='write a self-contained HTML report')
    p.add_argument('--until', type=_utc_arg, metavar='UTC',
                   help='analyse only the data before this time (ISO 8601, e.g. 2026-11-26T14:03:00Z): '
                        'what the node had then')
    p.add_argument('--window-motion-h', type=float, default=0.0, metavar='H',
                   help='analyse only the last H hours of steady rudder motion, as the node does '
                        '(its estimator.window_motion_h; default 0: all of it)')
    add_date_option(p)
    add_force_option(p)
    p.set_defaults(handler=lambda a: run(a.log, a.config, a.json_out, a.report, date=a.date, until_ns=a.until,
                                         window_motion_h=a.window_motion_h))


def _utc_arg(text: str) -> int:
    try:
        return parse_utc(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None
