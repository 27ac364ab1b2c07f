"""Binned sufficient statistics of steady-motion observations.

The declared model's regressors depend on a sample only through its rudder angle, the
side it lies on, the direction of motion and the ship speed: a sample's row is constant
within a bin of (|alpha|, sign alpha, direction, speed). The least-squares fit therefore
needs, per bin, only the count, the mean |alpha| and the moment matrix of
u = [1, z_1 .. z_m, y], where y is the ram force and z are per-sample quantities that some
candidate effects multiply with (ram speed, oil temperature ...). Batch and online
estimation share this form: the online estimator folds the same bins as the data come,
so on the same data it reaches the same numbers; memory is bounded by the bin layout.

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

__all__ = ['ANGLE_BIN', 'SPEED_BIN', 'Moments', 'bin_keys']

ANGLE_BIN = 0.1 * math.pi / 180.0     # rad
SPEED_BIN = 0.25 * 1852.0 / 3600.0    # m/s
NO_SPEED = -1


def bin_keys(alpha: NDArray[np.float64], direction: NDArray[np.int8],
             speed: NDArray[np.float64]) -> NDArray[np.int64]:
    """One int64 key per sample: angle bin, side, direction and speed class packed."""
    abin = np.floor(np.abs(alpha) / ANGLE_BIN).astype(np.int64)
    side = (alpha >= 0).astype(np.int64)
    dirn = (direction > 0).astype(np.int64)
    sbin = np.where(np.isfinite(speed), np.floor(np.nan_to_num(speed) / SPEED_BIN), NO_SPEED).astype(np.int64)
    return ((sbin + 1) << 24) | (abin << 2) | (side << 1) | dirn


@dataclass
class Moments:
    """Sufficient statistics per bin.

    Attributes:
        z_names: names of the per-sample columns z (without the leading 1 and trailing y).
        keys: bin keys, shape (B,), sorted.
        count: samples per bin, shape (B,) (float: it decays with forgetting).
        sum_abs_alpha, sum_speed_sq: sums per bin of |alpha| [rad] and speed^2 [m^2/s^2].
        m: moment matrices, shape (B, q, q) with q = len(z_names) + 2 over [1, z.., y].
    """

    z_names: tuple[str, ...] = ()
    keys: NDArray[np.int64] = field(default_factory=lambda: np.zeros(0, np.int64))
    count: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0))
    sum_abs_alpha: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0))
    sum_speed_sq: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0))
    m: NDArray[np.float64] = field(default_factory=lambda: np.zeros((0, 2, 2)))

    def __post_init__(self) -> None:
        self.keys.setflags(write=False)
        q = len(self.z_names) + 2
        if self.m.shape[1:] != (q, q):
            self.m = np.zeros((self.keys.size, q, q))

    def __len__(self) -> int:
        return int(self.keys.size)

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

    @classmethod
    def from_rows(cls, keys: NDArray[np.int64], abs_alpha: NDArray[np.float64],
                  speed_sq: NDArray[np.float64], u: NDArray[np.float64],
                  z_names: Sequence[str]) -> Moments:
        """Bin rows: ``u`` of shape (n, q) = [1, z.., y] per row."""
        uk, inv = np.unique(keys, return_inverse=True)
        b = uk.size
        count = np.bincount(inv, minlength=b).astype(float)
        s_a = np.bincount(inv, abs_alpha, minlength=b)
        s_v = np.bincount(inv, np.nan_to_num(speed_sq), minlength=b)
        q = u.shape[1]
        m = np.zeros((b, q, q))
        for i in range(q):
            for j in range(i, q):
                m[:, i, j] = np.bincount(inv, u[:, i] * u[:, j], minlength=b)
                m[:, j, i] = m[:, i, j]
        return cls(tuple(z_names), uk, count, s_a, s_v, m)

    def merge(self, other: Moments) -> Moments:
        """The statistics of both (same z columns)."""
        if other.z_names != self.z_names:
            msg = f'cannot merge moments over {other.z_names} into {self.z_names}'
            raise ValueError(msg)
        keys = np.union1d(self.keys, other.keys)
        q = len(self.z_names) + 2
        out = Moments(self.z_names, keys, np.zeros(keys.size), np.zeros(keys.size),
                      np.zeros(keys.size), np.zeros((keys.size, q, q)))
        for src in (self, other):
            if len(src):
                i = np.searchsorted(keys, src.keys)
                out.count[i] += src.count
                out.sum_abs_alpha[i] += src.sum_abs_alpha
                out.sum_speed_sq[i] += src.sum_speed_sq
                out.m[i] += src.m
        return out

    def subset(self, mask: NDArray[np.bool_]) -> Moments:
        """The bins where ``mask`` (shape (B,)) is true."""
        return Moments(self.z_names, self.keys[mask].copy(), self.count[mask], self.sum_abs_alpha[mask],
                       self.sum_speed_sq[mask], self.m[mask])

    def scaled(self, factor: float) -> Moments:
        """All statistics times ``factor`` (exponential forgetting)."""
        return Moments(self.z_names, self.keys.copy(), self.count * factor, self.sum_abs_alpha * factor,
                       self.sum_speed_sq * factor, self.m * factor)

    def to_arrays(self) -> dict[str, NDArray]:
        return {'keys': self.keys, 'count': self.count, 'sum_abs_alpha': self.sum_abs_alpha,
                'sum_speed_sq': self.sum_speed_sq, 'm': self.m,
                'z_names': np.array(self.z_names, dtype=str)}

    @classmethod
    def from_arrays(cls, d: dict[str, NDArray]) -> Moments:
        return cls(tuple(str(x) for x in d['z_names']), np.asarray(d['keys'], np.int64),
                   np.asarray(d['count'], float), np.asarray(d['sum_abs_alpha'], float),
                   np.asarray(d['sum_speed_sq'], float), np.asarray(d['m'], float))


def rows_from_observations(obs: Observations, z: dict[str, NDArray[np.float64]] | None = None
                           ) -> tuple[NDArray[np.int64], NDArray[np.float64], NDArray[np.float64],
                                      NDArray[np.float64], NDArray[np.intp]]:
    """Rows for :meth:`Moments.from_rows` from steady-motion samples, one per valid ram force.

    Returns (keys, |alpha|, speed^2, u, index of the observation each row came from).
    ``z`` holds per-observation columns of shape (n,) or per-ram columns of shape (n, 2).
    """
    z = z or {}
    idx_obs, ram = np.nonzero(np.isfinite(obs.force) & obs.moving[:, None])
    alpha = obs.alpha[idx_obs]
    speed = obs.speed[idx_obs]
    keys = bin_keys(alpha, obs.direction[idx_obs], speed)
    cols = [np.ones(idx_obs.size)]
    for arr in z.values():
        cols.append(arr[idx_obs, ram] if arr.ndim == 2 else arr[idx_obs])
    cols.append(obs.force[idx_obs, ram])
    return keys, np.abs(alpha), speed * speed, np.stack(cols, axis=1), idx_obs
