"""``steer-monitor backlash CHAIN.yaml``: backlash of a kinematic chain at the ram and the
rudder, and which IT grade keeps it within a limit."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import TextIO

from steer_monitor.cli.options import add_force_option, add_json_option
from steer_monitor.cli.output import check_json_target, emit_json, json_to_stdout
from steer_monitor.studies.chain import backlash_summary, write_backlash

__all__ = ['register', 'run']


def run(chain_path: str | Path, angle_deg: float = 0.0, limit_arcmin: float | None = None,
        basis: str = 'worst', json_out: str | Path | None = None, out: TextIO | None = None) -> int:
    out = out or sys.stdout
    check_json_target(json_out, [chain_path])
    s = backlash_summary(chain_path, angle_deg, limit_arcmin, basis)
    emit_json(s, json_out, out)
    if json_to_stdout(json_out):
        return 0
    write_backlash(s, out)
    return 0


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser('backlash', help='backlash of a kinematic chain from its fits',
                       description='Backlash of a kinematic chain (paper 000) at the ram and at the rudder.')
    p.add_argument('chain', help='chain YAML file, e.g. config/r18_chain.yaml')
    p.add_argument('--angle-deg', type=float, default=0.0, help='rudder angle to reduce to [deg]')
    p.add_argument('--limit-arcmin', type=float, help='find the coarsest IT grade within this backlash')
    p.add_argument('--basis', choices=('worst', 'probable'), default='worst',
                   help='which bound the limit applies to (default worst)')
    add_json_option(p, 'the chain, its clearances and the angles')
    add_force_option(p)
    p.set_defaults(handler=lambda a: run(a.chain, a.angle_deg, a.limit_arcmin, a.basis, a.json_out))
