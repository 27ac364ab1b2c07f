"""A decoded run's samples laid out for the pipeline to take at once. Pure.

:meth:`~steer_monitor.monitor.pipeline.Pipeline.feed_run` must leave the live model, the
analyst's window and the outputs exactly as :meth:`~steer_monitor.monitor.pipeline.Pipeline.feed`
of each frame would. Most samples only record a value (the pressures, the ship's speed, the
oil temperature) and most 10 ms slots only read the newest values; only the rudder's angle and
order drive state machines sample by sample. So a run is laid out once (:class:`RunPlan`):
per input its samples' positions, times and values; the four pressures as they stand after
each sample (forward filled) and the instants the residual will hold; where each input's
newest sample stands before any position. The pipeline then feeds the angle and order
samples one by one, brings the rest up to date only where something reads them (before a
whole second's diagnostics and analyses, at the run's end: :meth:`RunPlan.sync`), and works out the
slots' states at once (:meth:`RunPlan.states`) from the values that stood at each.

Positions are sample indices within the run; "before ``s``" means the samples ``< s``.
"""

from __future__ import annotations

import math
from bisect import bisect_left
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from steer_monitor.can.decoder import DecodedRun
from steer_monitor.model.inputs import INPUTS, PRESSURE_INPUTS
from steer_monitor.monitor.analyst import ANALYSED, Analyst
from steer_monitor.monitor.live import LiveMonitor, LiveState, states_at

__all__ = ['ANGLE', 'ORDER', 'RunPlan', 'StateRun', 'take_rudder']

_CODE = {name: k for k, name in enumerate(INPUTS)}
ANGLE, ORDER = _CODE['rudder_angle'], _CODE['rudder_order']
_PRESSURE = tuple(_CODE[n] for n in PRESSURE_INPUTS)
_RECORDED = tuple(k for k, n in enumerate(INPUTS) if k not in (ANGLE, ORDER))   # only recorded by update()
_SLOW = tuple(k for k in _RECORDED if k not in _PRESSURE)                         # read by the residual
_ANALYSED = tuple(_CODE[n] for n in ANALYSED)
_ENV = (_CODE['ship_speed'], _CODE['oil_temperature'])    # what an angle sample logs beside it


@dataclass(frozen=True)
class StateRun:
    """States of consecutive 10 ms slots as columns (n,): time [ns], angle [rad], rate
    [rad/s], measured torque [N m], the clearances in use [m]; their load sharing left to the
    writer, as :meth:`~steer_monitor.monitor.live.LiveMonitor.slot_state` leaves it."""

    t_ns: NDArray[np.int64]
    alpha: NDArray[np.float64]
    rate: NDArray[np.float64]
    torque: NDArray[np.float64]
    two_z: NDArray[np.float64]
    z_gb: NDArray[np.float64]

    def __len__(self) -> int:
        return int(self.t_ns.shape[0])


class RunPlan:
    """A run's samples laid out (see the module). ``emit_at``: the positions before which a
    slot's state may be emitted (the first sample of each frame that opens a slot)."""

    def __init__(self, run: DecodedRun, mon: LiveMonitor, emit_at: NDArray[np.intp]) -> None:
        m = run.sample_spec.shape[0]
        self.m = m
        code = np.array([_CODE[n] for n in run.spec_names], np.int8)[run.sample_spec] if m else np.zeros(0, np.int8)
        stamp = run.sample_t_ns
        value = run.sample_value
        self.codes: list[int] = code.tolist()
        # per input: its samples' positions, times and values (one stable sort by input)
        order = np.argsort(code, kind='stable')
        bounds = np.concatenate([[0], np.cumsum(np.bincount(code, minlength=len(INPUTS)))]).tolist()
        by_t = stamp[order]
        where_l, times_l, vals_l = order.tolist(), by_t.tolist(), value[order].tolist()
        back = np.flatnonzero(np.diff(by_t) < 0).tolist()        # a time before the one before it
        self._where = [order[bounds[c]:bounds[c + 1]] for c in range(len(INPUTS))]
        self.where = [where_l[bounds[c]:bounds[c + 1]] for c in range(len(INPUTS))]
        self.times = [times_l[bounds[c]:bounds[c + 1]] for c in range(len(INPUTS))]
        self.vals = [vals_l[bounds[c]:bounds[c + 1]] for c in range(len(INPUTS))]
        self.in_order = [not any(bounds[c] <= j < bounds[c + 1] - 1 for j in back) for c in range(len(INPUTS))]
        seq = np.flatnonzero((code == ANGLE) | (code == ORDER))
        self.seq = seq.tolist()
        self._seq_angle: list[bool] = (code[seq] == ANGLE).tolist()
        # what each angle sample logs beside it (_angle_logs, worked out when first needed)
        self._angle_held: list[int] | None = None
        self._angle_env: list[float] | None = None
        # before each position 0..m: the newest sample of the angle and of each pressure (-1:
        # none in the run; read then from what stood before it, and -1 picks the NaN put last)
        # (worked out along rows of (5, m), each input's positions contiguous: a third of the time)
        newest = np.where(code[None, :] == np.array((ANGLE, *_PRESSURE))[:, None], np.arange(m)[None, :], -1)
        np.maximum.accumulate(newest, axis=1, out=newest)
        self.newest = np.vstack([np.full((1, 5), -1, np.intp), newest.T])
        self._stamp = np.append(stamp, 0)
        self._value = np.append(value, math.nan)
        # what stood before the run
        angle = mon.signals['rudder_angle']
        self.angle0 = (angle.last_value, angle.last_t_ns or 0)
        self.rate0 = mon.rate
        self.pressure_t0 = np.array([mon.signals[n].last_t_ns or 0 for n in PRESSURE_INPUTS], np.int64)
        # the four pressures standing before each position 0..m, and the instants update()
        # holds for the residual (each pressure sample's, where all four are known)
        idx = self.newest[:, 1:]
        self.pressures = np.where(idx >= 0, self._value[idx], np.asarray(mon.pressures, float)[None, :])
        p = self.pressures[1:]
        held = np.isin(code, _PRESSURE) & ~np.isnan(((p[:, 0] + p[:, 1]) + p[:, 2]) + p[:, 3])
        hp = np.flatnonzero(held)
        self._held_at = hp
        self.held_at = hp.tolist()
        self.held_t = stamp[hp]
        self.held_p = p[hp]
        # rudder or pressure samples before each position (they make the live model's state change)
        self.changes = np.concatenate([[0], np.cumsum(np.isin(code, (ANGLE, *_PRESSURE)))])
        self._changes = self.changes.tolist()
        #: the rate after each angle sample (filled as they are taken); the last: what stood before
        self.rate_after = np.full(m + 1, math.nan)
        self.rate_after[m] = self.rate0
        # progress: per input, samples recorded in the live model and given to the analyst; instants held
        self._recorded = [0] * len(INPUTS)
        self._analysed = [0] * len(INPUTS)
        self._held = 0
        self._synced = 0          # everything before this position brought (sync, skip)
        self.ok = self._finite_at(emit_at)

    # --- the values standing before a position -------------------------------------------
    def _angle_before(self, at: NDArray[np.intp]) -> tuple[NDArray[np.float64], NDArray[np.int64],
                                                           NDArray[np.float64]]:
        """(angle [rad], its time [ns], the rate [rad/s]) standing before each position."""
        idx = self.newest[at, 0]
        has = idx >= 0
        a0, t0 = self.angle0
        return (np.where(has, self._value[idx], a0), np.where(has, self._stamp[idx], t0).astype(np.int64),
                self.rate_after[idx])

    def _pressures_before(self, at: NDArray[np.intp]) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
        """(the four pressures (n, 4) [Pa], the newest of their times (n,) [ns]) before each position."""
        idx = self.newest[at, 1:]
        t = np.where(idx >= 0, self._stamp[idx], self.pressure_t0[None, :]).max(axis=1, initial=0)
        return self.pressures[at], t

    def _finite_at(self, at: NDArray[np.intp]) -> bool:
        """Every state to be emitted can be evaluated (angle and pressures known, finite); else
        the run is taken frame by frame (the live model keeps its last state then)."""
        if at.size == 0:
            return True
        idx = self.newest[at, 0]
        alpha = np.where(idx >= 0, self._value[idx], self.angle0[0])
        return bool(np.isfinite(alpha).all() and np.isfinite(self.pressures[at]).all())

    def stamp(self, k: int) -> int:
        """The time of the sample at position ``k`` [ns]."""
        return int(self._stamp[k])

    def value(self, k: int) -> float:
        """The value of the sample at position ``k`` [SI]."""
        return float(self._value[k])

    def changed_between(self, start: int, stop: int) -> bool:
        """A rudder or pressure sample at a position in [start, stop)."""
        return self._changes[stop] > self._changes[start]

    # --- bringing the live model and the analyst up to a position ------------------------
    def _record_upto(self, mon: LiveMonitor, c: int, upto: int) -> bool:
        """Input ``c``'s samples before ``upto`` not yet recorded, recorded; whether there were any."""
        where, done = self.where[c], self._recorded[c]
        if done >= len(where) or where[done] >= upto:      # the common case: nothing new since
            return False
        i = bisect_left(where, upto, done)
        mon.inputs.record(INPUTS[c], self.times[c][done:i], self.vals[c][done:i], self.in_order[c])
        self._recorded[c] = i
        return True

    def before_sequential(self, mon: LiveMonitor, s: int) -> None:
        """Before the angle sample at ``s``: what it logs for the residual (the samples held,
        the ship's speed and oil temperature) brought up to it."""
        k = bisect_left(self.held_at, s)
        if k > self._held:
            mon.steady.hold_many(self.held_t[self._held:k], self.held_p[self._held:k])
            self._held = k
        for c in _SLOW:
            self._record_upto(mon, c, s)

    def take_rudder(self, mon: LiveMonitor, start: int, stop: int) -> bool:
        """The angle and order samples at positions [start, stop) taken at once
        (:func:`take_rudder`), each angle sample with
        what :meth:`before_sequential` would have brought up to it, and the rate after each
        noted; False, having changed nothing, where the live model cannot take them so (take
        them one by one)."""
        seq = self.seq
        s0, s1 = bisect_left(seq, start), bisect_left(seq, stop)
        if s0 == s1:
            return True
        if self._angle_held is None:
            self._angle_logs(mon)
        assert self._angle_held is not None and self._angle_env is not None
        where = self.where
        a0, a1 = bisect_left(where[ANGLE], start), bisect_left(where[ANGLE], stop)
        o0, o1 = bisect_left(where[ORDER], start), bisect_left(where[ORDER], stop)
        done = self._held
        last = max(self._angle_held[a1 - 1], done) if a1 > a0 else done
        rates = take_rudder(mon, self._seq_angle[s0:s1], self.times[ANGLE][a0:a1], self.vals[ANGLE][a0:a1],
                            [max(k - done, 0) for k in self._angle_held[a0:a1]], self._angle_env[2 * a0:2 * a1],
                            self.held_t[done:last], self.held_p[done:last], self.times[ORDER][o0:o1],
                            self.vals[ORDER][o0:o1], self.in_order[ORDER])
        if rates is None:
            return False
        self._held = last
        if rates:                            # the rate after each angle sample: all a state reads
            self.rate_after[self._where[ANGLE][a0:a1]] = rates
        return True

    def _angle_logs(self, mon: LiveMonitor) -> None:
        """What each angle sample of the run logs beside it: the held samples before it (as
        :attr:`held_at` counts them), and the ship's speed and oil temperature recorded before
        it (flat, two per angle sample): the run's newest before it, else what stood before
        the run (nothing of the run recorded yet)."""
        pos = self._where[ANGLE]
        self._angle_held = np.searchsorted(self._held_at, pos, 'left').tolist()
        env = np.empty((pos.shape[0], 2))
        for col, c in enumerate(_ENV):
            w = self._where[c]
            stood = mon.signals[INPUTS[c]].last_value
            if w.size:
                i = np.searchsorted(w, pos, 'left')
                env[:, col] = np.where(i > 0, self._value[w[i - 1]], stood)
            else:
                env[:, col] = stood
        self._angle_env = env.ravel().tolist()

    def sync(self, mon: LiveMonitor, analyst: Analyst | None, upto: int) -> None:
        """Everything before ``upto`` taken as update() and the analyst's add would have (the
        angle and order samples themselves the caller has fed)."""
        if upto <= self._synced:
            return
        self._synced = upto
        k = bisect_left(self.held_at, upto)
        moved = False
        for c in _RECORDED:
            moved = self._record_upto(mon, c, upto) and c in _PRESSURE or moved
        if k > self._held or moved:
            mon.steady.hold_many(self.held_t[self._held:k], self.held_p[self._held:k])
            if moved:
                mon.pressures = self.pressures[upto].tolist()
            self._held = k
        if analyst is not None:
            for c in _ANALYSED:
                where, done = self.where[c], self._analysed[c]
                if done < len(where) and where[done] < upto:
                    i = bisect_left(where, upto, done)
                    analyst.add_many(INPUTS[c], self.times[c][done:i], self.vals[c][done:i])
                    self._analysed[c] = i

    def skip(self, upto: int) -> None:
        """The samples before ``upto`` were fed one by one (update and add), those before them
        brought (:meth:`sync`): nothing to bring."""
        self._synced = max(self._synced, upto)
        for c in range(len(INPUTS)):
            self._recorded[c] = max(self._recorded[c], bisect_left(self.where[c], upto))
            self._analysed[c] = max(self._analysed[c], bisect_left(self.where[c], upto))
        self._held = max(self._held, bisect_left(self.held_at, upto))

    # --- states --------------------------------------------------------------------------
    def state_before(self, mon: LiveMonitor, s: int) -> LiveState:
        """The state :meth:`~steer_monitor.monitor.live.LiveMonitor.slot_state` evaluates before
        position ``s``, one (the same numbers as :meth:`states`, read without arrays)."""
        ai, *pi = self.newest[s].tolist()
        if ai >= 0:
            alpha, alpha_t = self.value(ai), self.stamp(ai)
        else:
            alpha, alpha_t = self.angle0
        t = alpha_t
        for k, i in enumerate(pi):
            t = max(t, self.stamp(i) if i >= 0 else int(self.pressure_t0[k]))
        return mon.state_at(t, alpha, alpha_t, float(self.rate_after[ai]), tuple(self.pressures[s].tolist()))

    def states(self, mon: LiveMonitor, at: NDArray[np.intp], two_z: NDArray[np.float64],
               z_gb: NDArray[np.float64]) -> StateRun:
        """The states evaluated before positions ``at`` (n,) with the clearances then in use
        (``two_z``, ``z_gb`` (n,) [m])."""
        alpha, alpha_t, rate = self._angle_before(at)
        p, pt = self._pressures_before(at)
        t = np.maximum(alpha_t, pt)
        alpha, torque = states_at(mon.gear, t, alpha, alpha_t, rate, p)
        return StateRun(t, alpha, rate, torque, np.asarray(two_z, float), np.asarray(z_gb, float))


def take_rudder(mon: LiveMonitor, kinds: list[bool], angle_t: list[int], angle_a: list[float], held: list[int],
                env: list[float], hold_t: NDArray[np.int64], hold_p: NDArray[np.float64], order_t: list[int],
                order_v: list[float], orders_in_order: bool) -> list[float] | None:
    """:meth:`~steer_monitor.monitor.live.LiveMonitor.update` of a replay's span of rudder
    samples at once, where the live model's rate part planned the angle samples' rates
    (:meth:`~steer_monitor.monitor.steady.SteadyMotion.plan`): ``kinds`` the span's rudder
    samples in order (True: an angle sample, False: an order sample); the angle samples'
    times (m,) [ns] and angles (m,) [rad], with what each one logs beside it (``held``, ``env``,
    ``hold_t``, ``hold_p``: :meth:`~steer_monitor.monitor.steady.SteadyMotion.take_span`); the
    order samples' times [ns] and orders [rad] (``orders_in_order``: their times in order).
    The same state as taking them one by one with the pressure samples between them; returns
    the rate [rad/s] after each angle sample, or None, having changed nothing, where the plan
    does not give them (then take them one by one)."""
    rates: list[float] = []
    spans: list[int | None] = []
    if angle_t:
        taken = mon.steady.take_span(angle_t, angle_a, held, env, hold_t, hold_p)
        if taken is None:
            return None
        rates, spans = taken
        mon.inputs.record('rudder_angle', angle_t, angle_a, True)
        mon.changed = True
        mon.performance.hard_over.angles(angle_t, angle_a)
    if order_t:
        mon.inputs.record('rudder_order', order_t, order_v, orders_in_order)
    responses = mon.performance.responses
    ia = io = 0
    for is_angle in kinds:               # the response: angle and order samples in their order
        if is_angle:
            if responses.response is not None:
                responses.angle(angle_t[ia], angle_a[ia], rates[ia], spans[ia])
            ia += 1
        else:
            responses.order(order_t[io], order_v[io])
            io += 1
    return rates
