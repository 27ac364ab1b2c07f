"""How often the node's clearance intervals hold the truth, second by second.

The node publishes, each second, the clearances of its last applied analysis (``analyze`` of
its window, on the schedule of ``estimator.*``) with their 95 % intervals. This study runs
the node's pipeline (decoder, live model, analyst, diagnostics; the same code a replay runs)
over simulated realistic voyages (``realistic:1500``: speed steps and drifts, pump changes,
a dead-band autopilot on solenoid valves, holds at odd angles, zigzags, hard-overs) and, for
every second at which the clearances are estimated, asks whether each interval holds the
plant's true clearance. Two sets of 16 voyages, each its own seed, true clearances drawn
uniformly off the estimator's grid (:func:`steer_monitor.studies.accuracy.off_grid_cases`: 2Z 0.1 to
0.6 mm, Z_gb 0.05 to 0.35 mm, drawn from seed 9301 by default (the second argument): the
study first ran from seed 9101 with the first analysis at 30 s of motion, and chose
``estimator.first_motion_s`` from it; these seeds were not used to choose anything):

* **clean**: the declared model;
* **effects**: each voyage carries one effect the declared model lacks, the library's seven
  (``viscous``, ``angle_delay``, ``pressure_offset``, ``temp_friction``, ``pressure_friction``,
  ``stribeck``, ``ram_inertia``) and one outside it (``band_friction``), two voyages each, at
  the simulator's default magnitude.

Reported per set: the estimated seconds, the share of them whose interval holds the truth
(Z_gb; 2Z, where a one-sided "2Z >= lower bound" holds when the bound is at or below the
truth), the same per finding (each analysis applied counted once) and for the last finding
of each voyage (what ``analyze`` of the whole voyage says, as docs/accuracy-off-grid.md
counts it), with Wilson 95 % intervals; and the clearance alarms raised against the truth
(a WARN or ERROR while the true clearance is under the warning share of its limit is a false
alarm). Seconds of one voyage are not independent (a finding stands for minutes): the
per-voyage column is the one whose interval means what it says.

Run from the repository: ``.venv/bin/python docs/studies/accuracy_online.py docs/accuracy-online.md [SEED]``
(about 6 minutes on two cores).
"""

from __future__ import annotations

import math
import os
import sys
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass

os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')

PROGRAM = 'realistic:1500'
N = 16
FIRST_SEED = 9301
EFFECTS = ('viscous', 'angle_delay', 'pressure_offset', 'temp_friction', 'pressure_friction', 'stribeck',
           'ram_inertia', 'band_friction')


@dataclass
class Voyage:
    seed: int
    two_z_mm: float
    z_gb_mm: float
    effect: str
    seconds: int = 0                 # seconds with estimated clearances
    zgb_held: int = 0
    tz_held: int = 0
    findings: int = 0
    zgb_findings_held: int = 0
    tz_findings_held: int = 0
    last_zgb_held: bool = False
    last_tz_held: bool = False
    last_zgb: str = ''
    last_verdict: str = ''
    by_motion: list = None           # each finding applied: (motion analysed [s], Z_gb held, within 0.03 mm)
    false_alarms: int = 0            # clearance WARN/ERROR seconds while the truth is under the warn share
    alarms: int = 0
    not_assessed: int = 0            # estimated seconds the clearances status said NOT ASSESSED
    first_estimated_motion_s: float = math.nan
    # per quantity, over the findings applied and for the last: [two-sided, two-sided holding the
    # truth, lower bounds, lower bounds at or below the truth]
    per_finding: dict = None
    per_last: dict = None


def _holds(lo: float | None, hi: float | None, truth: float) -> bool:
    return (lo is None or lo <= truth) and (hi is None or truth <= hi)


QUANTITIES = ('Z_gb', '2Z', 'F_s', 'mu_b', 'mu_g')


def _intervals(f) -> dict:   # noqa: ANN001 - a Finding
    """Each quantity's (lo, hi) in a finding (friction: empty when the finding has none)."""
    out = {'Z_gb': (f.z_gb.lo, f.z_gb.hi), '2Z': (f.two_z.lo, f.two_z.hi)}
    for name, ci in zip(('F_s', 'mu_b', 'mu_g'), f.friction_ci):
        out[name] = ci
    return out


def _count(tally: dict, f, truth: dict, temp: dict | None = None) -> None:   # noqa: ANN001 - a Finding
    """Tally each quantity's interval of ``f`` against ``truth``; with the plant's temp_friction
    ``temp``, the friction's truth is the plant's at the oil temperature the finding's term is
    relative to (``t_ref_k``), which is what its friction stands for."""
    truth = dict(truth)
    t_ref = f.terms.get('t_ref_k') if temp is not None else None
    if t_ref is not None and math.isfinite(t_ref):
        scale = 1.0 + float(temp['k_per_k']) * (t_ref - 273.15 - float(temp['t_ref_c']))
        for q in ('F_s', 'mu_b', 'mu_g'):
            truth[q] *= scale
    for q, (lo, hi) in _intervals(f).items():
        t = tally.setdefault(q, [0, 0, 0, 0])
        if lo is not None and hi is not None:
            t[0] += 1
            t[1] += lo <= truth[q] <= hi
        elif lo is not None:
            t[2] += 1
            t[3] += lo <= truth[q]


def run(v: Voyage) -> Voyage:
    from steer_monitor.runtime import single_blas_thread
    single_blas_thread()
    from steer_monitor import sim
    from steer_monitor.can import Decoder, RejectCounter
    from steer_monitor.can.busconfig import can_setup
    from steer_monitor.model import Clearances
    from steer_monitor.monitor import ERROR, WARN, DiagnosticsBuilder, DiagnosticsConfig, LiveMonitor
    from steer_monitor.monitor.pipeline import DiagOut, Pipeline, analyst_from_params
    from steer_monitor.params import friction_from_params, gaps_from_params, gear_from_params, load_params_file
    from steer_monitor.resources import default_config

    config = default_config()
    params = load_params_file(config)
    db, smap = can_setup(params, config)
    gear = gear_from_params(params)
    cfg = DiagnosticsConfig.from_params(params)
    effects = (sim.parse_effect(v.effect),) if v.effect else ()
    sim_cfg = sim.SimConfig(program=PROGRAM, gaps=Clearances.from_mm(v.two_z_mm, v.z_gb_mm), effects=effects)
    s = sim.run(params, sim_cfg, db, smap, v.seed)
    rejects = RejectCounter()
    mon = LiveMonitor(gear, gaps_from_params(params), 'configured', friction_from_params(params))
    p = Pipeline(Decoder(db, smap, rejects), rejects, mon, DiagnosticsBuilder(cfg, smap, gear),
                 analyst_from_params(gear, params))
    tz, zg = v.two_z_mm * 1e-3, v.z_gb_mm * 1e-3
    truth = {'Z_gb': zg, '2Z': tz, 'F_s': sim_cfg.seal_friction, 'mu_b': sim_cfg.mu_bushing, 'mu_g': sim_cfg.mu_guide}
    temp = sim_cfg.effect('temp_friction')
    v.by_motion, v.per_finding, v.per_last = [], {}, {}
    quiet = tz < cfg.clearance_warn_share * cfg.limit_2z and zg < cfg.clearance_warn_share * cfg.limit_zgb
    seen = None

    def second(o: DiagOut) -> None:
        nonlocal seen
        f = mon.finding
        if f is None or mon.gaps_source != 'estimated':
            return
        if f is not seen:
            seen = f
            v.findings += 1
            v.by_motion.append((f.motion_s, _holds(f.z_gb.lo, f.z_gb.hi, zg), abs(f.z_gb.value - zg) <= 0.03e-3))
            v.zgb_findings_held += _holds(f.z_gb.lo, f.z_gb.hi, zg)
            v.tz_findings_held += _holds(f.two_z.lo, f.two_z.hi, tz)
            _count(v.per_finding, f, truth, temp)
            if math.isnan(v.first_estimated_motion_s):
                v.first_estimated_motion_s = mon.motion_s
        v.seconds += 1
        v.zgb_held += _holds(f.z_gb.lo, f.z_gb.hi, zg)
        v.tz_held += _holds(f.two_z.lo, f.two_z.hi, tz)
        st = next(st for st in o.statuses if st.name.endswith('clearances'))
        v.alarms += st.level in (WARN, ERROR)
        v.false_alarms += st.level in (WARN, ERROR) and quiet
        v.not_assessed += not st.assessed

    for frame in s.frames.frames():
        for o in p.feed(frame):
            if isinstance(o, DiagOut):
                second(o)
    for o in p.finish():
        if isinstance(o, DiagOut):
            second(o)
    if seen is not None:
        _count(v.per_last, seen, truth, temp)
        v.last_zgb_held = _holds(seen.z_gb.lo, seen.z_gb.hi, zg)
        v.last_tz_held = _holds(seen.two_z.lo, seen.two_z.hi, tz)
        hi = 'n/a' if seen.z_gb.hi is None else f'{seen.z_gb.hi * 1e3:.3f}'
        lo = 'n/a' if seen.z_gb.lo is None else f'{seen.z_gb.lo * 1e3:.3f}'
        v.last_zgb = f'{seen.z_gb.value * 1e3:.3f} [{lo}, {hi}]'
        v.last_verdict = seen.verdict + (f' ({", ".join(e.name for e in seen.model)})' if seen.model else '')
    return v


def _share(hits: int, n: int) -> str:
    from steer_monitor.studies.accuracy import coverage_interval
    if n == 0:
        return '-'
    lo, hi = coverage_interval(hits, n)
    return f'{hits / n:.3f} ({hits}/{n}; {lo:.2f}-{hi:.2f})'


def _quantity_row(q: str, rows: list) -> str:
    def part(attr: str, two: bool) -> str:
        t = [sum(getattr(v, attr).get(q, [0, 0, 0, 0])[k] for v in rows) for k in range(4)]
        return _share(t[1], t[0]) if two else (f'{t[3]}/{t[2]}' if t[2] else '-')
    return (f'| {q} | {part("per_finding", True)} | {part("per_finding", False)} | {part("per_last", True)} '
            f'| {part("per_last", False)} |')


def main(argv: list[str]) -> int:
    from steer_monitor.params import load_params_file
    from steer_monitor.resources import default_config
    from steer_monitor.studies.accuracy import off_grid_cases

    out = argv[1] if len(argv) > 1 else None
    first_seed = int(argv[2]) if len(argv) > 2 else FIRST_SEED
    cases = off_grid_cases(['realistic'], N, first_seed=first_seed)
    voyages = [Voyage(c.seed, c.two_z_mm, c.z_gb_mm, '') for c in cases]
    voyages += [Voyage(c.seed + 100, c.two_z_mm, c.z_gb_mm, EFFECTS[k % len(EFFECTS)]) for k, c in enumerate(cases)]
    with ProcessPoolExecutor(2) as pool:
        done = list(pool.map(run, voyages))
    params = load_params_file(default_config())
    lines = [
        '# The node\'s clearances against the truth, second by second',
        '',
        'Generated by `docs/studies/accuracy_online.py` (its docstring says how): the node\'s pipeline over '
        f'{len(done)} simulated `{PROGRAM}` voyages with true clearances off the estimator\'s grid, '
        f'schedule of `config/r18.yaml` (window {params["estimator.window_motion_h"]:g} h of motion, the '
        f'residual loop at {params["estimator.first_motion_s"]:g} s of motion, as it doubles, then every '
        f'{params["estimator.loop_every_motion_s"]:g} s, '
        f'the estimate under its model every {params["estimator.every_motion_s"]:g} s). Seeds from {first_seed}. '
        'Shares with their Wilson 95 % intervals; seconds of one '
        'voyage are not independent (one finding stands for minutes), so the seconds\' interval is too '
        'narrow: the findings\' and the voyages\' say more.',
        '',
    ]
    for label, rows in (('clean (the declared model)', [v for v in done if not v.effect]),
                        ('one effect the declared model lacks', [v for v in done if v.effect])):
        sec = sum(v.seconds for v in rows)
        fnd = sum(v.findings for v in rows)
        lines += [
            f'## {label}',
            '',
            '| | Z_gb interval holds the truth | 2Z interval (or lower bound) holds the truth |',
            '|---|---|---|',
            f'| estimated seconds | {_share(sum(v.zgb_held for v in rows), sec)} | '
            f'{_share(sum(v.tz_held for v in rows), sec)} |',
            f'| findings applied | {_share(sum(v.zgb_findings_held for v in rows), fnd)} | '
            f'{_share(sum(v.tz_findings_held for v in rows), fnd)} |',
            f'| last finding of each voyage | {_share(sum(v.last_zgb_held for v in rows), len(rows))} | '
            f'{_share(sum(v.last_tz_held for v in rows), len(rows))} |',
            '',
            'Each quantity over the findings applied and the last finding of each voyage: two-sided 95 % '
            'intervals holding the truth, and lower bounds at or below it (F_s, mu_b, mu_g: the simulator\'s '
            '9000 N, 0.13, 0.05; a friction not determined counts in neither).',
            '',
            '| quantity | findings: two-sided holding the truth | findings: lower bounds at or below it '
            '| last findings: two-sided holding the truth | last findings: lower bounds at or below it |',
            '|---|---|---|---|---|',
            *(_quantity_row(q, rows) for q in QUANTITIES),
            '',
            f'Clearance WARN/ERROR seconds: {sum(v.alarms for v in rows)}, of which '
            f'{sum(v.false_alarms for v in rows)} on voyages whose true clearances are both under the warning '
            f'share of their limits (false alarms). NOT ASSESSED seconds: {sum(v.not_assessed for v in rows)} of '
            f'{sec} estimated.',
            '',
            '| seed | effect | true 2Z mm | true Z_gb mm | first estimate at s of motion | estimated seconds | '
            'Z_gb held (seconds) | findings | Z_gb held (findings) | last Z_gb mm | last verdict | alarm seconds |',
            '|---:|---|---:|---:|---:|---:|---:|---:|---:|---|---|---:|',
        ]
        for v in rows:
            lines.append(f'| {v.seed} | {v.effect or "-"} | {v.two_z_mm:.4f} | {v.z_gb_mm:.4f} | '
                         f'{v.first_estimated_motion_s:.0f} | {v.seconds} | '
                         f'{v.zgb_held / v.seconds if v.seconds else math.nan:.2f} | {v.findings} | '
                         f'{v.zgb_findings_held}/{v.findings} | {v.last_zgb} | {v.last_verdict} | {v.alarms} |')
        lines.append('')
    lines += ['## All 32 voyages', '',
              'Each quantity over every finding applied and every voyage\'s last finding, clean and with an effect '
              'together.', '',
              '| quantity | findings: two-sided holding the truth | findings: lower bounds at or below it '
              '| last findings: two-sided holding the truth | last findings: lower bounds at or below it |',
              '|---|---|---|---|---|',
              *(_quantity_row(q, done) for q in QUANTITIES), '']
    lines += ['## Findings by the motion they were made of', '',
              'Every finding applied on the 32 voyages, by the steady motion its analysis held: the share whose Z_gb '
              'interval holds the truth and whose value lies within 0.03 mm of it.', '',
              '| motion analysed s | findings | Z_gb interval holds the truth | Z_gb within 0.03 mm |',
              '|---|---:|---|---|']
    edges = (0, 60, 150, 300, 600, 1200, math.inf)
    rows_m = [r for v in done for r in v.by_motion]
    for lo, hi in zip(edges, edges[1:]):
        sel = [r for r in rows_m if lo <= r[0] < hi]
        if sel:
            lines.append(f'| {lo:g}-{hi:g} | {len(sel)} | {_share(sum(r[1] for r in sel), len(sel))} | '
                         f'{_share(sum(r[2] for r in sel), len(sel))} |')
    lines.append('')
    text = '\n'.join(lines)
    if out:
        with open(out, 'w', encoding='utf-8') as fh:
            fh.write(text)
    print(text)
    return 0


if __name__ == '__main__':
    sys.exit(main(sys.argv))
