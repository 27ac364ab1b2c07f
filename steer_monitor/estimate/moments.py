"""Binned sufficient statistics of steady-motion observations.

The declared model's regressors depend on a sample only through its rudder angle, the
side it lies on, the direction of motion and the ship speed. Within a bin of (|alpha|,
sign alpha, direction, speed class) the friction features are taken as constant; the axial
load is not: it scales with the speed squared, and a speed class 0.25 kn wide spans
+-3 % of V^2 at 8 kn (+-15 kN of a 500 kN load, far above the friction the clearances
change). So every row carries its own speed ratio ``speed_ratio`` = V^2 / V_c^2 (V_c the
centre of its speed class, 1 where the speed is not on the bus) as the first z column,
and the torque columns multiply it: the load is exact per sample however the speed
drifts within a class. The least-squares fit therefore needs, per bin, only the count,
the mean |alpha| and the moment matrix of u = [1, speed_ratio, z_1 .. z_m, y], where y is
the ram force and z are per-sample quantities that some candidate effects multiply with
(ram speed, oil temperature ...). Every estimate shares this form: ``analyze`` and the
batch path's review (which folds the same bins as a log is read, so its memory is bounded by
the bin layout, not the log's length) reach the same numbers on the same data.

Bins: |alpha| in ``ANGLE_BIN`` steps (0.1 deg), sign of alpha, direction, ship speed in
``SPEED_BIN`` steps (0.25 kn) or one class "speed not on the bus".
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from steer_monitor.estimate.observe import Observations

__all__ = ['ANGLE_BIN', 'SPEED_BIN', 'SPEED_Z', 'Moments', 'bin_keys', 'class_speed_sq', 'rows_from_observations',
           'speed_ratio']

ANGLE_BIN = 0.1 * math.pi / 180.0     # rad
SPEED_BIN = 0.25 * 1852.0 / 3600.0    # m/s
NO_SPEED = -1
SPEED_Z = 'speed_ratio'


def bin_keys(alpha: NDArray[np.float64], direction: NDArray[np.int8],
             speed: NDArray[np.float64]) -> NDArray[np.int64]:
    """One int64 key per sample: angle bin, side, direction and speed class packed."""
    abin = np.floor(np.abs(alpha) / ANGLE_BIN).astype(np.int64)
    side = (alpha >= 0).astype(np.int64)
    dirn = (direction > 0).astype(np.int64)
    sbin = np.where(np.isfinite(speed), np.floor(np.nan_to_num(speed) / SPEED_BIN), NO_SPEED).astype(np.int64)
    return ((sbin + 1) << 24) | (abin << 2) | (side << 1) | dirn


def class_speed_sq(keys: NDArray[np.int64]) -> NDArray[np.float64]:
    """V_c^2 [m^2/s^2] of each key's speed class (its centre); NaN for "speed not on the bus"."""
    sbin = (np.asarray(keys, np.int64) >> 24) - 1
    centre = (sbin + 0.5) * SPEED_BIN
    return np.where(sbin != NO_SPEED, centre * centre, np.nan)


def speed_ratio(keys: NDArray[np.int64], speed_sq: NDArray[np.float64]) -> NDArray[np.float64]:
    """Per row, V^2 / V_c^2 of its speed class (1 where the speed is not on the bus)."""
    vc2 = class_speed_sq(keys)
    return np.where(np.isfinite(vc2), np.nan_to_num(speed_sq) / np.where(np.isfinite(vc2), vc2, 1.0), 1.0)


@dataclass
class Moments:
    """Sufficient statistics per bin, centred: per bin the count, the mean of u and the
    scatter of u about that mean (not the raw sums of u u^T).

    Centring is what makes the residual sum of squares computable to a stated accuracy:
    the raw moment of y is ~1e16 N^2 on a voyage and the residual ~1e10, so a residual
    taken as y^T y - 2 b^T X^T y + b^T X^T X b loses six digits to cancellation and moves
    in the ninth with the order of summation. From centred statistics the residual is a sum
    over bins of non-negative terms, each computed from differences of the bin's own means
    (:func:`~steer_monitor.estimate.fit.residual_sum_of_squares`). Bins merge by Chan's
    update, which keeps the scatter centred.

    Attributes:
        z_names: names of the per-sample columns z (without the leading 1 and trailing y).
        keys: bin keys, shape (B,), sorted.
        count: samples per bin, shape (B,) (float: it decays with forgetting).
        sum_abs_alpha, sum_speed_sq: sums per bin of |alpha| [rad] and speed^2 [m^2/s^2].
        mean: per bin the mean of u = [1, z.., y], shape (B, q), q = len(z_names) + 2.
        scatter: per bin sum (u - mean)(u - mean)^T, shape (B, q, q).
    """

    z_names: tuple[str, ...] = (SPEED_Z,)
    keys: NDArray[np.int64] = field(default_factory=lambda: np.zeros(0, np.int64))
    count: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0))
    sum_abs_alpha: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0))
    sum_speed_sq: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0))
    mean: NDArray[np.float64] = field(default_factory=lambda: np.zeros((0, 0)))
    scatter: NDArray[np.float64] = field(default_factory=lambda: np.zeros((0, 0, 0)))

    def __post_init__(self) -> None:
        self.keys.setflags(write=False)
        q = len(self.z_names) + 2
        if self.mean.shape != (self.keys.size, q):
            self.mean = np.zeros((self.keys.size, q))
        if self.scatter.shape != (self.keys.size, q, q):
            self.scatter = np.zeros((self.keys.size, q, q))

    def __len__(self) -> int:
        return int(self.keys.size)

    @property
    def m(self) -> NDArray[np.float64]:
        """Raw moment matrices sum u u^T per bin, shape (B, q, q), for the normal equations
        (never for a residual: see the class docstring). Cached."""
        cached = self.__dict__.get('_m')
        if cached is None:
            cached = self.scatter + self.count[:, None, None] * self.mean[:, :, None] * self.mean[:, None, :]
            self.__dict__['_m'] = cached
        return cached

    @property
    def samples(self) -> float:
        return float(self.count.sum())

    @property
    def direction(self) -> NDArray[np.float64]:
        return np.where(self.keys & 1, 1.0, -1.0)

    @property
    def side(self) -> NDArray[np.float64]:
        return np.where(self.keys & 2, 1.0, -1.0)

    @property
    def has_speed(self) -> NDArray[np.bool_]:
        return (self.keys >> 24) != 0

    @property
    def abs_alpha(self) -> NDArray[np.float64]:
        return self.sum_abs_alpha / np.maximum(self.count, 1e-300)

    @property
    def speed_sq(self) -> NDArray[np.float64]:
        """Mean speed^2 per bin [m^2/s^2]; NaN where the speed is not on the bus."""
        v = self.sum_speed_sq / np.maximum(self.count, 1e-300)
        return np.where(self.has_speed, v, np.nan)

    @property
    def class_speed_sq(self) -> NDArray[np.float64]:
        """V_c^2 of each bin's speed class [m^2/s^2]; NaN where the speed is not on the bus."""
        return class_speed_sq(self.keys)

    @classmethod
    def from_rows(cls, keys: NDArray[np.int64], abs_alpha: NDArray[np.float64],
                  speed_sq: NDArray[np.float64], u: NDArray[np.float64],
                  z_names: Sequence[str]) -> Moments:
        """Bin rows: ``u`` of shape (n, q) = [1, z.., y] per row. Two passes: the bins'
        means, then the products of the rows' deviations from them."""
        uk, inv = np.unique(keys, return_inverse=True)
        b = uk.size
        count = np.bincount(inv, minlength=b).astype(float)
        s_a = np.bincount(inv, abs_alpha, minlength=b)
        s_v = np.bincount(inv, np.nan_to_num(speed_sq), minlength=b)
        q = u.shape[1]
        mean = np.empty((b, q))
        for i in range(q):
            mean[:, i] = np.bincount(inv, u[:, i], minlength=b) / np.maximum(count, 1.0)
        dev = np.empty_like(u)          # column by column: no (n, q) temporary of the means
        for i in range(q):
            dev[:, i] = u[:, i] - mean[inv, i]
        scatter = np.zeros((b, q, q))
        for i in range(q):
            for j in range(i, q):
                scatter[:, i, j] = np.bincount(inv, dev[:, i] * dev[:, j], minlength=b)
                scatter[:, j, i] = scatter[:, i, j]
        return cls(tuple(z_names), uk, count, s_a, s_v, mean, scatter)

    def merge(self, other: Moments) -> Moments:
        """The statistics of both (same z columns); bins in both by Chan's update."""
        if other.z_names != self.z_names:
            msg = f'cannot merge moments over {other.z_names} into {self.z_names}'
            raise ValueError(msg)
        keys = np.union1d(self.keys, other.keys)
        q = len(self.z_names) + 2
        count, s_a, s_v = np.zeros(keys.size), np.zeros(keys.size), np.zeros(keys.size)
        mean, scatter = np.zeros((keys.size, q)), np.zeros((keys.size, q, q))
        for src in (self, other):
            if not len(src):
                continue
            i = np.searchsorted(keys, src.keys)
            n1, n2 = count[i], src.count
            n = n1 + n2
            w = np.where(n > 0, n2 / np.where(n > 0, n, 1.0), 0.0)
            delta = src.mean - mean[i]
            scatter[i] += src.scatter + (n1 * w)[:, None, None] * delta[:, :, None] * delta[:, None, :]
            mean[i] += w[:, None] * delta
            count[i] = n
            s_a[i] += src.sum_abs_alpha
            s_v[i] += src.sum_speed_sq
        return Moments(self.z_names, keys, count, s_a, s_v, mean, scatter)

    def subset(self, mask: NDArray[np.bool_]) -> Moments:
        """The bins where ``mask`` (shape (B,)) is true."""
        return Moments(self.z_names, self.keys[mask].copy(), self.count[mask], self.sum_abs_alpha[mask],
                       self.sum_speed_sq[mask], self.mean[mask], self.scatter[mask])

    def scaled(self, factor: float) -> Moments:
        """All statistics times ``factor`` (exponential forgetting); the means stay."""
        return Moments(self.z_names, self.keys.copy(), self.count * factor, self.sum_abs_alpha * factor,
                       self.sum_speed_sq * factor, self.mean.copy(), self.scatter * factor)

    def to_arrays(self) -> dict[str, NDArray]:
        return {'keys': self.keys, 'count': self.count, 'sum_abs_alpha': self.sum_abs_alpha,
                'sum_speed_sq': self.sum_speed_sq, 'mean': self.mean, 'scatter': self.scatter,
                'z_names': np.array(self.z_names, dtype=str)}

    @classmethod
    def from_arrays(cls, d: dict[str, NDArray]) -> Moments:
        """The moments of :meth:`to_arrays`. ValueError naming what does not fit when the
        arrays are not such moments (shapes, key order, counts, values), rather than moments
        that fail later, in a fit."""
        z_names = tuple(str(x) for x in np.asarray(d['z_names']).reshape(-1))
        keys = np.asarray(d['keys'], np.int64)
        count, sum_abs_alpha, sum_speed_sq = (np.asarray(d[k], float) for k in ('count', 'sum_abs_alpha',
                                                                                  'sum_speed_sq'))
        mean, scatter = np.asarray(d['mean'], float), np.asarray(d['scatter'], float)
        b, q = keys.size, len(z_names) + 2
        shapes = {'keys': (keys.shape, (b,)), 'count': (count.shape, (b,)),
                  'sum_abs_alpha': (sum_abs_alpha.shape, (b,)), 'sum_speed_sq': (sum_speed_sq.shape, (b,)),
                  'mean': (mean.shape, (b, q)), 'scatter': (scatter.shape, (b, q, q))}
        for name, (got, want) in shapes.items():
            if got != want:
                msg = f'moments: {name} has shape {got}, expected {want}'
                raise ValueError(msg)
        if b > 1 and not bool(np.all(np.diff(keys) > 0)):
            msg = 'moments: bin keys not in increasing order'
            raise ValueError(msg)
        if not (np.all(count >= 0) and np.all(np.isfinite(sum_abs_alpha))):
            msg = 'moments: counts below 0 or not a number, or angle sums not finite'
            raise ValueError(msg)
        return cls(z_names, keys, count, sum_abs_alpha, sum_speed_sq, mean, scatter)


def rows_from_observations(obs: Observations, z: dict[str, NDArray[np.float64]] | None = None,
                           mask: NDArray[np.bool_] | None = None
                           ) -> tuple[NDArray[np.int64], NDArray[np.float64], NDArray[np.float64],
                                      NDArray[np.float64], NDArray[np.intp], NDArray[np.intp]]:
    """Rows for :meth:`Moments.from_rows` from steady-motion samples, one per valid ram force.

    Returns (keys, |alpha|, speed^2, u, index of the observation each row came from, its ram
    0 or 1), with u = [1, speed_ratio, z.., y]: its z columns are named ``(SPEED_Z, *z)``.
    ``z`` holds per-observation columns of shape (n,) or per-ram columns of shape (n, 2).
    ``mask`` (n,): only those observations (the same rows as from ``obs.select(mask)``, with
    indices into ``obs``, and no copy of it).
    """
    z = z or {}
    valid = np.isfinite(obs.force) & obs.moving[:, None]
    if mask is not None:
        valid &= mask[:, None]
    idx_obs, ram = np.nonzero(valid)
    alpha = obs.alpha[idx_obs]
    speed = obs.speed[idx_obs]
    keys = bin_keys(alpha, obs.direction[idx_obs], speed)
    u = np.empty((idx_obs.size, len(z) + 3))    # filled column by column: no second copy
    u[:, 0] = 1.0
    u[:, 1] = speed_ratio(keys, speed * speed)
    for i, arr in enumerate(z.values(), start=2):
        u[:, i] = arr[idx_obs, ram] if arr.ndim == 2 else arr[idx_obs]
    u[:, -1] = obs.force[idx_obs, ram]
    return keys, np.abs(alpha), speed * speed, u, idx_obs, ram
