"""The clearances beside an unexplained misfit spanned over the places it fits as well."""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from steer_monitor.estimate.batch import ClearanceEstimate
from steer_monitor.estimate.intervals import Interval
from steer_monitor.estimate.placements import Placed, grown, moved_off, spanned

TWO_Z = Interval(3e-4, 2e-4, 4e-4)


def _est(z_gb: Interval, two_z: Interval = TWO_Z, k: float = 0.0) -> ClearanceEstimate:
    """An estimate with the intervals a placement's fit gave (the rest is not read by spanned)."""
    return ClearanceEstimate(
        two_z=two_z, z_gb=z_gb, seal_friction=Interval(9e3 + k, 8.9e3 + k, 9.1e3 + k),
        mu_bushing=Interval(0.13, 0.12, 0.14), mu_guide=Interval(0.05, 0.04, 0.06), extra={},
        torque_curve=(np.zeros(1), np.zeros(1), np.zeros(1)), k_gl_max=Interval(0.7 + k, 0.6 + k, 0.8 + k),
        rms=1.0, rows=100, inflation=1.0, noise_rms=1.0, smooth_rms=0.1, residual=np.zeros((1, 2)),
        profile=None, fit=None, rss_floor=1.0 + k, sigma2=1.0)


class _Where:
    """A placement's place (spanned reads none of it)."""


def test_one_placement_that_fits_is_the_answer_as_it_is():
    best = _est(Interval(1.2e-4, 1.1e-4, 1.3e-4))
    worse = _est(Interval(3.0e-4, 2.7e-4, 3.3e-4), k=5.0)
    assert spanned([Placed(_Where(), best), Placed(_Where(), worse, fits=False)]) is best


def test_the_intervals_span_every_placement_that_fits_as_well_and_keep_the_best_point():
    best = _est(Interval(1.2e-4, 1.1e-4, 1.3e-4))
    alike = _est(Interval(2.0e-4, 1.8e-4, 2.2e-4), two_z=Interval(2.5e-4, 1.5e-4, 3.5e-4), k=1.0)
    far = _est(Interval(3.0e-4, 2.7e-4, 3.3e-4), k=9.0)
    out = spanned([Placed(_Where(), best), Placed(_Where(), alike), Placed(_Where(), far, fits=False)])
    assert (out.z_gb.value, out.z_gb.lo, out.z_gb.hi) == (1.2e-4, 1.1e-4, 2.2e-4)
    assert (out.two_z.value, out.two_z.lo, out.two_z.hi) == (3e-4, 1.5e-4, 4e-4)
    assert (out.k_gl_max.lo, out.k_gl_max.hi) == (0.6, 1.8) and out.k_gl_max.value == 0.7
    assert out.seal_friction.hi == 9.1e3 + 1.0 and out.seal_friction.lo == 8.9e3
    assert out.bound_why == ('', '')
    assert math.isclose(out.rss_floor, best.rss_floor)


def test_a_placement_that_bounds_a_clearance_only_from_below_makes_it_a_bound_saying_why():
    best = _est(Interval(1.2e-4, 1.1e-4, 1.3e-4))
    open_above = _est(Interval(2.0e-4, 0.0, None), k=1.0)
    out = spanned([Placed(_Where(), best), Placed(_Where(), open_above)])
    assert out.z_gb.lo == 0.0 and out.z_gb.hi is None and out.z_gb.one_sided
    assert out.bound_why[1] == 'the misfit the model lacks fits as well elsewhere, where the clearance reads higher'
    assert out.bound_why[0] == ''


def test_a_term_that_fits_best_away_from_where_the_residual_put_it_spans_every_place_tried():
    """The best of a few placements tried, none where the residual put the term: where it sits
    is not known, and a placement that fits clearly worse counts too."""
    moved = _est(Interval(1.34e-4, 1.24e-4, 1.75e-4))
    located = _est(Interval(1.7e-4, 0.0, None), k=200.0)
    beside = _est(Interval(1.3e-4, 0.9e-4, 1.5e-4), k=300.0)
    placed = [Placed(_Where(), moved, shift=1.0), Placed(_Where(), located, fits=False),
              Placed(_Where(), beside, fits=False, shift=-0.5)]
    assert moved_off(placed) and not moved_off(placed[1:]) and not moved_off([])
    out = spanned(placed)
    assert out.z_gb.lo == 0.0 and out.z_gb.hi is None
    assert out.bound_why[1].startswith('where the misfit the model lacks sits is not known')
    assert (out.two_z.lo, out.two_z.hi) == (2e-4, 4e-4) and out.two_z.value == 3e-4


@dataclass(frozen=True)
class _Term:
    """A located term over [lo, hi) of a variable seen up to ``end``, in pieces of about 1 unit
    (what grown reads of a Located)."""

    lo: float
    hi: float
    end: float = 20.0
    pieces: int = 0
    either_side: bool = True

    @property
    def cut_into(self) -> int:
        return self.pieces or round(self.hi - self.lo)

    def columns(self, obs: object) -> tuple[dict, tuple]:
        cuts = np.linspace(self.lo, self.hi, self.cut_into + 1)
        return {}, (None,) * int(np.sum(cuts[:-1] < self.end - 0.5))

    def moved(self, lo: float, hi: float) -> _Term:
        return replace(self, lo=lo, hi=hi)


def _fits(band: tuple[float, float], drop: float, tried: list[tuple[float, float]]):
    """A fit whose least RSS falls by ``drop`` per unit of ``band`` the term covers, from 10,000
    (10,000 rows, no inflation: a piece is charged log(10,000) = 9.2 and must buy 10 more)."""
    def fit(term: _Term) -> ClearanceEstimate:
        tried.append((term.lo, term.hi))
        covered = max(0.0, min(term.hi, band[1]) - max(term.lo, band[0]))
        return replace(_est(Interval(1e-4, 0.9e-4, 1.1e-4)), rows=10_000, rss_floor=1e4 - drop * covered)
    return fit


def test_a_term_grows_a_piece_at_a_time_while_the_fit_pays_for_each():
    """Located over part of a band (the residual of a fit that bent a clearance to take the
    rest): grown at the end where the band goes on, a piece of its own width at a time, its
    pieces kept, to the band's end."""
    tried: list[tuple[float, float]] = []
    fit = _fits((12.0, 18.0), 40.0, tried)
    start = _Term(12.0, 15.0)
    term, est = grown(start, fit(start), fit, None)
    assert (term.lo, term.hi, term.pieces) == (12.0, 18.0, 6)
    assert est.rss_floor == 1e4 - 40.0 * 6
    assert (11.0, 15.0) in tried and (12.0, 19.0) in tried     # each end tried, the piece past the band refused


def test_a_piece_that_does_not_pay_for_itself_is_not_added_nor_one_past_the_data():
    tried: list[tuple[float, float]] = []
    fit = _fits((12.0, 18.0), 15.0, tried)       # pays its charge, not the 10 more
    start = _Term(12.0, 15.0)
    term, _ = grown(start, fit(start), fit, None)
    assert (term.lo, term.hi) == (12.0, 15.0)
    tried.clear()
    fit = _fits((0.0, 30.0), 40.0, tried)
    start = _Term(0.5, 20.0)                    # the data end at 20 and the magnitude at 0
    term, _ = grown(start, fit(start), fit, None)
    assert (term.lo, term.hi) == (0.5, 20.0) and tried == [(0.5, 20.0)]


def test_a_term_that_does_not_grow_keeps_its_cuts_a_thin_piece_included():
    """A piece with too few rows to be fitted still counts in how the range is cut: a term that
    does not grow is fitted as located."""
    tried: list[tuple[float, float]] = []
    fit = _fits((0.0, 1.0), 40.0, tried)        # nothing to gain anywhere
    start = _Term(12.0, 19.6, end=19.0)         # 8 pieces, the last too thin to fit
    term, _ = grown(start, fit(start), fit, None)
    assert (term.lo, term.hi, term.cut_into) == (12.0, 19.6, 8)
    assert len(term.columns(None)[1]) == len(start.columns(None)[1]) == 7
