"""A decoded run's rejects, counted as its frames are reached: any sequence of stops counts
each reject once, by the stop at or after its frame, few at a time or many at once."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from steer_monitor.can.decodedrun import DecodedRun
from steer_monitor.can.rejects import RejectCounter

_KINDS = (('unknown_id', ''), ('duplicate', ''), ('out_of_range', 'rudder_angle'), ('unmapped', ''))


def _run(rows_by_kind: list[list[int]], n: int) -> DecodedRun:
    events = [(np.array(sorted(r), np.intp), reason, signal) for r, (reason, signal) in zip(rows_by_kind, _KINDS)]
    empty = np.zeros(0, np.intp)
    t = np.arange(n, dtype=np.int64)
    return DecodedRun(t, t, t, empty, np.zeros(0, np.int64), empty, (), np.zeros(0), events, RejectCounter())


@settings(max_examples=200, deadline=None)
@given(rows=st.lists(st.lists(st.integers(0, 299), max_size=150), min_size=4, max_size=4),
       stops=st.lists(st.integers(0, 299), max_size=8))
def test_each_reject_is_counted_once_by_the_first_stop_at_or_after_its_frame(rows, stops):
    run = _run(rows, 300)
    for stop in [*sorted(stops), 299]:
        run.count_rejects(stop)
        snap = run.rejects.snapshot()
        for r, (reason, signal) in zip(rows, _KINDS):
            assert snap.counts.get(reason, 0) == sum(1 for x in r if x <= stop)
            if signal:
                assert snap.by_signal.get((reason, signal), 0) == sum(1 for x in r if x <= stop)


def test_counting_rows_are_the_stops_that_count_something():
    run = _run([[3, 10], [10], [], [250]], 300)
    visited = np.array([0, 5, 9, 11, 100, 299], np.intp)
    assert run.counting_rows(visited).tolist() == [5, 11, 299]
