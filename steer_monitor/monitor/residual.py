"""The live residual: the model in use judged on the last minute of steady motion. Pure.

The model in use is the declared one (the configured clearances, torque and friction) until an
analysis gives its clearances with the torque, friction and effects fitted with them
(:meth:`LiveResidual.use`, :meth:`LiveResidual.use_effects`); then the last minute of motion
is judged again under it, so the residual never mixes models (an early fit used for seconds
left 17 bar in the window). At each instant of steady motion (from
:class:`~steer_monitor.monitor.steady.SteadyMotion`) each ram's force A_r (p_stbd - p_port)
is set against sign(alpha) Fa_model + direction F_fr + the effects' terms; the difference
over the ram area [bar] is its residual. Instants are judged when the residual is read (the
diagnostics, once a second), many at once.

Times are integer ns; values SI, residuals [bar].
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from steer_monitor.estimate.effects import Effect, InstantTerms, ram_speed
from steer_monitor.model.friction import FrictionParams, friction_force
from steer_monitor.model.gear import Clearances, GearParams
from steer_monitor.model.loadshare import declared_residuals, load_sharing_scalar
from steer_monitor.model.torque import TorqueTable
from steer_monitor.monitor.buffers import RowRing
from steer_monitor.monitor.exactsum import MAX_PARTIALS, partials_total, push_counting_squares
from steer_monitor.monitor.instants import OUT_FIELDS

__all__ = ['INSTANT_FIELDS', 'RESIDUAL_SAMPLES', 'LiveResidual']

RESIDUAL_SAMPLES = 1200        # about a minute of motion at 20 Hz
#: an instant of steady motion's columns: angle [rad], ship speed [m/s] (NaN: not known),
#: direction +-1, the rams' forces [N], rate [rad/s], oil temperature [K]
INSTANT_FIELDS = OUT_FIELDS[:7]


class LiveResidual:
    """The model in use and its residual over the last minute of steady motion."""

    def __init__(self, gear: GearParams, gaps: Clearances, priors: FrictionParams) -> None:
        self.gear = gear
        #: the clearances in use [m], with their intervals when estimated (2z/zgb: (lo, hi or
        #: None for a lower bound)), the friction and the tiller torque fitted with them (None:
        #: the configured curve)
        self.gaps = gaps
        self.interval: dict[str, tuple[float, float | None]] | None = None
        self.priors = priors
        self.torque: TorqueTable | None = None
        self._effects: tuple[Effect, ...] = ()
        self._terms = InstantTerms((), {})
        self._shape: FrictionParams | None = None
        # the last minute of steady motion since the clearances' source last changed, per
        # instant (INSTANT_FIELDS), and its residual pair [bar] under the model in use
        self._motion = RowRing(RESIDUAL_SAMPLES // 2, len(INSTANT_FIELDS))
        # the residual pairs of the instants of _motion, a ring of its length: the pair [bar] and
        # whether the instant was judged (1/0) (the minute's RMS is a correctly rounded sum, the
        # same whatever the rows' order)
        self._resid = RowRing(RESIDUAL_SAMPLES // 2, 3)
        self._summary: tuple[int, int, float | None] | None = None   # of _resid, until it changes
        # the exact sum of the squares of _resid's judged pairs, kept as rows come and go
        # (:meth:`push_rows`): its exact partials, their count, the judged values and
        # those whose square is not finite (then the sum is worked out from the rows)
        self._sq = np.zeros(MAX_PARTIALS)
        self._sq_k = 0
        self._sq_values = 0
        self._sq_bad = 0
        # instants of _motion not judged yet: judged together when the residuals are read
        # (:meth:`summary`), as one vectorized solve
        self._unjudged = RowRing(RESIDUAL_SAMPLES // 2, len(INSTANT_FIELDS))

    # --- the model in use ----------------------------------------------------------------
    def use(self, gaps: Clearances, interval: dict[str, tuple[float, float | None]] | None,
            friction: FrictionParams | None, torque: TorqueTable | None, *, new_source: bool) -> None:
        """Use new clearances (and the friction and torque fitted with them; None friction:
        unchanged); ``new_source``: they come from elsewhere than the last (the minute judged
        under other clearances says nothing of these: forgotten). The minute kept is judged
        again under the new model."""
        if new_source:
            self._motion.clear()
        self.gaps, self.interval = gaps, interval
        if friction is not None:
            self.priors = friction
        self.torque = torque
        self.clear_rows()
        self.push_rows(self.rows(self._motion.ordered()))
        self._unjudged.clear()
        self._summary = None

    def use_effects(self, effects: tuple[Effect, ...], terms: dict[str, float], shape: FrictionParams | None) -> None:
        """The effects an analysis adopted, their coefficients and the temperature friction's shape."""
        self._effects, self._terms, self._shape = effects, InstantTerms(effects, terms), shape

    # --- instants in, residuals out ------------------------------------------------------
    def add(self, instants: NDArray[np.float64]) -> None:
        """Instants of steady motion (n, len(INSTANT_FIELDS)), oldest first, after those kept."""
        self._motion.push(instants)
        self._unjudged.push(instants)
        self._summary = None

    @property
    def instants(self) -> NDArray[np.float64]:
        """The instants of the minute kept (n, len(INSTANT_FIELDS)), oldest first (a copy)."""
        return self._motion.ordered()

    def push_rows(self, rows: NDArray[np.float64]) -> None:
        """Rows (n, 3) of residual pairs [bar] and whether judged (1/0) into the ring, the
        kept sum of squares following the rows it takes and lets go (one compiled pass:
        :func:`~steer_monitor.monitor.exactsum.push_counting_squares`)."""
        ring = self._resid
        ring.next, ring.kept, self._sq_k, values, bad = push_counting_squares(
            ring.data, ring.next, ring.kept, np.ascontiguousarray(rows, float), self._sq, self._sq_k)
        self._sq_values += values
        self._sq_bad += bad
        self._summary = None

    def clear_rows(self) -> None:
        """The ring of residual pairs emptied, and its sum of squares."""
        self._resid.clear()
        self._sq_k = self._sq_values = self._sq_bad = 0
        self._summary = None

    @property
    def kept(self) -> int:
        """How many instants' rows the minute holds."""
        return int(self._resid.kept)

    @property
    def capacity(self) -> int:
        """How many instants the minute holds at most."""
        return int(self._resid.data.shape[0])

    def summary(self) -> tuple[int, int, float | None]:
        """(residuals, instants not judged, RMS [bar]) of the kept minute, worked out once
        per change of it (the diagnostics read them several times a second, and at rest the
        minute does not change for hours)."""
        if self._summary is None:
            if self._unjudged.kept:
                self.push_rows(self.rows(self._unjudged.ordered()))
                self._unjudged.clear()
            kept, size = self._resid.kept, self._sq_values
            rms = None
            if size:                  # correctly rounded, as math.fsum
                total = partials_total(self._sq, self._sq_k) if not self._sq_bad else math.nan
                if not math.isfinite(total):       # a square or the sum not finite: as math.fsum says
                    rows = self._resid.rows()
                    total = math.fsum(r * r for r in rows[rows[:, 2] != 0.0, :2].ravel().tolist())
                rms = math.sqrt(total / size)
            self._summary = (size, kept - size // 2, rms)
        return self._summary

    @property
    def residuals(self) -> list[float]:
        """The pressure residuals [bar] over the minute, two per judged instant (one per ram),
        oldest first, under the model now in use."""
        self.summary()
        rows = self._resid.ordered()
        return rows[rows[:, 2] != 0.0, :2].ravel().tolist()

    def pair(self, instant: tuple[float, float, float, float, float, float, float]) -> tuple[float, float] | None:
        """The residual [bar] of each ram at one instant of steady motion under the model in
        use: A_r (p_stbd - p_port) against sign(alpha) Fa + direction F_fr + the effects'
        terms; None where the model cannot judge it."""
        alpha, speed, direction, force_1, force_2, rate, oil = instant
        gear, gaps = self.gear, self.gaps
        torque = (self.torque or gear.torque).scalar(alpha, None if math.isnan(speed) else speed)
        if math.isnan(torque):           # beyond the angles the fitted torque was learned at
            return None
        m = load_sharing_scalar(gear, alpha, torque, gaps.two_z, gaps.z_gb)
        # a clearance the estimate bounds only from below: the data never saw the ram clamp (or
        # the beam touch), so where the live model puts one, its residual judges a guess
        iv = self.interval or {}
        if ('2z' in iv and iv['2z'][1] is None and m.lateral > m.f_theta) or \
                ('zgb' in iv and iv['zgb'][1] is None and m.lateral > m.f_z):
            return None
        f_fr = float(friction_force(self.priors, m.r_a, m.r_e, m.m_a, m.guide_force, gear.bushing_length))
        predicted = math.copysign(m.axial, alpha) + direction * f_fr
        area = gear.ram_area
        if not self._effects:
            return (force_1 - predicted) / area / 1e5, (force_2 - predicted) / area / 1e5
        shape = 0.0 if self._shape is None else float(friction_force(self._shape, m.r_a, m.r_e, m.m_a, m.guide_force,
                                                                     gear.bushing_length))
        v_ram = float(ram_speed(gear.stock_to_ram, alpha, rate))
        out = []
        for ram, force in enumerate((force_1, force_2)):
            term = self._terms(direction, v_ram, abs(force), oil, shape, ram)
            out.append((force - predicted - term) / area / 1e5)
        return out[0], out[1]

    def rows(self, instants: NDArray[np.float64]) -> NDArray[np.float64]:
        """:meth:`pair` of many instants at once (the minute a new estimate re-judges, up to
        600 instants once a second of motion: one compiled pass of the declared model,
        :func:`~steer_monitor.model.loadshare.declared_residuals`, instead of one solve per
        instant): rows (n, 3) of the pair [bar] (NaN where not judged) and whether the instant
        was judged (1.0 / 0.0). Equal to the one-instant results to rounding (tested); with the
        effects of an analysis in use, instant by instant. Element by element, so an instant's
        numbers do not depend on the others judged with it."""
        n = instants.shape[0]
        if self._effects or not n:
            rows = np.full((n, 3), math.nan)
            rows[:, 2] = 0.0
            for i, x in enumerate(instants.tolist()):
                pair = self.pair(x)
                if pair is not None:
                    rows[i] = (pair[0], pair[1], 1.0)
            return rows
        gear = self.gear
        torque = (self.torque or gear.torque).scalars(instants[:, 0], instants[:, 1])
        iv = self.interval or {}
        rows = declared_residuals(gear, instants[:, 0], torque, instants[:, 2], instants[:, 3:5], self.gaps,
                                  self.priors, open_2z='2z' in iv and iv['2z'][1] is None,
                                  open_zgb='zgb' in iv and iv['zgb'][1] is None)
        rows[:, :2] /= 1e5           # [Pa] to [bar], as pair divides
        return rows
