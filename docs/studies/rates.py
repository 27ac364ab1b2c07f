"""What a slow gateway costs: the clearances and the alarms at the rates a gateway forwards.

Each case is one realistic voyage (``realistic:1500``, 25 minutes: speed changes, pump changes,
a dead-band autopilot, holds at odd angles, zigzags, up to two hard-overs), true clearances
drawn uniformly off the estimator's grid (2Z 0.1-0.6 mm, Z_gb 0.05-0.35 mm), forwarded by the
simulator's gateway (``steer_monitor/sim/gateway.py``: a rate per message, ``hold`` or
``decimate``, latency 20 ms and jitter 10 ms, timers off by up to 50 ppm, the bus bad 2 % of
the time in spells of 0.2 s, two outages of 3 s) at the angle's and the pressures' rates of
the case. Per case:

* ``analyze`` of the gateway's log and of the same voyage at full rate: whether each 95 %
  interval (2Z, Z_gb, K_gl max, F_s) holds the truth (a lower bound holds when at or below it),
  the width of the two-sided ones against the full rate's, and each clearance's level
  (NOT ASSESSED counted; a refusal is NOT ASSESSED for both, its reason kept);
* the node's pipeline over the gateway's log, its analyses on, the parameters' rates set to
  the gateway's (as ``discover`` writes them): every second at WARN or ERROR in every status
  once the inputs are fresh, false unless a clearance's truth is past its warning share;
* a frozen angle sensor (``angle_stuck`` at 300 s of ``realistic:900``) through the same
  gateway: when steering performance first says ERROR.

Run from the repository:
``.venv/bin/python docs/studies/rates.py OUT.md FIRST_SEED N [JOBS] [RATES] [PROGRAM] [CONFIG]`` (RATES: a
comma-separated list of ``angle_hz/pressure_hz/mode[/loss]``; the default is the grid below;
PROGRAM: the voyage's helm programme, ``realistic:1500`` unless given, e.g. ``realistic:7200``
for two hours; CONFIG: the gear's parameters file, the packaged R-18's unless given). Write
the JSON lines of each case beside OUT (OUT.jsonl) as they finish, so a long run can be read
before it ends. A rate may end in ``/LOSS``, the share of the time the bus is bad (2 % else).
"""

from __future__ import annotations

import json
import math
import os
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')
os.environ.setdefault('OPENBLAS_NUM_THREADS', '1')

PROGRAM = 'realistic:1500'
FROZEN_PROGRAM = 'realistic:900'
FROZEN_AT_S = 300.0
RATES = ('20/20/decimate', '10/10/decimate', '5/5/decimate', '2/2/decimate', '1/1/decimate', '0.5/0.5/decimate',
         '2/5/decimate', '10/0.5/decimate', '0.5/20/decimate',
         '5/5/hold', '2/5/hold', '2/2/hold', '0.5/0.5/hold')
QUANTITIES = ('clearance_2z_mm', 'clearance_zgb_mm', 'k_gl_max', 'seal_friction_n')
_W: dict = {}


def _setup(config: str = '') -> None:
    from steer_monitor.can.busconfig import can_setup
    from steer_monitor.params import load_params_file
    from steer_monitor.resources import default_config
    path = config or str(default_config())
    params = load_params_file(path)
    _W.update(path=path, params=params, can=can_setup(params, path))


def _gateway(rate: str, seed: int):
    """``angle_hz/pressure_hz/mode[/loss]``: the case's gateway (loss 2 % unless given)."""
    from steer_monitor.sim.gateway import Gateway
    a, p, mode, *loss = rate.split('/')
    return Gateway({127245: float(a), 130314: float(p)}, mode=mode, loss=float(loss[0]) if loss else 0.02,
                   burst_s=0.2, outages=((400.0 + seed % 97, 3.0), (900.0 + seed % 89, 3.0)))


def _analysis(gear, signals, params) -> dict:
    """Each quantity's interval and each clearance's level from ``analyze`` (or the refusal)."""
    from steer_monitor.ashore.loganalysis import headlines
    from steer_monitor.estimate.analyze import analyze
    from steer_monitor.estimate.observe import EstimateError
    from steer_monitor.params import min_clearance_2z_from_params
    try:
        a = analyze(gear, signals, min_clearance_2z=min_clearance_2z_from_params(params))
    except EstimateError as exc:
        return {'refused': str(exc)}
    f = a.final
    out = {}
    for q, iv, k in (('clearance_2z_mm', f.two_z, 1e3), ('clearance_zgb_mm', f.z_gb, 1e3),
                     ('k_gl_max', f.k_gl_max, 1.0), ('seal_friction_n', f.seal_friction, 1.0)):
        out[q] = [iv.value * k, None if iv.lo is None else iv.lo * k, None if iv.hi is None else iv.hi * k]
    h2, hz = headlines(a, params['clearances.limit_2z_mm'] * 1e-3, params['clearances.limit_zgb_mm'] * 1e-3,
                       params['diagnostics.clearance_warn_share'])
    out['levels'] = [h2.level, hz.level]
    out['verdict'] = a.verdict
    return out


def _node(params, frames, rate: str, with_analyses: bool):
    """The node's pipeline over ``frames`` with the parameters' rates set to the gateway's:
    [(t_ns, status)]."""
    from steer_monitor.can import Decoder, RejectCounter
    from steer_monitor.can.busconfig import can_setup
    from steer_monitor.model.inputs import PRESSURE_INPUTS
    from steer_monitor.monitor import DiagnosticsBuilder, DiagnosticsConfig, LiveMonitor
    from steer_monitor.monitor.pipeline import DiagOut, Pipeline, analyst_from_params
    from steer_monitor.params import friction_from_params, gaps_from_params, gear_from_params
    a, p = rate.split('/')[:2]
    params = dict(params, **{'signals.rudder_angle.rate_hz': float(a), 'signals.rudder_order.rate_hz': float(a)},
                  **{f'signals.{n}.rate_hz': float(p) for n in PRESSURE_INPUTS})
    db, smap = can_setup(params, _W['path'])
    gear = gear_from_params(params)
    rejects = RejectCounter()
    mon = LiveMonitor(gear, gaps_from_params(params), 'configured', friction_from_params(params),
                      angle_period_ns=smap.period_ns('rudder_angle'))
    diag = DiagnosticsBuilder(DiagnosticsConfig.from_params(params), smap, gear)
    pipe = Pipeline(Decoder(db, smap, rejects), rejects, mon, diag,
                    analyst_from_params(gear, params) if with_analyses else None)
    out = []
    for f in frames.frames():
        out += [(o.t_ns, st) for o in pipe.feed(f) if isinstance(o, DiagOut) for st in o.statuses]
    out += [(o.t_ns, st) for o in pipe.finish() if isinstance(o, DiagOut) for st in o.statuses]
    return out


def run_case(args: tuple) -> dict:
    seed, rate, two_z_mm, z_gb_mm, *program = args
    program = program[0] if program else PROGRAM
    import numpy as np

    from steer_monitor import sim
    from steer_monitor.can import Decoder
    from steer_monitor.estimate.batch import k_gl_max
    from steer_monitor.model import Clearances
    from steer_monitor.monitor.diagnostics import LEVEL_NAMES
    from steer_monitor.params import gear_from_params
    from steer_monitor.sim.gateway import forward
    t0 = time.perf_counter()
    params = _W['params']
    db, smap = _W['can']
    gear = gear_from_params(params)
    cfg = sim.SimConfig(program=program, gaps=Clearances.from_mm(two_z_mm, z_gb_mm), max_duration_s=86400.0)
    s = sim.run(params, cfg, db, smap, seed)
    frames = forward(s.frames, _gateway(rate, seed), db, seed + 1)
    full = _analysis(gear, Decoder(db, smap).decode_arrays(s.frames, final=True), params)
    slow = _analysis(gear, Decoder(db, smap).decode_arrays(frames, final=True), params)
    # K_gl max of the true gear over the angles the voyage reached, at service speed
    angles = np.radians(np.arange(0.0, float(np.degrees(np.abs(s.plant.alpha).max())) + 1e-9, 0.5))
    truth = {'clearance_2z_mm': two_z_mm, 'clearance_zgb_mm': z_gb_mm, 'seal_friction_n': cfg.seal_friction,
             'k_gl_max': float(k_gl_max(gear, angles, gear.torque(angles), cfg.gaps.two_z, cfg.gaps.z_gb)[0])}
    # the node: every WARN/ERROR second after the inputs are fresh; a clearance's is true only
    # where its truth is past the warning share of its limit
    statuses = _node(params, frames, rate, True)
    fresh = next((t for t, st in statuses if st.name.endswith('CAN input') and st.level == 0), None)
    warn = params['diagnostics.clearance_warn_share']
    truly_worn = (two_z_mm >= warn * params['clearances.limit_2z_mm']
                  or z_gb_mm >= warn * params['clearances.limit_zgb_mm'])
    # the guide beam truly idle past its warning angle on the true clearances: its WARN is true
    from steer_monitor.monitor import DiagnosticsBuilder, DiagnosticsConfig
    onset = DiagnosticsBuilder(DiagnosticsConfig.from_params(params), smap, gear).guide_onset_deg(cfg.gaps)
    truly_idle = onset is None or onset > params['diagnostics.guide_idle_warn_deg']
    alarms: dict[str, int] = {}
    first_alarm = {}
    for t, st in statuses:
        if fresh is not None and t >= fresh and st.level in (1, 2):
            name = st.name.split(': ', 1)[1]
            if (name == 'clearances' and truly_worn) or (name == 'guide beam' and truly_idle):
                continue
            key = f'{name}/{LEVEL_NAMES[st.level]}'
            alarms[key] = alarms.get(key, 0) + 1
            first_alarm.setdefault(key, [round((t - s.frames.t_ns[0]) / 1e9), st.message[:200]])
    # the frozen sensor through the same gateway
    cfg_f = sim.SimConfig(program=FROZEN_PROGRAM, gaps=Clearances.from_mm(two_z_mm, z_gb_mm),
                          effects=(sim.parse_effect(f'angle_stuck:start_s={FROZEN_AT_S:g}'),))
    sf = sim.run(params, cfg_f, db, smap, seed)
    ff = forward(sf.frames, _gateway(rate, seed), db, seed + 1)
    perf = [(t, st) for t, st in _node(params, ff, rate, False) if st.name.endswith('steering performance')]
    t0f = int(sf.frames.t_ns[0])
    early = [round((t - t0f) / 1e9) for t, st in perf if st.level in (1, 2) and (t - t0f) / 1e9 < FROZEN_AT_S]
    found = next(((t - t0f) / 1e9 for t, st in perf if st.level == 2 and (t - t0f) / 1e9 >= FROZEN_AT_S), None)
    return {'seed': seed, 'rate': rate, 'program': program, 'truth': truth, 'full': full, 'slow': slow,
            'alarms': alarms, 'first_alarm': first_alarm,
            'frozen_found_s': None if found is None else round(found - FROZEN_AT_S, 1),
            'frozen_false_before': early[:5], 'seconds': round(time.perf_counter() - t0, 1)}


def _holds(iv, truth) -> bool:
    v, lo, hi = iv
    return (lo is None or lo <= truth * (1 + 1e-9)) and (hi is None or truth <= hi * (1 + 1e-9))


def _said(rate: str) -> str:
    a, p, mode, *loss = rate.split('/')
    return f'{a} / {p} / {mode}' + (f' ({float(loss[0]):.0%} lost)' if loss else '')


def _wilson(k: int, n: int) -> str:
    if n == 0:
        return '-'
    z = 1.959964
    p = k / n
    d = 1 + z * z / n
    c = (p + z * z / (2 * n)) / d
    h = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / d
    return f'{k}/{n} [{max(c - h, 0):.2f}, {min(c + h, 1):.2f}]'


def markdown(results: list[dict], command: str) -> str:
    lines = ['# Accuracy and alarms at the rates a gateway forwards', '',
             f'Made by `{command}` (docs/studies/rates.py; its docstring says what each case is). '
             'Seeds: as the command gives them, used for no choice. Gateway: latency 20 ms, jitter 10 ms, '
             'timers off by up to 50 ppm, the bus bad 2 % of the time in spells of 0.2 s, two outages of 3 s.', '',
             '## The clearances, against the same voyages at full rate', '',
             'Coverage: logs whose 95 % interval holds the truth (a lower bound holds at or below it), with a Wilson '
             '95 % interval; width: the median ratio of two-sided intervals to the full rate\'s on the same voyage; '
             'NOT ASSESSED: the share of clearance levels (2Z and Z_gb of each log) not assessed, a refusal counting '
             'both, beside the full rate\'s.', '',
             '| angle Hz / pressures Hz / mode | logs | refused | 2Z | Z_gb | K_gl max | F_s | width 2Z / Z_gb / K_gl '
             '/ F_s | NOT ASSESSED (full rate) | analysis s |',
             '|---|---|---|---|---|---|---|---|---|---|']
    by_rate: dict[str, list[dict]] = {}
    for r in results:
        by_rate.setdefault(r['rate'], []).append(r)
    for rate, rs in by_rate.items():
        cov, widths = {}, {}
        for q in QUANTITIES:
            held = [_holds(r['slow'][q], r['truth'][q]) for r in rs if 'refused' not in r['slow']]
            cov[q] = _wilson(sum(held), len(held))
            ratios = [(r['slow'][q][2] - r['slow'][q][1]) / (r['full'][q][2] - r['full'][q][1]) for r in rs
                      if 'refused' not in r['slow'] and 'refused' not in r['full']
                      and None not in r['slow'][q][1:] and None not in r['full'][q][1:]
                      and r['full'][q][2] > r['full'][q][1]]
            widths[q] = f'{sorted(ratios)[len(ratios) // 2]:.1f}' if ratios else '-'
        refused = sum('refused' in r['slow'] for r in rs)
        na = sum(2 if 'refused' in r['slow'] else sum(lv == 'NOT ASSESSED' for lv in r['slow']['levels']) for r in rs)
        na_full = sum(2 if 'refused' in r['full'] else sum(lv == 'NOT ASSESSED' for lv in r['full']['levels'])
                      for r in rs)
        secs = sorted(r['seconds'] for r in rs)[len(rs) // 2]
        lines.append(f'| {_said(rate)} | {len(rs)} | {refused} | ' + ' | '.join(cov[q] for q in QUANTITIES)
                     + f' | {" / ".join(widths[q] for q in QUANTITIES)} | {na / (2 * len(rs)):.0%} '
                     f'({na_full / (2 * len(rs)):.0%}) | {secs:.0f} |')
    lines += ['', '## Alarms, and a frozen angle sensor', '',
              'Seconds at WARN or ERROR in any status of the node over the gateway\'s log, its analyses on, once the '
              'inputs are fresh (a clearance\'s alarm counted false unless its truth is past the warning share, the '
              'guide beam\'s unless on the true clearances it is idle past its warning angle; '
              'STALE, a silent input, is not counted: the outages are silences); and, on a second voyage with the '
              'angle sensor frozen at 300 s, how long until steering performance said ERROR (the rule: 5 s after an '
              'order step a degree away, at the first angle sample from then on), and any alarm before the freeze.',
              '', '| angle Hz / pressures Hz / mode | false alarm seconds (status: seconds) | frozen sensor: '
              'ERROR after (median, max) | alarms before the freeze |', '|---|---|---|---|']
    for rate, rs in by_rate.items():
        alarms: dict[str, int] = {}
        for r in rs:
            for k, n in r['alarms'].items():
                alarms[k] = alarms.get(k, 0) + n
        found = sorted(r['frozen_found_s'] for r in rs if r['frozen_found_s'] is not None)
        missed = sum(r['frozen_found_s'] is None for r in rs)
        before = sum(len(r['frozen_false_before']) for r in rs)
        said = ', '.join(f'{k}: {n}' for k, n in sorted(alarms.items())) or 'none'
        fz = (f'{found[len(found) // 2]:.0f} s, {found[-1]:.0f} s' if found else '-') + (
            f' ({missed} not found)' if missed else '')
        lines.append(f'| {_said(rate)} | {said} | {fz} | {before} |')
    return '\n'.join(lines) + '\n'


def main() -> int:
    out = Path(sys.argv[1])
    first, n = int(sys.argv[2]), int(sys.argv[3])
    jobs = int(sys.argv[4]) if len(sys.argv) > 4 else 2
    rates = tuple(sys.argv[5].split(',')) if len(sys.argv) > 5 else RATES
    program = sys.argv[6] if len(sys.argv) > 6 else PROGRAM
    config = sys.argv[7] if len(sys.argv) > 7 else ''
    import numpy as np
    rng = np.random.default_rng(first)
    clearances = [(round(float(rng.uniform(0.1, 0.6)), 4), round(float(rng.uniform(0.05, 0.35)), 4))
                  for _ in range(n)]
    todo = [(first + k, rate, *clearances[k], program) for k in range(n) for rate in rates]
    jsonl = out.with_suffix('.jsonl')
    results = []
    with ProcessPoolExecutor(jobs, initializer=_setup, initargs=(config,)) as pool, open(jsonl, 'w') as fh:
        for r in pool.map(run_case, todo):
            results.append(r)
            fh.write(json.dumps(r) + '\n')
            fh.flush()
    command = f'.venv/bin/python docs/studies/rates.py {out} {first} {n}' + (
        f' {jobs}' if len(sys.argv) > 4 else '') + (f' {sys.argv[5]}' if len(sys.argv) > 5 else '') + (
        f' {program}' if len(sys.argv) > 6 else '') + (f' {config}' if len(sys.argv) > 7 else '')
    out.write_text(markdown(results, command))
    return 0


if __name__ == '__main__':
    sys.exit(main())
