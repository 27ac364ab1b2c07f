"""What the live monitor hears of each input: arrivals kept, rates, the rate window."""

from __future__ import annotations

import numpy as np
import pytest

from steer_monitor.model.inputs import Sample
from steer_monitor.monitor.arrivals import ARRIVALS_KEPT_NS, Arrivals, InputLog


def test_a_rate_window_longer_than_the_arrivals_kept_is_refused():
    inputs = InputLog()
    with pytest.raises(ValueError, match='rate window 31 s is longer than the 30 s of arrivals kept'):
        inputs.rate_hz('oil_temperature', 0, ARRIVALS_KEPT_NS + 1_000_000_000)


@pytest.mark.parametrize('times_s', [
    [0.0, 0.1, 0.2, 0.5, 1.0, 4.0, 6.5, 7.0],
    [0.0, 5.0, 9.0],
    [1.0, 2.0, 3.0, 2.5, 3.5, 4.0],          # a step back in time: read as it came, not bisected
    [7.0],
    [],
])
@pytest.mark.parametrize('now_s', [0.0, 3.0, 7.0, 9.5, 60.0])
def test_rate_is_the_spacing_of_the_arrivals_in_the_window(times_s, now_s):
    inputs = InputLog()
    for t in times_s:
        s = Sample(int(t * 1e9), 'oil_temperature', 40.0)
        inputs.heard(s.signal, s.t_ns, s.value)
    recent = [t for t in times_s if t >= now_s - 5.0]
    want = 0.0 if len(recent) < 2 or recent[-1] == recent[0] else (len(recent) - 1) / (recent[-1] - recent[0])
    assert inputs.rate_hz('oil_temperature', int(now_s * 1e9)) == pytest.approx(want, rel=1e-12)


@pytest.mark.parametrize('back_at', [None, 700, 5000])
def test_arrivals_kept_are_those_a_deque_popped_from_the_front_keeps(back_at):
    """An input's arrival times kept (the last 30 s, dropped from the front while the first is
    older than the newest's window, as they came; a clock step back makes them unordered) over
    a long stream, one by one and in ordered batches, against a deque doing just that."""
    from collections import deque

    rng = np.random.default_rng(7)
    times = np.cumsum(rng.integers(1, 200_000_000, 8000)).tolist()
    if back_at is not None:
        times = times[:back_at] + [t - 40_000_000_000 for t in times[back_at:]]
    want: deque[int] = deque()
    one, many = Arrivals(), Arrivals()
    k = 0
    while k < len(times):
        batch = times[k:k + int(rng.integers(1, 40))]
        for t in batch:
            want.append(t)
            while want and want[0] < t - ARRIVALS_KEPT_NS:
                want.popleft()
            one.arrive(t)
        if many.ordered and (not many.kept() or batch[0] >= many.times[-1]) and batch == sorted(batch):
            many.arrive_many(batch)
        else:
            for t in batch:
                many.arrive(t)
        assert one.arrivals == many.arrivals == list(want) and one.kept() == len(want)
        k += len(batch)
    assert len(one.times) < 2 * len(want) + 2048            # cut down as it goes
    assert one.ordered == (back_at is None)
