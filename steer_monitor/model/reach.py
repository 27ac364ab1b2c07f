"""How far each clearance can show in the pressures of a gear: its observable range. Pure.

A clearance shows in the pressures only past its contact: 2Z where the ram clamps in its
bushing (its slope at bushing A reaches 2Z / l_s), Z_gb where the guide beam carries load
(the slipper's deflection reaches Z_gb). Below the load that makes the contact, the
clearance changes no pressure at all, however large it is. So at given loads there is a
largest clearance that can still show: a larger one leaves the contact open under every
load, and the data can say of it only that it is at least what they showed.

:func:`reach` works out that largest clearance from the load-sharing model
(:func:`~steer_monitor.model.loadshare.load_sharing`, the one the estimator fits): at the
other clearance's value, over a set of (rudder angle, tiller torque) loads, by bisection on
the contact's onset (the contact comes at a smaller load for a smaller clearance, so whether
it comes anywhere is monotone in the clearance; a test checks that against a scan). Two
sets of loads matter (:func:`gear_reach`): those a voyage held (what a log could show) and
the gear's largest, a hard-over at service speed (what any voyage could show). Where the
voyage's loads already reach as far as the gear's, no manoeuvre can show more: the
clearance has to be measured.

Units SI: m, rad, N m, m/s.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from steer_monitor.model.gear import GearParams
from steer_monitor.model.loadshare import STAGE_CLAMPED, load_sharing

__all__ = ['ANGLE_STEP', 'MAX_CLEARANCE', 'TOLERANCE', 'WHAT', 'Reach', 'gear_loads', 'gear_reach', 'reach']

#: the clearances the bisection looks within [m]: ten times any shipped limit
MAX_CLEARANCE = 10e-3
#: the bisection stops within this [m] (a micrometre: below what any estimate resolves)
TOLERANCE = 1e-6
#: the gear's loads are read at this spacing of rudder angle [rad]
ANGLE_STEP = math.radians(0.25)
#: which clearance: 2Z (0) or Z_gb (1), and the contact that shows it
WHAT = ('2Z', 'Z_gb')


@dataclass(frozen=True)
class Reach:
    """How far a clearance can show: ``seen`` [m] the largest value the loads a voyage held
    could show (0: those loads make no contact at any value), ``gear`` [m] the largest the
    gear's largest loads could (a hard-over to ``angle`` [rad] at ``speed`` [m/s], its service
    speed), both at ``other`` [m], the other clearance's value they were worked out at; where
    the other is known only from below (``other_bound``), at that bound. Each clearance's
    reach grows with the other's (a freer ram deflects further before the guide beam takes
    load; a slipper further off lets the ram bend further in its bushing), so then the reach
    is at least this."""

    seen: float
    gear: float
    angle: float
    speed: float
    other: float
    other_bound: bool = False

    def beyond(self, lower_bound: float, margin: float) -> bool:
        """Whether a clearance known only to be at least ``lower_bound`` [m] lies beyond what
        any manoeuvre could show: the voyage's loads already reach to within ``margin`` [m] of
        the gear's (a hard-over would show no more than they did), or the gear's reach stops
        below the bound itself. Never where the other clearance is itself only a lower bound:
        its true value may put the reach anywhere above this one."""
        if self.other_bound:
            return False
        return self.gear <= self.seen + margin or self.gear <= lower_bound + margin

    def as_list(self) -> list[float]:
        """``[seen, gear, angle, speed, other, other_bound]`` (SI; the flag 0 or 1): the one
        form a reach is kept in (the node's state, the fleet's results)."""
        return [self.seen, self.gear, self.angle, self.speed, self.other, float(self.other_bound)]

    @classmethod
    def of_list(cls, x: object) -> Reach:
        """The reach of :meth:`as_list` (one kept before the flag, five numbers, reads as the
        other clearance's estimate); ValueError when it is not five or six numbers."""
        v = [float(a) for a in x]  # type: ignore[attr-defined]
        if len(v) not in (5, 6):
            msg = f'a reach of {len(v)} numbers, expected 5 or 6'
            raise ValueError(msg)
        return cls(*v[:5], other_bound=bool(v[5]) if len(v) == 6 else False)


def _shows(gear: GearParams, which: int, alpha: NDArray[np.float64], torque: NDArray[np.float64],
           value: float, other: float) -> bool:
    """Whether clearance ``which`` at ``value`` makes its contact at one of the loads."""
    two_z, z_gb = (value, other) if which == 0 else (other, value)
    ls = load_sharing(gear, alpha, torque, two_z, z_gb)
    if which == 0:
        return bool(np.any((ls.stages & STAGE_CLAMPED) != 0))
    return bool(np.any(ls.guide_force > 0))


def reach(gear: GearParams, which: int, alpha: ArrayLike, torque: ArrayLike, other: float) -> float:
    """The largest value [m] of clearance ``which`` (0: 2Z, 1: Z_gb) at which its contact comes
    under one of the loads (``alpha`` [rad], ``torque`` [N m], same shape), the other
    clearance at ``other`` [m]; 0 when it comes at none (no load, or none large enough even
    at no clearance); :data:`MAX_CLEARANCE` when it comes at that. Bisection to
    :data:`TOLERANCE`, the answer its low end (a value that shows)."""
    a = np.abs(np.asarray(alpha, dtype=float)).reshape(-1)
    t = np.abs(np.asarray(torque, dtype=float)).reshape(-1)
    keep = np.isfinite(a) & np.isfinite(t) & (t > 0)
    a, t = a[keep], t[keep]
    if a.size == 0 or not _shows(gear, which, a, t, 0.0, other):
        return 0.0
    if _shows(gear, which, a, t, MAX_CLEARANCE, other):
        return MAX_CLEARANCE
    lo, hi = 0.0, MAX_CLEARANCE
    while hi - lo > TOLERANCE:
        mid = 0.5 * (lo + hi)
        if _shows(gear, which, a, t, mid, other):
            lo = mid
        else:
            hi = mid
    return lo


def gear_loads(gear: GearParams) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The gear's largest loads: its torque curve at service speed from midships to its
    largest rudder angle (angles [rad], torques [N m])."""
    alpha = np.union1d(np.arange(0.0, gear.max_rudder, ANGLE_STEP), [gear.max_rudder])
    return alpha, np.abs(gear.torque(alpha))


def gear_reach(gear: GearParams, which: int, other: float, alpha_seen: ArrayLike, torque_seen: ArrayLike,
               other_bound: bool = False) -> Reach:
    """Clearance ``which``'s reach at the other's value ``other`` [m] (``other_bound``: the
    other known only to be at least that): under the loads a voyage held (``alpha_seen``
    [rad], ``torque_seen`` [N m]) and under the gear's largest."""
    ga, gt = gear_loads(gear)
    return Reach(seen=reach(gear, which, alpha_seen, torque_seen, other), gear=reach(gear, which, ga, gt, other),
                 angle=float(gear.max_rudder), speed=float(gear.torque.service_speed), other=float(other),
                 other_bound=other_bound)
