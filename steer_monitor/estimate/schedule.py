"""When the node analyses its data: a schedule on the data alone. Pure.

A wear figure needs no update every second. The node runs

* the whole residual loop (``loop``: the declared model, every candidate effect, the verdict)
  once ``first_s`` seconds of steady rudder motion are in, again each time the motion has
  doubled, and from then on every ``loop_every_s`` of motion: early on the data grow fast
  and the model chosen may change, later the loop's choice settles;
* between loops, the estimate under the model the loop last chose (``estimate``: its effects
  applied, no screening) every ``every_s`` of motion.

The motion is counted by the caller from the data (so a replay of the same frames runs the
same analyses at the same data times), and it survives a restart (:meth:`to_dict`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Literal

__all__ = ['FIRST_S', 'AnalysisSchedule', 'Kind']

FIRST_S = 240.0         # seconds of steady motion before the first analysis (``estimator.first_motion_s``)

Kind = Literal['loop', 'estimate']


@dataclass
class AnalysisSchedule:
    """The next analysis due at a count of motion seconds (see the module docstring)."""

    loop_every_s: float
    every_s: float
    first_s: float = FIRST_S
    next_loop_s: float = field(default=math.nan)
    next_estimate_s: float = math.inf

    def __post_init__(self) -> None:
        for name in ('loop_every_s', 'every_s', 'first_s'):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                msg = f'analysis schedule: {name} must be a positive number of seconds, got {value!r}'
                raise ValueError(msg)
        if math.isnan(self.next_loop_s):
            self.next_loop_s = self.first_s

    def due(self, motion_s: float) -> Kind | None:
        """The analysis due now that ``motion_s`` seconds of motion are in (None: none), and
        the schedule moved on past it."""
        if motion_s >= self.next_loop_s:
            self.next_loop_s = motion_s + min(max(motion_s, self.first_s), self.loop_every_s)
            self.next_estimate_s = motion_s + self.every_s
            return 'loop'
        if motion_s >= self.next_estimate_s:
            self.next_estimate_s = motion_s + self.every_s
            return 'estimate'
        return None

    def to_dict(self) -> dict[str, float]:
        return {'next_loop_s': self.next_loop_s, 'next_estimate_s': self.next_estimate_s}

    def restore(self, d: dict[str, float]) -> None:
        """Take the progress of :meth:`to_dict` (ValueError naming what does not fit)."""
        nl, ne = float(d['next_loop_s']), float(d['next_estimate_s'])
        if not (math.isfinite(nl) and nl > 0 and (ne > 0)):
            msg = f'analysis schedule: next loop at {nl!r} s, next estimate at {ne!r} s of motion'
            raise ValueError(msg)
        self.next_loop_s, self.next_estimate_s = nl, ne
