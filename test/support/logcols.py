"""Comparing the column readers with the reference reader: frames column by column."""

from __future__ import annotations

import numpy as np

from steer_monitor.can import FrameArrays, RejectCounter
from steer_monitor.logfiles.blocks import read_log_fast
from steer_monitor.logfiles.candumpcols import iter_candump_blocks
from test.logfiles.reference_reader import read_log_reference

__all__ = ['COLUMNS', 'both', 'same']

COLUMNS = ('t_ns', 'can_id', 'dlc', 'data', 'flags')


def same(a: FrameArrays, b: FrameArrays) -> None:
    """The two hold the same frames, column by column."""
    assert len(a) == len(b)
    for c in COLUMNS:
        np.testing.assert_array_equal(getattr(a, c), getattr(b, c), err_msg=c)


def both(path, **kw):
    """(the reference reader's frames, the column reader's, their two reject snapshots)."""
    r1, r2 = RejectCounter(), RejectCounter()
    ref = read_log_reference(path, r1)
    got = (
        FrameArrays.concat(list(iter_candump_blocks(path, r2, **kw)))
        if path.suffix == '.log'
        else read_log_fast(path, r2)
    )
    return ref, got, r1.snapshot(), r2.snapshot()
