"""The tables of the paper-level studies, in engineers' units: an ISO fit's limits and
clearances (paper 000 [2]), and the load sharing over rudder angle with its landmarks
(paper 004 [1], Fig. 7). ``steer-monitor fit``, ``loadshare`` and ``study`` print them."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from steer_monitor.errors import ParameterError
from steer_monitor.model.gear import Clearances, GearParams
from steer_monitor.model.isofits import parse_fit
from steer_monitor.model.landmarks import Landmarks, landmarks
from steer_monitor.model.loadshare import LoadSharing, load_sharing_at

__all__ = ['KNOT', 'MIN_STEP_DEG', 'ROW_KEYS', 'fit_summary', 'loadshare_rows']

ROW_KEYS = ('alpha_deg', 'torque_knm', 'f_lateral_n', 'f_ram_n', 'f_guide_n', 'k_gl',
            'deflection_mm', 'case')
KNOT = 1852.0 / 3600.0
MIN_STEP_DEG = 0.001    # 35,000 rows over the R-18's range; finer says nothing more and runs out of memory


def _deg_or_none(x: float | None) -> float | None:
    return None if x is None else round(math.degrees(x), 2)


def loadshare_rows(gear: GearParams, gaps: Clearances, speed_kn: float | None = None,
                   step_deg: float = 0.5) -> tuple[dict[str, Any], tuple[Any, LoadSharing, Landmarks]]:
    """The sweep 0..max rudder angle as rows (engineers' units) plus its landmarks, and the
    sweep itself (angles [rad], load sharing, landmarks) for plotting."""
    if not (math.isfinite(step_deg) and MIN_STEP_DEG <= step_deg <= 5):
        msg = f'--step-deg must lie in [{MIN_STEP_DEG:g}, 5], got {step_deg!r}'
        raise ParameterError(msg)
    if speed_kn is not None and not (math.isfinite(speed_kn) and 0 <= speed_kn <= 60):
        msg = f'--speed-kn must lie in [0, 60] kn, got {speed_kn!r}'
        raise ParameterError(msg)
    max_deg = math.degrees(gear.max_rudder)
    deg = np.round(np.arange(0.0, max_deg + 1e-9, step_deg), 6)
    alpha = np.radians(deg)
    speed = None if speed_kn is None else speed_kn * KNOT
    res = load_sharing_at(gear, alpha, gaps, speed)
    torque = gear.torque(alpha, speed)
    # rounded to what they mean: 0.01 deg, 1 N m, 0.1 N, 1e-4 of K_gl, 0.1 um of deflection
    rows = [dict(zip(ROW_KEYS, (round(float(deg[i]), 2), round(float(torque[i]) / 1e3, 3),
                                round(float(res.lateral[i]), 1), round(float(res.ram_force[i]), 1),
                                round(float(res.guide_force[i]), 1), round(float(res.k_gl[i]), 4),
                                round(float(res.deflection[i]) * 1e3, 4), int(res.case[i]))))
            for i in range(deg.size)]
    marks = landmarks(alpha, res)
    return {
        'clearance_2z_mm': round(gaps.two_z * 1e3, 4),
        'clearance_zgb_mm': round(gaps.z_gb * 1e3, 4),
        'speed_kn': speed_kn if speed_kn is not None else gear.torque.service_speed / KNOT,
        'landmarks': {
            'guide_onset_deg': _deg_or_none(marks.guide_onset),
            'crossover_deg': _deg_or_none(marks.crossover),
            'k_gl_max': round(marks.k_gl_max, 4),
            'k_gl_max_deg': round(math.degrees(marks.k_gl_max_angle), 2),
            'clamp_onset_deg': _deg_or_none(marks.clamp_onset),
        },
        'rows': rows,
    }, (alpha, res, marks)


def fit_summary(designation: str) -> dict[str, Any]:
    """The fit's tolerances and clearances in mm."""
    fit = parse_fit(designation)
    hole, shaft, cl = fit.hole, fit.shaft, fit.clearance
    mm = 1e3
    return {
        'fit': fit.designation,
        'hole_mm': {'upper': round(hole.upper * mm, 4), 'lower': round(hole.lower * mm, 4)},
        'shaft_mm': {'upper': round(shaft.upper * mm, 4), 'lower': round(shaft.lower * mm, 4)},
        'clearance_min_mm': round(cl.minimum * mm, 4),
        'clearance_max_mm': round(cl.maximum * mm, 4),
        'clearance_mean_mm': round(cl.mean * mm, 4),
        'probable_min_mm': round(cl.probable_min * mm, 4),
        'probable_max_mm': round(cl.probable_max * mm, 4),
    }
