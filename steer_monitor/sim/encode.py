"""From plant history to NMEA 2000 frames: sensor rates, noise, quantisation, effects on the
sensors, and the frames' identifiers (config/nmea2000_steering.dbc and the signals map).

Streams (rate, priority, source address): Rudder 127245 at 10 Hz, priority 2, SA 0x10;
Actual Pressure 130314 at 20 Hz per transducer, priority 5, SA 0x20 + k; Speed 128259 at
1 Hz, priority 2, SA 0x30; Temperature 130316 at 0.5 Hz, priority 5, SA 0x40. Each stream
has its own phase and a +-0.2 ms jitter; times are whole microseconds.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from steer_monitor.can.codec import CanDatabase, FieldLayout, MessageLayout
from steer_monitor.can.frames import FLAG_EXTENDED, MAX_DLC, FrameArrays, make_id
from steer_monitor.can.signals import PRESSURE_INPUTS, SignalMap
from steer_monitor.errors import ParameterError
from steer_monitor.sim.plant import SimConfig, SimResult

__all__ = ['STREAMS', 'SensorStreams', 'encode_frames', 'sensor_streams']


@dataclass(frozen=True)
class Stream:
    rate_hz: float
    priority: int
    source: int


STREAMS = {
    'rudder': Stream(10.0, 2, 0x10),
    'pressure_r1_stbd': Stream(20.0, 5, 0x20),
    'pressure_r1_port': Stream(20.0, 5, 0x21),
    'pressure_r2_stbd': Stream(20.0, 5, 0x22),
    'pressure_r2_port': Stream(20.0, 5, 0x23),
    'ship_speed': Stream(1.0, 2, 0x30),
    'oil_temperature': Stream(0.5, 5, 0x40),
}
JITTER_NS = 200_000


@dataclass(frozen=True)
class SensorStreams:
    """What each sensor sends: ``t_ns`` per stream, and per input the value it reports
    (``exact``: before noise; ``noisy``: after noise, before quantisation), SI units."""

    t_ns: dict[str, NDArray[np.int64]]
    exact: dict[str, NDArray[np.float64]]
    noisy: dict[str, NDArray[np.float64]]


def _times(duration: float, stream: Stream, k: int, start_ns: int, rng: np.random.Generator) -> NDArray[np.int64]:
    period_ns = round(1e9 / stream.rate_hz)
    phase_ns = (7_919 * (k + 1) * 1000) % period_ns  # fixed, distinct per stream
    base = np.arange(phase_ns, int(duration * 1e9) + 1, period_ns, dtype=np.int64)
    jitter = rng.integers(-JITTER_NS // 1000, JITTER_NS // 1000 + 1, base.size) * 1000
    t = np.maximum(base + jitter, 0)
    return start_ns + (t // 1000) * 1000


def sensor_streams(res: SimResult, cfg: SimConfig, rng: np.random.Generator) -> SensorStreams:
    """Sample the plant as the sensors do."""
    t_ns: dict[str, NDArray[np.int64]] = {}
    exact: dict[str, NDArray[np.float64]] = {}
    noisy: dict[str, NDArray[np.float64]] = {}
    plant_t = res.t
    for k, (name, stream) in enumerate(STREAMS.items()):
        t_ns[name] = _times(res.duration, stream, k, res.start_ns, rng)
    ts = {name: (t - res.start_ns) / 1e9 for name, t in t_ns.items()}

    delay = cfg.effect('angle_delay')
    tau = float(delay['tau_s']) if delay is not None else 0.0
    angle = np.interp(ts['rudder'] - tau, plant_t, res.alpha)
    zero, span = cfg.effect('angle_zero'), cfg.effect('angle_span')
    if span is not None:           # the transmitter's span, then its zero, as it reads
        angle = angle * (1.0 + float(span['span_pct']) / 100.0)
    if zero is not None:
        angle = angle + np.radians(float(zero['offset_deg']))
    exact['rudder_angle'] = angle
    exact['rudder_order'] = np.interp(ts['rudder'], plant_t, res.order)
    offset, p_span, p_delay = cfg.effect('pressure_offset'), cfg.effect('pressure_span'), cfg.effect('pressure_delay')
    for name in PRESSURE_INPUTS:
        late = float(p_delay['tau_s']) if p_delay is not None and p_delay['input'] == name else 0.0
        value = np.interp(ts[name] - late, plant_t, res.pressures[name])
        if p_span is not None and p_span['input'] == name:
            value = value * (1.0 + float(p_span['span_pct']) / 100.0)
        if offset is not None and offset['input'] == name:
            value = value + float(offset['offset_bar']) * 1e5
        exact[name] = value
    exact['ship_speed'] = np.interp(ts['ship_speed'], plant_t, res.speed)
    exact['oil_temperature'] = np.interp(ts['oil_temperature'], plant_t, res.oil_temp)

    sigma = {'rudder_angle': cfg.angle_noise, **{p: cfg.pressure_noise for p in PRESSURE_INPUTS}}
    for name, value in exact.items():
        s = sigma.get(name, 0.0) if cfg.noise else 0.0
        noisy[name] = value + rng.normal(0.0, s, value.size) if s > 0 else value.copy()
    stuck = cfg.effect('angle_stuck')
    if stuck is not None:          # the sensor's last reading before start_s, sent on unchanged
        angle = noisy['rudder_angle']
        i = int(np.searchsorted(ts['rudder'], float(stuck['start_s'])))
        if angle.size:
            angle[i:] = angle[max(i - 1, 0)]
    return SensorStreams(t_ns, exact, noisy)


def _quantise(f: FieldLayout, value: NDArray[np.float64]) -> NDArray[np.int64]:
    raw = np.rint((value - f.offset) / f.scale)
    lo = -(1 << (f.length - 1)) if f.signed else 0
    hi = f.error - 1  # never emit a sentinel by accident
    return np.clip(raw, lo, hi).astype(np.int64)


def _na(f: FieldLayout, n: int) -> NDArray[np.int64]:
    return np.full(n, f.not_available, np.int64)


def _block(layout: MessageLayout, raw: dict[str, NDArray[np.int64]], t: NDArray[np.int64],
           priority: int, source: int) -> FrameArrays:
    n = t.size
    for name, f in layout.fields.items():
        if name not in raw:
            raw[name] = _na(f, n)
    payload = CanDatabase.encode(layout, raw, n)
    data = np.zeros((n, MAX_DLC), np.uint8)
    data[:, :layout.length] = payload
    return FrameArrays(t.astype(np.int64), np.full(n, make_id(priority, layout.pgn, source), np.uint32),
                       np.full(n, layout.length, np.uint8), data, np.full(n, FLAG_EXTENDED, np.uint8))


def _sid(n: int, start: int) -> NDArray[np.int64]:
    return (np.arange(n, dtype=np.int64) + start) % 250


def encode_frames(streams: SensorStreams, db: CanDatabase, smap: SignalMap) -> FrameArrays:
    """All streams as frames, merged in time order (ties keep stream order)."""
    specs = {s.name: s for s in smap.specs}
    blocks: list[FrameArrays] = []

    def layout_for(name: str) -> tuple[MessageLayout, str]:
        spec = specs.get(name)
        if spec is None:
            msg = f'the simulator needs input {name} in the signal map'
            raise ParameterError(msg)
        layout = db.message(spec.pgn)
        assert layout is not None  # SignalMap.check ran in the Decoder / caller
        return layout, spec.field

    # Rudder: position, order and direction order in one frame.
    layout, pos_field = layout_for('rudder_angle')
    t = streams.t_ns['rudder']
    raw = {pos_field: _quantise(layout.fields[pos_field], streams.noisy['rudder_angle'])}
    order_spec = specs.get('rudder_order')
    if order_spec is not None and order_spec.pgn == layout.pgn:
        raw[order_spec.field] = _quantise(layout.fields[order_spec.field], streams.noisy['rudder_order'])
    if 'DirectionOrder' in layout.fields:
        diff = streams.exact['rudder_order'] - streams.exact['rudder_angle']
        raw['DirectionOrder'] = np.where(diff > 1e-3, 1, np.where(diff < -1e-3, 2, 0)).astype(np.int64)
    if 'Instance' in layout.fields:
        raw['Instance'] = np.full(t.size, max(specs['rudder_angle'].instance, 0), np.int64)
    blocks.append(_block(layout, raw, t, STREAMS['rudder'].priority, STREAMS['rudder'].source))

    for k, name in enumerate(('pressure_r1_stbd', 'pressure_r1_port', 'pressure_r2_stbd',
                              'pressure_r2_port', 'ship_speed', 'oil_temperature')):
        if name not in specs and name in ('ship_speed', 'oil_temperature'):
            continue
        layout, fld = layout_for(name)
        t = streams.t_ns[name]
        spec = specs[name]
        raw = {fld: _quantise(layout.fields[fld], streams.noisy[name])}
        if 'SID' in layout.fields:
            raw['SID'] = _sid(t.size, 17 * k)
        if 'Instance' in layout.fields:
            raw['Instance'] = np.full(t.size, max(spec.instance, 0), np.int64)
        if 'Source' in layout.fields:
            default_source = 4 if name.startswith('pressure') else 3
            raw['Source'] = np.full(t.size, spec.source if spec.source >= 0 else default_source, np.int64)
        if name == 'ship_speed' and 'SpeedWaterReferencedType' in layout.fields:
            raw['SpeedWaterReferencedType'] = np.zeros(t.size, np.int64)
        stream = STREAMS[name]
        blocks.append(_block(layout, raw, t, stream.priority, stream.source))
    frames = FrameArrays.concat(blocks)
    order = np.argsort(frames.t_ns, kind='stable')
    return frames.take(order)
