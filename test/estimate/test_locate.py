"""Locating an unexplained residual: synthetic residuals with a known term, against the truth
and against a brute-force search of the range's ends."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from steer_monitor.estimate import locate as L
from steer_monitor.estimate.observe import GRID_NS, Observations

KNOT = 1852.0 / 3600.0


def _observations(n: int = 40000, seed: int = 0) -> Observations:
    """A rudder sweeping +-30 deg, both directions, both rams; speed in steps, oil temperature
    cycling (neither follows the time)."""
    rng = np.random.default_rng(seed)
    t = np.arange(n, dtype=np.int64) * GRID_NS
    alpha = np.radians(30.0) * np.sin(2 * np.pi * np.arange(n) / 1200.0)
    rate = np.gradient(alpha, GRID_NS / 1e9)
    direction = np.sign(rate).astype(np.int8)
    force = rng.normal(0.0, 15e3, (n, 2))
    pressure = 2e5 + np.abs(rng.normal(60e5, 20e5, (n, 4)))
    speed = np.repeat(rng.choice([8.0, 12.0, 16.0], n // 2000 + 1), 2000)[:n] * KNOT   # engine orders
    oil = 318.0 + 5.0 * np.sin(2 * np.pi * np.arange(n) / (n / 3))                   # cooler cycling
    return Observations(t, alpha, rate, direction, force, pressure, speed, oil)


def _noise(obs: Observations, seed: int = 1, sigma: float = 1.5e3) -> np.ndarray:
    return np.random.default_rng(seed).normal(0.0, sigma, (len(obs), 2))


def _band_located() -> L.Located:
    """The term located on 4 kN more friction between 12 and 18 deg either side."""
    obs = _observations()
    deg = np.degrees(np.abs(obs.alpha))
    band = (deg >= 12.0) & (deg <= 18.0)
    loc = L.locate(obs, _noise(obs) + (obs.direction * band * 4e3)[:, None], 1.0)
    assert loc is not None
    return loc


def test_a_friction_band_on_both_sides_is_found_on_the_angle():
    loc = _band_located()
    assert loc.variable == 'alpha_deg' and loc.either_side
    assert loc.shape == L.Shape(None, 0, True)
    assert loc.lo == pytest.approx(12.0, abs=0.2) and loc.hi == pytest.approx(18.0, abs=0.2)
    assert loc.level == pytest.approx(4e3, rel=0.05)
    assert 'rudder angle 12' in loc.message(0.045) and 'more friction than the model' in loc.message(0.045)


def test_an_offset_on_one_ram_late_in_the_log_is_found_on_time():
    """A transducer of ram 2 that drifts off in the last quarter, moving to port only."""
    obs = _observations(seed=2)
    late = np.arange(len(obs)) >= 0.75 * len(obs)
    resid = _noise(obs, 3)
    resid[:, 1] += np.where(late & (obs.direction < 0), -5e3, 0.0)
    loc = L.locate(obs, resid, 1.0)
    assert loc is not None and loc.variable == 'time_s'
    assert loc.shape.ram == 1 and loc.shape.direction == -1
    span = (obs.t_ns[-1] - obs.t_ns[0]) / 1e9
    assert loc.lo == pytest.approx(0.75 * span, abs=0.02 * span) and loc.hi == pytest.approx(span, rel=0.01)
    assert loc.level < 0 and 'ram 2, moving to port' in loc.message(0.045)


def test_white_noise_locates_nothing():
    obs = _observations(seed=4)
    assert L.locate(obs, _noise(obs, 5), 1.0) is None


def test_too_few_rows_locate_nothing():
    obs = _observations(n=200)
    assert L.locate(obs, _noise(obs), 1.0) is None


@pytest.mark.parametrize('lo, hi', [(5.3, 9.1), (12.0, 18.0), (20.45, 27.7)])
def test_refined_ends_match_a_brute_force_search(lo, hi):
    """The cumulative-sum search against a direct boxcar fit at every candidate pair."""
    rng = np.random.default_rng(7)
    x = rng.uniform(0.0, 30.0, 20000)
    t = np.where((x >= lo) & (x < hi), 3.0, 0.0) + rng.normal(0.0, 1.0, x.size)
    edges = np.linspace(0.0, 30.0, L.N_BINS + 1)
    run = (int(lo // 1.0), int(np.ceil(hi)) - 1)
    got = L._refine_edges(x, t, edges, run)
    w = 1.0
    best, arg = -1.0, None
    for a in np.linspace(edges[run[0]] - w, edges[run[0]] + w, 21):
        for b in np.linspace(edges[run[1] + 1] - w, edges[run[1] + 1] + w, 21):
            m = (x >= a) & (x < b)
            if m.sum() >= L.MIN_BIN_ROWS:
                g = t[m].sum() ** 2 / m.sum()
                if g > best:
                    best, arg = g, (a, b)
    assert got == pytest.approx(arg)
    assert got[0] == pytest.approx(lo, abs=0.1) and got[1] == pytest.approx(hi, abs=0.1)


def test_nuisance_columns_span_the_range_with_the_term_sign():
    obs = _observations()
    deg = np.degrees(np.abs(obs.alpha))
    resid = _noise(obs) + (obs.direction * ((deg >= 12.0) & (deg <= 18.0)) * 4e3)[:, None]
    loc = L.locate(obs, resid, 1.0)
    z, cols = loc.columns(obs)
    assert [c.name for c in cols] == list(z) and len(cols) >= 3
    total = sum(z.values())
    inside = (deg >= loc.lo) & (deg < loc.hi) & (obs.direction != 0)
    np.testing.assert_array_equal(total[:, 0], np.where(inside, obs.direction, 0.0))
    near = loc.near_ends(obs)
    assert near.any() and not near[np.abs(deg - 15.0) < 2.0].any()


def test_named_pieces_on_other_data_are_the_same_levels():
    """The windows fit a term located on the whole log on part of it: the pieces the whole
    log's fit kept, by name and in that order, each the same column on any rows, a piece the
    part holds few rows of included; a name the term has no piece for is refused."""
    obs = _observations()
    deg = np.degrees(np.abs(obs.alpha))
    resid = _noise(obs) + (obs.direction * ((deg >= 12.0) & (deg <= 18.0)) * 4e3)[:, None]
    loc = L.locate(obs, resid, 1.0)
    z, cols = loc.columns(obs)
    names = tuple(reversed([c.name for c in cols]))
    low = deg < 14.0                                        # the range's upper pieces hold no row of it
    part = obs.select(low)
    zp, cp = loc.columns(part, names)
    assert tuple(zp) == names and [c.name for c in cp] == list(names) and L.piece_columns(names) == cp
    for name in names:
        np.testing.assert_array_equal(zp[name], z[name][low])
    assert len(loc.columns(part)[0]) < len(names)           # unnamed: the part's empty pieces left out
    with pytest.raises(ValueError, match='the located term has no piece located_99'):
        loc.columns(part, ('located_99',))


def test_an_unknown_variable_is_named():
    with pytest.raises(ValueError, match="unknown variable 'depth_m'"):
        L.variable_values(_observations(n=100), 'depth_m')


def test_a_moved_term_measures_its_level_on_the_bins_it_covers():
    loc = _band_located()
    same = loc.moved(loc.lo, loc.hi)
    assert same.level == pytest.approx(4e3, rel=0.05) and same.share == pytest.approx(loc.share, rel=0.1)
    beside = loc.moved(loc.hi, loc.hi + (loc.hi - loc.lo))          # its width further out: noise only
    assert (beside.lo, beside.hi) == (loc.hi, 2 * loc.hi - loc.lo)
    assert abs(beside.level) < 0.05 * 4e3 and beside.share < 0.01
    half = loc.moved(loc.lo + 0.5 * (loc.hi - loc.lo), loc.hi + 0.5 * (loc.hi - loc.lo))
    assert 0.3 * loc.share < half.share < 0.7 * loc.share
    assert loc.moved(80.0, 90.0).level == 0.0                       # no bin there


def test_a_term_given_its_pieces_keeps_their_cuts_when_an_end_moves_by_one():
    """Grown by a piece of its own width (``pieces`` one more), the term's pieces are the ones
    it had and one more beside them; by the bin width alone they would be cut again."""
    obs = _observations()
    loc = _band_located()
    w = float(loc.edges[1] - loc.edges[0])
    loc = loc.moved(loc.lo, loc.lo + 3.4 * w)       # 3 pieces; 4.53 bins grown: 5 if cut again
    z, cols = loc.columns(obs)
    k = len(cols)
    assert k == 3
    step = (loc.hi - loc.lo) / k
    longer = replace(loc.moved(loc.lo, loc.hi + step), pieces=k + 1)
    zg, cg = longer.columns(obs)
    assert len(cg) == k + 1
    for name in z:
        np.testing.assert_array_equal(zg[name], z[name])
