"""The observable range of each clearance: the bisection against a scan of the paper's own
stepwise loading (the test oracle), on the gear's largest loads and a voyage's."""

from __future__ import annotations

import math

import numpy as np
import pytest

from steer_monitor.model.gear import Clearances
from steer_monitor.model.landmarks import landmarks
from steer_monitor.model.loadshare import STAGE_CLAMPED, load_sharing_at
from steer_monitor.model.reach import TOLERANCE, Reach, gear_loads, gear_reach, reach
from test.model.loadshare_oracle import load_sharing_stepwise

SCAN_STEP = 2e-6


def _scan(gear, which, alpha, torque, other, top):
    """Every value on a 2-um scan up to ``top`` [m] where the oracle makes the contact."""
    values = np.arange(0.0, top, SCAN_STEP)
    shows = []
    for v in values:
        tz, zg = (v, other) if which == 0 else (other, v)
        ls = load_sharing_stepwise(gear, alpha, torque, np.full(alpha.shape, tz), np.full(alpha.shape, zg))
        shows.append(bool(np.any((ls.stages & STAGE_CLAMPED) != 0)) if which == 0 else bool(np.any(ls.guide_force > 0)))
    return values, np.array(shows)


@pytest.mark.parametrize('which, other, top', [(0, 0.25e-3, 0.4e-3), (0, 0.10e-3, 0.3e-3), (1, 0.3e-3, 1.2e-3)])
def test_the_reach_is_where_the_stepwise_loading_last_makes_the_contact(r18, which, other, top):
    """On the gear's largest loads: every value below the reach makes the contact, none above
    (monotone, as the bisection assumes), and the reach lies within a scan step of the last."""
    alpha, torque = gear_loads(r18)
    got = reach(r18, which, alpha, torque, other)
    values, shows = _scan(r18, which, alpha, torque, other, top)
    last = values[shows][-1]
    assert np.all(shows[values <= last]) and not np.any(shows[values > last])
    assert last - TOLERANCE <= got <= last + SCAN_STEP + TOLERANCE
    assert 0.0 < got < top


def test_the_r18s_ram_bushing_shows_up_to_about_a_third_of_its_limit_at_its_guide_clearance(r18):
    """The figure the issue quoted: at Z_gb 0.25 mm, 2Z changes no pressure from about 0.2 mm
    up; the landmarks of a sweep agree (a clamp onset just below the reach, none above)."""
    r = gear_reach(r18, 0, 0.25e-3, *gear_loads(r18))
    assert 0.18e-3 < r.gear < 0.24e-3 and r.seen == pytest.approx(r.gear, abs=TOLERANCE)
    alpha = np.radians(np.arange(0.0, 35.0 + 1e-9, 0.25))
    assert landmarks(alpha, load_sharing_at(r18, alpha, Clearances(r.gear - 2e-6, 0.25e-3))).clamp_onset is not None
    assert landmarks(alpha, load_sharing_at(r18, alpha, Clearances(r.gear + 2e-6, 0.25e-3))).clamp_onset is None
    assert r.angle == pytest.approx(math.radians(35.0)) and r.speed == pytest.approx(16.0 * 1852 / 3600)


def test_a_voyage_of_small_angles_reaches_less_than_the_gear(r18):
    """Ten degrees at half speed: a smaller reach, so a hard-over would show more; no load at
    all shows nothing."""
    alpha = np.radians(np.linspace(0.0, 10.0, 41))
    r = gear_reach(r18, 0, 0.1e-3, alpha, r18.torque(alpha, 8.0 * 1852 / 3600))
    assert r.seen < r.gear
    assert not r.beyond(0.9 * r.seen, 0.02e-3) and r.beyond(r.gear, 0.02e-3)
    assert reach(r18, 0, alpha, np.zeros_like(alpha), 0.1e-3) == 0.0


def test_a_voyage_that_held_the_gear_s_largest_loads_leaves_nothing_to_show():
    r = Reach(seen=0.199e-3, gear=0.2e-3, angle=0.6, speed=8.0, other=0.25e-3)
    assert r.beyond(0.08e-3, 0.02e-3)
    # the other known only from below: its true value may put the reach anywhere above, so never beyond
    assert not Reach(seen=0.199e-3, gear=0.2e-3, angle=0.6, speed=8.0, other=0.25e-3, other_bound=True).beyond(
        0.08e-3, 0.02e-3)


@pytest.mark.parametrize('which, others, top', [(0, (0.0, 0.05e-3, 0.15e-3, 0.3e-3), 0.4e-3),
                                                (1, (0.0, 0.05e-3, 0.15e-3), 0.6e-3)])
def test_each_clearance_s_reach_grows_with_the_other_s(r18, which, others, top):
    """What makes a reach at the other's lower bound a lower bound of the reach: on the paper's
    stepwise loading (the oracle, scanned), the last value that makes the contact does not fall
    as the other clearance grows, under the gear's largest loads."""
    alpha, torque = gear_loads(r18)
    alpha, torque = alpha[::8], torque[::8]
    lasts = []
    for other in others:
        values, shows = _scan(r18, which, alpha, torque, other, top)
        lasts.append(values[shows][-1] if shows.any() else 0.0)
    assert all(b >= a - SCAN_STEP for a, b in zip(lasts, lasts[1:])), lasts
    assert lasts[-1] > lasts[0]


def test_a_reach_is_kept_as_a_list_and_read_back():
    r = Reach(seen=0.1e-3, gear=0.2e-3, angle=0.6, speed=8.0, other=0.02e-3, other_bound=True)
    assert Reach.of_list(r.as_list()) == r
    assert Reach.of_list(r.as_list()[:5]) == Reach(0.1e-3, 0.2e-3, 0.6, 8.0, 0.02e-3)   # kept before the flag
    with pytest.raises(ValueError, match='a reach of 4 numbers, expected 5 or 6'):
        Reach.of_list([1.0, 2.0, 3.0, 4.0])
