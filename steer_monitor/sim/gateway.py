"""A gateway between the sensors and the monitor's bus, as retrofit gateways forward: slower,
late, jittered, with frames lost in bursts and outages. Pure; acts on frames.

Many vessels bring their steering signals onto NMEA 2000 through a converter or gateway that
forwards each message far slower than the sensor sends it, each at its own rate (NMEA 2000's
own default interval for Actual Pressure, PGN 130314, is 2 s). What such a gateway does to
the frames, modelled from what gateways do and nothing the estimator assumes:

* **rate per message**: each PGN (and each instance within it, one channel of the gateway)
  forwarded at its own rate, on its own timer, whose crystal runs off by up to ``drift_ppm``
  (so its phase against the sensor's slides); PGNs not named pass as they came;
* **two ways of forwarding**: ``decimate`` forwards the first frame received at or after each
  tick of its timer (the frame's own payload, late by the wait for the next frame);
  ``hold`` sends on its own timer the last payload received (a value may go out twice, or
  never), and nothing once that payload is older than ``hold_timeout_s``
  (a gateway that times out a silent sensor);
* **latency and jitter**: every forwarded frame stamped ``latency_s`` later plus a uniform
  jitter of up to ``jitter_s`` (the bus it goes onto, the gateway's own loop), never out of
  order within a channel;
* **lost frames in bursts**: the bus the gateway forwards onto is bad now and then (errors, a
  full transmit queue), for ``burst_s`` at a time on average and ``loss`` of the time in all,
  the bad and good spells exponential (a two-state process in time); every frame forwarded
  in a bad spell is lost, of every channel at once. A burst of a fast message is several
  frames in a row; of a slow one, mostly one;
* **outages**: spans ``(start_s, duration_s)`` of the recording in which nothing of a named PGN
  is forwarded (a gateway rebooting, its upstream bus off).

Times are integer ns; rates in Hz; durations in seconds only in this record, as a user gives them.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from steer_monitor.can.codec import CanDatabase
from steer_monitor.can.frames import FrameArrays, pgn_of
from steer_monitor.errors import ParameterError

__all__ = ['MODES', 'PGN_NAMES', 'Gateway', 'bad_spells', 'forward', 'gateway_json', 'parse_gateway']

MODES = ('decimate', 'hold')

#: the names a gateway's rates may be given by in :func:`parse_gateway` (NMEA 2000 PGNs)
PGN_NAMES = {'rudder': 127245, 'pressure': 130314, 'speed': 128259, 'temperature': 130316}


@dataclass(frozen=True)
class Gateway:
    """How a gateway forwards (see the module): ``rates_hz`` per PGN (others pass unchanged)."""

    rates_hz: Mapping[int, float]
    mode: str = 'hold'
    latency_s: float = 0.02
    jitter_s: float = 0.01
    loss: float = 0.0
    burst_s: float = 0.2
    hold_timeout_s: float = 2.5
    drift_ppm: float = 50.0
    outages: tuple[tuple[float, float], ...] = field(default=())

    def __post_init__(self) -> None:
        if self.mode not in MODES:
            msg = f'gateway mode {self.mode!r}: one of {", ".join(MODES)}'
            raise ParameterError(msg)
        for pgn, rate in self.rates_hz.items():
            if not (np.isfinite(rate) and rate > 0):
                msg = f'gateway rate of PGN {pgn}: {rate} Hz, must be above 0'
                raise ParameterError(msg)
        for name, value, lo, hi in (('latency_s', self.latency_s, 0.0, 10.0), ('jitter_s', self.jitter_s, 0.0, 10.0),
                                    ('loss', self.loss, 0.0, 0.9), ('burst_s', self.burst_s, 1e-3, 60.0),
                                    ('hold_timeout_s', self.hold_timeout_s, 0.0, 1e6),
                                    ('drift_ppm', self.drift_ppm, 0.0, 1e4)):
            if not (lo <= value <= hi):
                msg = f'gateway {name} {value}: must be within {lo:g} .. {hi:g}'
                raise ParameterError(msg)
        for start, duration in self.outages:
            if not (start >= 0 and duration > 0):
                msg = f'gateway outage at {start} s for {duration} s: a start from 0 and a duration above 0'
                raise ParameterError(msg)


def _ticks(t0: int, t1: int, rate_hz: float, drift_ppm: float, rng: np.random.Generator) -> NDArray[np.int64]:
    """A channel's timer over [t0, t1] [ns]: a period of 1/rate, off by a drift drawn within
    +-``drift_ppm``, from a random phase."""
    period = 1e9 / rate_hz * (1.0 + rng.uniform(-drift_ppm, drift_ppm) * 1e-6)
    start = t0 + float(rng.uniform(0.0, period))
    return np.round(start + period * np.arange(int((t1 - start) // period) + 1)).astype(np.int64)


def bad_spells(t0: int, t1: int, loss: float, burst_s: float, rng: np.random.Generator) -> NDArray[np.int64]:
    """The bus's bad spells over [t0, t1] [ns] (n, 2: start, end): exponential spells of mean
    ``burst_s`` between exponential good ones of mean ``burst_s (1 - loss) / loss``, so that
    ``loss`` of the time is bad in the long run."""
    if loss <= 0 or t1 <= t0:
        return np.zeros((0, 2), np.int64)
    bad, good = burst_s * 1e9, burst_s * 1e9 * (1.0 - loss) / loss
    n = int((t1 - t0) / (bad + good) * 1.5) + 16
    spells = []
    t = t0 + (0.0 if rng.random() < loss else rng.exponential(good))
    while t <= t1:
        b = rng.exponential(bad, n)
        g = rng.exponential(good, n)
        starts = t + np.concatenate([[0.0], np.cumsum(b + g)[:-1]])
        spells.append(np.stack([starts, starts + b], axis=1))
        t = float(starts[-1] + b[-1] + g[-1])
    out = np.concatenate(spells)
    return out[out[:, 0] <= t1].astype(np.int64)


def _in_spells(t: NDArray[np.int64], spells: NDArray[np.int64]) -> NDArray[np.bool_]:
    """Which of the times ``t`` [ns] fall in one of the ``spells`` (sorted, not overlapping)."""
    if spells.shape[0] == 0:
        return np.zeros(t.shape[0], bool)
    k = np.searchsorted(spells[:, 0], t, 'right') - 1
    return (k >= 0) & (t < spells[np.maximum(k, 0), 1])


def _channels(frames: FrameArrays, db: CanDatabase, pgn: int) -> dict[tuple[int, int], NDArray[np.intp]]:
    """The rows of ``pgn``'s frames per channel: (identifier, instance field or -1)."""
    rows = np.flatnonzero(pgn_of(frames.can_id) == pgn)
    layout = db.message(pgn)
    instance = np.full(rows.shape[0], -1, np.int64)
    if layout is not None and 'Instance' in layout.fields and rows.shape[0]:
        instance = CanDatabase.extract(layout.fields['Instance'], CanDatabase.words(frames.data[rows]))
    out: dict[tuple[int, int], NDArray[np.intp]] = {}
    keys = np.stack([frames.can_id[rows].astype(np.int64), instance], axis=1) if rows.shape[0] else np.zeros((0, 2))
    for key in sorted({(int(a), int(b)) for a, b in keys}):
        out[key] = rows[(keys[:, 0] == key[0]) & (keys[:, 1] == key[1])]
    return out


def forward(frames: FrameArrays, gateway: Gateway, db: CanDatabase, seed: int) -> FrameArrays:
    """The frames as they leave ``gateway`` (see the module), in time order: the PGNs it is
    given rates for forwarded so, the rest as they came. The same seed, the same frames."""
    rng = np.random.default_rng(seed)
    if len(frames) == 0:
        return frames
    t_first, t_last = int(frames.t_ns.min()), int(frames.t_ns.max())
    named = np.isin(pgn_of(frames.can_id), np.array(sorted(gateway.rates_hz), np.uint32))
    parts = [frames.take(np.flatnonzero(~named))]
    lat, jit = int(round(gateway.latency_s * 1e9)), int(round(gateway.jitter_s * 1e9))
    timeout = int(round(gateway.hold_timeout_s * 1e9))
    spells = bad_spells(t_first, t_last + lat + jit, gateway.loss, gateway.burst_s, rng)
    for pgn in sorted(gateway.rates_hz):
        for rows in _channels(frames, db, pgn).values():
            t_in = frames.t_ns[rows]
            ticks = _ticks(t_first, t_last, gateway.rates_hz[pgn], gateway.drift_ppm, rng)
            if gateway.mode == 'decimate':      # the first frame at or after each tick
                k = np.searchsorted(t_in, ticks, 'left')
                keep = np.unique(k[k < t_in.shape[0]])
                src, t_out = rows[keep], t_in[keep]
            else:                               # the last payload received by each tick
                k = np.searchsorted(t_in, ticks, 'right') - 1
                ok = k >= 0
                ok[ok] &= ticks[ok] - t_in[k[ok]] <= timeout
                src, t_out = rows[k[ok]], ticks[ok]
            t_out = t_out + lat + (rng.integers(0, jit + 1, t_out.shape[0]) if jit else 0)
            t_out = np.maximum.accumulate(t_out)                     # a channel keeps its order
            keep = ~_in_spells(t_out, spells)
            for start, duration in gateway.outages:
                a = t_first + int(start * 1e9)
                keep &= ~((t_out >= a) & (t_out < a + int(duration * 1e9)))
            part = frames.take(src[keep])
            parts.append(FrameArrays(t_out[keep].astype(np.int64), part.can_id, part.dlc, part.data, part.flags))
    out = FrameArrays.concat(parts)
    return out.take(np.argsort(out.t_ns, kind='stable'))


def parse_gateway(text: str) -> Gateway:
    """A gateway from ``rudder=2,pressure=0.5,mode=hold,loss=0.02,burst=0.2,latency=0.05,
    jitter=0.02,timeout=2.5,drift=50,outage=600+3`` (rates in Hz by message name or PGN number;
    times in s; drift in ppm; ``outage`` start+duration, repeatable)."""
    rates: dict[int, float] = {}
    kw: dict[str, object] = {}
    outages: list[tuple[float, float]] = []
    names = {'latency': 'latency_s', 'jitter': 'jitter_s', 'loss': 'loss', 'burst': 'burst_s',
             'timeout': 'hold_timeout_s', 'drift': 'drift_ppm'}
    for item in filter(None, (s.strip() for s in text.split(','))):
        key, sep, value = item.partition('=')
        try:
            if not sep:
                raise ValueError
            if key == 'mode':
                kw['mode'] = value
            elif key == 'outage':
                start, _, duration = value.partition('+')
                outages.append((float(start), float(duration)))
            elif key in names:
                kw[names[key]] = float(value)
            elif key in PGN_NAMES or key.isdigit():
                rates[PGN_NAMES.get(key) or int(key)] = float(value)
            else:
                raise KeyError(key)
        except KeyError:
            msg = (f'gateway: unknown item {key!r} (rates by {", ".join(PGN_NAMES)} or a PGN number; mode, '
                   f'{", ".join(names)}, outage)')
            raise ParameterError(msg) from None
        except ValueError:
            msg = f'gateway: cannot read {item!r} (key=value; outage=start+duration in s)'
            raise ParameterError(msg) from None
    return Gateway(rates, outages=tuple(outages), **kw)  # type: ignore[arg-type]


def gateway_json(gateway: Gateway) -> dict[str, object]:
    """The gateway as the truth file of ``simulate`` gives it (docs/json.md)."""
    return {'rates': [{'pgn': pgn, 'rate_hz': rate} for pgn, rate in sorted(gateway.rates_hz.items())],
            'mode': gateway.mode, 'latency_s': gateway.latency_s, 'jitter_s': gateway.jitter_s, 'loss': gateway.loss,
            'burst_s': gateway.burst_s, 'hold_timeout_s': gateway.hold_timeout_s, 'drift_ppm': gateway.drift_ppm,
            'outages': [{'start_s': a, 'duration_s': d} for a, d in gateway.outages]}
