"""The physical range of every parameter the estimator fits, each with its reason. Pure.

A least-squares fit left free will buy a better fit with a parameter no gear can have: a
guide friction of 0.37, or -1.3, that lets a clearance sit where the data's misfit likes it;
a Stribeck excess of 3.6 MN where the rams' whole force is 200 kN. The declared model's
friction coefficients are therefore *constrained* to their ranges (the fit is the best one
inside them, :func:`~steer_monitor.estimate.fit.fit_at`), and an effect whose fit needs a
value outside its range is refused (:func:`~steer_monitor.estimate.plausible.refusal`): what
the data then show is not that effect. A fit that ends on a range's edge says so
(:func:`at_edge`).

Ranges are in SI units. Those of the effects are relative to the declared fit where the
physics makes them so (a Stribeck excess is a share of the seal friction); the limits are
deliberately wide, so they only catch what no gear does, and each encloses the simulator's
default size of the effect with room to spare.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

__all__ = ['DECLARED', 'EFFECT_RANGES', 'EDGE_TOL', 'Range', 'at_edge', 'effect_range']


@dataclass(frozen=True)
class Range:
    """``lo`` <= value <= ``hi`` (either may be infinite), and why."""

    lo: float
    hi: float
    reason: str

    def contains(self, x: float) -> bool:
        return math.isfinite(x) and self.lo <= x <= self.hi

    def text(self, unit: str = '') -> str:
        lo = '-inf' if math.isinf(self.lo) else f'{self.lo:g}'
        hi = 'inf' if math.isinf(self.hi) else f'{self.hi:g}'
        return f'{lo} .. {hi}{(" " + unit) if unit else ""}'


#: The declared friction law's parameters (docs/physics.md, docs/estimation.md).
DECLARED = {
    'seal_friction_n': Range(
        0.0, math.inf,
        'seal friction opposes the motion: it cannot push the ram (it is never near 0 in a working gear; '
        'a negative value is a misfit leaning on the constant column)'),
    'mu_bushing': Range(
        0.0, 0.3,
        'a lubricated bronze or cast-iron bushing on a steel ram runs at 0.05-0.15, 0.2 in boundary '
        'lubrication; 0.3 is a dry bushing about to seize, and friction never pushes'),
    'mu_guide': Range(
        0.0, 0.3,
        'a lubricated slipper on the guide beam runs at 0.03-0.15; 0.3 is a dry, scored slipper, and '
        'friction never pushes'),
}

#: Effect parameters (the columns of :mod:`~steer_monitor.estimate.effects`): (low, high) as
#: functions of the declared fit's seal friction F_s [N] and the rams' rated axial force F_r
#: [N] (the tiller torque at 35 deg through the Rapson slide), with the reason.
EFFECT_RANGES: dict[tuple[str, str], tuple[float, float, str]] = {
    # (effect, coefficient): (low factor, high factor, what the factor multiplies: 'F_s', 'F_r', or '' for SI)
    ('viscous', 'c_ns_per_m'): (
        0.0, 0.25,
        'F_r/v: viscous friction at the ram speed of two pumps (about 30 mm/s) takes at most a quarter of the '
        'rated force (more and the gear could not reach hard over); it never pushes'),
    ('stribeck', 'f_st_n'): (
        0.0, 3.0,
        'F_s: the excess of static over running friction of ram seals is up to two or three times the running '
        'friction, and friction is never lower at rest'),
    ('pressure_friction', 'k'): (
        0.0, 0.1,
        '-: seal or stock-bearing friction rising with the load takes at most a tenth of the ram force; it '
        'never falls as the pressure rises'),
    ('temp_friction', 'k_per_k'): (
        -0.05, 0.05,
        '1/K: 5 % per kelvin doubles or halves the friction within 20 K of oil temperature, past what oil '
        'viscosity does to seals and bushings'),
    ('pressure_offset', 'offset_ram1_n'): (
        -0.05, 0.05,
        'F_r: a transducer reading off by more than 5 % of the rated force (about 6 bar) is a failed sensor, '
        'not an offset to fit'),
    ('pressure_offset', 'offset_ram2_n'): (
        -0.05, 0.05,
        'F_r: as ram 1'),
    ('ram_inertia', 'mass_kg'): (
        0.0, 200e3,
        'kg: rams, crosshead, oil and the rudder seen at the rams (J / H^2) weigh tens of tonnes, not hundreds; '
        'a mass is never negative'),
}

EDGE_TOL = 1e-9      # relative: a fitted value this close to a bound is on it
V_RAM_RATED = 0.03   # m/s: the ram speed of two pumps, where the viscous range is stated


def effect_range(effect: str, coef: str, seal_friction: float, rated_force: float) -> Range | None:
    """The range of an effect's coefficient [SI] for a declared seal friction ``seal_friction``
    [N] and rated axial force ``rated_force`` [N], or None when it has none."""
    spec = EFFECT_RANGES.get((effect, coef))
    if spec is None:
        return None
    lo, hi, reason = spec
    unit, _, why = reason.partition(': ')
    scale = {'F_r/v': rated_force / V_RAM_RATED, 'F_s': max(seal_friction, 0.0), 'F_r': rated_force}.get(unit, 1.0)
    return Range(lo * scale, hi * scale, why)


def at_edge(value: float, rng: Range) -> str | None:
    """'low' or 'high' when ``value`` lies on that bound of ``rng`` (a constrained fit stopped
    there), else None."""
    tol = EDGE_TOL * max(abs(value), 1e-12)
    if math.isfinite(rng.lo) and value <= rng.lo + max(tol, EDGE_TOL):
        return 'low'
    if math.isfinite(rng.hi) and value >= rng.hi - max(tol, EDGE_TOL * abs(rng.hi)):
        return 'high'
    return None
