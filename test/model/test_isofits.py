"""ISO 286 tables and paper 000's clearance arithmetic, pinned by published rows."""

from __future__ import annotations

import pytest

from steer_monitor.errors import FitError
from steer_monitor.model import Tolerance, clearance_of, hole_tolerance, it_value, parse_fit, shaft_tolerance

UM = 1e-6


def test_240_h9_f9_matches_paper_004():
    c = parse_fit('240 H9/f9').clearance
    assert round(c.minimum * 1e3, 3) == 0.050
    assert round(c.maximum * 1e3, 3) == 0.280
    assert round(c.probable_min * 1e3, 3) == 0.084
    assert round(c.probable_max * 1e3, 3) == 0.246


# Published rows of ISO 286-2 (limit deviations in um: upper, lower).
@pytest.mark.parametrize('nominal,grade,upper', [
    (240, 9, 115), (25, 7, 21), (50, 8, 39), (100, 11, 220), (10, 6, 9), (500, 5, 27),
    (3, 10, 40), (400, 7, 57),
])
def test_hole_rows(nominal, grade, upper):
    t = hole_tolerance(nominal, grade)
    assert (round(t.upper / UM), round(t.lower / UM)) == (upper, 0)


@pytest.mark.parametrize('nominal,letter,grade,upper,lower', [
    (240, 'f', 9, -50, -165),
    (25, 'g', 6, -7, -20),
    (100, 'f', 7, -36, -71),
    (30, 'c', 11, -110, -240),
    (50, 'k', 6, 18, 2),
    (50, 'h', 7, 0, -25),
    (80, 'e', 8, -60, -106),
    (160, 'd', 9, -145, -245),
    (40, 'm', 6, 25, 9),
    (20, 'n', 6, 28, 15),
    (60, 'p', 6, 51, 32),
    (25, 'js', 7, 10, -10),
    (18, 'js', 6, 5.5, -5.5),
    (120, 'k', 8, 54, 0),
])
def test_shaft_rows(nominal, letter, grade, upper, lower):
    t = shaft_tolerance(nominal, letter, grade)
    assert (t.upper / UM, t.lower / UM) == (pytest.approx(upper), pytest.approx(lower))


def test_size_step_boundaries_are_inclusive_above():
    assert it_value(250, 9) == pytest.approx(115 * UM)      # "over 180 up to and including 250"
    assert it_value(250.001, 9) == pytest.approx(130 * UM)


def test_seed_000_mean_and_half_tolerance():
    t = Tolerance.from_deviations(0.240, 115 * UM, 0.0)
    assert t.mean == pytest.approx(0.240 + 57.5 * UM)
    assert t.half_tolerance == pytest.approx(57.5 * UM)
    s = Tolerance.from_deviations(0.240, -50 * UM, -165 * UM)
    c = clearance_of(t, s)
    assert c.mean == pytest.approx(165 * UM)
    assert c.probable_dev == pytest.approx((2 * 57.5**2) ** 0.5 * UM)
    assert c.worst_dev == pytest.approx(115 * UM)


def test_probable_clearance_against_monte_carlo():
    """RSS of half-tolerances = 3-sigma band of uniform-free normal sizes (independent check):
    sizes normal with 3 sigma = half tolerance give clearance sd * 3 = RSS."""
    import numpy as np
    fit = parse_fit('240 H9/f9')
    rng = np.random.default_rng(0)
    n = 400_000
    hole = rng.normal(fit.hole.mean, fit.hole.half_tolerance / 3, n)
    shaft = rng.normal(fit.shaft.mean, fit.shaft.half_tolerance / 3, n)
    sd3 = 3 * np.std(hole - shaft)
    assert sd3 == pytest.approx(fit.clearance.probable_dev, rel=0.01)


@pytest.mark.parametrize('text,msg', [
    ('240 G9/f9', "only hole-basis fits \\(hole H\\) are supported, got hole 'G'"),
    ('240 H12/f12', 'grade IT12 is not supported \\(supported: IT5..IT11\\)'),
    ('240 H9/z9', "shaft letter 'z' is not supported"),
    ('600 H9/f9', 'nominal size 600 mm is outside the supported ISO 286 range'),
    ('0 H9/f9', 'nominal size 0 mm is outside the supported ISO 286 range'),
    ('H9/f9', 'cannot read fit'),
    ('240 H9 f9', 'cannot read fit'),
])
def test_bad_designations(text, msg):
    with pytest.raises(FitError, match=msg):
        parse_fit(text)


def test_designation_round_trip():
    assert parse_fit(' 240mm H9 / f9 ').designation == '240 H9/f9'
    assert parse_fit('240 H9/f9').with_grade(11).designation == '240 H11/f11'
