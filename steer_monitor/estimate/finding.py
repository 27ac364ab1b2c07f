"""What a node keeps and publishes of an analysis: a :class:`Finding`. Pure.

An :class:`~steer_monitor.estimate.analyze.Analysis` holds the data and every fit; the node
needs its answer only: the clearances and K_gl max with their 95 % intervals, the model it
rests on (the effects applied, with the coefficients the live residual uses), the torque and
friction fitted with the clearances, and the verdict. Plain values, so it is saved in the
node's state, sent between processes and compared in the tests.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from steer_monitor.estimate import fit as F
from steer_monitor.estimate.analyze import Analysis
from steer_monitor.estimate.effects import Effect
from steer_monitor.estimate.intervals import Interval
from steer_monitor.model.gear import GearParams
from steer_monitor.model.reach import Reach
from steer_monitor.model.torque import TorqueTable

__all__ = ['KINDS', 'Finding', 'finding_of']

#: a run of the whole residual loop, or the estimate under the model the loop last chose
KINDS = ('loop', 'estimate')


@dataclass(frozen=True)
class Finding:
    """An analysis's answer, as the node publishes it. SI units.

    Attributes:
        t_ns: the data's time at the cut: the analysis is of the data before it [ns].
        kind: 'loop' or 'estimate' (see :data:`KINDS`).
        two_z, z_gb: the clearances and their 95 % intervals [m] (``hi`` None: bounded from
            below only).
        k_gl_max: the largest K_gl over the angles seen, with its range over the clearances'
            95 % region.
        friction: F_s [N], mu_b, mu_g fitted with them.
        torque_coef: the tiller torque fitted with them, B-spline coefficients of
            :class:`~steer_monitor.estimate.fit.TorqueBasis` at service speed [N m];
            max_angle: the largest |alpha| it was fitted to [rad].
        model: the effects applied, in order; terms: their fitted coefficients by name (SI:
            ``c_ns_per_m``, ``f_st_n``, ``k``, ``k_per_k``, ``offset_ram1_n`` ..., ``tau_s``,
            ``mass_kg``, and ``t_ref_k``, the oil temperature temp_friction is relative to).
        verdict: 'declared', 'effect' or 'unexplained'; message: the analysis's sentence.
        rms_bar, systematic_bar, noise_bar: the residual of the model judged (the adopted effects,
            before any located nuisance) and its two parts [bar]: what the verdict weighed.
        motion_s: the steady motion the window held [s]; rows: the rows fitted.
        friction_ci: the 95 % intervals (lo, hi) of F_s, mu_b, mu_g (None: open; empty when not
            known: a finding saved by an earlier version).
        bound_why: (2Z, Z_gb) why a clearance is given as a lower bound only although its
            profile closed ('' when it is not): the contact's evidence too thin to place it.
        reach: (2Z, Z_gb) how far each can show on the gear (:mod:`~steer_monitor.model.reach`;
            None: not known, a finding saved by an earlier version).
    """

    t_ns: int
    kind: str
    two_z: Interval
    z_gb: Interval
    k_gl_max: Interval
    friction: tuple[float, float, float]
    torque_coef: tuple[float, ...]
    max_angle: float
    model: tuple[Effect, ...]
    terms: dict[str, float] = field(default_factory=dict)
    verdict: str = 'declared'
    message: str = ''
    rms_bar: float = math.nan
    systematic_bar: float = math.nan
    noise_bar: float = math.nan
    motion_s: float = 0.0
    rows: int = 0
    bound_why: tuple[str, str] = ('', '')
    friction_ci: tuple[tuple[float | None, float | None], ...] = ()
    reach: tuple[Reach, Reach] | None = None

    @property
    def explained(self) -> bool:
        """The model explains the pressures to the sensor noise (its systematic part at most
        :data:`~steer_monitor.estimate.analyze.EXPLAINED_RATIO` of the noise)."""
        return self.verdict != 'unexplained'

    def torque_table(self, gear: GearParams, step: float = math.radians(0.05)) -> TorqueTable | None:
        """The fitted torque as a table up to :attr:`max_angle` (None when not known)."""
        if not self.torque_coef or not self.max_angle > step:
            return None
        basis = F.TorqueBasis(gear.max_rudder)
        top = min(self.max_angle, gear.max_rudder)
        angles = np.append(np.arange(0.0, top, step), top)
        return TorqueTable(angles, basis.torque(np.asarray(self.torque_coef), angles), gear.torque.service_speed)

    def to_json(self) -> dict[str, object]:
        def iv(x: Interval) -> list[float | None]:
            return [x.value, x.lo, x.hi]
        return {'t_ns': self.t_ns, 'kind': self.kind, 'two_z': iv(self.two_z), 'z_gb': iv(self.z_gb),
                'k_gl_max': iv(self.k_gl_max), 'friction': list(self.friction), 'torque_coef': list(self.torque_coef),
                'max_angle': self.max_angle, 'model': [e.to_json() for e in self.model], 'terms': dict(self.terms),
                'verdict': self.verdict, 'message': self.message, 'rms_bar': self.rms_bar,
                'systematic_bar': self.systematic_bar, 'noise_bar': self.noise_bar, 'motion_s': self.motion_s,
                'rows': self.rows, 'bound_why': list(self.bound_why),
                'friction_ci': [list(x) for x in self.friction_ci],
                'reach': None if self.reach is None else [r.as_list() for r in self.reach]}

    @classmethod
    def from_json(cls, d: dict) -> Finding:
        """The finding of :meth:`to_json` (ValueError, TypeError or KeyError naming what does not fit)."""
        def iv(x: list) -> Interval:
            value, lo, hi = x
            return Interval(float(value), None if lo is None else float(lo), None if hi is None else float(hi))
        kind, verdict = str(d['kind']), str(d['verdict'])
        if kind not in KINDS or verdict not in ('declared', 'effect', 'unexplained'):
            msg = f'a finding of kind {kind!r} and verdict {verdict!r}'
            raise ValueError(msg)
        friction = tuple(float(x) for x in d['friction'])
        if len(friction) != 3:
            msg = f'friction of {len(friction)} values, expected 3'
            raise ValueError(msg)
        return cls(int(d['t_ns']), kind, iv(d['two_z']), iv(d['z_gb']), iv(d['k_gl_max']),
                   friction, tuple(float(x) for x in d['torque_coef']),  # type: ignore[arg-type]
                   float(d['max_angle']), tuple(Effect.from_json(e) for e in d['model']),
                   {str(k): float(v) for k, v in dict(d['terms']).items()}, verdict, str(d['message']),
                   float(d['rms_bar']), float(d['systematic_bar']), float(d['noise_bar']), float(d['motion_s']),
                   int(d['rows']), tuple(str(x) for x in d.get('bound_why', ('', ''))),  # type: ignore[arg-type]
                   tuple((None if lo is None else float(lo), None if hi is None else float(hi))
                         for lo, hi in d.get('friction_ci', ())),
                   _reach_of(d.get('reach')))


def _reach_of(x: object) -> tuple[Reach, Reach] | None:
    """The reach of :meth:`Finding.to_json` (None kept; ValueError when it has not two)."""
    if x is None:
        return None
    rs = [Reach.of_list(r) for r in x]  # type: ignore[attr-defined]
    if len(rs) != 2:
        msg = f'reach of {len(rs)} clearances, expected 2'
        raise ValueError(msg)
    return rs[0], rs[1]


def finding_of(a: Analysis, t_ns: int, kind: str) -> Finding:
    """The answer of ``a``, an analysis of the data before ``t_ns`` (see :class:`Finding`). Its
    clearances, friction and torque are those of the final fit (with the located term as a
    nuisance when the verdict is 'unexplained')."""
    f = a.final
    bar = f.ram_area * 1e5
    basis_size = len([n for n in f.fit.names if n.startswith('torque_')])     # they come first
    terms: dict[str, float] = {}
    for step in a.steps:
        for col in step.candidate.columns:
            terms[col.name] = float(f.extra[col.name].value)
        if step.candidate.angle_shift_s:
            terms['tau_s'] = float(step.candidate.angle_shift_s)
        if step.name == 'temp_friction':
            oil = a.final_observations.oil_temp
            terms['t_ref_k'] = float(np.nanmean(oil)) if np.isfinite(oil).any() else math.nan
    motion = a.window.motion_s if a.window is not None else float(np.count_nonzero(a.observations.moving)) * 0.05
    judged = a.model if a.model is not None else f      # the verdict's model, before any located nuisance
    return Finding(
        t_ns=int(t_ns), kind=kind, two_z=f.two_z, z_gb=f.z_gb, k_gl_max=f.k_gl_max,
        friction=(f.seal_friction.value, f.mu_bushing.value, f.mu_guide.value),
        torque_coef=tuple(float(c) for c in f.fit.coef[:basis_size]), max_angle=float(f.max_angle_seen),
        model=a.adopted, terms=terms, verdict=a.verdict, message=a.message, rms_bar=judged.rms / bar,
        systematic_bar=judged.smooth_rms / bar, noise_bar=judged.noise_rms / bar, motion_s=motion, rows=int(f.rows),
        bound_why=f.bound_why, reach=f.reach,
        friction_ci=tuple((iv.lo, iv.hi) for iv in (f.seal_friction, f.mu_bushing, f.mu_guide)))

