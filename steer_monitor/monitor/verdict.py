"""A clearance's verdict from its estimate and interval, as the live diagnostics and the
report both judge it. Pure.

ERROR (OVER LIMIT) when the interval's low end is past the limit; WARN when the low end
passes ``warn_share`` of the limit, or the point passes the limit with an interval narrow
enough to say so; OK otherwise. An interval wider than the limit itself that reaches from
below the warning to past the limit is too wide to judge yet: OK, and the text says so.
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ['ERROR', 'OK', 'WARN', 'Verdict', 'clearance_verdict']

OK, WARN, ERROR = 0, 1, 2      # REP-107's levels (diagnostic_msgs/DiagnosticStatus); the diagnostics use them
LABELS = {OK: 'OK', WARN: 'WARN', ERROR: 'OVER LIMIT'}


@dataclass(frozen=True)
class Verdict:
    """``level`` (OK, WARN, ERROR), its ``label`` for people, the point's share of the limit
    and a ``note`` ('' or why it is not judged further)."""

    level: int
    share: float
    note: str

    @property
    def label(self) -> str:
        return LABELS[self.level]


def clearance_verdict(value: float, lo: float | None, hi: float | None, limit: float,
                      warn_share: float) -> Verdict:
    """The verdict on a clearance ``value`` [m] with interval [``lo``, ``hi``] (``hi`` None:
    a lower bound only; ``lo`` None: not estimated, the value is configured, not judged)."""
    share = value / limit
    if lo is None:
        return Verdict(OK, share, 'not estimated: configured value, not judged')
    warn = warn_share * limit
    too_wide = hi is not None and lo < warn and hi > limit and hi - lo > limit
    if lo > limit:
        return Verdict(ERROR, share, '')
    if lo >= warn or (value > limit and not too_wide):
        return Verdict(WARN, share, '')
    if too_wide:
        return Verdict(OK, share, 'the interval, wider than the limit, reaches from below the warning to past '
                                  'it: too wide to judge yet')
    if hi is None:
        return Verdict(OK, share, 'lower bound only: not reached at the loads seen')
    return Verdict(OK, share, '')
