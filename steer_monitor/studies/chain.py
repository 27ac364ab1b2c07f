"""The backlash of a kinematic chain from its fits (paper 000 [2]): the clearances at the ram
and the rudder, and which IT grade keeps it within a limit. ``steer-monitor backlash`` and
``study`` print it."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any, TextIO

from steer_monitor.chainfile import load_chain
from steer_monitor.errors import ParameterError
from steer_monitor.model.backlash import chain_backlash, grade_for_limit, rapson_arm
from steer_monitor.texttable import table

__all__ = ['ARCMIN', 'backlash_summary', 'write_backlash']

ARCMIN = math.radians(1.0 / 60.0)


def backlash_summary(chain_path: str | Path, angle_deg: float = 0.0,
                     limit_arcmin: float | None = None, basis: str = 'worst') -> dict[str, Any]:
    """The chain of ``chain_path`` (a YAML file) reduced to the rudder at ``angle_deg``, in mm
    and arc minutes; with ``limit_arcmin``, the IT grades checked against it on ``basis``
    ('worst' or 'probable')."""
    if limit_arcmin is not None and not (math.isfinite(limit_arcmin) and limit_arcmin > 0):
        msg = f'--limit-arcmin must be a positive number of arc minutes, got {limit_arcmin:g}'
        raise ParameterError(msg)
    chain = load_chain(chain_path)
    if not abs(angle_deg) <= math.degrees(chain.max_rudder):
        msg = f'--angle-deg {angle_deg:g} is outside the chain\'s range +-{math.degrees(chain.max_rudder):g} deg'
        raise ParameterError(msg)
    res = chain_backlash(chain.joints, chain.actuator_mean, chain.actuator_dev)
    arm_at = float(rapson_arm(chain.stock_to_ram, math.radians(angle_deg)))
    arm_min = float(rapson_arm(chain.stock_to_ram, 0.0))  # H / cos^2 is smallest at midships
    at = res.angle(arm_at)
    worst = res.angle(arm_min)
    out: dict[str, Any] = {
        'chain': chain.name,
        'joints': [{
            'name': j.name,
            'fit': j.fit.designation if j.fit else None,
            'coefficient': j.coefficient,
            'clearance_mean_mm': round(j.clearance.mean * 1e3, 4),
            'probable_dev_mm': round(j.clearance.probable_dev * 1e3, 4),
            'worst_dev_mm': round(j.clearance.worst_dev * 1e3, 4),
        } for j in chain.joints],
        'rod_mm': {'mean': round(res.mean * 1e3, 4), 'probable_dev': round(res.probable_dev * 1e3, 4),
                   'worst_dev': round(res.worst_dev * 1e3, 4),
                   'probable_max': round((res.mean + res.probable_dev) * 1e3, 4),
                   'worst_max': round((res.mean + res.worst_dev) * 1e3, 4)},
        'angle_deg': angle_deg,
        'at_angle_arcmin': {k: round(float(v) / ARCMIN, 3) for k, v in at.items()},
        'worst_angle_deg': 0.0,
        'at_worst_angle_arcmin': {k: round(float(v) / ARCMIN, 3) for k, v in worst.items()},
    }
    if limit_arcmin is not None:
        grade, checks = grade_for_limit(chain.joints, limit_arcmin * ARCMIN, arm_min,
                                        chain.actuator_mean, chain.actuator_dev, basis)
        out['limit'] = {
            'limit_arcmin': limit_arcmin, 'basis': basis, 'coarsest_grade': grade,
            'grades': [{'grade': c.grade, 'probable_max_arcmin': c.probable_max / ARCMIN,
                        'worst_max_arcmin': c.worst_max / ARCMIN, 'within': c.within}
                       for c in checks],
        }
    return out


def write_backlash(s: dict[str, Any], out: TextIO) -> None:
    """:func:`backlash_summary`'s answer as text for people."""
    out.write(f"chain: {s['chain']}\n")
    table(['joint', 'fit', 'c', 'mean mm', 'RSS mm', 'worst mm'],
          [[j['name'], j['fit'] or 'deviations', f"{j['coefficient']:g}", f"{j['clearance_mean_mm']:.3f}",
            f"{j['probable_dev_mm']:.3f}", f"{j['worst_dev_mm']:.3f}"] for j in s['joints']], out)
    r = s['rod_mm']
    out.write(f"\nat the ram: {r['mean']:.3f} mm, probable +-{r['probable_dev']:.3f}, "
              f"worst +-{r['worst_dev']:.3f} (max {r['worst_max']:.3f} mm)\n")
    a, w = s['at_angle_arcmin'], s['at_worst_angle_arcmin']
    out.write(f"at the rudder, alpha = {s['angle_deg']:g} deg: {a['mean']:.2f}' "
              f"(probable {a['probable_min']:.2f}..{a['probable_max']:.2f}', worst max {a['worst_max']:.2f}')\n")
    out.write(f"at the rudder, worst angle (midships, smallest arm): {w['mean']:.2f}' "
              f"(probable max {w['probable_max']:.2f}', worst max {w['worst_max']:.2f}')\n")
    if 'limit' in s:
        lim = s['limit']
        out.write(f"\nlimit {lim['limit_arcmin']:g}' ({lim['basis']} case, at midships):\n")
        table(['grade', "probable max '", "worst max '", 'within'],
              [[f"IT{g['grade']}", f"{g['probable_max_arcmin']:.2f}", f"{g['worst_max_arcmin']:.2f}",
                'yes' if g['within'] else 'no'] for g in lim['grades']], out)
        grade = lim['coarsest_grade']
        out.write(f"=> coarsest grade within the limit: IT{grade}\n" if grade is not None else
                  '=> no grade IT5..IT11 keeps the chain within the limit '
                  '(the joints given by deviations or the actuator already exceed it)\n')
