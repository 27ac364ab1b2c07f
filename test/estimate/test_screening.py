"""What an adopted effect must take from the residual: something systematic that is there."""

from __future__ import annotations

import numpy as np

from steer_monitor.estimate.analyze import MIN_SYSTEMATIC_SHARE, SYSTEMATIC_LAG_STEPS
from steer_monitor.estimate.sampling import GRID_NS
from steer_monitor.estimate.screening import takes_systematic

N = 20_000
T = np.arange(N, dtype=np.int64) * GRID_NS


def _both(r: np.ndarray) -> tuple[np.ndarray, np.ndarray, int]:
    return np.stack([r, r[::-1]], axis=1), T, GRID_NS


def test_a_term_that_is_there_taken_out_is_systematic():
    """A slow misfit (AR(1), 0.9 per step) beside white noise: a model that takes the misfit
    takes a positive autocovariance, most of the fall of the mean square."""
    rng = np.random.default_rng(1)
    noise = rng.normal(0.0, 1.0, N)
    slow = np.zeros(N)
    e = rng.normal(0.0, 0.5, N)
    for k in range(1, N):
        slow[k] = 0.9 * slow[k - 1] + e[k]
    assert takes_systematic(_both(noise + slow), _both(noise), SYSTEMATIC_LAG_STEPS, MIN_SYSTEMATIC_SHARE)
    # and what fits the noise alone takes nothing that shows at the next instant
    assert not takes_systematic(_both(noise + slow), _both(0.95 * noise + slow), SYSTEMATIC_LAG_STEPS,
                                MIN_SYSTEMATIC_SHARE)


def test_making_a_nil_or_negative_autocovariance_more_negative_takes_nothing():
    """Noise that alternates (MA(1), -0.3: its autocovariance at the next instant negative,
    nothing systematic there): a column that lowers the mean square and pushes the
    autocovariance further down has taken nothing that was there. The rule before counted the
    fall from one negative value to a lower one as systematic, and adopted it."""
    rng = np.random.default_rng(2)
    e = rng.normal(0.0, 1.0, N + 1)
    before = e[1:] - 0.3 * e[:-1]
    after = 0.95 * e[1:] - 0.42 * e[:-1]          # lower mean square, more negative at lag 1
    mse = (float(np.mean(before ** 2)), float(np.mean(after ** 2)))
    cov = (float(np.mean(before[1:] * before[:-1])), float(np.mean(after[1:] * after[:-1])))
    assert mse[1] < mse[0] and cov[1] < cov[0] < 0
    assert cov[0] - cov[1] >= MIN_SYSTEMATIC_SHARE * (mse[0] - mse[1])        # what the old rule passed
    assert not takes_systematic(_both(before), _both(after), SYSTEMATIC_LAG_STEPS, MIN_SYSTEMATIC_SHARE)


def test_nothing_to_compare_is_not_systematic():
    empty = np.full((4, 2), np.nan)
    t = np.arange(4, dtype=np.int64) * GRID_NS
    assert not takes_systematic((empty, t, GRID_NS), (empty, t, GRID_NS), SYSTEMATIC_LAG_STEPS, MIN_SYSTEMATIC_SHARE)
