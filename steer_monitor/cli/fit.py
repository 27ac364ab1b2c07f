"""``steer-monitor fit "240 H9/f9"``: limits, mean and probable clearance of an ISO fit."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import TextIO

from steer_monitor.cli.options import add_force_option, add_json_option
from steer_monitor.cli.output import check_json_target, emit_json, json_to_stdout
from steer_monitor.studies.tables import fit_summary

__all__ = ['register', 'run']


def run(designation: str, json_out: str | Path | None = None, out: TextIO | None = None) -> int:
    out = out or sys.stdout
    check_json_target(json_out)
    s = fit_summary(designation)
    emit_json(s, json_out, out)
    if json_to_stdout(json_out):
        return 0
    out.write(f"fit {s['fit']}\n"
              f"  hole  deviations  {s['hole_mm']['upper']:+.3f} / {s['hole_mm']['lower']:+.3f} mm\n"
              f"  shaft deviations  {s['shaft_mm']['upper']:+.3f} / {s['shaft_mm']['lower']:+.3f} mm\n"
              f"  clearance limits  {s['clearance_min_mm']:.3f} .. {s['clearance_max_mm']:.3f} mm (worst case)\n"
              f"  mean clearance    {s['clearance_mean_mm']:.3f} mm\n"
              f"  probable          {s['probable_min_mm']:.3f} .. {s['probable_max_mm']:.3f} mm (root-sum-square)\n")
    if s['clearance_min_mm'] < 0:
        kind = ('an interference fit' if s['clearance_max_mm'] <= 0 else
                'a transition fit: from interference to clearance')
        out.write(f"  a negative clearance is interference (the shaft larger than the hole): {kind}\n")
    return 0


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser('fit', help='limits and probable clearance of an ISO 286 fit',
                       description='Limits, mean and probable clearance of a hole-basis ISO 286 fit (paper 000).')
    p.add_argument('designation', help='e.g. "240 H9/f9" (nominal mm, H hole, shaft letter and grade)')
    add_json_option(p, 'the limits and clearances')
    add_force_option(p)
    p.set_defaults(handler=lambda a: run(a.designation, a.json_out))
