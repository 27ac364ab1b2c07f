"""Whether an effect's fitted coefficients are physical: a sign the physics fixes, or a value
within its range (:mod:`~steer_monitor.estimate.ranges`). Pure."""

from __future__ import annotations

import math
from collections.abc import Mapping

from steer_monitor.estimate.intervals import Interval
from steer_monitor.estimate.ranges import effect_range
from steer_monitor.model.gear import GearParams
from steer_monitor.model.kinematics import axial_of_torque

__all__ = ['SIGNS', 'guide_contact_at_friction_limit', 'rated_force', 'refusal']

# Coefficients whose sign the physics fixes: (effect, coefficient) -> what a negative value
# would claim. A fit may still find one negative: another misfit leaning on its column.
SIGNS = {
    ('viscous', 'c_ns_per_m'): 'a negative viscous coefficient (friction falling as the ram speeds up)',
    ('stribeck', 'f_st_n'): 'friction below the declared law near zero speed (a negative Stribeck amplitude)',
    ('pressure_friction', 'k'): 'a negative pressure-friction factor (friction falling as the pressure rises)',
    ('ram_inertia', 'mass_kg'): 'a negative moving mass',
}


def refusal(name: str, values: Mapping[str, float], seal_friction: float = math.inf,
            rated_force: float = math.inf) -> str | None:
    """Why an effect with these fitted coefficients (SI) is unphysical, or None: a sign the
    physics fixes, or a value outside its range (:mod:`~steer_monitor.estimate.ranges`, some
    relative to the declared fit's seal friction ``seal_friction`` [N] and the rams' rated
    axial force ``rated_force`` [N]): what the data then show is not that effect."""
    for (effect, coef), claim in SIGNS.items():
        if effect == name and values.get(coef, 0.0) < 0:
            return f'refused: its fit needs {claim}, {coef} = {values[coef]:.4g}'
    for coef, value in values.items():
        rng = effect_range(name, coef, seal_friction, rated_force)
        if rng is not None and math.isfinite(rng.hi + rng.lo) and not rng.contains(value):
            return (f'refused: its fit needs {coef} = {value:.4g}, outside the physical range {rng.text()} '
                    f'({rng.reason})')
    return None


def rated_force(gear: GearParams) -> float:
    """The rams' rated axial force [N]: the tiller torque at the largest rudder angle and the
    service speed through the Rapson slide, M cos^2(alpha) / (n H)."""
    a = gear.max_rudder
    return float(axial_of_torque(gear, abs(gear.torque(a)), math.cos(a)))


def guide_contact_at_friction_limit(z_gb: Interval, mu_guide: Interval) -> tuple[Interval, str]:
    """Z_gb's interval as it stands, or a lower bound and why, where its fit stopped the guide
    friction at the top of its physical range (``mu_guide.edge == 'high'``: a slipper about to
    seize). Such a contact is bought with a limit value: the fit wanted more friction than a
    slipper can have to place it, which an effect the model lacks does (a temperature-dependent
    or Stribeck friction took up at the highest loads: Z_gb 0.299 [0.283, 0.308] mm for a true
    0.350, 0.3 the guide friction). The data still say the clearance is at least the low end."""
    if z_gb.hi is None or z_gb.lo is None or mu_guide.edge != 'high':
        return z_gb, ''
    return (Interval(z_gb.value, z_gb.lo, None),
            f'the guide friction fitted at the top of its physical range ({mu_guide.value:.2f}): '
            f'a contact bought with a limit value')
