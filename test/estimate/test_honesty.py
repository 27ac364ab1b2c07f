"""Never confidently wrong: an answer the data support, or "not assessed" with why.

Each case simulates a voyage (seeds and clearances chosen for these tests, none used to set the
estimator's constants) and runs ``analyze``'s path; the levels are those the report, the fleet and
``analyze`` print (:func:`~steer_monitor.ashore.loganalysis.headlines`, the node's own rule)."""

from __future__ import annotations

import pytest

from steer_monitor import sim
from steer_monitor.ashore.loganalysis import NOT_JUDGED, headlines
from steer_monitor.can import Decoder
from steer_monitor.estimate.analyze import analyze
from steer_monitor.model import Clearances
from steer_monitor.params import gear_from_params, min_clearance_2z_from_params

MM = 1e-3


def _analysis(params, can_db, program, two_z_mm, z_gb_mm, seed, effects=()):
    db, smap = can_db
    cfg = sim.SimConfig(program=program, gaps=Clearances.from_mm(two_z_mm, z_gb_mm), max_duration_s=7200.0,
                        effects=tuple(sim.parse_effect(e) for e in effects))
    s = sim.run(params, cfg, db, smap, seed)
    signals = Decoder(db, smap).decode_arrays(s.frames, final=True)
    gear = gear_from_params(params)
    return analyze(gear, signals, min_clearance_2z=min_clearance_2z_from_params(params))


def _levels(params, a):
    return headlines(a, params['clearances.limit_2z_mm'] * MM, params['clearances.limit_zgb_mm'] * MM,
                     params['diagnostics.clearance_warn_share'])


def _holds_or_is_a_bound(iv, truth):
    """A two-sided interval holds the truth; a lower bound is at or below it."""
    assert iv.lo is not None and iv.lo <= truth + 1e-9, (iv, truth)
    if iv.hi is not None:
        assert truth <= iv.hi + 1e-9, (iv, truth)


def test_a_coastal_voyage_with_a_worn_slipper_is_not_assessed(r18_params, can_db):
    """The rudder stays under 10 deg on autopilot: the guide beam never loads, so a slipper past
    its limit (0.30 mm for 0.25) cannot show. Never OK, never a bounded interval without the truth."""
    a = _analysis(r18_params, can_db, 'autopilot:1500', 0.35, 0.30, 4242)
    two_z, z_gb = _levels(r18_params, a)
    assert z_gb.level == NOT_JUDGED
    assert 'guide beam' in z_gb.note and 'a hard-over to 35 deg at 16 kn would load the guide beam' in z_gb.note
    assert two_z.level != 'OK' or a.final.two_z.hi is not None
    _holds_or_is_a_bound(a.final.z_gb, 0.30 * MM)
    _holds_or_is_a_bound(a.final.two_z, 0.35 * MM)
    for iv in (a.final.mu_bushing, a.final.mu_guide, a.final.seal_friction, a.final.k_gl_max):
        for x in (iv.value, iv.lo, iv.hi):
            assert x is None or abs(x) < 1e7, iv        # no absurd number where a friction is not determined


def test_a_friction_band_beside_a_small_slipper_clearance_is_caught(r18_params, can_db):
    """Friction between 12 and 18 deg (outside the library) with Z_gb 0.096 mm: it was taken for
    the guide beam's friction (Z_gb 0.000 [0.000, 0.000], verdict 'declared'). Now it is located,
    or the clearance is not assessed; an interval given holds the truth."""
    a = _analysis(r18_params, can_db, 'realistic:1500', 0.2499, 0.0961, 9416, ('band_friction',))
    _, z_gb = _levels(r18_params, a)
    located = a.located is not None and a.located.variable == 'alpha_deg'
    assert located or z_gb.level == NOT_JUDGED
    _holds_or_is_a_bound(a.final.z_gb, 0.0961 * MM)
    assert not (a.final.z_gb.hi is not None and a.final.z_gb.hi - a.final.z_gb.lo < 1e-9)   # no zero-width interval


def test_a_viscous_gear_whose_slipper_never_loads_is_not_reported_new(r18_params, can_db):
    """Viscous friction, the rudder never past 15 deg, a slipper worn past its limit: was Z_gb
    0.022 [0.014, 0.041] mm for 0.338 (a worn slipper reported as new)."""
    a = _analysis(r18_params, can_db, 'realistic:1500', 0.1832, 0.3378, 9409, ('viscous',))
    _, z_gb = _levels(r18_params, a)
    _holds_or_is_a_bound(a.final.z_gb, 0.3378 * MM)
    assert z_gb.level != 'OK'


@pytest.mark.parametrize('seed, two_z, z_gb', [(7301, 0.41, 0.17), (7302, 0.27, 0.23)])
def test_a_clean_voyage_adopts_no_effect(r18_params, can_db, seed, two_z, z_gb):
    a = _analysis(r18_params, can_db, 'realistic:1500', two_z, z_gb, seed)
    assert a.steps == () and a.verdict == 'declared', a.message
    _holds_or_is_a_bound(a.final.z_gb, z_gb * MM)


def test_a_contact_placed_at_the_datas_edge_is_a_lower_bound(r18_params, can_db):
    """A ram clamped early (2Z 0.12 mm) keeps the slipper (0.34 mm) from ever touching; the fit
    placed a guide contact in 0.7 % of the rows with a friction of 0.25 to take up a misfit at
    the highest loads: Z_gb 0.265 [0.258, 0.270] mm. Now a lower bound (with the profile's
    valleys between grid points looked into, the profile's own; where the profile would still
    place such a contact, the rule that says why: the test below), and 2Z holds the truth."""
    a = _analysis(r18_params, can_db, 'realistic:1500', 0.1229, 0.3386, 20022)
    two_z, iv = a.final.two_z, a.final.z_gb
    assert two_z.hi is not None and two_z.lo <= 0.1229 * MM <= two_z.hi
    assert iv.hi is None and iv.lo <= 0.3386 * MM
    _, z_gb = _levels(r18_params, a)
    assert z_gb.level != 'OK'


def test_a_valley_narrower_than_the_grid_step_is_found(r18_params, can_db):
    """2Z 0.1128 mm clamps the ram in a valley of the profile 8 um wide, between the grid's
    0.10 and 0.12 mm; the grid's points on its flanks read 1,150 and 145 units above a fake
    optimum (2Z above 0.2 mm, a guide contact at the highest loads), and the answer was 2Z
    >= 0.18 mm, the truth excluded. Its bottom lies 100 units below that optimum."""
    a = _analysis(r18_params, can_db, 'realistic:1500', 0.1128, 0.3469, 46012)
    two_z, z_gb = a.final.two_z, a.final.z_gb
    assert two_z.hi is not None and two_z.lo <= 0.1128 * MM <= two_z.hi
    assert two_z.hi - two_z.lo < 0.01 * MM
    assert z_gb.hi is None and z_gb.lo <= 0.3469 * MM
    assert 'too little to place a contact' in a.final.bound_why[1]


def test_a_valley_wins_on_its_bottom_not_on_a_finer_search(r18_params, can_db):
    """Looked into between its grid neighbours with the other clearance searched finely, a
    valley away from the grid's best read below the best's grid point only for the finer
    search, and was taken: 2Z 0.1093 [0.1078, 0.1106] mm, where the grid's best, looked into
    alike, lies lower. The grid's best is now looked into the same way before a valley is
    taken, and the answer is the grid's refined one: 0.1093 [0.1057, 0.1127] mm (truth 0.1101)."""
    a = _analysis(r18_params, can_db, 'realistic:1500', 0.1101, 0.2252, 53021)
    two_z = a.final.two_z
    assert two_z.hi is not None and two_z.lo <= 0.1101 * MM <= two_z.hi
    assert two_z.lo < 0.1065 * MM and two_z.hi > 0.1120 * MM
    _holds_or_is_a_bound(a.final.z_gb, 0.2252 * MM)
