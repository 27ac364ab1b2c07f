"""The live monitor: what the node knows at each moment, updated sample by sample. Pure.

A façade over its parts, each with one job and its own module:

* :class:`~steer_monitor.monitor.arrivals.InputLog` (``inputs``): every input's newest sample and
  arrival times (the diagnostics' rates and silences);
* :class:`~steer_monitor.monitor.steady.SteadyMotion` (``steady``): the rudder's rate (slope of the
  angle over the last 0.5 s) and the instants of steady motion, with the pressure samples held
  until the angle past them is known, and the motion counted (what the analyses are
  scheduled on);
* :class:`~steer_monitor.monitor.residual.LiveResidual` (``residual``): the model in use (the
  declared one until an analysis gives its clearances with the torque, friction and effects
  fitted with them: :meth:`LiveMonitor.set_finding`) judged on the last minute of steady motion;
* :class:`~steer_monitor.estimate.ramscheck.RamsCheck` (``rams``): how the two rams share the
  driving force, the instants judged in windows as ``analyze`` judges a log's;
* :class:`~steer_monitor.monitor.performance.SteeringPerformance` (``performance``): hard-over
  times and the response to order steps.

The façade routes each sample (:meth:`LiveMonitor.update`) and evaluates the live model on
demand (:attr:`LiveMonitor.state`): the axial ram force from the *measured* pressures,
Fa = A_r |p_stbd - p_port| (mean of the two rams), the tiller torque it implies,
M = Fa n H / cos^2(alpha), and the scalar load-sharing solver with the clearances in use
(while the rudder moves Fa includes friction; the estimator of the clearances separates it).
A replay feeds whole runs through the parts' public interfaces
(:mod:`~steer_monitor.monitor.runfeed`): the same state to the bit.

Times are integer ns; values SI.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from functools import partial
from typing import Any

import numpy as np
from numpy.typing import NDArray

from steer_monitor.estimate.finding import Finding
from steer_monitor.estimate.ramscheck import RamsCheck
from steer_monitor.model.friction import FrictionParams
from steer_monitor.model.gear import Clearances, GearParams
from steer_monitor.model.inputs import PRESSURE_INPUTS, Sample
from steer_monitor.model.kinematics import torque_of_axial
from steer_monitor.model.loadshare import ShareScalar, load_sharing_scalar
from steer_monitor.model.ramforce import ram_force
from steer_monitor.model.torque import TorqueTable
from steer_monitor.monitor.arrivals import Arrivals, InputLog
from steer_monitor.monitor.performance import HardOver, Response, SteeringPerformance
from steer_monitor.monitor.residual import LiveResidual
from steer_monitor.monitor.steady import MAX_DELAY_NS, MOVING_RATE, SteadyMotion
from steer_monitor.utc import utc_json

__all__ = ['LiveMonitor', 'LiveState', 'states_at']

_PRESSURE_INDEX = {name: k for k, name in enumerate(PRESSURE_INPUTS)}


def _carried(alpha: Any, rate: Any, t_ns: Any, alpha_t_ns: Any) -> Any:
    """The angle [rad] read at ``alpha_t_ns`` carried to ``t_ns`` [ns] at ``rate`` [rad/s]:
    floats or arrays, the same operations in the same order."""
    return alpha + rate * (t_ns - alpha_t_ns) / 1e9


def _torque(gear: GearParams, cos_a: Any, p0: Any, p1: Any, p2: Any, p3: Any) -> Any:
    """The tiller torque [N m] the measured pressures [Pa] imply where cos(alpha) is ``cos_a``:
    Fa = A_r |p_stbd - p_port| (mean of the two rams), M = Fa n H / cos^2(alpha); floats or
    arrays, the same operations in the same order."""
    area = gear.ram_area
    fa = 0.5 * (abs(ram_force(area, p0, p1)) + abs(ram_force(area, p2, p3)))
    return torque_of_axial(gear, fa, cos_a)


def states_at(gear: GearParams, t_ns: NDArray[np.int64], alpha: NDArray[np.float64], alpha_t_ns: NDArray[np.int64],
              rate: NDArray[np.float64], p: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The live model's numbers of states (n,) at ``t_ns`` from the angle ``alpha`` [rad] read
    at ``alpha_t_ns``, the rate [rad/s] and the four pressures ``p`` (n, 4) [Pa] standing then:
    (the angle carried to ``t_ns`` at the rate, the measured torque [N m]). Element by element,
    by the formulas :meth:`LiveMonitor.state_at` applies to one state (the cosine by
    ``math.cos``): the same numbers to the bit."""
    a = np.where(t_ns > alpha_t_ns, _carried(alpha, rate, t_ns, alpha_t_ns), alpha)
    cos_a = np.fromiter(map(math.cos, a.tolist()), float, a.shape[0])
    return a, _torque(gear, cos_a, p[:, 0], p[:, 1], p[:, 2], p[:, 3])


@dataclass(frozen=True)
class LiveState:
    """One evaluation of the live model (SI). ``share`` is None until angle and all four
    pressures have been seen, or (``torque_measured`` set) when it was left to the caller
    (:meth:`LiveMonitor.slot_state`)."""

    t_ns: int
    alpha: float
    rate: float
    moving: bool
    torque_measured: float | None
    share: ShareScalar | None
    gaps: Clearances


def _to_residual_and_rams(residual: LiveResidual, rams: RamsCheck, instants: NDArray[np.float64],
                          t_ns: NDArray[np.int64], forces: NDArray[np.float64], pressures: NDArray[np.float64]) -> None:
    """Instants of steady motion taken (:data:`~steer_monitor.monitor.steady.InstantSink`): to
    the residual and the rams check."""
    residual.add(instants)
    rams.feed(t_ns, forces, pressures)


class LiveMonitor:
    """Sample-by-sample state of the gear (see the module). Not thread-safe: feed it from one thread."""

    def __init__(self, gear: GearParams, gaps: Clearances, gaps_source: str = 'configured',
                 priors: FrictionParams | None = None, *, defer_share: bool = False,
                 ram_share_warn: float = 0.15, angle_period_ns: int | None = None) -> None:
        self.gear = gear
        #: :meth:`slot_state` leaves the load sharing to its caller (see there)
        self.defer_share = defer_share
        self.gaps_source = gaps_source
        self.estimate_info: dict[str, str] = {}   # what the estimator adds to the diagnostics
        self.inputs = InputLog()
        self.residual = LiveResidual(gear, gaps, priors or FrictionParams())
        #: the rams check, fed the same instants whatever the model in use (the rams' share
        #: does not depend on it), the four pressures kept for its last window; ``ram_share_warn``
        #: its band (``diagnostics.ram_share_warn_pct`` as a fraction)
        self.rams = RamsCheck(ram_share_warn, gear.ram_area)
        # the instants taken go to the residual and the rams check (a function of those two, not a
        # method of this monitor: no reference cycle for the collector to find)
        # ``angle_period_ns``: the angle's configured period, which the steady motion's windows
        # are made for (a gateway's 2 Hz: configured so, the motion is counted at that rate)
        self.steady = SteadyMotion(gear.ram_area, partial(_to_residual_and_rams, self.residual, self.rams),
                                   angle_period_ns)
        self.performance = SteeringPerformance()
        #: the analysis the model in use comes from (None: the configured model)
        self.finding: Finding | None = None
        #: per clearance ('2z', 'zgb'), the last estimate that assessed it: (value, lo, hi [m],
        #: the data's time [ns]); kept by the analyses' state across restarts
        self.last_assessed: dict[str, tuple[float, float, float, int]] = {}
        #: the four pressures standing [Pa] (NaN until heard), in PRESSURE_INPUTS' order
        self.pressures = [math.nan] * 4
        #: a rudder or pressure sample came since the state was last read
        self.changed = False
        #: the state last read (None: none yet)
        self.latest: LiveState | None = None
        self._model_signals = tuple(self.inputs.signals[n] for n in ('rudder_angle', *PRESSURE_INPUTS))
        self._speed, self._oil = self.inputs.signals['ship_speed'], self.inputs.signals['oil_temperature']

    # --- what the parts hold -------------------------------------------------------------
    @property
    def signals(self) -> dict[str, Arrivals]:
        """Every input's newest sample and arrivals (:attr:`inputs`)."""
        return self.inputs.signals

    @property
    def rate(self) -> float:
        """The rudder's rate after the last angle sample [rad/s]."""
        return self.steady.rate

    @property
    def gaps(self) -> Clearances:
        """The clearances in use [m]."""
        return self.residual.gaps

    @property
    def gaps_interval(self) -> dict[str, tuple[float, float | None]] | None:
        """Their intervals, when estimated (None: configured)."""
        return self.residual.interval

    @property
    def priors(self) -> FrictionParams:
        """The friction in use."""
        return self.residual.priors

    @property
    def torque(self) -> TorqueTable | None:
        """The tiller torque fitted with the clearances in use (None: the configured curve)."""
        return self.residual.torque

    @property
    def hard_over_s(self) -> float | None:
        """The last hard-over's time [s], its longest reading."""
        return self.performance.hard_over_s

    @property
    def hard_over(self) -> HardOver | None:
        """The last hard-over, with the shortest time its samples allow (None: none seen)."""
        return self.performance.last_hard_over

    @property
    def response(self) -> Response | None:
        """The response to the last order step."""
        return self.performance.response

    @property
    def motion_ns(self) -> int:
        """Steady rudder motion counted since this monitor started [ns]."""
        return self.steady.motion_ns

    @property
    def motion_s(self) -> float:
        """Seconds of steady rudder motion counted since this monitor started."""
        return self.motion_ns / 1e9

    # --- clearances ----------------------------------------------------------------------
    def set_gaps(self, gaps: Clearances, source: str,
                 interval: dict[str, tuple[float, float | None]] | None = None,
                 friction: FrictionParams | None = None, torque: TorqueTable | None = None) -> None:
        """Use new clearance values (e.g. from the estimator) and say where they come from;
        with ``friction`` and ``torque``, the friction and tiller torque estimated together with
        them (the model's residual needs all three from the same fit: the fit's friction beside
        the configured torque is not the fit; torque and friction trade off on a few
        manoeuvres, and such a mix put the residual of a clean gear at 3-10 bar)."""
        self.steady.take()
        new_source = source != self.gaps_source
        self.gaps_source = source
        self.residual.use(gaps, interval, friction, torque, new_source=new_source)

    def set_finding(self, finding: Finding) -> None:
        """Use an analysis's answer as the model in use: its clearances with their intervals,
        the torque and friction fitted with them, its effects (their terms in the residual; a
        delay reads the angle later) and what the diagnostics add (K_gl max, the verdict).
        A delay beyond :data:`~steer_monitor.monitor.steady.MAX_DELAY_NS` is read as that."""
        self.steady.take()
        temp = next((e for e in finding.model if e.name == 'temp_friction'), None)
        self.residual.use_effects(tuple(e for e in finding.model if e.name != 'angle_delay'), finding.terms,
                                  FrictionParams(*temp.shape) if temp is not None and temp.shape is not None else None)
        self.steady.delay_ns = min(int(round(finding.terms.get('tau_s', 0.0) * 1e9)), MAX_DELAY_NS)
        self.finding = finding
        interval = {'2z': (finding.two_z.lo, finding.two_z.hi), 'zgb': (finding.z_gb.lo, finding.z_gb.hi)}
        self.set_gaps(Clearances(finding.two_z.value, finding.z_gb.value), 'estimated', interval,   # type: ignore[arg-type]
                      FrictionParams(*finding.friction), finding.torque_table(self.gear))
        k = finding.k_gl_max
        self.estimate_info = {'k_gl_max_estimated': f'{k.value:.3f}',
                              'k_gl_max_lo': 'n/a' if k.lo is None else f'{k.lo:.3f}',
                              'k_gl_max_hi': 'n/a' if k.hi is None else f'{k.hi:.3f}',
                              'estimate_rows': str(int(finding.rows)),
                              'estimate_motion_s': f'{finding.motion_s:.0f}',
                              'estimate_kind': finding.kind,
                              'estimate_data_until_utc': utc_json(finding.t_ns)}

    # --- the residual --------------------------------------------------------------------
    def residual_summary(self) -> tuple[int, int, float | None]:
        """(residuals, instants of the minute the model in use cannot judge, RMS [bar]) over the
        last minute of steady motion, what is held judged first."""
        self.steady.take()
        return self.residual.summary()

    @property
    def residuals(self) -> list[float]:
        """The model's pressure residuals [bar] over the last minute of steady motion, two per
        judged instant (one per ram), oldest first, under the model now in use."""
        self.steady.take()
        return self.residual.residuals

    @property
    def residuals_skipped(self) -> int:
        """Instants of that minute the model in use cannot judge: where it clamps the ram (or
        touches the beam) at a clearance the estimate bounds from below only, or beyond the
        angles its fitted torque was learned at."""
        return self.residual_summary()[1]

    def residual_rms_bar(self) -> float | None:
        """RMS of the model's pressure residual over the last minute of motion [bar]."""
        return self.residual_summary()[2]

    # --- input ---------------------------------------------------------------------------
    def update(self, sample: Sample) -> None:
        """Take one sample. The live model is evaluated on demand (:attr:`state`), for the
        newest sample; the residual and the performance trackers see every sample."""
        name, t_ns, value = sample.signal, sample.t_ns, sample.value
        self.inputs.heard(name, t_ns, value)
        if name == 'rudder_angle':
            rate = self.steady.angle(t_ns, value, self._speed.last_value, self._oil.last_value)
            self.performance.angle(t_ns, value, rate, self.steady.rate_span_ns)
            self.changed = True
        elif name == 'rudder_order':
            self.performance.order(t_ns, value)
        elif name in _PRESSURE_INDEX:
            p = self.pressures
            p[_PRESSURE_INDEX[name]] = value
            if not math.isnan(p[0] + p[1] + p[2] + p[3]):
                self.steady.hold(t_ns, p)
            self.changed = True

    @property
    def state(self) -> LiveState | None:
        """The live model at the newest sample (None until angle and all four pressures)."""
        st = self.slot_state()
        if st is not None and st.share is None and st.torque_measured is not None:
            st = self.latest = LiveState(st.t_ns, st.alpha, st.rate, st.moving, st.torque_measured,
                                         self.share_of(st), st.gaps)
        return st

    def slot_state(self) -> LiveState | None:
        """:attr:`state`, but with :attr:`defer_share` its load sharing is left to the caller
        (``share`` None, ``torque_measured`` set): a replay solves the states of many slots
        at once (:func:`~steer_monitor.model.loadshare.load_sharing`, the same numbers
        as :meth:`share_of`, to the bit)."""
        if self.changed:
            self.changed = False
            a, p0, p1, p2, p3 = self._model_signals
            t = max(a.last_t_ns or 0, p0.last_t_ns or 0, p1.last_t_ns or 0, p2.last_t_ns or 0, p3.last_t_ns or 0)
            self.latest = self._evaluate(t) or self.latest
        return self.latest

    def share_of(self, state: LiveState) -> ShareScalar:
        """The load sharing of a state from its angle, measured torque and clearances."""
        assert state.torque_measured is not None
        return load_sharing_scalar(self.gear, state.alpha, state.torque_measured, state.gaps.two_z, state.gaps.z_gb)

    # --- model ---------------------------------------------------------------------------
    def _evaluate(self, t_ns: int) -> LiveState | None:
        angle = self._model_signals[0]
        a = angle.last_value
        p = self.pressures
        if math.isnan(a) or math.isnan(p[0] + p[1] + p[2] + p[3]):
            return None
        alpha_t = angle.last_t_ns if angle.last_t_ns is not None else t_ns
        st = self.state_at(t_ns, a, alpha_t, self.steady.rate, tuple(p))
        if self.defer_share:
            return st
        return replace(st, share=load_sharing_scalar(self.gear, st.alpha, st.torque_measured, self.gaps.two_z,
                                                     self.gaps.z_gb))

    def state_at(self, t_ns: int, alpha: float, alpha_t_ns: int, rate: float, pressures: tuple[float, ...]
                 ) -> LiveState:
        """The state :meth:`slot_state` makes at ``t_ns`` from the angle ``alpha`` [rad] read at
        ``alpha_t_ns``, the rate [rad/s] and the four pressures [Pa] standing then, its load
        sharing left to the caller (:func:`states_at`'s formulas, on floats)."""
        a = _carried(alpha, rate, t_ns, alpha_t_ns) if t_ns > alpha_t_ns else alpha
        torque = _torque(self.gear, math.cos(a), *pressures)
        return LiveState(t_ns, a, rate, abs(rate) > MOVING_RATE, torque, None, self.gaps)
