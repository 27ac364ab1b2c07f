"""The library of candidate effects the declared model lacks (docs/residual-loop.md).

Each candidate adds one or a few regressors to the declared model, a per-bin feature times a
per-sample column (see :class:`~steer_monitor.estimate.fit.Column`), or, for the sensor
delay, reads the angle later. Parameters are reported in the units an engineer would use
(the same names the simulator takes for its effects):

==================== ======================================================= ===============
name                 what it adds to the ram force y                         parameters
==================== ======================================================= ===============
viscous              d c |v_ram|                                             c_ns_per_m
stribeck             d F_st exp(-(|v_ram| / v_s)^2), v_s on a grid           f_st_n, v_s_mm_s
pressure_friction    d k |y| (friction rising with the load: seal friction      k
                     pushed by the driving pressure, or stock-bearing friction;
                     the pressures cannot tell these two apart, since
                     |y| = |Fa| +- F_fr and F_fr is already in the model)
temp_friction        d k (T - T_mean) F_fr (friction rising with oil temp.)  k_per_k, t_ref_c
pressure_offset      a constant per ram (a transducer reading off)           offset_bar per ram, input
angle_delay          the angle read tau later                                tau_s
ram_inertia          m a_ram (mass of ram, crosshead and oil)                mass_kg
==================== ======================================================= ===============

(d: direction of motion, v_ram: ram speed, a_ram: its acceleration, T: oil temperature.)
Internal leakage and pump wear change the rudder's speed, not the pressure balance: the
hard-over time shows them, not this residual.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from steer_monitor.estimate.fit import Column
from steer_monitor.estimate.moments import Moments
from steer_monitor.estimate.observe import GRID_NS, Observations
from steer_monitor.model.gear import GearParams

__all__ = ['DELAYS_S', 'NAMES', 'STRIBECK_SPEEDS_MM_S', 'Candidate', 'Effect', 'InstantTerms', 'candidate_of',
           'candidates', 'iter_z_columns', 'live_term', 'low_side_offsets', 'ram_speed', 'stribeck_z', 'z_columns']

STRIBECK_SPEEDS_MM_S = (1.0, 2.0, 3.0, 5.0, 8.0)
DELAYS_S = tuple(round(0.05 * k, 2) for k in range(1, 21))   # 0.05 .. 1.0 s


#: the library's effects, in the order the table above gives them
NAMES = ('viscous', 'stribeck', 'pressure_friction', 'temp_friction', 'pressure_offset', 'angle_delay', 'ram_inertia')


@dataclass(frozen=True)
class Candidate:
    """One candidate (for stribeck: one of its v_s; for angle_delay: one tau). ``shape``:
    temp_friction's friction law (F_s [N], mu_b, mu_g) its column scales with temperature."""

    name: str
    columns: tuple[Column, ...] = ()
    fixed: dict[str, float] | None = None     # parameters fixed by the candidate (v_s, tau)
    angle_shift_s: float = 0.0
    shape: tuple[float, float, float] | None = None


@dataclass(frozen=True)
class Effect:
    """An effect the residual loop adopted, as a later run applies it without screening (plain
    values: it is kept in the node's state and sent to other processes): its name, the
    parameters its candidate fixes (``v_s_mm_s``, ``tau_s``) and temp_friction's ``shape``."""

    name: str
    fixed: tuple[tuple[str, float], ...] = ()
    shape: tuple[float, float, float] | None = None

    def __post_init__(self) -> None:
        if self.name not in NAMES:
            msg = f'unknown effect {self.name!r} (the library has {", ".join(NAMES)})'
            raise ValueError(msg)

    def to_json(self) -> dict[str, object]:
        return {'name': self.name, 'fixed': dict(self.fixed), 'shape': None if self.shape is None else list(self.shape)}

    @classmethod
    def from_json(cls, d: dict) -> Effect:
        """The effect of :meth:`to_json` (ValueError, TypeError or KeyError naming what does not fit)."""
        shape = d.get('shape')
        return cls(str(d['name']), tuple(sorted((str(k), float(v)) for k, v in dict(d.get('fixed') or {}).items())),
                   None if shape is None else tuple(float(x) for x in shape))    # type: ignore[arg-type]


def candidate_of(effect: Effect) -> Candidate:
    """The candidate an adopted effect stands for (its columns made again)."""
    fixed = dict(effect.fixed)
    if effect.name == 'angle_delay':
        tau = float(fixed['tau_s'])
        return Candidate('angle_delay', fixed={'tau_s': tau}, angle_shift_s=tau)
    if effect.name == 'stribeck':
        vs = float(fixed['v_s_mm_s'])
        return Candidate('stribeck', (Column('f_st_n', f'stribeck_{vs:g}', _direction),), fixed={'v_s_mm_s': vs})
    if effect.name == 'temp_friction':
        if effect.shape is None:
            msg = 'temp_friction needs the friction law it scales (shape)'
            raise ValueError(msg)
        return Candidate('temp_friction', (Column('k_per_k', 'dtemp', _friction_feature(*effect.shape)),),
                         shape=effect.shape)
    return next(c for c in candidates({}, (0.0, 0.0, 0.0)) if c.name == effect.name)


def _ones(mom: Moments, feats: dict) -> NDArray[np.float64]:
    return np.ones(len(mom))


def _direction(mom: Moments, feats: dict) -> NDArray[np.float64]:
    return mom.direction


# each feature's value at one instant (direction +-1, the friction law temp_friction scales [N])
_ones.at_instant = lambda direction, shape_friction: 1.0              # type: ignore[attr-defined]
_direction.at_instant = lambda direction, shape_friction: direction   # type: ignore[attr-defined]


def _friction_feature(seal: float, mu_b: float, mu_g: float) -> Callable[[Moments, dict], NDArray[np.float64]]:
    def feature(mom: Moments, feats: dict) -> NDArray[np.float64]:
        d = mom.direction.reshape((-1,) + (1,) * (np.ndim(feats['n_b']) - 1))
        return d * (seal + mu_b * feats['n_b'] + mu_g * feats['f_gb'])
    feature.uses_clearances = True  # type: ignore[attr-defined]
    feature.at_instant = lambda direction, shape_friction: direction * shape_friction  # type: ignore[attr-defined]
    return feature


def ram_speed(stock_to_ram: float, alpha: ArrayLike, rate: ArrayLike) -> Any:
    """|Ram speed| [m/s] at the rudder angle ``alpha`` [rad] turning at ``rate`` [rad/s]: the
    Rapson slide's reduced arm H / cos^2(alpha) times |rate| (floats or arrays)."""
    cos_a = np.cos(alpha)
    return stock_to_ram / (cos_a * cos_a) * np.abs(rate)


def stribeck_z(v_ram: Any, v_s_mm_s: float) -> Any:
    """The Stribeck column's shape exp(-(|v_ram| / v_s)^2) (``v_ram`` [m/s], floats or arrays)."""
    return np.exp(-(v_ram / (v_s_mm_s * 1e-3)) ** 2)


def z_columns(obs: Observations, gear: GearParams) -> dict[str, NDArray[np.float64]]:
    """Per-sample columns the candidates multiply with (NaN where not available)."""
    return dict(iter_z_columns(obs, gear))


def iter_z_columns(obs: Observations, gear: GearParams) -> Iterator[tuple[str, NDArray[np.float64]]]:
    """:func:`z_columns` one at a time, (name, column of shape (n,) or (n, 2)): a caller that
    keeps a few of them (or only their validity) does not hold all of them at once."""
    n = len(obs)
    cos2 = np.cos(obs.alpha) ** 2
    v_ram = ram_speed(gear.stock_to_ram, obs.alpha, obs.rate)
    yield 'ram1', np.tile([1.0, 0.0], (n, 1))
    yield 'ram2', np.tile([0.0, 1.0], (n, 1))
    yield 'v_ram', v_ram
    yield 'abs_y', np.abs(obs.force)
    for vs in STRIBECK_SPEEDS_MM_S:
        yield f'stribeck_{vs:g}', stribeck_z(v_ram, vs)
    # ram acceleration along its axis: d/dt (H tan alpha)'' ~ H / cos^2 alpha * alpha''
    rate = np.where(np.isfinite(obs.rate), obs.rate, np.nan)
    acc = np.full(n, np.nan)
    if n >= 3:
        dt = GRID_NS / 1e9
        acc[1:-1] = (rate[2:] - rate[:-2]) / (2 * dt)
        steps = np.diff(obs.t_ns)
        gap = np.zeros(n, bool)
        gap[1:-1] = (steps[1:] != GRID_NS) | (steps[:-1] != GRID_NS)
        acc[gap] = np.nan
    yield 'accel', np.where(np.isfinite(acc), gear.stock_to_ram / cos2 * acc, 0.0)
    if np.isfinite(obs.oil_temp).any():
        yield 'dtemp', obs.oil_temp - float(np.nanmean(obs.oil_temp))


def candidates(z: dict[str, NDArray], declared: tuple[float, float, float]) -> list[Candidate]:
    """Every candidate the data allow (temp_friction only with the oil temperature on the bus).
    ``declared``: (F_s, mu_b, mu_g) of the declared fit, the shape temp_friction scales."""
    out = [
        Candidate('viscous', (Column('c_ns_per_m', 'v_ram', _direction),)),
        Candidate('pressure_friction', (Column('k', 'abs_y', _direction),)),
        Candidate('pressure_offset', (Column('offset_ram1_n', 'ram1', _ones), Column('offset_ram2_n', 'ram2', _ones))),
        Candidate('ram_inertia', (Column('mass_kg', 'accel', _ones),)),
    ]
    for vs in STRIBECK_SPEEDS_MM_S:
        out.append(Candidate('stribeck', (Column('f_st_n', f'stribeck_{vs:g}', _direction),),
                             fixed={'v_s_mm_s': vs}))
    if 'dtemp' in z:
        out.append(Candidate('temp_friction', (Column('k_per_k', 'dtemp', _friction_feature(*declared)),),
                             shape=tuple(float(x) for x in declared)))   # type: ignore[arg-type]
    for tau in DELAYS_S:
        out.append(Candidate('angle_delay', fixed={'tau_s': tau}, angle_shift_s=tau))
    return out


def low_side_offsets(obs: Observations, names: tuple[str, ...], margin: float = 5e5) -> dict[str, float]:
    """Per transducer, its median reading while its chamber is the return side (the other
    chamber of its ram at least ``margin`` Pa higher) minus the median of all four such
    medians [Pa]. A transducer that reads off by a constant stands out here."""
    p = obs.pressure
    med = {}
    for k, name in enumerate(names):
        other = k ^ 1
        low = np.isfinite(p[:, k]) & np.isfinite(p[:, other]) & (p[:, other] - p[:, k] > margin)
        med[name] = float(np.median(p[low, k])) if low.sum() >= 20 else math.nan
    finite = [v for v in med.values() if math.isfinite(v)]
    ref = float(np.median(finite)) if finite else math.nan
    return {k: v - ref for k, v in med.items()}


class InstantTerms:
    """What the adopted effects ``model`` add to a ram's force [N] at one instant, from the
    same columns the fits use (:func:`candidate_of`): each column's coefficient (``terms``,
    :attr:`Finding.terms`) times its per-bin feature and its per-sample ``z`` taken at the
    instant, for a residual worked out sample by sample (the live monitor's). A delay is not a
    term (the caller reads the angle later) and a ram's moving mass is left out (its
    acceleration is not followed sample by sample); temp_friction counts once ``terms`` hold
    its reference temperature ``t_ref_k``."""

    def __init__(self, model: tuple[Effect, ...], terms: dict[str, float]) -> None:
        self.columns = tuple((terms[col.name], col) for e in model for col in candidate_of(e).columns
                             if col.z != 'accel')
        self.t_ref_k = float(terms.get('t_ref_k', math.nan))

    def __call__(self, direction: float, v_ram: float, abs_y: float, oil_temp: float, shape_friction: float,
                 ram: int) -> float:
        """``direction`` +-1, ram speed ``v_ram`` [m/s], the ram's |force| ``abs_y`` [N], the oil
        temperature [K], ``shape_friction`` the friction law temp_friction scales, at this
        instant [N] (F_s + mu_b N_b + mu_g |F_gb| of its shape), ``ram`` 0 or 1."""
        out = 0.0
        for coef, col in self.columns:
            z = _z_at(col.z, v_ram, abs_y, oil_temp - self.t_ref_k, ram)
            if math.isfinite(z):
                out += col.feature.at_instant(direction, shape_friction) * coef * z  # type: ignore[attr-defined]
        return out


def _z_at(name: str, v_ram: float, abs_y: float, dtemp: float, ram: int) -> float:
    """A column's per-sample ``z`` at one instant (:func:`iter_z_columns` of one sample)."""
    if name == 'v_ram':
        return v_ram
    if name == 'abs_y':
        return abs_y
    if name in ('ram1', 'ram2'):
        return 1.0 if ram == int(name[-1]) - 1 else 0.0
    if name == 'dtemp':
        return dtemp
    if name.startswith('stribeck_'):
        return stribeck_z(v_ram, float(name[len('stribeck_'):]))
    msg = f'no per-instant value of the column {name!r}'
    raise ValueError(msg)


def live_term(model: tuple[Effect, ...], terms: dict[str, float], direction: float, v_ram: float, abs_y: float,
              oil_temp: float, shape_friction: float, ram: int) -> float:
    """:class:`InstantTerms` of ``model`` and ``terms`` at one instant (a caller judging many
    instants with the same model keeps the :class:`InstantTerms`)."""
    return InstantTerms(model, terms)(direction, v_ram, abs_y, oil_temp, shape_friction, ram)
