"""How often the report's timeline intervals hold the truth, beside the model check's.

``report`` shows two kinds of clearance estimate: the model check's (``analyze`` of the whole
log: the page's boxes and its load-sharing figure) and, over time, the review's windows (the
plot of the clearances over time: an estimate from the binned statistics of the data up to each
window's end, its intervals scaled by the residuals' spread over a sample of its rows). This study runs the
report's paths (:func:`steer_monitor.ashore.reviewlogs.review_logs`,
:func:`steer_monitor.ashore.loganalysis.model_check`, and the windows refitted under the effects
it adopted, :func:`steer_monitor.ashore.reviewlogs.refit_windows`) over
simulated realistic voyages (``realistic:1500``, the clean plant, true clearances drawn
uniformly off the estimator's grid by :func:`steer_monitor.studies.accuracy.off_grid_cases`
from ``FIRST_SEED``, seeds used for no choice) and counts, for Z_gb and 2Z, the two-sided
intervals that hold the truth and the lower bounds at or below it: per window, per voyage's
last window, and for the model check, with Wilson 95 % intervals. Windows of one voyage are
not independent (each holds the one before): the last-window column is the per-voyage one.

With ``effects``, voyage k carries the k-th effect of ``accuracy_online.EFFECTS`` in turn.

Other conditions than the simulator's defaults, to prove on data the estimator was not
developed on: ``--plant=KEY=VALUE,...`` sets fields of the simulated plant
(:class:`~steer_monitor.sim.SimConfig`: ``seal_friction`` [N], ``mu_bushing``, ``mu_guide``,
``pressure_noise`` [Pa], ``angle_noise`` [rad], ``oil_temp_start_c``, ...; the monitor's
configuration stays ``config/r18.yaml``'s), ``--scale=F`` multiplies each effect's size
(:data:`SIZES`) by F, ``--program=TEXT`` replaces the helm programme (default
``realistic:1500``).

Run from the repository: ``.venv/bin/python docs/studies/timeline_coverage.py [N] [FIRST_SEED]
[effects] [--plant=...] [--scale=F] [--program=TEXT]`` (prints a Markdown table).
"""

from __future__ import annotations

import os
import sys
import tempfile
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')

# the node's study's voyages and effects (with ``effects``, voyage k carries the k-th in turn)
from accuracy_online import EFFECTS, PROGRAM  # noqa: E402  (a sibling script: docs/studies is sys.path[0])

N = 40
FIRST_SEED = 36001
#: each effect's size, the parameter ``--scale`` multiplies (the others, a place or a time
#: constant, stay)
SIZES = {'viscous': 'c_ns_per_m', 'angle_delay': 'tau_s', 'pressure_offset': 'offset_bar',
         'temp_friction': 'k_per_k', 'pressure_friction': 'k', 'stribeck': 'f_st_n', 'ram_inertia': 'mass_kg',
         'band_friction': 'f_n'}


def _effect_text(name: str, scale: float) -> str:
    """The ``--effect`` text of an effect at ``scale`` times its default size."""
    if scale == 1.0:
        return name
    from steer_monitor.sim.plant_effects import EFFECTS as DEFAULTS
    key = SIZES[name]
    return f'{name}:{key}={float(DEFAULTS[name][key]) * scale:g}'


def _plant(text: str) -> dict[str, float]:
    """``KEY=VALUE,...`` -> the plant's fields to set (numbers); one line naming what is wrong
    (SystemExit) otherwise."""
    import dataclasses

    from steer_monitor.sim import SimConfig
    numbers = {f.name for f in dataclasses.fields(SimConfig) if f.type in ('float', float)}
    out = {}
    for item in filter(None, text.split(',')):
        key, _, value = (x.strip() for x in item.partition('='))
        if key not in numbers:
            raise SystemExit(f'--plant: {key!r} is not a number of the simulated plant ({", ".join(sorted(numbers))})')
        try:
            out[key] = float(value)
        except ValueError:
            raise SystemExit(f'--plant: {key} must be a number, got {value!r}') from None
    return out


def _count(out: dict, key: str, iv, truth: float) -> None:
    two = iv.lo is not None and iv.hi is not None
    kind = 'two' if two else 'bound'
    n, held = out.setdefault((key, kind), [0, 0])
    out[(key, kind)] = [n + 1, held + int(iv.contains(truth))]


def run(job) -> dict:
    case, plant, program = job
    from steer_monitor import sim
    from steer_monitor.ashore.loganalysis import model_check
    from steer_monitor.ashore.reviewlogs import refit_windows, review_logs
    from steer_monitor.ashore.windowmodel import window_model
    from steer_monitor.can.busconfig import load_setup
    from steer_monitor.jsonvocab import estimate_text
    from steer_monitor.logfiles.logs import write_candump
    from steer_monitor.model.gear import Clearances
    from steer_monitor.runtime import single_blas_thread
    single_blas_thread()
    path, params, db, smap = load_setup(None)
    cfg = sim.SimConfig(program=program, gaps=Clearances.from_mm(case.two_z_mm, case.z_gb_mm),
                        effects=tuple(sim.parse_effect(e) for e in case.effects), **plant)
    s = sim.run(params, cfg, db, smap, case.seed)
    truth = {'2Z': case.two_z_mm * 1e-3, 'Z_gb': case.z_gb_mm * 1e-3}
    out: dict = {}
    with tempfile.TemporaryDirectory() as tmp:
        log = Path(tmp) / 'voyage.log'
        with open(log, 'wb') as fh:
            write_candump(fh, s.frames)
        batch = review_logs([log], jobs=1)
        a, why = model_check([log], params, path, int(batch.review.t_ns[-1]))
        if a is not None:           # as the report: the windows under the model check's model
            model, nuisance = window_model(a)
            batch = refit_windows(batch, model, path, nuisance=nuisance)
        windows = batch.review.estimates
    for k, w in enumerate(windows):
        for name, iv in (('2Z', w.estimate.two_z), ('Z_gb', w.estimate.z_gb)):
            _count(out, f'window {name}', iv, truth[name])
            if k == len(windows) - 1:
                _count(out, f'last window {name}', iv, truth[name])
                if not iv.contains(truth[name]):
                    out.setdefault('missed', []).append(f'{case.seed} {name} {"+".join(case.effects) or "clean"}')
    if a is None:
        raise SystemExit(f'seed {case.seed}: {why}')
    for name, iv in (('2Z', a.final.two_z), ('Z_gb', a.final.z_gb)):
        _count(out, f'model check {name}', iv, truth[name])
        if not iv.contains(truth[name]):
            out.setdefault('check missed', []).append(
                f'{case.seed} {name} {estimate_text(iv.scaled(1e3), "mm")} for {truth[name] * 1e3:.4f} mm '
                f'{"+".join(case.effects) or "clean"} ({a.verdict}: {", ".join(e.name for e in a.adopted) or "-"})')
    return out


def main(n: int = N, first_seed: int = FIRST_SEED, effects: bool = False, plant: str = '', scale: float = 1.0,
         program: str = PROGRAM) -> None:
    from steer_monitor.studies.accuracy import coverage_interval, off_grid_cases
    texts = tuple(_effect_text(e, scale) for e in EFFECTS) if effects else ()
    cases = off_grid_cases(['realistic'], n, first_seed=first_seed, effects=texts)
    fields = _plant(plant)
    total: dict = {}
    missed: list[str] = []
    check_missed: list[str] = []
    with ProcessPoolExecutor(2) as pool:
        for out in pool.map(run, [(c, fields, program) for c in cases]):
            missed += out.pop('missed', [])
            check_missed += out.pop('check missed', [])
            for key, (k, held) in out.items():
                a, b = total.get(key, (0, 0))
                total[key] = (a + k, b + held)
    kind = 'voyages, each with one effect the declared model lacks,' if effects else 'clean voyages'
    other = ''.join([f'; the plant with {plant}' if plant else '', f'; effects at {scale:g} x their size' if
                     effects and scale != 1.0 else ''])
    print(f'{n} {kind} ({program}{other}), seeds {first_seed}-{first_seed + n - 1}\n')
    print('| estimate | two-sided holding the truth | lower bounds at or below it |')
    print('|---|---|---|')
    for what in ('window', 'last window', 'model check'):
        for name in ('Z_gb', '2Z'):
            cells = []
            for kind in ('two', 'bound'):
                k, held = total.get((f'{what} {name}', kind), (0, 0))
                if k == 0:
                    cells.append('-')
                    continue
                lo, hi = coverage_interval(held, k)
                cells.append(f'{held / k:.3f} ({held}/{k}; {lo:.2f}-{hi:.2f})')
            print(f'| {what} {name} | {cells[0]} | {cells[1]} |')
    print('\nlast windows missing the truth (seed, clearance, effect): ' + ('; '.join(missed) or 'none'))
    print('\nmodel checks missing the truth (seed, clearance, estimate, truth, effect, verdict: adopted): '
          + ('; '.join(check_missed) or 'none'))


if __name__ == '__main__':
    args = [int(a) for a in sys.argv[1:3] if a.isdigit()]
    opts = dict(a[2:].split('=', 1) for a in sys.argv[1:] if a.startswith('--'))
    main(*args, effects='effects' in sys.argv[1:], plant=opts.get('plant', ''), scale=float(opts.get('scale', 1.0)),
         program=opts.get('program', PROGRAM))
