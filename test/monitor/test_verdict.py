"""The clearance verdict's words where the gear's reach is known: a manoeuvre named only where it
can show more than the data did, and no share of the limit for a bound below it."""

from __future__ import annotations

import math

import pytest

from steer_monitor.model.reach import Reach
from steer_monitor.monitor.verdict import MARGIN, NOT_ASSESSED, clearance_verdict

SPEED = 16.0 * 1852.0 / 3600.0


def _reach(seen_mm: float, gear_mm: float) -> Reach:
    return Reach(seen=seen_mm * 1e-3, gear=gear_mm * 1e-3, angle=math.radians(35.0), speed=SPEED, other=0.25e-3)


def test_a_bushing_past_what_the_gear_can_show_is_to_be_measured_with_no_manoeuvre():
    """The issue's case: two hard-overs at 16 kn seen, 2Z 0.75 mm true, the bound 0.08 mm: the
    voyage's loads reached as far as the gear's, so no manoeuvre can help."""
    v = clearance_verdict(0.1e-3, 0.08e-3, None, 0.6e-3, 0.9, '2Z', reach=_reach(0.212, 0.212))
    assert v.level == NOT_ASSESSED
    assert ('beyond what the pressures can show on this gear: at Z_gb 0.250 mm the ram clamps in its bushing only '
            'for 2Z up to 0.212 mm, even at a hard-over to 35 deg at 16 kn; measure it at the next survey') in v.note
    assert 'would' not in v.note


def test_a_manoeuvre_that_can_show_more_is_named_with_its_angle_speed_and_reach():
    v = clearance_verdict(0.06e-3, 0.05e-3, None, 0.6e-3, 0.9, '2Z', reach=_reach(0.08, 0.212))
    assert v.level == NOT_ASSESSED
    assert v.note.endswith('a hard-over to 35 deg at 16 kn would clamp the ram in its bushing for 2Z up to '
                           '0.212 mm and show it')


def test_with_the_other_clearance_only_a_lower_bound_the_reach_is_at_least_and_never_beyond():
    """A slow voyage at 8 kn, neither contact made: Z_gb >= 0.02 mm, 2Z >= 0.06 mm. 2Z's reach
    at Z_gb 0.02 mm (0.052 mm) is below the bound, but the true Z_gb may be larger and with it
    the reach: a hard-over would show both, so no 'measure it', the reach said as a least."""
    r = Reach(seen=0.012e-3, gear=0.052e-3, angle=math.radians(35.0), speed=SPEED, other=0.02e-3, other_bound=True)
    v = clearance_verdict(0.06e-3, 0.06e-3, None, 0.6e-3, 0.9, '2Z', reach=r)
    assert v.level == NOT_ASSESSED and 'beyond' not in v.note and 'measure' not in v.note
    assert v.note.endswith('how far 2Z can show grows with Z_gb, itself known only to be at least 0.020 mm: a '
                           'hard-over to 35 deg at 16 kn would show Z_gb where it can, and with it how far 2Z can')
    # where even the least reach passes the bound, the manoeuvre shows at least that far
    v = clearance_verdict(0.03e-3, 0.03e-3, None, 0.6e-3, 0.9, '2Z', reach=r)
    assert v.note.endswith('a hard-over to 35 deg at 16 kn would clamp the ram in its bushing for 2Z up to 0.052 mm '
                           'at least (further the larger Z_gb, known only to be at least 0.020 mm) and show it')


@pytest.mark.parametrize('seen_mm, bound_mm, beyond', [(0.212 - 0.019, 0.05, True), (0.212 - 0.021, 0.05, False),
                                                        (0.05, 0.195, True), (0.05, 0.19, False)])
def test_a_manoeuvre_helps_only_past_one_grid_step_of_what_was_seen_and_of_the_bound(seen_mm, bound_mm, beyond):
    assert MARGIN['2Z'] == pytest.approx(0.02e-3)
    v = clearance_verdict(bound_mm * 1e-3, bound_mm * 1e-3, None, 0.6e-3, 0.9, '2Z', reach=_reach(seen_mm, 0.212))
    assert ('beyond what the pressures can show' in v.note) is beyond and ('would clamp' in v.note) is not beyond


def test_the_level_does_not_depend_on_the_reach():
    for lo, hi in ((0.08e-3, None), (0.55e-3, None), (0.1e-3, 0.2e-3), (0.3e-3, 0.7e-3), (0.7e-3, 0.8e-3)):
        value = lo if hi is None else (lo + hi) / 2
        assert (clearance_verdict(value, lo, hi, 0.6e-3, 0.9, '2Z').level
                == clearance_verdict(value, lo, hi, 0.6e-3, 0.9, '2Z', reach=_reach(0.2, 0.21)).level)
