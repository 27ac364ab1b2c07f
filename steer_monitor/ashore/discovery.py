"""What is on an NMEA 2000 bus, and a signal map proposed from it.

:class:`Discovery` reads blocks of frames (any log, through the column readers) and keeps one
:class:`Stream` per PGN, source address and instance (the ``Instance`` field of PGNs the DBC
knows), with its frame count, time span and, for PGNs of the DBC, each field's range of
valid values and how many were "not available"; and one :class:`Device` per NAME from ISO
address claims (PGN 60928). :func:`propose` turns that into a ``signals`` map by rules it
states (:data:`RULES`), never silently: every choice among candidates and every input left
as it was is a note. Pure: arrays and records in, records out.
"""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from steer_monitor.can.codec import CanDatabase
from steer_monitor.can.devices import ADDRESS_CLAIM_PGN, DeviceName, DeviceTable, format_name
from steer_monitor.can.frames import FLAG_ERROR, FLAG_EXTENDED, FLAG_REMOTE, FrameArrays, pgn_of
from steer_monitor.can.signals import PRESSURE_INPUTS, SignalMap, SignalSpec
from steer_monitor.estimate.sampling import DESIGN_ANGLE_PERIOD_NS, DESIGN_PRESSURE_PERIOD_NS, SLOWER
from steer_monitor.utc import time_json

__all__ = ['RULES', 'Device', 'Discovery', 'FieldStats', 'Stream', 'propose']

_NO_INSTANCE = 256
#: how :func:`propose` chooses, as printed with its notes
RULES = ('an input is taken from the PGN and field the given map names for it; among the devices and instances '
         'sending them with valid values, the one with the most valid values (then the lowest address); '
         'PGN 130314 only with the pressure source field the map names (4, hydraulic: never 0, atmospheric); '
         'the four chambers from one device, in the order of its instances; an input nobody sends is '
         'left out when optional and kept as given when required, with a note')


@dataclass
class FieldStats:
    """One field of a stream: range of its valid values [SI, ``unit``] and counts."""

    unit: str
    valid: int = 0
    not_available: int = 0
    error: int = 0
    min: float = math.inf
    max: float = -math.inf

    def as_dict(self) -> dict[str, Any]:
        has = self.valid > 0
        return {'min': self.min if has else None, 'max': self.max if has else None, 'unit': self.unit,
                'valid': self.valid, 'not_available': self.not_available, 'error': self.error}


@dataclass
class Stream:
    """Frames of one PGN from one source address with one instance (None: no instance field)."""

    pgn: int
    source: int
    instance: int | None
    name: str | None = None
    frames: int = 0
    first_ns: int = 2 ** 63 - 1
    last_ns: int = -(2 ** 63)
    fields: dict[str, FieldStats] = field(default_factory=dict)

    @property
    def rate_hz(self) -> float | None:
        span = self.last_ns - self.first_ns
        return (self.frames - 1) / (span / 1e9) if self.frames > 1 and span > 0 else None

    def as_dict(self) -> dict[str, Any]:
        return {'pgn': self.pgn, 'name': self.name, 'source': self.source, 'instance': self.instance,
                'frames': self.frames, 'rate_hz': None if self.rate_hz is None else round(self.rate_hz, 4),
                **time_json('first', self.first_ns), **time_json('last', self.last_ns),
                'fields': {k: v.as_dict() for k, v in self.fields.items()}}


@dataclass
class Device:
    """A device known by its NAME, from its address claims."""

    name: int
    source: int                 # the address of its latest claim (254: cannot claim)
    claims: int = 0
    addresses: list[int] = field(default_factory=list)
    first_ns: int = 0
    last_ns: int = 0

    def as_dict(self) -> dict[str, Any]:
        return {'source': self.source, **DeviceName(self.name).fields(), 'claims': self.claims,
                'addresses': self.addresses, **time_json('first', self.first_ns), **time_json('last', self.last_ns)}


class Discovery:
    """Streams and devices of the frames given to :meth:`add`, block by block."""

    def __init__(self, db: CanDatabase, pgn_names: Mapping[int, str] | None = None) -> None:
        self.db = db
        self.pgn_names = dict(pgn_names or {})
        self.pgn_names.setdefault(ADDRESS_CLAIM_PGN, 'ISO Address Claim')
        self.streams: dict[tuple[int, int, int | None], Stream] = {}
        self.devices: dict[int, Device] = {}
        self._table = DeviceTable()             # who holds which address, claim after claim
        #: frames that are no stream: error, remote, 11-bit
        self.skipped: Counter[str] = Counter()
        self.frames = 0

    def _name(self, pgn: int) -> str | None:
        layout = self.db.message(pgn)
        return layout.name if layout is not None else self.pgn_names.get(pgn)

    def add(self, fa: FrameArrays) -> None:
        """Count a block of frames (in arrival order)."""
        n = len(fa)
        self.frames += n
        if n == 0:
            return
        ok = np.ones(n, bool)
        for flag, reason in ((FLAG_ERROR, 'error_frame'), (FLAG_REMOTE, 'remote_frame')):
            hit = ok & ((fa.flags & flag) != 0)
            self.skipped[reason] += int(hit.sum())
            ok &= ~hit
        hit = ok & ((fa.flags & FLAG_EXTENDED) == 0)
        self.skipped['not_extended'] += int(hit.sum())
        ok &= ~hit
        rows = np.nonzero(ok)[0]
        pgns = pgn_of(fa.can_id[rows].astype(np.uint32)).astype(np.int64)
        src = (fa.can_id[rows] & 0xFF).astype(np.int64)
        for i in np.nonzero((pgns == ADDRESS_CLAIM_PGN) & (fa.dlc[rows] == 8))[0].tolist():
            self._claim(int(src[i]), fa.data[rows[i]].tobytes(), int(fa.t_ns[rows[i]]))
        inst = np.full(rows.size, _NO_INSTANCE, np.int64)
        words = CanDatabase.words(fa.data[rows]) if rows.size else np.zeros(0, np.uint64)
        layouts = {}
        for pgn in np.unique(pgns).tolist():
            layout = self.db.message(pgn)
            if layout is None:
                continue
            sel = np.nonzero((pgns == pgn) & (fa.dlc[rows] == layout.length))[0]
            layouts[pgn] = (layout, sel)
            if 'Instance' in layout.fields:
                inst[sel] = CanDatabase.extract(layout.fields['Instance'], words[sel])
        key = (pgns << 17) | (src << 9) | inst
        order = np.argsort(key, kind='stable')
        ks = key[order]
        starts = np.concatenate([[0], np.nonzero(ks[1:] != ks[:-1])[0] + 1]) if ks.size else np.zeros(0, np.intp)
        t = fa.t_ns[rows][order]
        counts = np.diff(np.concatenate([starts, [ks.size]]))
        t_min = np.minimum.reduceat(t, starts) if ks.size else t
        t_max = np.maximum.reduceat(t, starts) if ks.size else t
        group = np.cumsum(np.isin(np.arange(ks.size), starts)) - 1     # sorted row -> group
        streams = []
        for g, s0 in enumerate(starts.tolist()):
            k = int(ks[s0])
            pgn, source, instance = k >> 17, (k >> 9) & 0xFF, k & 0x1FF
            sk = (pgn, source, None if instance == _NO_INSTANCE else instance)
            st = self.streams.get(sk)
            if st is None:
                st = self.streams[sk] = Stream(pgn, source, sk[2], self._name(pgn))
            st.frames += int(counts[g])
            st.first_ns = min(st.first_ns, int(t_min[g]))
            st.last_ns = max(st.last_ns, int(t_max[g]))
            streams.append(st)
        # field ranges, per stream, of the PGNs the DBC knows
        rank = np.empty(ks.size, np.intp)
        rank[order] = np.arange(ks.size)
        for layout, sel in layouts.values():
            if sel.size == 0:
                continue
            g_of = group[rank[sel]]
            w = words[sel]
            for fname, f in layout.fields.items():
                raw = CanDatabase.extract(f, w)
                na = raw == f.not_available
                err = raw == f.error
                good = ~(na | err)
                phys = f.to_physical(raw.astype(np.float64))
                for g in np.unique(g_of).tolist():
                    in_g = g_of == g
                    fs = streams[g].fields.setdefault(fname, FieldStats(f.unit))
                    fs.not_available += int((in_g & na).sum())
                    fs.error += int((in_g & err).sum())
                    v = phys[in_g & good]
                    if v.size:
                        fs.valid += int(v.size)
                        fs.min = min(fs.min, float(v.min()))
                        fs.max = max(fs.max, float(v.max()))

    def _claim(self, source: int, data: bytes, t_ns: int) -> None:
        name = DeviceName.from_data(data).name
        dev = self.devices.get(name)
        if dev is None:
            dev = self.devices[name] = Device(name, source, first_ns=t_ns)
        dev.claims += 1
        dev.source = source
        dev.last_ns = t_ns
        if source not in dev.addresses:
            dev.addresses.append(source)
        self._table.claim(source, name)

    def name_at(self, source: int) -> int | None:
        """The NAME holding ``source`` after the claims seen (None: none holds it)."""
        return self._table.name_at(source)

    def sorted_streams(self) -> list[Stream]:
        return sorted(self.streams.values(), key=lambda s: (s.pgn, s.source, -1 if s.instance is None else s.instance))


def _valid(stream: Stream, fname: str) -> int:
    fs = stream.fields.get(fname)
    return fs.valid if fs is not None else 0


def _describe(st: Stream, fname: str) -> str:
    fs = st.fields.get(fname)
    rate = f'{st.rate_hz:.1f} Hz' if st.rate_hz else 'one frame'
    rng = f', {fs.min:.4g}..{fs.max:.4g} {fs.unit}' if fs is not None and fs.valid else ''
    inst = '' if st.instance is None else f' instance {st.instance}'
    return f'address {st.source}{inst} ({fs.valid if fs else 0} valid of {st.frames} frames, {rate}{rng})'


def _entry(spec: SignalSpec, st: Stream, fname: str, discovery: Discovery, notes: list[str]) -> dict[str, Any]:
    name = discovery.name_at(st.source)
    if st.instance == 255:
        notes.append(f'{spec.name}: PGN {st.pgn} from address {st.source} has instance 255 (a sender of one '
                     'instance): mapped by its address, whatever the instance')
    if name is None and discovery.devices:      # a log of no claims at all is said once (propose)
        notes.append(f'{spec.name}: no address claim from address {st.source} in the log: mapped by address only '
                     '(a device that changes address is not followed)')
    instance = -1 if st.instance is None or st.instance == 255 else st.instance
    rate = st.rate_hz
    design = {'rudder_angle': DESIGN_ANGLE_PERIOD_NS, **{n: DESIGN_PRESSURE_PERIOD_NS for n in PRESSURE_INPUTS}}
    if spec.name in design and rate is not None and rate > 0 and 1e9 / rate > SLOWER * design[spec.name]:
        notes.append(f'{spec.name}: PGN {st.pgn} from address {st.source} comes at {rate:.2g} Hz, slower than a '
                     f'direct tap ({1e9 / design[spec.name]:g} Hz): the analyses then count only long steady '
                     'motion and need more steering to assess the clearances; raise its rate on the gateway or '
                     'through NMEA 2000\'s group function (PGN 126208, a request to change its transmission '
                     'interval) where the device supports it')
    return {'pgn': spec.pgn, 'field': fname, 'instance': instance, 'source': spec.source,
            'address': st.source, 'device_name': format_name(name) if name is not None else '',
            'rate_hz': round(rate, 1) if rate is not None and rate >= 0.1 else spec.rate_hz}


def _given(spec: SignalSpec) -> dict[str, Any]:
    return {'pgn': spec.pgn, 'field': spec.field, 'instance': spec.instance, 'source': spec.source,
            'address': spec.address, 'device_name': format_name(spec.device_name) if spec.device_name is not None
            else '', 'rate_hz': spec.rate_hz}


def _source_field(st: Stream) -> str:
    fs = st.fields.get('Source')
    if fs is None or not fs.valid:
        return 'n/a'
    return f'{fs.min:g}' if fs.min == fs.max else f'{fs.min:g}..{fs.max:g}'


def _candidates(discovery: Discovery, spec: SignalSpec) -> list[Stream]:
    out = [st for st in discovery.streams.values() if st.pgn == spec.pgn and _valid(st, spec.field) > 0]
    if spec.source >= 0:       # the payload's source field: what is measured
        out = [st for st in out if (fs := st.fields.get('Source')) is not None and fs.valid
               and fs.min == fs.max == spec.source]
    return sorted(out, key=lambda st: (-_valid(st, spec.field), st.source, st.instance or 0))


def propose(discovery: Discovery, smap: SignalMap, required: tuple[str, ...]) -> tuple[dict[str, dict[str, Any]],
                                                                                      list[str]]:
    """A ``signals`` map for the streams found, from the map ``smap`` (its PGNs, fields and
    source fields say where each input is looked for), and the notes saying what was chosen
    among several, what is not on the bus and what was kept. ``required``: inputs that
    cannot be left out (kept as given when not found). Each entry says whether its stream was
    found (``on_bus``)."""
    specs = {s.name: s for s in smap.specs}
    proposed: dict[str, dict[str, Any]] = {}
    notes: list[str] = []

    def not_found(name: str, why: str) -> None:
        spec = specs[name]
        if name in required:
            proposed[name] = {**_given(spec), 'on_bus': False}
            notes.append(f'{name}: {why}; kept as the given map has it (PGN {spec.pgn}): the monitor needs it')
        else:
            proposed[name] = {**_given(spec), 'pgn': 0, 'on_bus': False}
            notes.append(f'{name}: {why}; left out (pgn 0)')

    def choose(name: str, cands: list[Stream]) -> Stream:
        spec = specs[name]
        if len(cands) > 1:
            others = '; '.join(_describe(st, spec.field) for st in cands[1:])
            notes.append(
                f'{name}: {len(cands)} senders of {spec.pgn} {spec.field}: took {_describe(cands[0], spec.field)} '
                f'(the most valid values); not taken: {others}. To take another, set '
                f'signals.{name}.address'
            )
        return cands[0]

    rudder = None
    if 'rudder_angle' in specs:
        spec = specs['rudder_angle']
        cands = _candidates(discovery, spec)
        if cands:
            rudder = choose('rudder_angle', cands)
            proposed['rudder_angle'] = _entry(spec, rudder, spec.field, discovery, notes)
        else:
            not_found('rudder_angle', f'no PGN {spec.pgn} with a valid {spec.field} on this bus')
    if 'rudder_order' in specs:
        spec = specs['rudder_order']
        if rudder is not None and spec.pgn == rudder.pgn and _valid(rudder, spec.field):
            proposed['rudder_order'] = _entry(spec, rudder, spec.field, discovery, notes)
        else:
            cands = _candidates(discovery, spec)
            if cands:
                proposed['rudder_order'] = _entry(spec, choose('rudder_order', cands), spec.field, discovery, notes)
            else:
                not_found('rudder_order', f'no valid {spec.field} of PGN {spec.pgn} (the rudder sensor sends it as '
                                          '"not available")' if rudder is not None else f'no PGN {spec.pgn}')
    _propose_pressures(discovery, specs, proposed, notes, not_found)
    for name in ('ship_speed', 'oil_temperature'):
        if name not in specs:
            continue
        spec = specs[name]
        cands = _candidates(discovery, spec)
        if cands:
            proposed[name] = _entry(spec, choose(name, cands), spec.field, discovery, notes)
        else:
            what = f' with source field {spec.source}' if spec.source >= 0 else ''
            others = [st for st in discovery.streams.values() if st.pgn == spec.pgn and _valid(st, spec.field)]
            seen = '; '.join(f"address {st.source} with source field {_source_field(st)}" for st in
                             sorted(others, key=lambda s: s.source))
            not_found(name, f'no PGN {spec.pgn}{what} with a valid {spec.field} on this bus'
                            + (f' (there are: {seen})' if seen else ''))
    for entry in proposed.values():
        entry.setdefault('on_bus', True)
    if not discovery.devices and any(e['on_bus'] for e in proposed.values()):
        notes.append('no address claim in the log (none sent, or the log began after them): every input mapped by '
                     'its address only; a device that changes address is not followed')
    return proposed, notes


def _propose_pressures(discovery: Discovery, specs: Mapping[str, SignalSpec], proposed: dict[str, dict[str, Any]],
                       notes: list[str], not_found: Any) -> None:
    names = [n for n in PRESSURE_INPUTS if n in specs]
    if not names:
        return
    spec = specs[names[0]]
    for st in sorted(discovery.streams.values(), key=lambda s: s.source):
        fs = st.fields.get('Source')
        if st.pgn == spec.pgn and fs is not None and fs.valid and not (fs.min == fs.max == spec.source):
            kind = 'atmospheric (pressure source 0): a barometer' if fs.max == 0 else \
                f'pressure source {fs.min:g}..{fs.max:g}'
            notes.append(f'PGN {st.pgn} from address {st.source} instance {st.instance} is {kind}, '
                         f'never a ram chamber (these need pressure source {spec.source})')
    by_device: dict[int, list[Stream]] = {}
    for st in _candidates(discovery, spec):
        by_device.setdefault(st.source, []).append(st)
    full = {a: sorted(v, key=lambda s: s.instance or 0) for a, v in by_device.items() if len(v) >= len(names)}
    if not full:
        # a transducer per chamber, each a device of its own: found where the given map's instance is
        own = {n: [st for st in _candidates(discovery, specs[n]) if st.instance == specs[n].instance
                   and specs[n].address in (-1, st.source)] for n in names}
        if all(own.values()) and len({own[n][0].source for n in names}) == len(names):
            for n in names:
                proposed[n] = _entry(specs[n], own[n][0], specs[n].field, discovery, notes)
            notes.append('pressures: a device per chamber, found at the given map\'s instances ('
                         + ', '.join(f'{n} = address {own[n][0].source} instance {own[n][0].instance}' for n in names)
                         + '): check this against the sensors\' wiring')
            return
        seen = ', '.join(f'address {a}: {len(v)} instance(s)' for a, v in sorted(by_device.items()))
        for n in names:
            not_found(n, f'no device sends {len(names)} instances of PGN {spec.pgn} with pressure source '
                         f'{spec.source}' + (f' ({seen})' if seen else ''))
        return
    address = max(full, key=lambda a: (sum(_valid(s, spec.field) for s in full[a]), -a))
    if len(full) > 1:
        notes.append(f'pressures: {len(full)} devices send {len(names)} hydraulic pressures; took address {address} '
                     '(the most valid values)')
    streams = full[address][:len(names)]
    for n, st in zip(names, streams):
        proposed[n] = _entry(specs[n], st, specs[n].field, discovery, notes)
    notes.append('pressures: chambers assigned in the order of the instances ('
                 + ', '.join(f'{n} = instance {st.instance}' for n, st in zip(names, streams))
                 + '): check this against the sensors\' wiring')

