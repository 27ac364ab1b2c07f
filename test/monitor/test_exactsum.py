"""Correctly rounded sums kept as values come and go: math.fsum's, to the bit."""

from __future__ import annotations

import math

import numpy as np
import pytest

from steer_monitor.monitor.exactsum import MAX_PARTIALS, partials_total, push_counting_squares


def test_the_kept_sum_of_squares_is_math_fsums_to_the_bit():
    """Values of magnitudes from 1e-8 to 1e8 pushed as judged pairs into a ring that holds
    them all: the partials' total is math.fsum of their squares, to the bit (a sum plain
    addition gets wrong among them); an overflowing square is counted as not finite and left
    out, as is a NaN's."""
    rng = np.random.default_rng(11)
    for _ in range(500):
        x = rng.normal(0.0, 1.0, 2 * int(rng.integers(0, 650))) * 10.0 ** rng.integers(-8, 8)
        rows = np.column_stack([x.reshape(-1, 2), np.ones(x.size // 2)])
        partials = np.empty(MAX_PARTIALS)
        _, kept, k, values, bad = push_counting_squares(np.zeros((700, 3)), 0, 0, rows, partials, 0)
        assert (kept, values, bad) == (x.size // 2, x.size, 0)
        assert partials_total(partials, k) == math.fsum(v * v for v in x.tolist())
    partials = np.empty(MAX_PARTIALS)
    rows = np.array([[1e200, 3.0, 1.0], [math.nan, 4.0, 1.0], [5.0, 6.0, 0.0]])
    _, _, k, values, bad = push_counting_squares(np.zeros((4, 3)), 0, 0, rows, partials, 0)
    assert (values, bad) == (4, 2) and partials_total(partials, k) == 25.0


@pytest.mark.parametrize('sizes', [[1] * 40, [3, 7, 2, 11, 5, 9, 1, 13], [25, 4, 30, 0, 2], [8, 8, 8, 8, 8, 8]])
def test_pushing_rows_keeps_the_last_and_the_exact_sum_of_their_squares(sizes):
    """push_counting_squares against a list that keeps the last cap rows: the ring's rows
    (oldest first from next - kept) are the list's, and after every push the partials' total
    is math.fsum of the squares of the judged pairs held, to the bit; the counts of values and
    of non-finite squares follow the rows held. Pushes larger than the ring included; rows of
    big and tiny magnitudes, a NaN and an overflowing value among them."""
    cap = 10
    rng = np.random.default_rng(len(sizes))
    data = np.zeros((cap, 3))
    partials = np.empty(MAX_PARTIALS)
    nxt = kept = k = values = bad = 0
    held: list[list[float]] = []
    for size in sizes:
        rows = np.column_stack([rng.normal(0, 1, (size, 2)) * 10.0 ** rng.integers(-8, 9, (size, 2)),
                                rng.integers(0, 2, size).astype(float)])
        if size > 3:
            rows[1, 0], rows[2, 1], rows[2, 2], rows[3, 2] = math.nan, 1e200, 1.0, 1.0
        nxt, kept, k, dv, db = push_counting_squares(data, nxt, kept, rows, partials, k)
        values, bad = values + dv, bad + db
        held = (held + rows.tolist())[-cap:]
        assert kept == len(held)
        ring = data[(np.arange(kept) + nxt - kept) % cap]
        assert ring.tolist() == held or np.array_equal(ring, np.array(held), equal_nan=True)
        judged = [v for r in held if r[2] != 0.0 for v in r[:2]]
        squares = [v * v for v in judged]
        assert values == len(judged)
        assert bad == sum(not math.isfinite(q) for q in squares)
        finite = [q for q in squares if math.isfinite(q)]
        assert partials_total(partials, k) == math.fsum(finite)
