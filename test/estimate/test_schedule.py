"""When the node analyses: on the motion counted, as it doubles, then at fixed periods."""

from __future__ import annotations

import math

import pytest

from steer_monitor.estimate.schedule import FIRST_S, AnalysisSchedule


def _runs(s: AnalysisSchedule, upto: float, step: float = 1.0) -> list[tuple[float, str]]:
    out = []
    m = 0.0
    while m <= upto:
        kind = s.due(m)
        if kind is not None:
            out.append((m, kind))
        m += step
    return out


def test_the_first_analysis_waits_for_four_minutes_of_motion():
    runs = _runs(AnalysisSchedule(loop_every_s=1800.0, every_s=300.0), 6000.0)
    assert FIRST_S == 240.0 and runs[0] == (240.0, 'loop')
    assert [m for m, k in runs if k == 'loop'] == [240.0, 480.0, 960.0, 1920.0, 3720.0, 5520.0]


def test_loops_as_the_motion_doubles_then_every_period_with_estimates_between():
    runs = _runs(AnalysisSchedule(loop_every_s=1800.0, every_s=300.0, first_s=30.0), 6000.0)
    loops = [m for m, k in runs if k == 'loop']
    assert loops == [30.0, 60.0, 120.0, 240.0, 480.0, 960.0, 1920.0, 3720.0, 5520.0]
    estimates = [m for m, k in runs if k == 'estimate']
    assert estimates[:3] == [780.0, 1260.0, 1560.0]
    for a, b in zip(loops, loops[1:]):          # between two loops: every 300 s of motion from the first
        between = [m for m in estimates if a < m < b]
        assert between == [a + 300.0 * k for k in range(1, len(between) + 1)]
        assert not between or b - between[-1] <= 300.0


def test_motion_that_jumps_runs_one_analysis():
    """A restart with an hour of motion counted: one loop, not the ones it skipped."""
    s = AnalysisSchedule(loop_every_s=1800.0, every_s=300.0)
    assert s.due(3600.0) == 'loop' and s.due(3600.0) is None
    assert s.next_loop_s == 3600.0 + 1800.0


def test_its_progress_survives_a_restart():
    a = AnalysisSchedule(loop_every_s=1800.0, every_s=300.0)
    _runs(a, 1000.0)
    b = AnalysisSchedule(loop_every_s=1800.0, every_s=300.0)
    b.restore(a.to_dict())
    assert _runs(a, 4000.0)[-3:] == _runs(b, 4000.0)[-3:]
    with pytest.raises(ValueError, match='next loop at'):
        b.restore({'next_loop_s': math.nan, 'next_estimate_s': 1.0})


@pytest.mark.parametrize('field', ['loop_every_s', 'every_s', 'first_s'])
@pytest.mark.parametrize('bad', [0.0, -1.0, math.inf, math.nan])
def test_a_schedule_needs_positive_periods(field, bad):
    kwargs = {'loop_every_s': 1800.0, 'every_s': 300.0, 'first_s': FIRST_S, field: bad}
    with pytest.raises(ValueError, match=f'{field} must be a positive number of seconds'):
        AnalysisSchedule(**kwargs)
