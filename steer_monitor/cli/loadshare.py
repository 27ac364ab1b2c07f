"""``steer-monitor loadshare``: ram / guide-beam load sharing over the rudder range."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import TextIO

from steer_monitor.cli.options import add_config_option, add_force_option, add_json_option
from steer_monitor.cli.output import check_json_target, emit_json, json_to_stdout, table, text_stream
from steer_monitor.model.loadshare import case_words
from steer_monitor.params import gear_from_params, given_gaps, load_config
from steer_monitor.studies.tables import loadshare_rows

__all__ = ['register', 'run']

def run(config: str | Path | None = None, gap_2z_mm: float | None = None,
        gap_zgb_mm: float | None = None, speed_kn: float | None = None,
        plot: str | Path | None = None, step_deg: float = 0.5, json_out: str | Path | None = None,
        out: TextIO | None = None) -> int:
    out = out or sys.stdout
    out = text_stream([json_out, plot], out, sys.stderr)
    check_json_target(json_out, [config, plot])
    _, params = load_config(config)
    gear = gear_from_params(params)
    gaps = given_gaps(params, gap_2z_mm, gap_zgb_mm)
    s, (alpha, res, marks) = loadshare_rows(gear, gaps, speed_kn, step_deg)
    if plot is not None:
        from steer_monitor.studies.plots import plot_load_sharing
        title = (f"{params['gear.name']}: 2Z = {s['clearance_2z_mm']:.3f} mm, "
                 f"Z_gb = {s['clearance_zgb_mm']:.3f} mm, {s['speed_kn']:.1f} kn")
        s['plot'] = str(plot_load_sharing(alpha, res, plot, title, marks))
    emit_json(s, json_out, out)
    if json_to_stdout(json_out):
        return 0
    out.write(f"{params['gear.name']}: 2Z = {s['clearance_2z_mm']:.3f} mm, Z_gb = {s['clearance_zgb_mm']:.3f} mm, "
              f"speed {s['speed_kn']:.1f} kn\n")
    table(['alpha deg', 'M kN m', 'Fl kN', 'Fr kN', 'Fgb kN', 'K_gl', 'defl mm', 'carried by (paper 004)'],
          [[f"{r['alpha_deg']:.1f}", f"{r['torque_knm']:.1f}", f"{r['f_lateral_n'] / 1e3:.1f}",
            f"{r['f_ram_n'] / 1e3:.1f}", f"{r['f_guide_n'] / 1e3:.1f}", f"{r['k_gl']:.3f}",
            f"{r['deflection_mm']:.4f}", case_words(r['case'])] for r in s['rows']], out)
    lm = s['landmarks']

    rows = s['rows']
    onset = ('the guide beam never carries load' if lm['guide_onset_deg'] is None
             else f"the guide beam carries load from {lm['guide_onset_deg']:.1f} deg")
    if lm['crossover_deg'] is not None:
        cross = f"F_r = F_gb at {lm['crossover_deg']:.1f} deg"
    elif any(r['f_guide_n'] > r['f_ram_n'] for r in rows):
        cross = 'the guide beam carries more than the rams wherever it carries'
    else:
        cross = 'the guide beam never carries as much as the rams'
    clamp = ('the ram never clamps in its bushing' if lm['clamp_onset_deg'] is None
             else f"the ram clamps in its bushing from {lm['clamp_onset_deg']:.1f} deg")
    out.write(f"\n{onset}; {cross}; max K_gl {lm['k_gl_max']:.3f} at {lm['k_gl_max_deg']:.1f} deg; {clamp}\n")
    if plot is not None:
        out.write(f"plot: {s['plot']}\n")
    return 0


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser('loadshare', help='ram / guide-beam load sharing over the rudder range',
                       description='Load sharing between ram and guide beam (paper 004), '
                                   'a row per step from 0 to the largest rudder angle.')
    add_config_option(p)
    p.add_argument('--gap-2z', type=float, help='ram/bushing diametral clearance 2Z [mm] (default: config)')
    p.add_argument('--gap-zgb', type=float, help='slipper/guide-beam clearance Z_gb [mm] (default: config)')
    p.add_argument('--speed-kn', type=float, help='ship speed [kn] (default: the service speed)')
    p.add_argument('--step-deg', type=float, default=0.5, help='angle step [deg] (default 0.5)')
    p.add_argument('--plot', help='write the Fig. 7 plot to this PNG')
    add_json_option(p, 'the table and its landmarks')
    add_force_option(p)
    p.set_defaults(handler=lambda a: run(a.config, a.gap_2z, a.gap_zgb, a.speed_kn, a.plot,
                                         a.step_deg, a.json_out))
