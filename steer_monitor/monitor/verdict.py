"""A clearance's verdict from its estimate and interval, as the live diagnostics, ``analyze``,
the report and the fleet all judge it. Pure.

OK means *assessed and within limits*; nothing else reads OK:

* OVER LIMIT (ERROR) when the interval's low end is past the limit (a lower bound past it too);
* WARN when the low end passes ``warn_share`` of the limit (a lower bound too: the clearance is
  at least that), or the point passes the limit with an interval narrow enough to say so;
* NOT ASSESSED (REP-107's STALE: no current knowledge) when the data cannot say whether it is
  within limits: no estimate yet, a lower bound below the warning (the contact never showed
  at the loads seen), an interval reaching from below the warning to past the limit (a point
  below the limit, or an interval wider than the limit), or a model that does not explain the
  pressures. The note says why and what would assess it: the manoeuvre, with its angle and
  speed and how far it would show the clearance, where one can show more than the data did
  (:mod:`~steer_monitor.model.reach`); where none can (the loads seen already reached as far as
  the gear's largest, or the gear's largest stop short of the bound), that the clearance is
  beyond what the pressures can show on this gear and has to be measured (never said while the
  other clearance is itself only a lower bound: how far one shows grows with the other);
* OK otherwise: the whole interval within the limit, its low end below the warning.

So OK is wrong (the truth past the limit) only when the interval misses above its high end: for
an interval that holds the truth at its stated 95 %, at most 2.5 % of the time.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass

from steer_monitor.model.reach import Reach

__all__ = ['ERROR', 'LABELS', 'MARGIN', 'NOT_ASSESSED', 'OK', 'WARN', 'Verdict', 'assess_hint', 'beyond_words',
           'clearance_verdict', 'worst']

OK, WARN, ERROR = 0, 1, 2      # REP-107's levels (diagnostic_msgs/DiagnosticStatus); the diagnostics use them
NOT_ASSESSED = 3               # REP-107's STALE: the data do not tell
LABELS = {OK: 'OK', WARN: 'WARN', ERROR: 'OVER LIMIT', NOT_ASSESSED: 'NOT ASSESSED'}
#: from the least to the most serious: a clearance not assessed is worse than one known fine,
#: never worse than one known worn
SEVERITY = (OK, NOT_ASSESSED, WARN, ERROR)

#: what a ship's crew can do to assess a clearance the data have not shown
HINTS = {
    '2Z': 'a hard-over at sea speed would clamp the ram in its bushing and show it',
    'Z_gb': 'a hard-over at sea speed would load the guide beam and show it',
}


#: why a clearance is a lower bound only when the estimate gives no reason of its own
NEVER = {
    '2Z': 'no clamping of the ram in its bushing shows at the loads seen',
    'Z_gb': 'no load on the guide beam shows at the loads seen',
}


#: the contact that shows each clearance, as a manoeuvre would make it
CONTACT = {'2Z': 'clamp the ram in its bushing', 'Z_gb': 'load the guide beam'}
#: a manoeuvre showing a clearance less than this much further than the data did shows nothing
#: new [m]: the estimator's grid step of that clearance (estimate/fit.py GRID_2Z, GRID_ZGB)
MARGIN = {'2Z': 0.02e-3, 'Z_gb': 0.005e-3}
OTHER = {'2Z': 'Z_gb', 'Z_gb': '2Z'}
KNOT = 1852.0 / 3600.0


def assess_hint(name: str, reach: Reach | None = None, lower_bound: float | None = None) -> str:
    """The manoeuvre that would assess clearance ``name`` ('2Z' or 'Z_gb'): with ``reach``, its
    angle and speed and how far it would show the clearance. Where the other clearance is
    itself only a lower bound the reach grows with it: at least that far, or, where that least
    does not pass the clearance's own ``lower_bound`` [m], that it depends on the other."""
    if reach is None or (reach.gear <= 0 and not reach.other_bound):
        return HINTS.get(name, 'a hard-over at sea speed would show it')
    manoeuvre = f'a hard-over to {math.degrees(reach.angle):.0f} deg at {reach.speed / KNOT:.0f} kn'
    other = OTHER.get(name, 'the other')
    if reach.other_bound and (lower_bound is None or reach.gear <= lower_bound):
        return (f'how far {name} can show grows with {other}, itself known only to be at least '
                f'{reach.other * 1e3:.3f} mm: {manoeuvre} would show {other} where it can, and with it how far '
                f'{name} can')
    up_to = f'up to {reach.gear * 1e3:.3f} mm'
    if reach.other_bound:
        up_to += f' at least (further the larger {other}, known only to be at least {reach.other * 1e3:.3f} mm)'
    return f'{manoeuvre} would {CONTACT.get(name, "make its contact")} for {name} {up_to} and show it'


def beyond_words(name: str, reach: Reach) -> str:
    """Why a clearance past ``reach`` cannot be shown, and what to do instead."""
    contact = {'2Z': 'the ram clamps in its bushing', 'Z_gb': 'the guide beam carries load'}.get(name, 'it shows')
    return (f'beyond what the pressures can show on this gear: at {OTHER.get(name, "the other")} '
            f'{reach.other * 1e3:.3f} mm {contact} only for {name} up to {reach.gear * 1e3:.3f} mm, even at a '
            f'hard-over to {math.degrees(reach.angle):.0f} deg at {reach.speed / KNOT:.0f} kn; measure it at the next '
            'survey')


def worst(levels: Iterable[int]) -> int:
    """The most serious of ``levels`` (:data:`SEVERITY`); OK for none."""
    return max(levels, key=SEVERITY.index, default=OK)


@dataclass(frozen=True)
class Verdict:
    """``level`` (OK, WARN, ERROR, NOT_ASSESSED), its ``label`` for people, the point's share
    of the limit (NaN without a point) and a ``note`` ('' or why it is not judged further)."""

    level: int
    share: float
    note: str

    @property
    def label(self) -> str:
        return LABELS[self.level]

    @property
    def assessed(self) -> bool:
        return self.level != NOT_ASSESSED


def clearance_verdict(value: float, lo: float | None, hi: float | None, limit: float,
                      warn_share: float, name: str = '', why: str = '', reach: Reach | None = None) -> Verdict:
    """The verdict on a clearance ``value`` [m] with interval [``lo``, ``hi``] (``hi`` None:
    a lower bound only; ``lo`` None: not estimated, the value is configured). ``name`` ('2Z'
    or 'Z_gb') chooses the hint of what would assess it; ``why``: the estimate's own reason
    for a lower bound, when it has one; ``reach``: how far the clearance can show on this gear
    (None: not known, the hint then names no figures). The level does not depend on ``reach``:
    only what the note says would assess it."""
    share = value / limit
    hint = assess_hint(name, reach, lo)
    if lo is None:
        return Verdict(NOT_ASSESSED, share, f'not estimated yet (the configured value is shown); {hint}')
    warn = warn_share * limit
    too_wide = hi is not None and lo < warn and hi > limit and hi - lo > limit
    if lo > limit:
        return Verdict(ERROR, share, '' if hi is not None else 'lower bound past the limit')
    if hi is None:
        if lo >= warn:
            return Verdict(WARN, share, 'lower bound past the warning')
        reason = why or NEVER.get(name, 'the contact did not show at the loads seen')
        if reach is not None and reach.beyond(lo, MARGIN.get(name, 0.0)):
            return Verdict(NOT_ASSESSED, share, f'lower bound only ({reason}); {beyond_words(name, reach)}')
        return Verdict(NOT_ASSESSED, share, f'lower bound only ({reason}); {hint}')
    if lo >= warn or (value > limit and not too_wide):
        return Verdict(WARN, share, '')
    if hi > limit:                    # within the limit or past it: the interval holds both
        reach = ('the interval, wider than the limit, reaches from below the warning to past it' if too_wide
                 else 'the interval reaches from below the warning to past the limit')
        return Verdict(NOT_ASSESSED, share, f'{reach}; {hint}')
    return Verdict(OK, share, '')
