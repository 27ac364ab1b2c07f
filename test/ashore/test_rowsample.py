"""The rows a review window measures its residual spread on: a function of the rows before
the window's end alone (checked against the definition written out), spread over all of them,
and bounded in what it keeps, planned or not."""

from __future__ import annotations

import numpy as np
import pytest

from steer_monitor.ashore.rowsample import CHUNK_NS, RowSample
from steer_monitor.estimate.observe import Observations

SLICE_NS = 600 * 1_000_000_000     # the review's windows end on whole slices
T0 = 1_767_225_600 * 1_000_000_000


def _rows(t_ns: np.ndarray) -> Observations:
    n = t_ns.size
    return Observations(t_ns.astype(np.int64), np.full(n, 0.1), np.full(n, 0.01), np.ones(n, np.int8),
                        np.ones((n, 2)), np.ones((n, 4)), np.full(n, np.nan), np.full(n, np.nan))


def _voyage(seed: int, hours: float) -> np.ndarray:
    """Grid times of steady motion in bursts (a realistic voyage's: minutes of steering, then
    minutes of none), some of it dense."""
    rng = np.random.default_rng(seed)
    t, out = T0, []
    while t < T0 + hours * 3600e9:
        n = int(rng.integers(20, 4000))
        out.append(t + np.arange(n, dtype=np.int64) * 50_000_000)
        t += n * 50_000_000 + int(rng.integers(1, 900)) * 1_000_000_000
    return np.concatenate(out)


def _expected(t: np.ndarray, end: int, max_rows: int) -> np.ndarray:
    """The definition: the rows before ``end`` of every s-th chunk, s the least power of two
    leaving at most ``max_rows`` rows of the chunks begun before ``end``."""
    chunk = t // CHUNK_NS
    begun = chunk < -(-end // CHUNK_NS)
    s = 1
    while np.count_nonzero(begun & (chunk % s == 0)) > max_rows:
        s *= 2
    return t[(t < end) & (chunk % s == 0)]


def _blocks(t: np.ndarray, seed: int) -> list[np.ndarray]:
    rng = np.random.default_rng(seed)
    cuts = np.sort(rng.choice(np.arange(1, t.size), size=min(40, t.size - 1), replace=False))
    return np.split(t, cuts)


@pytest.mark.parametrize('seed', [1, 2, 3])
def test_a_planned_reviews_windows_get_the_sample_of_their_own_rows(seed):
    t = _voyage(seed, 8.0)
    max_rows, step = 20_000, 2 * SLICE_NS
    sample = RowSample(max_rows)
    first_end = (T0 // SLICE_NS) * SLICE_NS + step
    end, kept = first_end, []
    for block in _blocks(t, seed):
        sample.add(_rows(block))
        while block[-1] >= end:          # the data passed the window's end: estimated now
            got = sample.before(end)
            np.testing.assert_array_equal(got.t_ns if got is not None else np.zeros(0, np.int64),
                                          _expected(t, end, max_rows))
            end += step
        sample.prune(next_end_ns=end, step_ns=step)
        kept.append(sample.kept)
    whole = sample.before(int(t[-1]) + 1)
    np.testing.assert_array_equal(whole.t_ns, _expected(t, int(t[-1]) + 1, max_rows))
    # spread over the voyage, not its end
    assert np.unique(whole.t_ns // CHUNK_NS).size >= 5 and whole.t_ns[-1] - whole.t_ns[0] > 0.8 * (t[-1] - t[0])
    assert t.size > 4 * max_rows and max(kept) <= 2 * max_rows


@pytest.mark.parametrize('seed', [4, 5])
def test_a_review_not_planned_keeps_what_any_window_may_ask_for(seed):
    """Windows decided at the end may end on any slice: every slice's sample is there, and what
    is kept grows with the logarithm of the log's length, not with it."""
    t = _voyage(seed, 24.0)
    max_rows = 20_000
    sample = RowSample(max_rows)
    for block in _blocks(t, seed):
        sample.add(_rows(block))
        sample.prune(boundary_ns=SLICE_NS)
    first = (int(t[0]) // SLICE_NS + 1) * SLICE_NS
    for end in range(first, int(t[-1]) + SLICE_NS, SLICE_NS):
        got = sample.before(end)
        np.testing.assert_array_equal(got.t_ns if got is not None else np.zeros(0, np.int64),
                                      _expected(t, end, max_rows))
    assert t.size > 8 * max_rows
    assert sample.kept <= max_rows * (np.log2(t.size / max_rows) + 3)


def test_a_short_voyage_is_sampled_whole():
    t = _voyage(6, 0.5)
    sample = RowSample(t.size)
    sample.add(_rows(t))
    np.testing.assert_array_equal(sample.before(int(t[-1]) + 1).t_ns, t)
    assert sample.before(int(t[0])) is None
    mid = int(t[t.size // 2])            # an end inside a chunk: its rows before the end only
    np.testing.assert_array_equal(sample.before(mid).t_ns, t[t < mid])
    assert sample.first_ns() == int(t[0])


def test_a_sample_refuses_a_size_it_cannot_have():
    with pytest.raises(ValueError, match='max_rows and chunk_ns >= 1, got 0'):
        RowSample(0)


def test_windows_that_do_not_end_on_whole_chunks_are_refused():
    """A window's sample counts whole chunks: an end inside one would make it depend on the
    rows read after the end."""
    sample = RowSample(100)
    sample.add(_rows(_voyage(7, 0.2)))
    with pytest.raises(ValueError, match='windows must end on whole chunks of 300000000000 ns'):
        sample.prune(boundary_ns=CHUNK_NS // 2)
    with pytest.raises(ValueError, match='whole chunks'):
        sample.prune(next_end_ns=T0 + CHUNK_NS + 1, step_ns=CHUNK_NS)
