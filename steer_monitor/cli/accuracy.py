"""``steer-monitor accuracy``: the accuracy study of the clearance estimator.

Simulates a grid of true clearances (2Z x Z_gb) under several helm programmes, analyzes each
log as ``steer-monitor analyze`` would, and writes a Markdown table of the error and the
95 %-interval coverage of every estimate (``--out``, default ``accuracy.md``) and the
per-case results as JSON (``--json``). With ``--sensitivity-seeds N`` (docs/accuracy.md: 2)
it also runs the residual loop's sensitivity study (:func:`~steer_monitor.studies.accuracy.sensitivity_cases`)
and tabulates detection against effect magnitude; with ``--long-seeds N`` (docs: 2) its
hour-long part too (:func:`~steer_monitor.studies.accuracy.long_voyage_cases`). Cases run in parallel over ``--jobs``
processes; the outcome does not depend on the number of jobs.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
from collections.abc import Sequence
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any, TextIO

from steer_monitor.atomic import check_target, write_text
from steer_monitor.can.busconfig import can_setup
from steer_monitor.cli.options import add_config_option, add_force_option, add_json_option
from steer_monitor.cli.output import check_json_target, emit_json, json_to_stdout
from steer_monitor.errors import ParameterError, SteerMonitorError
from steer_monitor.params import load_params_file
from steer_monitor.resources import default_config
from steer_monitor.studies import accuracy as A

__all__ = ['markdown', 'register', 'run']

_WORKER: dict[str, Any] = {}


def _init_worker(config: str) -> None:
    params = load_params_file(config, getattr(config, 'node', None))
    db, smap = can_setup(params, config)
    _WORKER.update(params=params, db=db, smap=smap)


def _work(case: A.Case) -> A.CaseResult:
    return A.run_case(_WORKER['params'], _WORKER['db'], _WORKER['smap'], case)


def _parse_grid(text: str | None, default: Sequence[float], what: str) -> tuple[float, ...]:
    if text is None:
        return tuple(default)
    try:
        vals = tuple(float(x) for x in text.split(','))
    except ValueError:
        vals = ()
    if not vals or not all(math.isfinite(v) and v > 0 for v in vals):
        msg = f'{what}: expected a comma-separated list of positive millimetres, got {text!r}'
        raise ParameterError(msg)
    return vals


def _cov(g: dict[str, Any]) -> str:
    if not g['cases']:
        return '-'
    lo, hi = g['coverage_ci95']
    return f"{g['coverage']:.2f} ({g['cases']}; {lo:.2f}-{hi:.2f})"


def _effects_of(results: Sequence[A.CaseResult]) -> list[str]:
    return sorted({e for r in results for e in r.case.effects})


def _coverage_row(q: str, g: dict[str, Any]) -> str:
    lo, hi = g['two_sided_coverage_ci95']
    held = f"{g['two_sided_coverage']:.3f} ({lo:.2f}-{hi:.2f})" if g['two_sided'] else '-'
    return (f"| {q} | {g['two_sided']} | {held} | {g['lower_bounds']} | {g['lower_bounds_holding']} "
            f"| {g['not_determined']} | {_num(g['median_width'], '.4g')} |")


def _num(x: float, fmt: str) -> str:
    return '-' if x is None or (isinstance(x, float) and math.isnan(x)) else format(x, fmt)


def _cell(r: A.CaseResult) -> str:
    zg = r.estimate['clearance_zgb_mm']
    zlo, zhi = r.ci95['clearance_zgb_mm']
    tz = r.estimate['clearance_2z_mm']
    tlo, thi = r.ci95['clearance_2z_mm']
    zmark = '' if r.covered('clearance_zgb_mm') else ' **x**'
    tmark = '' if r.covered('clearance_2z_mm') else ' **x**'
    zs = f'{zg:.3f}' + (f' [{_num(zlo, ".3f")}, {_num(zhi, ".3f")}]')
    ts = (f'{tz:.2f} [{tlo:.2f}, {thi:.2f}]' if thi is not None and tlo is not None
          else f'>= {_num(tlo, ".2f")}')
    clamp = f' c{r.clamped_share:.0%}' if r.clamped_share > 0 else ''
    return f'{zs}{zmark} / {ts}{tmark}{clamp}'


def _misfit(row: dict[str, Any]) -> str:
    """The effect's misfit cells: 'before -> after | halved/logs'."""
    return (f"{_num(row['effect_misfit_before_bar'], '.3f')} -> {_num(row['effect_misfit_after_bar'], '.3f')} "
            f"| {row['effect_misfit_halved']}/{row['logs']}")


def _sensitivity_markdown(sens: dict[str, Any]) -> list[str]:
    lines = [
        '',
        '## Sensitivity of the residual loop',
        '',
        'The **realistic** voyage with undeclared effects in the plant: each effect of the analysis '
        'library alone at a fraction of the simulator\'s default magnitude (defaults in '
        '`steer_monitor/sim/plant_effects.py`), two effects at once, and an effect outside the library. '
        '*Named*: logs whose adopted effects include every simulated library effect; *other adopted*: logs '
        'that adopted an effect that was not simulated; *systematic* is the median smooth part of the '
        'residual (bar) under the declared model and under the final model with the adopted effects. '
        '*Effect\'s misfit* is what only a simulation can show: the model\'s error against the true, '
        'noise-free force (prediction against the plant\'s pressures at the same instants) in excess of the '
        'declared model\'s error on the same seed\'s log with the effects at size 0 (its clean twin: the '
        'declared fit\'s own error, about 0.2 bar, most of it from the load taken as constant within each 0.1° '
        'bin of rudder angle, which no effect removes); median over the logs, declared '
        '-> final model, and on how many logs adopting the effects at least halved it. '
        'For the effect outside the library the right answer is the verdict "unexplained" with the '
        'residual located on the rudder angle, and clearance intervals that still hold the truth.',
        '',
        '| simulated effects | fraction of default | logs | named | other adopted | verdict "unexplained" '
        '| located on the angle | Z_gb and 2Z covered | systematic declared -> final bar '
        '| effect\'s misfit declared -> final bar | halved |',
        '|---|---:|---:|---:|---:|---:|---:|---:|---|---|---:|',
    ]
    for r in sens['rows']:
        frac = '-' if r['fraction_of_default'] is None else f"{r['fraction_of_default']:.2g}"
        named = '-' if r['named'] is None else f"{r['named']}/{r['logs']}"
        loc = '-' if r['located_on_angle'] is None else f"{r['located_on_angle']}/{r['logs']}"
        lines.append(f"| `{' + '.join(r['effects'])}` | {frac} | {r['logs']} | {named} | {r['wrong_adoptions']} "
                     f"| {r['unexplained']}/{r['logs']} | {loc} | {r['clearances_covered']}/{r['logs']} "
                     f"| {r['systematic_before_bar']:.2f} -> {r['systematic_after_bar']:.2f} | {_misfit(r)} |")
    if sens['clean_logs']:
        lines += ['', f"False adoption on the clean logs above: {sens['clean_false_adoptions']} of "
                      f"{sens['clean_logs']}."]
    return lines


def _long_markdown(sens: dict[str, Any]) -> list[str]:
    (text,) = A.LONG_PROGRAMMES.values()
    lines = [
        '',
        '### On hour-long voyages',
        '',
        f'The same loop on the realistic voyage run about twice as long (`{text}`; other seeds than the '
        f'table above): each library effect at {A.LONG_FRACTION:g} of its default, and '
        f"{sens['clean_logs']} clean logs. An effect at the edge of detection on a 25-minute log "
        'should be found on a longer one; a longer log must not make the loop adopt what is not there.',
        '',
        '| simulated effect | minutes (median) | logs | named | other adopted | Z_gb and 2Z covered '
        '| systematic declared -> final bar | effect\'s misfit declared -> final bar | halved |',
        '|---|---:|---:|---:|---:|---:|---|---|---:|',
    ]
    for r in sens['rows']:
        lines.append(f"| `{' + '.join(r['effects'])}` | {r['median_minutes']:.0f} | {r['logs']} | "
                     f"{r['named']}/{r['logs']} | {r['wrong_adoptions']} | {r['clearances_covered']}/{r['logs']} "
                     f"| {r['systematic_before_bar']:.2f} -> {r['systematic_after_bar']:.2f} | {_misfit(r)} |")
    adopted = ', '.join(f'`{e}`' for e in sens['clean_adopted']) or 'none'
    lines += ['', f"False adoption on the clean hour-long logs: {sens['clean_false_adoptions']} of "
                  f"{sens['clean_logs']} (adopted: {adopted})."]
    return lines


def markdown(results: Sequence[A.CaseResult], summary: dict[str, Any], command: str, gear: str,
             sensitivity: dict[str, Any] | None = None, long: dict[str, Any] | None = None) -> str:
    """The study as a Markdown page (deterministic: no times, no host names)."""
    n = len(results)
    progs = sorted({r.case.programme for r in results}, key=list(A.PROGRAMMES).index)
    lines = [
        '# Accuracy of the clearance estimator',
        '',
        f'Generated by `{command}` (gear {gear}): {n} simulated logs, each analyzed as '
        '`steer-monitor analyze` does. Every log is its own seed (its own sensor noise and helm '
        'sequence); the plant is the declared model'
        + (' with one undeclared effect' if any(r.case.effects for r in results) else ' (no undeclared effect)')
        + ', with the simulator\'s '
        'default sensor noise (angle 0.15 mrad, pressures 0.25 bar), seal friction 9 kN, '
        'mu_bushing 0.13, mu_guide 0.05, 16 kn (the **realistic** voyages step and drift between 8 and 17 kn, '
        'change pumps between manoeuvres and steer by a dead-band autopilot on solenoid valves: '
        'stop-start rudder motion).',
        '',
        'Helm programmes: ' + '; '.join(f'**{p}** = `{A.PROGRAMMES[p]}`' for p in progs) + '.',
        '',
        *([f'Here each log carries one undeclared effect in turn ({", ".join(_effects_of(results))}), so '
           '"declared" below is not the right answer: the effect should be named.', '']
          if any(r.case.effects for r in results) else []),
        '*Coverage* is the share of logs whose 95 % interval holds the true value (honest intervals: '
        'about 0.95); in brackets the number of logs and the Wilson 95 % interval of that share. '
        '2Z is identifiable only where the ram clamps in its bushing at the loads of the log '
        '(the slope of the ram reaches 2Z / l_s); the "clamped" columns are the logs where the true ram '
        'was clamped during at least 5 % of the rudder\'s motion, and for the others the question is '
        'whether the reported lower bound stays at or below the truth.',
        '',
        '## Coverage per quantity',
        '',
        'Over all logs: how many 95 % intervals were two-sided and how many of them held the truth '
        '(Wilson 95 % interval of the share), how many were a lower bound only and how many of those '
        'were at or below the truth, how many quantities were not determined (a friction no row loads), '
        'and the median width of the two-sided intervals.',
        '',
        '| quantity | two-sided intervals | holding the truth | lower bounds | at or below the truth '
        '| not determined | median width |',
        '|---|---:|---:|---:|---:|---:|---:|',
        *(_coverage_row(q, summary['all'][q]) for q in A.QUANTITIES),
        '',
        '## Clearances',
        '',
        '| programme | logs | Z_gb RMS error mm | Z_gb max abs error mm | Z_gb within 0.03 mm | Z_gb coverage '
        '| 2Z clamped logs | 2Z RMS error (clamped) mm | 2Z within 0.05 mm (clamped) | 2Z coverage (clamped) '
        '| 2Z lower bound <= truth (not clamped) |',
        '|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|',
    ]
    for p in progs + ['all']:
        g = summary[p]
        zg, tc, tf = g['clearance_zgb_mm'], g['clearance_2z_mm_clamped'], g['clearance_2z_mm_not_clamped']
        lines.append(
            f"| {p} | {g['cases']} | {zg['rms_error']:.4f} | {zg['max_abs_error']:.4f} | {zg['within_0.03mm']:.2f} "
            f"| {_cov(zg)} | {tc['cases']} | {_num(tc['rms_error'], '.4f')} | {_num(tc['within_0.05mm'], '.2f')} "
            f"| {_cov(tc)} | {_cov(tf)} |")
    lines += [
        '',
        '## Guide-beam coefficient and friction',
        '',
        'K_gl max is the largest guide-beam share over the angles the log reached (truth: the plant\'s '
        'own K_gl over those angles, at the service speed where the estimated torque curve stands). '
        + ('With an effect in the plant, "effect" naming it is the right verdict (the sensitivity table '
           'below says which were named). ' if any(r.case.effects for r in results) else
           'Verdict "declared" is the right answer on these clean logs; any other is a false alarm of the '
           'residual loop. ')
        + 'The systematic residual is the smooth part of the declared model\'s residual '
        '(its autocovariance at 200 ms); the sensor noise alone leaves about 0.35 bar of noise and no '
        'systematic part.',
        '',
        '| programme | K_gl max RMS error | K_gl max coverage | F_s coverage | mu_bushing coverage '
        '| mu_guide coverage | verdict "declared" | effects adopted | median variance inflation '
        '| largest systematic residual bar |',
        '|---|---:|---:|---:|---:|---:|---:|---|---:|---:|',
    ]
    for p in progs + ['all']:
        g = summary[p]
        lines.append(
            f"| {p} | {g['k_gl_max']['rms_error']:.4f} | {_cov(g['k_gl_max'])} | {_cov(g['seal_friction_n'])} "
            f"| {_cov(g['mu_bushing'])} | {_cov(g['mu_guide'])} | {g['declared_share']:.2f} "
            f"| {', '.join(g['effects_adopted']) or 'none'} | {g['median_inflation']:.1f} "
            f"| {g['max_systematic_bar']:.2f} |")
    if sensitivity is not None:
        lines += _sensitivity_markdown(sensitivity)
    if long is not None:
        lines += _long_markdown(long)
    lines += [
        '',
        '## Every log',
        '',
        'Each cell: Z_gb estimate [95 % interval] / 2Z estimate [interval], or ">= lower bound" where '
        'the data only bound 2Z from below; **x** marks an interval that misses the truth; cN% is '
        'the share of motion the true ram spent clamped. Millimetres.',
    ]
    two_z = sorted({r.case.two_z_mm for r in results})
    z_gb = sorted({r.case.z_gb_mm for r in results})
    if len(two_z) * len(z_gb) > 4 * n:      # clearances off the grid: a row per log, not a sparse grid
        lines += ['', '| programme | seed | effect | true 2Z | true Z_gb | Z_gb / 2Z | F_s N | verdict (adopted) |',
                  '|---|---:|---|---:|---:|---|---|---|']
        for r in sorted(results, key=lambda r: (progs.index(r.case.programme), r.case.seed)):
            fs = r.ci95['seal_friction_n']
            fs_text = (f"{r.estimate['seal_friction_n']:.0f} [{_num(fs[0], '.0f')}, {_num(fs[1], '.0f')}]"
                       + ('' if r.covered('seal_friction_n') else ' **x**'))
            lines.append(f"| {r.case.programme} | {r.case.seed} | {', '.join(r.case.effects) or '-'} "
                         f"| {r.case.two_z_mm:.4f} | {r.case.z_gb_mm:.4f} | {_cell(r)} | {fs_text} "
                         f"| {r.verdict}{' (' + ', '.join(r.adopted) + ')' if r.adopted else ''} |")
        return '\n'.join(lines) + '\n'
    for p in progs:
        by = {}
        for r in results:
            if r.case.programme == p:
                by.setdefault((r.case.two_z_mm, r.case.z_gb_mm), []).append(r)
        lines += ['', f'### {p}', '',
                  '| true 2Z \\ true Z_gb | ' + ' | '.join(f'{z:.2f}' for z in z_gb) + ' |',
                  '|---|' + '---|' * len(z_gb)]
        for tz in two_z:
            cells = ['<br>'.join(_cell(r) for r in by.get((tz, zg), [])) or '-' for zg in z_gb]
            lines.append(f'| **{tz:.2f}** | ' + ' | '.join(cells) + ' |')
    return '\n'.join(lines) + '\n'


def run(config: str | Path | None = None, programmes: Sequence[str] = tuple(A.PROGRAMMES),
        grid_2z_mm: Sequence[float] = A.GRID_2Z_MM, grid_zgb_mm: Sequence[float] = A.GRID_ZGB_MM,
        seeds: int = 1, jobs: int | None = None, out_md: str | Path | None = 'accuracy.md',
        json_out: str | Path | None = None, command: str = 'steer-monitor accuracy',
        out: TextIO | None = None, sensitivity_seeds: int = 0, long_seeds: int = 0, off_grid: int = 0,
        first_seed: int | None = None, effects: Sequence[str] = ()) -> int:
    out = out or sys.stdout
    if off_grid < 0:
        msg = f'--off-grid must be 0 or more, got {off_grid}'
        raise ParameterError(msg)
    if seeds < 1:
        msg = f'--seeds must be at least 1, got {seeds}'
        raise ParameterError(msg)
    if sensitivity_seeds < 0:
        msg = f'--sensitivity-seeds must be 0 or more, got {sensitivity_seeds}'
        raise ParameterError(msg)
    if long_seeds < 0:
        msg = f'--long-seeds must be 0 or more, got {long_seeds}'
        raise ParameterError(msg)
    if jobs is not None and jobs < 1:
        msg = f'--jobs must be at least 1, got {jobs}'
        raise ParameterError(msg)
    try:
        if effects and not off_grid:
            msg = '--effects needs --off-grid (the grid study is of the clean plant)'
            raise ValueError(msg)
        for e in effects:
            A.sim.parse_effect(e)
        todo = (A.off_grid_cases(programmes, off_grid, **({} if first_seed is None else {'first_seed': first_seed}),
                                 effects=tuple(effects)) if off_grid
                else A.cases(programmes, grid_2z_mm, grid_zgb_mm, seeds,
                             **({} if first_seed is None else {'first_seed': first_seed})))
        n_clean = len(todo)
        sens_todo = (A.sensitivity_cases(sensitivity_seeds, **({} if first_seed is None else
                                                              {'first_seed': first_seed + 10_000}))
                     if sensitivity_seeds else [])
        long_effects, long_clean = A.long_voyage_cases(long_seeds) if long_seeds else ([], [])
        todo += sens_todo + long_effects + long_clean
    except (ValueError, SteerMonitorError) as exc:
        raise ParameterError(str(exc)) from None
    config_path = config or str(default_config())
    params = load_params_file(config_path, getattr(config, 'node', None))
    can_setup(params, config_path)   # a bad config fails here, not in every worker
    if out_md is not None and str(out_md) != '-':     # before an hour of work, not after
        check_target(out_md, [config_path])
    check_json_target(json_out, [config_path, out_md])
    if out_md is not None and json_out is not None and str(out_md) == '-' and json_to_stdout(json_out):
        msg = '--out - and --json - would both write to stdout: give one of them a file'
        raise ParameterError(msg)
    from tqdm import tqdm
    jobs = jobs or min(len(todo), os.cpu_count() or 1)
    bar = tqdm(total=len(todo), unit='log', disable=not sys.stderr.isatty(), file=sys.stderr, desc='accuracy')
    with bar:
        if jobs == 1:
            _init_worker(config_path)
            results = []
            for c in todo:
                results.append(_work(c))
                bar.update(1)
        else:
            with ProcessPoolExecutor(jobs, initializer=_init_worker, initargs=(config_path,)) as pool:
                results = []
                for r in pool.map(_work, todo):
                    results.append(r)
                    bar.update(1)
    results, rest = results[:n_clean], results[n_clean:]
    sens_results, rest = rest[:len(sens_todo)], rest[len(sens_todo):]
    long_results, long_clean_results = rest[:len(long_effects)], rest[len(long_effects):]
    summary = A.summarize(results)
    sens = A.summarize_sensitivity(sens_results, results) if sens_results else None
    if sens is None and effects:        # the off-grid logs with one effect each: what the loop named
        sens = A.summarize_sensitivity(results)
    long = A.summarize_sensitivity(long_results, long_clean_results) if long_results else None
    doc = markdown(results, summary, command, str(params['gear.name']), sens, long)
    if out_md is not None:
        if str(out_md) == '-':
            out.write(doc)
        else:
            write_text(out_md, doc)
    if json_out is not None:
        payload = {'summary': summary, 'cases': [r.to_json() for r in results]}
        if sens is not None:
            payload['sensitivity'] = {**sens, 'cases': [r.to_json() for r in sens_results]}
        if long is not None:
            payload['sensitivity_long'] = {**long, 'cases': [r.to_json() for r in long_results],
                                           'clean_cases': [r.to_json() for r in long_clean_results]}
        emit_json(payload, json_out, out)
    a = summary['all']
    if str(out_md) != '-' and not json_to_stdout(json_out):
        out.write(
            f"{len(results)} logs: Z_gb coverage {a['clearance_zgb_mm']['coverage']:.2f}, "
            f"RMS error {a['clearance_zgb_mm']['rms_error']:.4f} mm; 2Z coverage {a['clearance_2z_mm']['coverage']:.2f}"
            f" ({a['clearance_2z_mm_clamped']['cases']} clamped); K_gl max coverage {a['k_gl_max']['coverage']:.2f}"
            + (f'; table in {out_md}' if out_md else '')
            + '\n'
        )
    return 0


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser('accuracy', help='accuracy study of the clearance estimator over simulated logs',
                       description='Simulate a grid of true clearances under several helm programmes, analyze '
                                   'each log, and tabulate error and 95 % interval coverage.')
    add_config_option(p)
    p.add_argument('--programmes', default=','.join(A.PROGRAMMES),
                   help=f'comma-separated, from {", ".join(A.PROGRAMMES)} (default: all)')
    p.add_argument('--grid-2z-mm', help='true 2Z values, mm (default: ' + ','.join(map(str, A.GRID_2Z_MM)) + ')')
    p.add_argument('--grid-zgb-mm', help='true Z_gb values, mm (default: ' + ','.join(map(str, A.GRID_ZGB_MM)) + ')')
    p.add_argument('--seeds', type=int, default=1, help='logs per grid point and programme (default: 1)')
    p.add_argument('--off-grid', type=int, default=0, metavar='N',
                   help='instead of the grid of true clearances, N logs per programme whose clearances are drawn '
                        'uniformly over 2Z 0.1-0.6 mm and Z_gb 0.05-0.35 mm (seeds 9001 on), between the '
                        "estimator's grid points as real clearances are (default: 0, the grid)")
    p.add_argument('--jobs', type=int, help='worker processes (default: one per core)')
    p.add_argument('--sensitivity-seeds', type=int, default=0,
                   help='logs per effect and magnitude in the residual loop\'s sensitivity study (default: 0, '
                        'none; docs/accuracy.md is made with 2)')
    p.add_argument(
        '--long-seeds',
        type=int,
        default=0,
        help=f'logs per library effect at {A.LONG_FRACTION:g} of its default on the hour-long realistic voyage, '
        f'and {A.LONG_CLEAN_PER_SEED} clean hour-long logs per seed (default: 0, none; '
        'docs/accuracy.md is made with 2)',
    )
    p.add_argument('--out', default='accuracy.md',
                   help='Markdown table, - for stdout (default: accuracy.md in the working directory; the '
                        "repository's docs/accuracy*.md are written with --out docs/... --force)")
    add_json_option(p, 'the per-case results and the summary')

    def handler(a: argparse.Namespace) -> int:
        return run(a.config, [x.strip() for x in a.programmes.split(',') if x.strip()],
                   _parse_grid(a.grid_2z_mm, A.GRID_2Z_MM, '--grid-2z-mm'),
                   _parse_grid(a.grid_zgb_mm, A.GRID_ZGB_MM, '--grid-zgb-mm'),
                   a.seeds, a.jobs, a.out, a.json_out, command='steer-monitor accuracy ' + ' '.join(sys.argv[2:]),
                   sensitivity_seeds=a.sensitivity_seeds, off_grid=a.off_grid, long_seeds=a.long_seeds,
                   first_seed=a.first_seed, effects=A.sim.split_effects(a.effects))
    p.add_argument('--first-seed', type=int, metavar='S',
                   help='the first seed: of the grid (default 1), of the off-grid draws (default 9001); the '
                        'sensitivity study from S + 10000 (default 5001). A study meant to prove something runs on '
                        'seeds its author used for no choice')
    p.add_argument('--effects', default='', metavar='NAME[:k=v],...',
                   help='with --off-grid: each log carries one of these undeclared effects in turn (default: none, '
                        'the clean plant)')
    add_force_option(p)
    p.set_defaults(handler=handler)
