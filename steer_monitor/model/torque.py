"""Tiller torque against rudder angle: a monotone PCHIP curve, odd in angle, scaled with
the square of ship speed (the configured curve, evaluated the same way by the live model and
the analyses), and the table an analysis fitted (linear between its points, unknown beyond)."""

from __future__ import annotations

import bisect
import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.interpolate import PchipInterpolator

from steer_monitor.errors import ParameterError

__all__ = ['TorqueCurve', 'TorqueTable']


@dataclass(frozen=True, eq=False)
class TorqueCurve:
    """Tiller torque M(alpha) at service speed, through given points.

    Attributes:
        angles: rudder angles of the points, shape (k,), strictly increasing, first 0 [rad].
        torques: torque at those angles, shape (k,), first 0, non-decreasing [N m].
        service_speed: ship speed at which the curve holds [m/s].

    The curve is PCHIP (shape preserving, so monotone points give a monotone curve), odd in
    alpha, held at its last value beyond the last point, and scales with (V / V_s)^2.
    """

    angles: NDArray[np.float64]
    torques: NDArray[np.float64]
    service_speed: float

    def __post_init__(self) -> None:
        angles = np.asarray(self.angles, dtype=float)
        torques = np.asarray(self.torques, dtype=float)
        if angles.ndim != 1 or angles.shape != torques.shape or angles.size < 2:
            msg = (f'torque curve needs two equal-length lists of at least 2 points, got '
                   f'{angles.shape} angles and {torques.shape} torques')
            raise ParameterError(msg)
        if not (np.all(np.isfinite(angles)) and np.all(np.isfinite(torques))):
            msg = 'torque curve points must be finite numbers'
            raise ParameterError(msg)
        if angles[0] != 0.0 or torques[0] != 0.0:
            msg = (f'torque curve must start at (0 deg, 0 kN m), got '
                   f'({math.degrees(angles[0]):g} deg, {torques[0] / 1e3:g} kN m)')
            raise ParameterError(msg)
        if np.any(np.diff(angles) <= 0):
            msg = 'torque curve angles must be strictly increasing'
            raise ParameterError(msg)
        if np.any(np.diff(torques) < 0):
            msg = 'torque curve torques must not decrease with angle (the curve is monotone)'
            raise ParameterError(msg)
        if not (math.isfinite(self.service_speed) and self.service_speed > 0):
            msg = f'service speed must be positive, got {self.service_speed!r} m/s'
            raise ParameterError(msg)
        object.__setattr__(self, 'angles', angles)
        object.__setattr__(self, 'torques', torques)
        object.__setattr__(self, '_pchip', PchipInterpolator(angles, torques, extrapolate=False))

    @classmethod
    def from_degrees_knm(cls, angles_deg: ArrayLike, torques_knm: ArrayLike,
                         service_speed_kn: float) -> TorqueCurve:
        """Build from engineers' units: degrees, kN m and knots."""
        return cls(np.radians(np.asarray(angles_deg, dtype=float)),
                   np.asarray(torques_knm, dtype=float) * 1e3,
                   float(service_speed_kn) * 1852.0 / 3600.0)

    def scalar(self, alpha: float, speed: float | None = None) -> float:
        """Torque [N m] of one sample: the curve itself (one evaluation for the live model and
        the analyses)."""
        return float(self(alpha, speed))

    def scalars(self, alpha: NDArray[np.float64], speed: NDArray[np.float64]) -> NDArray[np.float64]:
        """:meth:`scalar` over arrays (n,), ``speed`` NaN where not known (no scaling there)."""
        a, v = _one_shape(alpha, speed)
        m = self(a)
        return np.where(np.isnan(v), m, m * (v / self.service_speed) ** 2)

    def __call__(self, alpha: ArrayLike, speed: ArrayLike | None = None) -> NDArray[np.float64]:
        """Torque [N m] at rudder angle ``alpha`` [rad], optionally at ship speed [m/s].

        Shapes broadcast; the sign follows alpha (the torque opposes the rudder's turn out of
        the flow, so its magnitude is what the gear carries).
        """
        a = np.asarray(alpha, dtype=float)
        mag = np.abs(a)
        m = self._pchip(np.minimum(mag, self.angles[-1]))
        m = np.where(mag > self.angles[-1], self.torques[-1], m)
        m = np.sign(a) * m
        if speed is not None:
            m = m * (np.asarray(speed, dtype=float) / self.service_speed) ** 2
        return m


@dataclass(frozen=True, eq=False)
class TorqueTable:
    """A tiller torque curve known as a table, up to the largest angle it was learned at: the
    torque an estimate fitted (the estimator's torque is a free smooth curve, and its friction
    is what the data leave beside *that* curve, not beside the configured one).

    Attributes:
        angles: |alpha| of the table, shape (k,), strictly increasing from 0 [rad].
        torques: torque at service speed at those angles, shape (k,) [N m].
        service_speed: the speed at which the table holds [m/s]; scales with (V / V_s)^2.

    Odd in alpha; :meth:`scalar` interpolates linearly and gives NaN beyond the last angle
    (the fit says nothing there), so a caller can tell "not known" from a value.
    """

    angles: NDArray[np.float64]
    torques: NDArray[np.float64]
    service_speed: float

    def __post_init__(self) -> None:
        angles = np.asarray(self.angles, dtype=float)
        torques = np.asarray(self.torques, dtype=float)
        if angles.ndim != 1 or angles.shape != torques.shape or angles.size < 2 or angles[0] != 0.0 \
                or np.any(np.diff(angles) <= 0) or not np.all(np.isfinite(torques)):
            msg = 'torque table needs at least 2 finite points at strictly increasing angles from 0'
            raise ParameterError(msg)
        object.__setattr__(self, '_grid', angles.tolist())
        object.__setattr__(self, '_table', torques.tolist())
        object.__setattr__(self, '_arrays', (np.asarray(self._grid), np.asarray(self._table)))  # type: ignore[attr-defined]

    @property
    def max_angle(self) -> float:
        """The largest |alpha| the table holds [rad]."""
        return self._grid[-1]  # type: ignore[attr-defined, no-any-return]

    def scalar(self, alpha: float, speed: float | None = None) -> float:
        """Torque [N m] of one sample (NaN beyond :attr:`max_angle`), without numpy."""
        return _lookup(self._grid, self._table, alpha, speed, self.service_speed, math.nan)  # type: ignore[attr-defined]

    def scalars(self, alpha: NDArray[np.float64], speed: NDArray[np.float64]) -> NDArray[np.float64]:
        """:meth:`scalar` over arrays (n,): the same table, ``speed`` NaN where not known."""
        return _lookup_many(self._arrays, alpha, speed, self.service_speed, math.nan)  # type: ignore[attr-defined]


def _lookup(grid: list[float], table: list[float], alpha: float, speed: float | None, service_speed: float,
            beyond: float) -> float:
    """One sample's torque [N m] from a table over |alpha| (linear between its points,
    ``beyond`` past its last angle), odd in alpha, scaled with (speed / service_speed)^2."""
    mag = abs(alpha)
    if mag > grid[-1]:
        m = beyond
    else:
        i = min(bisect.bisect_right(grid, mag) - 1, len(grid) - 2)
        m = table[i] + (table[i + 1] - table[i]) * (mag - grid[i]) / (grid[i + 1] - grid[i])
    m = math.copysign(m, alpha) if alpha != 0 else 0.0
    if speed is not None:
        m *= (speed / service_speed) ** 2
    return m


def _lookup_loop(g: NDArray[np.float64], tb: NDArray[np.float64], a: NDArray[np.float64], v: NDArray[np.float64],
                 service_speed: float, beyond: float, out: NDArray[np.float64]) -> None:
    """:func:`_lookup_many`'s samples one by one, compiled when first used (small batches cost
    microseconds, where numpy's twenty array operations cost tens; a command that never looks
    up many does not load numba)."""
    last = g.size - 2
    top = g[g.size - 1]
    for j in range(a.size):
        x = a[j]
        mag = abs(x)
        i = min(max(np.searchsorted(g, mag, side='right') - 1, 0), last)
        m = tb[i] + (tb[i + 1] - tb[i]) * (mag - g[i]) / (g[i + 1] - g[i])
        if mag > top:
            m = beyond
        m = math.copysign(m, x) if x != 0 else 0.0
        s = v[j]
        if not math.isnan(s):
            r = s / service_speed
            m = m * (r * r)
        out[j] = m


def _lookup_many(arrays: tuple[NDArray[np.float64], NDArray[np.float64]], alpha: NDArray[np.float64],
                 speed: NDArray[np.float64], service_speed: float, beyond: float) -> NDArray[np.float64]:
    """:func:`_lookup` of many samples, shapes (n,), from the table as arrays (grid, values):
    the same interpolation (each value equal to the one-sample lookup to rounding), ``speed``
    NaN where not known (no scaling there)."""
    a, v = _one_shape(alpha, speed)
    out = np.empty(a.shape[0])
    _compiled_loop()(arrays[0], arrays[1], a, v, float(service_speed), float(beyond), out)
    return out


def _one_shape(alpha: NDArray[np.float64], speed: NDArray[np.float64]) -> tuple[NDArray[np.float64],
                                                                                NDArray[np.float64]]:
    """Angles and speeds as contiguous float arrays of one shape (n,), or the error saying not."""
    a = np.ascontiguousarray(alpha, dtype=float)
    v = np.ascontiguousarray(speed, dtype=float)
    if a.ndim != 1 or v.shape != a.shape:
        msg = f'torque lookup needs angles and speeds of one shape (n,), got {a.shape} and {v.shape}'
        raise ValueError(msg)
    return a, v


_LOOP: list[Callable[..., None]] = []


def _compiled_loop() -> Callable[..., None]:
    """:func:`_lookup_loop` compiled (:mod:`steer_monitor.compiled`), once."""
    if not _LOOP:
        from steer_monitor.compiled import njit
        _LOOP.append(njit(cache=True, nogil=True, error_model='numpy')(_lookup_loop))
    return _LOOP[0]

