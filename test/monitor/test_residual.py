"""The live residual: the model in use judged on the last minute of steady motion."""

from __future__ import annotations

import math

import numpy as np
import pytest

from steer_monitor.model import Clearances
from steer_monitor.model.friction import FrictionParams
from steer_monitor.monitor.residual import LiveResidual
from steer_monitor.params import gear_from_params


def test_the_residual_rms_is_a_correctly_rounded_sum(r18_params):
    """Squares whose plain sum differs from the exact one in the last bit: the RMS is the
    correctly rounded one (math.fsum)."""
    residual = LiveResidual(gear_from_params(r18_params), Clearances.from_mm(0.6, 0.25), FrictionParams())
    residual.push_rows(np.array([[1e8, 1.0, 1.0], [1.0, 1.0, 1.0]]))    # two judged pairs
    res = [1e8, 1.0, 1.0, 1.0]
    assert sum(r * r for r in res) != math.fsum(r * r for r in res)
    assert residual.summary()[2] == math.sqrt(math.fsum(r * r for r in res) / 4)


@pytest.mark.parametrize('case', ['configured', 'lower bounds only', 'fitted torque'])
def test_a_minute_rejudged_at_once_is_each_instant_judged_alone(r18_params, case):
    """A new estimate re-judges the kept minute of motion in one vectorized pass; each
    instant's residual pair (or None: a clamp the data never saw, an angle beyond the fitted
    torque) is the one-instant result, to rounding."""
    from steer_monitor.model.torque import TorqueTable
    gear = gear_from_params(r18_params)
    gaps = Clearances.from_mm(0.1, 0.05)
    residual = LiveResidual(gear, Clearances.from_mm(0.6, 0.25), FrictionParams())
    rng = np.random.default_rng(7)
    # (angle, speed (NaN: not known), direction, the rams' forces, rate, oil temperature)
    instants = [(float(a), math.nan if rng.random() < 0.3 else float(rng.uniform(2.0, 9.0)), float(d), float(f1),
                 float(f2), 0.02, 310.0)
                for a, d, f1, f2 in zip(rng.uniform(-0.61, 0.61, 600), rng.choice([-1.0, 1.0], 600),
                                        rng.uniform(-3e5, 3e5, 600), rng.uniform(-3e5, 3e5, 600))]
    angles = np.radians(np.arange(0.0, 25.01, 0.5))
    table = (
        TorqueTable(angles, 1.1 * gear.torque(angles), gear.torque.service_speed) if case == 'fitted torque' else None
    )
    interval = {'2z': (0.05e-3, None), 'zgb': (0.0, None)} if case == 'lower bounds only' else None
    residual.use(gaps, interval, FrictionParams(9000.0, 0.13, 0.05), table, new_source=case != 'configured')
    rows = residual.rows(np.array(instants))
    many, judged = rows[:, :2], rows[:, 2] == 1.0
    one = [residual.pair(i) for i in instants]
    assert judged.tolist() == [p is not None for p in one]
    assert set(rows[:, 2].tolist()) <= {0.0, 1.0}
    assert np.isnan(many[~judged]).all()
    if case != 'configured':
        assert 0 < sum(p is None for p in one) < len(one)
    for p, ok, q in zip(many.tolist(), judged, one):
        if ok:
            assert p == pytest.approx(q, rel=1e-12, abs=1e-9)


@pytest.mark.parametrize('seed', [1, 2, 3])
def test_the_residual_rms_kept_as_rows_come_and_go_is_the_minutes_fsum(r18_params, seed):
    """The minute's residual RMS, its sum of squares kept exactly as rows enter and leave the
    ring (blocks of any size, one longer than the ring, rows not judged, values from 1e-9 to
    1e6 bar, the ring emptied for a new model, a NaN judged), is math.fsum's over the rows held,
    to the bit, at every step."""
    import math
    rng = np.random.default_rng(seed)
    residual = LiveResidual(gear_from_params(r18_params), Clearances.from_mm(0.6, 0.25), FrictionParams())
    cap = residual.capacity
    for step in range(80):
        n = int(rng.choice([1, 7, 40, 333, cap + 17]))
        rows = np.column_stack([rng.normal(0, 1, (n, 2)) * 10.0 ** rng.integers(-9, 7, (n, 2)),
                                rng.random(n) < 0.8])
        rows[rows[:, 2] == 0.0, :2] = np.nan
        if step == 50:
            rows[0] = (math.nan, 1.0, 1.0)                 # a judged NaN: the RMS is NaN while it is held
        if step == 30:
            residual.clear_rows()                      # as a new model does
        residual.push_rows(rows)
        values = np.array(residual.residuals)
        count, skipped, rms = residual.summary()
        assert count == values.size and skipped == residual.kept - values.size // 2
        want = math.sqrt(math.fsum(v * v for v in values.tolist()) / values.size)
        assert rms == want or (math.isnan(rms) and math.isnan(want))
