"""The clearances a log's page, the fleet and ``analyze`` give: ``analyze`` of its last hours.

A review on the batch path (:mod:`~steer_monitor.ashore.review`) fits the declared model to
windows of the log, for the clearances over time; what the gear is *now* is the residual
loop's answer (:func:`~steer_monitor.estimate.analyze.analyze`), which names an effect the
declared model lacks and refits with it, or says the model does not explain the data. This
module runs it on the last ``hours`` of a log's data (:data:`ANALYSIS_HOURS` by default: on
a longer log the check is about the gear as it is now and its cost stays bounded; on a shorter
one it is ``steer-monitor analyze`` of the whole log) and turns its answer into each
clearance's headline: the estimate with its interval and the level the page shows.
"""

from __future__ import annotations

import datetime
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from steer_monitor.estimate.analyze import Analysis, analyze
from steer_monitor.estimate.intervals import Interval
from steer_monitor.estimate.observe import EstimateError
from steer_monitor.monitor.verdict import LABELS, NOT_ASSESSED, assess_hint, clearance_verdict

__all__ = ['ANALYSIS_HOURS', 'NOT_JUDGED', 'Headline', 'headline_json', 'headline_text', 'headlines', 'model_check']

#: hours of data at a log's end the check looks at (``report --analysis-hours``)
ANALYSIS_HOURS = 3.0
#: the level of a clearance the data do not assess: no estimate, a lower bound below the warning,
#: an interval too wide, or one from a model that does not explain the data (one word everywhere)
NOT_JUDGED = LABELS[NOT_ASSESSED]


def model_check(paths: Sequence[str | Path], params: Mapping[str, Any], config_path: str | Path,
                end_ns: int, hours: float = ANALYSIS_HOURS, date: datetime.date | None = None
                ) -> tuple[Analysis | None, str]:
    """``analyze`` of the data of ``paths`` from ``hours`` before ``end_ns`` (the last data
    time, ns) on; (None, why) when it cannot be made. Breaks in the logs are the review's to
    report (read here again)."""
    from steer_monitor.can.busconfig import can_setup
    from steer_monitor.can.rejects import RejectCounter
    from steer_monitor.logfiles.decodelog import decode_logs
    from steer_monitor.params import gear_from_params, min_clearance_2z_from_params, ram_share_warn_from_params

    db, smap = can_setup(params, config_path)
    logs = decode_logs(paths, db, smap, RejectCounter(), since_ns=int(end_ns - hours * 3.6e12), date=date)
    if logs.first_ns is None:
        return None, 'no data for the model check'
    try:
        return analyze(gear_from_params(params), logs.signals, min_clearance_2z=min_clearance_2z_from_params(params),
                       ram_share_warn=ram_share_warn_from_params(params)), ''
    except EstimateError as exc:
        return None, f'model check not made: {exc}'


@dataclass(frozen=True)
class Headline:
    """One clearance as the page shows it: its estimate (None: none), the level (``OK``,
    ``WARN``, ``OVER LIMIT`` or ``NOT ASSESSED``), the limit [m] and a note ('' or why)."""

    name: str
    estimate: Interval | None
    level: str
    limit: float
    note: str


def headlines(analysis: Analysis | None, limit_2z: float, limit_zgb: float, warn_share: float
              ) -> tuple[Headline, Headline]:
    """2Z and Z_gb from the model check: judged as the node's diagnostics judge them
    (:func:`~steer_monitor.monitor.verdict.clearance_verdict`), or not judged when there is
    no check or its model does not explain the data (the clearances then rest on an
    incomplete model)."""
    out = []
    for name, limit, attr in (('2Z', limit_2z, 'two_z'), ('Z_gb', limit_zgb, 'z_gb')):
        if analysis is None:
            out.append(Headline(name, None, NOT_JUDGED, limit,
                                f'not estimated (too little steady motion); {assess_hint(name)}'))
            continue
        iv = getattr(analysis.final, attr)
        why = analysis.final.bound_why[0 if attr == 'two_z' else 1]
        v = clearance_verdict(iv.value, iv.lo, iv.hi, limit, warn_share, name, why)
        if analysis.verdict == 'unexplained':
            out.append(Headline(name, iv, NOT_JUDGED, limit, 'the model does not explain the pressures, so the '
                                                             'clearances rest on an incomplete model'))
            continue
        out.append(Headline(name, iv, v.label, limit, v.note))
    return out[0], out[1]


def headline_text(h: Headline) -> str:
    """One clearance's line for a terminal: the estimate, its share of the limit, the level and
    why (the words of ``analyze`` and the report's box)."""
    iv = h.estimate
    if iv is None:
        est = 'not estimated'
    elif iv.hi is None:
        est = f'>= {iv.lo * 1e3:.3f} mm (lower bound only), {iv.lo / h.limit:.0%} of the {h.limit * 1e3:g} mm limit'
    else:
        est = (f'{iv.value * 1e3:.3f} mm [{iv.lo * 1e3:.3f} .. {iv.hi * 1e3:.3f}], {iv.value / h.limit:.0%} of the '
               f'{h.limit * 1e3:g} mm limit')
    return f'{h.name:<7} {est}  {h.level}' + (f': {h.note}' if h.note else '')


def headline_json(h: Headline) -> dict[str, object]:
    """``{value, ci95, bounded, level}`` in mm (``value`` and ``ci95`` null without an
    estimate)."""
    if h.estimate is None:
        return {'value': None, 'ci95': [None, None], 'bounded': False, 'level': h.level}
    return {**h.estimate.scaled(1e3), 'level': h.level}
