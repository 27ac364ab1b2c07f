"""The friction's intervals over the lags a slow log's stamps allow between angle and pressures.

A gateway stamps a value when it sends it, not when the sensor read it: one that holds the last
value and sends it on its own timer sends the angle up to a period of the sensor old, the
pressures up to theirs (:attr:`~steer_monitor.estimate.sampling.Windows.lag_span_ns`). Read
against pressures of another instant, the angle's motion puts the force a ram needed at a
slightly other angle; the error follows the direction of motion, as friction does, and the
fitted friction takes it. On the simulator's gateway holding 5 Hz values (angle sensor 10 Hz,
pressures 20 Hz) the seal friction read 5-12 % high in four voyages of five, outside its
interval; reading the angle 25-50 ms later put it on the truth. The clearances did not move
out of their intervals: a clearance shows as a kink in the force against the angle, which a
shift along the motion moves little.

Which lag a log has cannot be told from its stamps (a gateway that forwards each frame as it
comes adds none), nor from the fit: the residual over the lag is nearly flat, and its minimum
is not where the friction is true (seed 74602 through that gateway: smallest residual at a
lag of -25 to 0 ms, where F_s read 10.0-10.6 kN for 9.0; a deviance set over the lag would
have excluded the truth). So the friction coefficients (F_s, mu_b, mu_g) are fitted again with the
angle read at either end of the span, on the same instants and model, and each interval is
widened to hold theirs: the interval then holds the truth at any lag in the span (the friction
moves with the lag about linearly, so its ends are the extremes). At the design rates the
span is nothing and the estimate is returned as it is. Pure.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import replace

import numpy as np
from numpy.typing import NDArray

from steer_monitor.estimate import fit as F
from steer_monitor.estimate.batch import ClearanceEstimate, estimate_clearances, make_rows, within_range
from steer_monitor.estimate.effects import z_columns
from steer_monitor.estimate.intervals import Interval
from steer_monitor.estimate.observe import EstimateError, Observations, build_observations, in_sorted
from steer_monitor.estimate.sampling import Windows
from steer_monitor.model.gear import GearParams
from steer_monitor.model.inputs import Series

__all__ = ['FRICTION', 'over_stamp_lags', 'spanning']

#: the friction coefficients whose intervals span the lags: (the estimate's field, the fit's name)
FRICTION = (('seal_friction', 'seal_friction_n'), ('mu_bushing', 'mu_bushing'), ('mu_guide', 'mu_guide'))


def spanning(name: str, iv: Interval, others: Sequence[Interval]) -> Interval:
    """``iv`` (its value kept) widened to hold each of ``others``, held to ``name``'s physical
    range; not determined (both ends None) where any of them is not."""
    ends = (iv, *others)
    if any(x.lo is None or x.hi is None for x in ends):
        return Interval(iv.value, None, None)
    return within_range(name, iv.value, min(x.lo for x in ends), max(x.hi for x in ends))  # type: ignore[type-var]


def over_stamp_lags(gear: GearParams, signals: Mapping[str, Series], est: ClearanceEstimate, obs: Observations,
                    keep: NDArray[np.bool_], extra: tuple[F.Column, ...], shift_s: float, grid_2z: NDArray,
                    model_inflation: float = 1.0, say: Callable[[str], None] | None = None) -> ClearanceEstimate:
    """``est`` (fitted on ``obs``, the angle read ``shift_s`` later, at the instants ``keep``
    with the columns ``extra``) with its friction intervals spanning the fits with the angle
    read at either end of the lags ``signals``' stamps allow (see the module). A fit that
    cannot be made at a lag (too little steady motion left) leaves the friction not determined."""
    lo_ns, hi_ns = Windows.of(signals).lag_span_ns
    if lo_ns == 0 and hi_ns == 0:
        return est
    instants = obs.t_ns[keep & obs.moving]
    others: dict[str, list[Interval]] = {field: [] for field, _ in FRICTION}
    for lag_ns in (lo_ns, hi_ns):
        if say is not None:
            say(f'the friction refitted with the angle read {lag_ns / 1e6:+.0f} ms from its stamps')
        o = build_observations(signals, gear.ram_area, angle_shift_s=shift_s + lag_ns / 1e9)
        try:
            alt = estimate_clearances(gear, o, make_rows(o, z_columns(o, gear), in_sorted(o.t_ns, instants)), extra,
                                      grid_2z=grid_2z, model_inflation=model_inflation)
        except EstimateError:
            return replace(est, **{field: Interval(getattr(est, field).value, None, None) for field, _ in FRICTION})
        for field, _ in FRICTION:
            others[field].append(getattr(alt, field))
    return replace(est, **{field: spanning(name, getattr(est, field), others[field]) for field, name in FRICTION})
