"""The guide beam's contact read as a bound where its fit needs a slipper about to seize."""

from __future__ import annotations

from steer_monitor.estimate.intervals import Interval
from steer_monitor.estimate.plausible import guide_contact_at_friction_limit

MM = 1e-3


def test_a_contact_bought_with_the_friction_limit_is_a_lower_bound():
    """A voyage with temperature-dependent friction: Z_gb 0.299 [0.283, 0.308] mm for a true
    0.350, the guide friction fitted at 0.3, the top of its range. Read as Z_gb >= 0.283 mm."""
    z_gb = Interval(0.299 * MM, 0.283 * MM, 0.308 * MM)
    iv, why = guide_contact_at_friction_limit(z_gb, Interval(0.3, 0.241, 0.3, 'high'))
    assert (iv.value, iv.lo, iv.hi) == (z_gb.value, z_gb.lo, None)
    assert why == ('the guide friction fitted at the top of its physical range (0.30): '
                   'a contact bought with a limit value')


def test_a_friction_inside_its_range_or_at_zero_leaves_the_interval():
    z_gb = Interval(0.25 * MM, 0.24 * MM, 0.26 * MM)
    for mu in (Interval(0.05, 0.04, 0.06), Interval(0.0, 0.0, 0.087, 'low'), Interval(0.1, None, None)):
        assert guide_contact_at_friction_limit(z_gb, mu) == (z_gb, '')


def test_a_bound_stays_a_bound():
    z_gb = Interval(0.25 * MM, 0.24 * MM, None)
    assert guide_contact_at_friction_limit(z_gb, Interval(0.3, 0.25, 0.3, 'high')) == (z_gb, '')
