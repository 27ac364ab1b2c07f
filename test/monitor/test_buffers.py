"""The live monitor's buffers: a ring of rows, the held pressure samples."""

from __future__ import annotations

import numpy as np
import pytest

from steer_monitor.monitor.buffers import HeldSamples, RowRing


@pytest.mark.parametrize('sizes', [[3, 4, 5], [7], [12], [25, 1, 9], [0, 2, 30]])
def test_a_ring_puts_rows_pushed_together_where_one_by_one_would(sizes):
    """The rams' share is summed over the ring's rows in the order they lie: a block of rows,
    even one longer than the ring, lies as the same rows pushed one at a time."""
    rng = np.random.default_rng(len(sizes))
    together, alone = RowRing(8, 3), RowRing(8, 3)
    every = np.zeros((0, 3))
    for n in sizes:
        block = rng.normal(size=(n, 3))
        every = np.concatenate([every, block])
        together.push(block)
        for row in block:
            alone.push(row[None, :])
        assert (together.next, together.kept) == (alone.next, alone.kept)
        np.testing.assert_array_equal(together.rows(), alone.rows())
        np.testing.assert_array_equal(together.ordered(), alone.ordered())
        np.testing.assert_array_equal(together.ordered(), every[len(every) - together.kept:])   # oldest first
    assert together.kept == min(sum(sizes), 8)


@pytest.mark.parametrize('seed', [4, 5])
def test_held_samples_come_out_as_they_went_in(seed):
    """The held pressure samples' buffer (blocks and single samples added, the oldest
    released, the rest moved down or the buffer grown as it fills) holds what a list would."""
    rng = np.random.default_rng(seed)
    held, want = HeldSamples(), []
    k = 0
    for _ in range(400):
        what = rng.integers(0, 3)
        if what == 0:                                   # a block, up to past the buffer's size
            n = int(rng.choice([0, 3, 80, 700, 3000]))
            t = np.arange(k, k + n, dtype=np.int64)
            held.add(t, np.column_stack([t, -t, 2 * t, t + 0.5]).astype(float))
            want += [(int(x), (float(x), float(-x), float(2 * x), x + 0.5)) for x in t]
            k += n
        elif what == 1:                                 # single samples
            for _ in range(int(rng.integers(1, 30))):
                held.add_one(k, [float(k), float(-k), float(2 * k), k + 0.5])
                want.append((k, (float(k), float(-k), float(2 * k), k + 0.5)))
                k += 1
        else:
            r = int(rng.integers(0, len(want) + 1))
            held.release(r)
            del want[:r]
        assert len(held) == len(want)
        t, p = held.view()
        assert t.tolist() == [w[0] for w in want] and [tuple(row) for row in p.tolist()] == [w[1] for w in want]
