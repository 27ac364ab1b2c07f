"""Frames to timestamped samples per input, frame by frame (live) or as arrays (logs).

Both paths apply the same checks in the same order and count every refusal in a
:class:`~steer_monitor.can.rejects.RejectCounter`:

1. frame level: error frame, remote frame, 11-bit identifier, an ISO address claim (read
   into the device table, :mod:`~steer_monitor.can.devices`, then counted), PGN not in the
   DBC, wrong length; a time jump (:mod:`~steer_monitor.can.timejump`: a frame far from the stream's
   time, unless confirmed by the frames after it, which then wait for that); time earlier
   than the previous frame with the same identifier, duplicate (same identifier, data and
   time as the previous accepted one);
2. the frame matches no input's instance, source field, address or device: ``unmapped``
   (once per frame). The device holding a frame's address is the one at the frame's
   arrival, in both paths, whenever the frame is decided;
3. per mapped field: not available, error value, physically impossible.

What passes becomes a sample: (t_ns, input name, SI value).

Why one module of some 750 lines: :meth:`Decoder.decode` (a frame), :meth:`Decoder.decode_arrays`
(a log's columns) and :meth:`Decoder.decode_run` (a run of frames, as replay feeds the pipeline)
are three ways into one decoder whose verdicts depend on the same state (the device table, the
time-jump filter, the last time and data per identifier, the frames held); the two over arrays
take and judge the fields by one definition (``Decoder._mapped_fields``). Kept beside each
other, a check changed in one is seen to change in the others; ``test/can/test_decoder.py``
holds the three to the same samples and rejects.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from steer_monitor.can.codec import CanDatabase, FieldLayout, MessageLayout
from steer_monitor.can.decodedrun import DecodedRun
from steer_monitor.can.devices import ADDRESS_CLAIM_PGN, DeviceName, DeviceTable, format_name
from steer_monitor.can.frames import FLAG_ERROR, FLAG_EXTENDED, FLAG_REMOTE, Frame, FrameArrays, pgn_of
from steer_monitor.can.rejects import RejectCounter
from steer_monitor.can.signals import SignalMap, SignalSpec
from steer_monitor.can.timejump import HELD, NO_TIME, REJECTED, RELEASED, JumpFilter
from steer_monitor.model.inputs import Sample, Series, SignalSet
from steer_monitor.utc import utc_text

__all__ = ['STITCH_GAP_NS', 'ClockStep', 'DecodedRun', 'Decoder', 'Sample', 'Series', 'SignalSet', 'clock_notes',
           'collect']




#: the flags a frame's structural checks read, and no rows
_FLAG_CHECKED = FLAG_ERROR | FLAG_REMOTE | FLAG_EXTENDED
_NO_ROWS = np.zeros(0, np.intp)
_NO_TIMES = np.zeros(0, np.int64)
_NO_VALUES = np.zeros(0, np.float64)


def collect(samples: Iterable[Sample], names: Iterable[str]) -> SignalSet:
    """Gather per-frame samples into per-input series (in arrival order)."""
    t: dict[str, list[int]] = {n: [] for n in names}
    v: dict[str, list[float]] = {n: [] for n in names}
    for s in samples:
        t[s.signal].append(s.t_ns)
        v[s.signal].append(s.value)
    return {n: Series(np.array(t[n], np.int64), np.array(v[n], np.float64)) for n in t}


def _id_text(can_id: int) -> str:
    return f'0x{can_id:08X}'


#: what a log's data after a step of its clock back are put after the data before it [ns]:
#: longer than any gap the observations bridge, so the two stretches stay apart
STITCH_GAP_NS = 60_000_000_000
#: unknown identifiers whose reject text is kept (a bus has tens; a flood of random ones is not kept)
MAX_UNKNOWN_TEXTS = 4096


@dataclass(frozen=True)
class ClockStep:
    """A step of a log's clock: the last frame's time before it and the first after it [ns,
    the frames' own times]; ``shift_ns``: what was added to the times from there on (after a
    step back: the data follow the data before, ``STITCH_GAP_NS`` later; 0 otherwise)."""

    before_ns: int
    after_ns: int
    shift_ns: int

    @property
    def step_s(self) -> float:
        return (self.after_ns - self.before_ns) / 1e9

    def text(self) -> str:
        """One line: when and how large, and what was done."""
        size = _duration_text(abs(self.after_ns - self.before_ns))
        when = utc_text(self.before_ns)
        if self.after_ns < self.before_ns:
            return (f'the frames\' clock steps back {size} after {when} (a clock set back): the data after it are '
                    f'kept as a new stretch, their times shifted by +{_duration_text(self.shift_ns)} in the outputs')
        return f'the frames\' clock jumps forward {size} after {when} (a clock step, or a pause in the log)'


def _duration_text(ns: int) -> str:
    s = ns / 1e9
    if s < 120:
        return f'{s:.1f} s'
    if s < 7200:
        return f'{s / 60:.1f} min'
    if s < 172800:
        return f'{s / 3600:.2f} h'
    return f'{s / 86400:.2f} days'


def clock_notes(steps: list[ClockStep]) -> list[str]:
    """What to say of a stream's clock steps: one line per step back, one for the steps
    forward together (a log paused is one too)."""
    out = [st.text() for st in steps if st.after_ns < st.before_ns]
    fwd = [st for st in steps if st.after_ns > st.before_ns]
    if len(fwd) == 1:
        out.append(fwd[0].text())
    elif fwd:
        big = max(fwd, key=lambda st: st.after_ns - st.before_ns)
        out.append(f'the frames\' clock jumps forward {len(fwd)} times (clock steps, or pauses in the log); the '
                   f'largest: {big.text().partition("jumps forward ")[2]}')
    return out


class _Field(NamedTuple):
    """One input's field in one PGN's frames (:meth:`Decoder._mapped_fields`): the frames it
    takes (``rows``), which of them are not available, an error value, out of the input's
    range (each under the first that applies), and the physical values [SI]; shapes (k,)."""

    spec: SignalSpec
    unit: str
    rows: NDArray[np.intp]
    na: NDArray[np.bool_]
    err: NDArray[np.bool_]
    bad: NDArray[np.bool_]
    phys: NDArray[np.float64]

    @property
    def good(self) -> NDArray[np.bool_]:
        return ~(self.na | self.err | self.bad)


class Decoder:
    """Decode steering frames with a DBC and a signal map, counting rejects.

    Keeps, per identifier, the time and data of the last accepted frame (for the time and
    duplicate checks), so successive calls continue one stream.
    """

    def __init__(self, db: CanDatabase, signal_map: SignalMap, rejects: RejectCounter | None = None,
                 stitch: bool = False) -> None:
        """``stitch`` (logs read block by block, :meth:`decode_arrays`): a confirmed step of
        the frames' clock back in time starts a new stretch after the data before it, rather
        than the frames being refused as ``time_backwards`` until the clock has caught up;
        every step is kept in :attr:`clock_steps`. The live node restarts its monitor
        instead."""
        signal_map.check(db)
        self.db = db
        self.map = signal_map
        self.rejects = rejects if rejects is not None else RejectCounter()
        self.stitch = stitch
        #: the clock steps met (back or forward beyond the jump limit), in order
        self.clock_steps: list[ClockStep] = []
        self._shift_ns = 0                   # added to the times after the steps back so far
        self._last_released: int | None = None   # the last released frame's own time
        self._last: dict[int, tuple[int, bytes]] = {}
        self.jumps = JumpFilter(signal_map.max_jump_ns)
        self._held: list[tuple[Frame, MessageLayout, int]] = []  # frame by frame, after a jump
        self._held_fa = FrameArrays.empty()                     # the same, block by block,
        self._held_owner = np.zeros(0, np.int16)                # with their owners
        self.frames_seen = 0
        self._unknown: dict[int, str] = {}      # an unknown identifier's reject text, made once
        #: who holds which address (seeded with the map's devices given an address too)
        self.devices = DeviceTable()
        self._owner_lut = np.full(256, -1, np.int16)
        for spec in signal_map.specs:
            if spec.device_name is not None and spec.address >= 0:
                self.devices.seed(spec.address, spec.device_name)
        self._update_owners()
        # the DBC's PGNs, sorted, and each one's data length (a PGN looked up by a search)
        pgn_list = sorted(db.by_pgn) or [-1]
        self._pgn_table = (np.array(pgn_list, np.int64),
                           np.array([db.by_pgn[p].length if p in db.by_pgn else -1 for p in pgn_list], np.int64))

    @property
    def settled(self) -> bool:
        """The stream's time established and no frame held after a jump: a run without a jump
        is then decoded with no decision across its frames."""
        return self.jumps.ref_ns is not None and not self.jumps.pending

    # --- devices ---------------------------------------------------------------------------
    def _update_owners(self) -> None:
        """The map's device index (into ``map.device_names``) holding each address; -1: none."""
        self._owner_lut[:] = -1
        for k, name in enumerate(self.map.device_names):
            address = self.devices.address_of(name)
            if address is not None:
                self._owner_lut[address] = k

    def _claim(self, can_id: int, data: bytes, dlc: int) -> tuple[str, str]:
        """An address claim read into the device table when well formed -> the reject it is
        counted as, and its text (the caller counts it, now or when its frame is reached)."""
        if dlc != 8:
            return 'wrong_length', f'address claim {_id_text(can_id)} has {dlc} bytes, expected 8'
        name = DeviceName.from_data(data).name
        self.devices.claim(can_id & 0xFF, name)
        if self.map.device_names:
            self._update_owners()
        return 'address_claim', f'device {format_name(name)} at address {can_id & 0xFF}'

    # --- frame-level checks shared by both paths -----------------------------------------
    def _frame_layout(self, frame: Frame) -> MessageLayout | None:
        """Structural checks; the layout of an acceptable frame, None (counted) otherwise."""
        r = self.rejects
        if frame.is_error:
            r.add('error_frame', f'at t={frame.t_ns} ns')
            return None
        if frame.is_remote:
            r.add('remote_frame', _id_text(frame.can_id))
            return None
        if not frame.is_extended:
            r.add('not_extended', f'0x{frame.can_id:03X}')
            return None
        pgn = int(pgn_of(frame.can_id))
        if pgn == ADDRESS_CLAIM_PGN:
            r.add(*self._claim(frame.can_id, frame.data, len(frame.data)))
            return None
        layout = self.db.message(pgn)
        if layout is None:     # most of a busy bus: its text made once per identifier (a bounded few)
            text = self._unknown.get(frame.can_id)
            if text is None:
                text = f'{_id_text(frame.can_id)} (PGN {pgn})'
                if len(self._unknown) < MAX_UNKNOWN_TEXTS:
                    self._unknown[frame.can_id] = text
            r.add('unknown_id', text)
            return None
        if len(frame.data) != layout.length:
            r.add('wrong_length', f'{layout.name} {_id_text(frame.can_id)} has {len(frame.data)} bytes, '
                                  f'expected {layout.length}')
            return None
        return layout

    def _in_order(self, frame: Frame, layout: MessageLayout) -> bool:
        """Time and duplicate checks against the last accepted frame of the identifier."""
        r = self.rejects
        last = self._last.get(frame.can_id)
        if last is not None:
            if frame.t_ns < last[0]:
                r.add('time_backwards', f'{layout.name} {_id_text(frame.can_id)} at {frame.t_ns} ns '
                                        f'after {last[0]} ns')
                return False
            if frame.t_ns == last[0] and bytes(frame.data) == last[1]:
                r.add('duplicate', f'{layout.name} {_id_text(frame.can_id)} at {frame.t_ns} ns')
                return False
        self._last[frame.can_id] = (frame.t_ns, bytes(frame.data))
        return True

    def _jumped(self, frame: Frame) -> None:
        self.rejects.add('time_jump', f'{_id_text(frame.can_id)} at {frame.t_ns} ns, more than '
                                      f'{self.jumps.max_jump_ns / 1e9:g} s from the frames around it')

    def _matches(self, spec: SignalSpec, raw: dict[str, int], address: int, owner: int) -> bool:
        instance = raw.get('Instance')
        return ((spec.instance < 0 or instance == spec.instance or (instance == 255 and spec.bound))
                and (spec.source < 0 or raw.get('Source') == spec.source)
                and (spec.address < 0 or spec.device_name is not None or address == spec.address)
                and (spec.device_name is None or (owner >= 0 and self.map.device_names[owner] == spec.device_name)))

    # --- one frame -----------------------------------------------------------------------
    def decode(self, frame: Frame) -> list[Sample]:
        """Samples of one frame; rejects are counted, never raised.

        A frame after a time jump is held until its chain is confirmed (see
        :mod:`~steer_monitor.can.timejump`), so a call may return the samples of frames
        passed earlier, in their order, or none yet."""
        self.frames_seen += 1
        layout = self._frame_layout(frame)
        if layout is None:
            return []
        self._held_to_frames()
        rejected, released = self.jumps.push(frame.t_ns)
        self._held.append((frame, layout, int(self._owner_lut[frame.can_id & 0xFF])))
        for f, _, _ in self._held[:rejected]:
            self._jumped(f)
        rest = self._held[rejected:]
        cut = len(rest) - released
        self._held = rest[:cut]
        out: list[Sample] = []
        for f, lay, owner in rest[cut:]:
            if self._in_order(f, lay):
                out += self._fields(f, lay, owner)
        return out

    def finish(self) -> list[Sample]:
        """End of the stream. Frames still held are decided: a chain after a time jump is
        too short to be believed and is rejected as ``time_jump``; the stream's first
        chain (no jump seen, just fewer than ``CONFIRM_FRAMES`` frames) is released, and
        its samples are returned."""
        self._held_to_frames()
        held, self._held = self._held, []
        start = self.jumps.ref_ns is None
        self.jumps.finish()
        out: list[Sample] = []
        for f, lay, owner in held:
            if not start:
                self._jumped(f)
            elif self._in_order(f, lay):
                out += self._fields(f, lay, owner)
        if start and held:
            self.jumps.ref_ns = held[-1][0].t_ns
        return out

    def _held_to_frames(self) -> None:
        """Frames held by the block path, handed to the frame path (the two are not mixed
        often, but a stream may be fed both ways)."""
        if len(self._held_fa):
            self._held = [(f, self.db.message(int(pgn_of(f.can_id))), int(o))  # type: ignore[misc]
                          for f, o in zip(self._held_fa.frames(), self._held_owner)]
            self._held_fa = FrameArrays.empty()
            self._held_owner = np.zeros(0, np.int16)

    def _fields(self, frame: Frame, layout: MessageLayout, owner: int) -> list[Sample]:
        """The samples of an accepted frame's mapped fields (``owner``: the map's device
        holding the frame's address when it arrived, -1: none)."""
        raw = self.db.decode_raw(layout, frame.data)
        address = frame.can_id & 0xFF
        specs = [s for s in self.map.for_pgn(layout.pgn) if self._matches(s, raw, address, owner)]
        if not specs:
            self.rejects.add('unmapped', f'{layout.name} {_id_text(frame.can_id)} instance '
                                         f'{raw.get("Instance", "-")} source field {raw.get("Source", "-")} '
                                         f'address {address}')
            return []
        out = []
        for spec in specs:
            f = layout.fields[spec.field]
            value = raw[spec.field]
            if value == f.not_available:
                self.rejects.add('not_available', f'{spec.name} at {frame.t_ns} ns', spec.name)
                continue
            if value == f.error:
                self.rejects.add('error_value', f'{spec.name} at {frame.t_ns} ns', spec.name)
                continue
            phys = f.to_physical(value)
            if not spec.low <= phys <= spec.high:
                self.rejects.add('out_of_range', f'{spec.name} = {phys:g} {f.unit} at {frame.t_ns} ns '
                                                 f'(possible: {spec.low:g}..{spec.high:g})', spec.name)
                continue
            out.append(Sample(frame.t_ns, spec.name, float(phys)))
        return out

    # --- many frames ---------------------------------------------------------------------
    def decode_arrays(self, fa: FrameArrays, final: bool = False) -> SignalSet:
        """Series per input from a block of frames, vectorized with numpy.

        Gives the same samples and reject counts as :meth:`decode` frame by frame; with
        ``final`` (the stream's last block; may be empty), as :meth:`decode` of each frame
        followed by :meth:`finish`.
        """
        n = len(fa)
        self.frames_seen += n
        r = self.rejects
        error, remote, standard = self._flag_rejects(fa.flags)
        for hit, reason in ((error, 'error_frame'), (remote, 'remote_frame'), (standard, 'not_extended')):
            r.add(reason, 'in a log block', n=int(hit.sum()))
        ok = ~(error | remote | standard)
        pgns = pgn_of(fa.can_id.astype(np.uint32))
        claims = ok & (pgns == ADDRESS_CLAIM_PGN)
        owner = self._owners(fa, np.nonzero(claims)[0])
        ok &= ~claims
        known, length_ok = self._known(pgns, fa.dlc)
        hit = ok & ~known
        if hit.any():
            i = int(np.argmax(hit))
            r.add('unknown_id', f'{_id_text(int(fa.can_id[i]))} (PGN {int(pgns[i])}) and others',
                  n=int(hit.sum()))
        ok &= known
        hit = ok & ~length_ok
        r.add('wrong_length', 'in a log block', n=int(hit.sum()))
        ok &= length_ok
        self._held_as_arrays()
        held = len(self._held_fa)
        if held:                   # frames held after a jump come first, structurally checked already
            fa = FrameArrays.concat([self._held_fa, fa])
            ok = np.concatenate([np.ones(held, bool), ok])
            owner = np.concatenate([self._held_owner, owner])
            pgns = pgn_of(fa.can_id.astype(np.uint32))
        rows = np.nonzero(ok)[0]
        verdict = self.jumps.decide(fa.t_ns[rows[held:]]).verdict     # the held ones' too, first
        jumped = rows[verdict == REJECTED]
        if jumped.size:
            i = int(jumped[0])
            r.add('time_jump', f'{_id_text(int(fa.can_id[i]))} at {int(fa.t_ns[i])} ns and others, more than '
                               f'{self.jumps.max_jump_ns / 1e9:g} s from the frames around them', n=int(jumped.size))
        if final and (verdict == HELD).any():    # see finish()
            if self.jumps.ref_ns is None:
                verdict[verdict == HELD] = RELEASED
                self.jumps.ref_ns = int(fa.t_ns[rows[-1]])
            else:
                held = rows[verdict == HELD]
                r.add('time_jump', f'{_id_text(int(fa.can_id[held[0]]))} at {int(fa.t_ns[held[0]])} ns and '
                                   f'others at the end', n=int(held.size))
                verdict[verdict == HELD] = REJECTED
            self.jumps.finish()
        self._held_fa = fa.take(rows[verdict == HELD])
        self._held_owner = owner[rows[verdict == HELD]]
        ok[rows[verdict != RELEASED]] = False
        if self.stitch:
            fa = self._stitched(fa, np.nonzero(ok)[0])
        ok &= self._time_checks(fa, ok)

        out_t: dict[str, list[NDArray[np.int64]]] = {s: [] for s in self.map.names}
        out_v: dict[str, list[NDArray[np.float64]]] = {s: [] for s in self.map.names}
        for layout, fields, unmapped in self._mapped_fields(fa, ok, pgns, owner):
            for f in fields:
                spec = f.spec
                t = fa.t_ns[f.rows]
                r.add('not_available', f'{spec.name} in a log block', spec.name, int(f.na.sum()))
                r.add('error_value', f'{spec.name} in a log block', spec.name, int(f.err.sum()))
                if f.bad.any():
                    j = int(np.argmax(f.bad))
                    r.add('out_of_range', f'{spec.name} = {f.phys[j]:g} {f.unit} at {int(t[j])} ns and others '
                                          f'(possible: {spec.low:g}..{spec.high:g})', spec.name, int(f.bad.sum()))
                good = f.good
                out_t[spec.name].append(t[good])
                out_v[spec.name].append(f.phys[good])
            r.add('unmapped', f'{layout.name} frames in a log block', n=int(unmapped.size))
        return {name: Series(np.concatenate(out_t[name]) if out_t[name] else np.zeros(0, np.int64),
                             np.concatenate(out_v[name]) if out_v[name] else np.zeros(0, np.float64))
                for name in self.map.names}

    def _mapped_fields(self, fa: FrameArrays, ok: NDArray[np.bool_], pgns: NDArray, owner: NDArray[np.int16]
                       ) -> Iterator[tuple[MessageLayout, list[_Field], NDArray[np.intp]]]:
        """The fields of the frames ``ok`` as the map takes them, each PGN of the DBC they hold in
        turn: its layout, each of its inputs' field judged where a frame holds it (:class:`_Field`,
        in the PGN's order of inputs: a frame's samples' order) and the frames no input takes. ``owner``: each
        frame's device (the map's index holding its address when it came, -1: none); shapes (n,).
        The one definition of decoding frames as arrays, for :meth:`decode_arrays` and
        :meth:`decode_run`."""
        sound = np.flatnonzero(ok)
        if sound.size == 0:
            return
        present = {int(pgns[sound[0]])} if sound.size == 1 else set(np.unique(pgns[sound]).tolist())
        words = CanDatabase.words(fa.data)
        for pgn, layout in self.db.by_pgn.items():
            if pgn not in present:
                continue
            rows = sound[pgns[sound] == pgn]
            specs = self.map.for_pgn(pgn)
            if not specs:
                yield layout, [], rows
                continue
            w = words[rows]
            inst = (CanDatabase.extract(layout.fields['Instance'], w)
                    if 'Instance' in layout.fields and any(sp.instance >= 0 for sp in specs) else None)
            src = (CanDatabase.extract(layout.fields['Source'], w)
                   if 'Source' in layout.fields and any(sp.source >= 0 for sp in specs) else None)
            address = fa.can_id[rows] & 0xFF
            mapped = np.zeros(rows.size, bool)
            fields = []
            for spec in specs:
                sel = self._selected(spec, inst, src, address, owner[rows])
                if not sel.any():                    # no frame of this input: nothing to judge
                    continue
                mapped |= sel
                f = layout.fields[spec.field]
                na, err, bad, phys = self._judged(spec, f, CanDatabase.extract(f, w[sel]))
                fields.append(_Field(spec, f.unit, rows[sel], na, err, bad, phys))
            yield layout, fields, rows[~mapped]

    def _stitched(self, fa: FrameArrays, rows: NDArray[np.intp]) -> FrameArrays:
        """``fa`` with the released ``rows``' times put after every step back of the clock
        (:data:`STITCH_GAP_NS` after the last time before the step), the steps kept."""
        if rows.size == 0:
            return fa
        t = fa.t_ns[rows]
        prev = np.empty_like(t)
        prev[0] = t[0] if self._last_released is None else self._last_released
        prev[1:] = t[:-1]
        step = np.nonzero(np.abs(t - prev) > self.jumps.max_jump_ns)[0]
        shift = np.full(t.size, self._shift_ns, np.int64)
        for k in step.tolist():
            before, after = int(prev[k]), int(t[k])
            add = before - after + STITCH_GAP_NS if after < before else 0
            self.clock_steps.append(ClockStep(before, after, self._shift_ns + add))
            self._shift_ns += add
            shift[k:] += add
        self._last_released = int(t[-1])
        if not shift.any():
            return fa
        t_ns = fa.t_ns.copy()
        t_ns[rows] = t + shift
        return FrameArrays(t_ns, fa.can_id, fa.dlc, fa.data, fa.flags)

    @staticmethod
    def _flag_rejects(flags: NDArray[np.uint8]) -> tuple[NDArray[np.bool_], NDArray[np.bool_], NDArray[np.bool_]]:
        """Rows refused by their flags, each under the first reason :meth:`_frame_layout`
        gives: error frames, remote frames, standard identifiers; shapes (n,)."""
        error = (flags & FLAG_ERROR) != 0
        remote = ~error & ((flags & FLAG_REMOTE) != 0)
        standard = ~error & ~remote & ((flags & FLAG_EXTENDED) == 0)
        return error, remote, standard

    @staticmethod
    def _judged(spec: SignalSpec, f: FieldLayout, raw: NDArray[np.int64]
                ) -> tuple[NDArray[np.bool_], NDArray[np.bool_], NDArray[np.bool_], NDArray[np.float64]]:
        """A mapped field's raw values judged as :meth:`_fields` judges one: not available,
        error value, out of the input's range (each row under the first that applies), and
        the physical values [SI]; shapes (n,)."""
        na = raw == f.not_available
        err = ~na & (raw == f.error)
        phys = f.to_physical(raw.astype(np.float64))
        bad = ~na & ~err & ~((phys >= spec.low) & (phys <= spec.high))
        return na, err, bad, phys

    def _known(self, pgns: NDArray, dlc: NDArray[np.uint8]) -> tuple[NDArray[np.bool_], NDArray[np.bool_]]:
        """Rows whose PGN the DBC has, and rows of such a PGN with its data length; shapes (n,)."""
        table, lengths = self._pgn_table
        at = np.minimum(np.searchsorted(table, pgns), table.shape[0] - 1)
        known = table[at] == pgns
        return known, known & (lengths[at] == dlc)

    def _selected(self, spec: SignalSpec, inst: NDArray | None, src: NDArray | None, address: NDArray,
                  owner: NDArray[np.int16]) -> NDArray[np.bool_]:
        """The rows of one PGN's frames that ``spec`` takes (:meth:`_matches` over arrays):
        instance (or 255 where the spec is bound), source field, address, or the device
        holding the address (``owner``: the map's device index per row, -1: none)."""
        sel = np.ones(address.shape[0], bool)
        if spec.instance >= 0:
            sel &= (inst == spec.instance) | ((inst == 255) & spec.bound)
        if spec.source >= 0:
            sel &= src == spec.source
        if spec.address >= 0 and spec.device_name is None:    # with a NAME: where it starts
            sel &= address == spec.address
        if spec.device_name is not None:
            sel &= owner == self.map.device_names.index(spec.device_name)
        return sel

    def _owners(self, fa: FrameArrays, claims: NDArray[np.intp], counted: dict[str, list[int]] | None = None
                ) -> NDArray[np.int16]:
        """Each row's owner (the map's device holding its address when it arrived, -1: none),
        reading the address claims at rows ``claims`` in order; shape (n,). The claims' rejects
        are counted now, or, given ``counted``, their rows kept there by reason (a run counts
        them when its frames are reached)."""
        address = (fa.can_id & 0xFF).astype(np.intp)
        owner = np.empty(len(fa), np.int16)
        start = 0
        for c in claims.tolist():
            owner[start:c] = self._owner_lut[address[start:c]]
            reason, text = self._claim(int(fa.can_id[c]), fa.data[c].tobytes(), int(fa.dlc[c]))
            if counted is None:
                self.rejects.add(reason, text)
            else:
                counted.setdefault(reason, []).append(c)
            owner[c] = -1
            start = c + 1
        owner[start:] = self._owner_lut[address[start:]]
        return owner

    def _time_checks(self, fa: FrameArrays, ok: NDArray[np.bool_]) -> NDArray[np.bool_]:
        """Time-backwards and duplicate checks per identifier, continuing from earlier calls."""
        back, dup = self._time_verdicts(fa, ok)
        self.rejects.add('time_backwards', 'in a log block', n=int(back.sum()))
        self.rejects.add('duplicate', 'in a log block', n=int(dup.sum()))
        return ok & ~back & ~dup

    def _time_verdicts(self, fa: FrameArrays, ok: NDArray[np.bool_]) -> tuple[NDArray[np.bool_], NDArray[np.bool_]]:
        """Which of the rows ``ok`` are earlier than the last accepted frame of their
        identifier, and which duplicate it; shapes (n,). Remembers the last accepted frames."""
        back_all = np.zeros(len(fa), bool)
        dup_all = np.zeros(len(fa), bool)
        rows_all = np.nonzero(ok)[0]
        if rows_all.size == 0:
            return back_all, dup_all
        ids = fa.can_id[rows_all]
        # payloads compared as one 64-bit word each
        data = np.ascontiguousarray(fa.data)
        words = data.view('<u8')[:, 0] if data.shape[1] == 8 else None
        uniq, first, counts = np.unique(ids, return_index=True, return_counts=True)
        for cid, k, c in zip(uniq.tolist(), first.tolist(), counts.tolist()):
            if c == 1:                          # one frame of the identifier (a node's read): as _in_order
                r = int(rows_all[k])
                ti, last = int(fa.t_ns[r]), self._last.get(cid)
                payload = fa.data[r, :int(fa.dlc[r])].tobytes()
                if last is not None and ti < last[0]:
                    back_all[r] = True
                elif last is not None and ti == last[0] and payload == last[1]:
                    dup_all[r] = True
                else:
                    self._last[cid] = (ti, payload)
                continue
            rows = rows_all[ids == cid]
            t = fa.t_ns[rows]
            last = self._last.get(cid)
            seed = last[0] if last is not None else np.iinfo(np.int64).min
            prev_max = np.maximum.accumulate(np.concatenate([[seed], t[:-1]]))
            prev_max = np.maximum(prev_max, seed)
            back = t < prev_max
            fwd = rows[~back]
            tf = fa.t_ns[fwd]
            same_t = np.zeros(fwd.size, bool)
            same_d = np.zeros(fwd.size, bool)
            if fwd.size:
                same_t[1:] = tf[1:] == tf[:-1]
                if words is not None:
                    wf = words[fwd]
                    same_d[1:] = wf[1:] == wf[:-1]
                else:
                    df = data[fwd]
                    same_d[1:] = np.all(df[1:] == df[:-1], axis=1)
                if last is not None:
                    first_data = bytes(data[fwd[0], :int(fa.dlc[fwd[0]])])
                    same_t[0] = tf[0] == last[0]
                    same_d[0] = first_data == last[1]
            dup = same_t & same_d
            back_all[rows[back]] = True
            dup_all[fwd[dup]] = True
            accepted = fwd[~dup]
            if accepted.size:
                i = int(accepted[-1])
                self._last[cid] = (int(fa.t_ns[i]), bytes(fa.data[i, :int(fa.dlc[i])]))
        return back_all, dup_all

    # --- a run of frames, frame by frame's answers at once ---------------------------------
    def decode_run(self, fa: FrameArrays, until_step_back: bool = False) -> DecodedRun:
        """What :meth:`decode` of each frame of ``fa`` in turn would give, vectorized: each
        frame's samples and rejects, indexed by the frame at whose arrival :meth:`decode` gives
        them, for a caller that must act between frames (the pipeline's schedule) without a
        Python call per frame. The rejects are *not* counted here: :meth:`DecodedRun.count_rejects`
        counts those of the frames up to one, so a count read between frames is the
        frame-by-frame one.

        Address claims are read in order, each frame's device the one holding its address when
        it came. The stream's start and time jumps are decided as :meth:`decode` decides them
        (:meth:`JumpFilter.decide`): frames held after a jump, here or in an earlier call, give
        their samples at the frame that confirms their chain, stamped with their own times
        (:attr:`DecodedRun.sample_t_ns`). ``until_step_back``: the run ends at the frame that
        confirms the stream's time going back (at once if it went back before), its
        :attr:`~DecodedRun.t_ns` then shorter than ``fa``; the frames after it are not taken."""
        n = len(fa)
        jumps = self.jumps
        events: list[tuple[NDArray[np.intp], str, str]] = []
        ok = (fa.flags & _FLAG_CHECKED) == FLAG_EXTENDED          # no error, remote or 11-bit frame
        if not ok.all():
            error, remote, standard = self._flag_rejects(fa.flags)
            events += [(np.flatnonzero(m), reason, '') for m, reason in (
                (error, 'error_frame'), (remote, 'remote_frame'), (standard, 'not_extended')) if m.any()]
        pgns = pgn_of(fa.can_id.astype(np.uint32))
        claims = ok & (pgns == ADDRESS_CLAIM_PGN)
        any_claim = bool(claims.any())
        if any_claim:
            ok &= ~claims
        known, length_ok = self._known(pgns, fa.dlc)
        events += [(np.flatnonzero(m), reason, '') for m, reason in (
            (ok & ~known, 'unknown_id'), (ok & known & ~length_ok, 'wrong_length')) if m.any()]
        ok &= length_ok
        t = fa.t_ns
        rows = np.flatnonzero(ok)
        t_ok = t[rows]
        self._held_as_arrays()
        ref0 = NO_TIME if jumps.ref_ns is None else jumps.ref_ns
        settled = (not jumps.pending and jumps.ref_ns is not None
                   and (t_ok.size == 0 or (abs(int(t_ok[0]) - jumps.ref_ns) <= jumps.max_jump_ns
                                           and (t_ok.size == 1
                                                or not (np.abs(np.diff(t_ok)) > jumps.max_jump_ns).any()))))
        if until_step_back and n > 1:
            cut = 0 if jumps.steps_back else -1
            if cut < 0 and not settled:          # a run without a jump confirms no chain
                probe = dataclasses.replace(jumps, pending=list(jumps.pending))
                at = probe.decide(t_ok).step_back_at
                cut = int(rows[at]) if at >= 0 else -1
            if 0 <= cut < n - 1:
                return self.decode_run(fa.take(np.arange(cut + 1)))
        counted: dict[str, list[int]] = {}
        owner = self._owners(fa, np.flatnonzero(claims) if any_claim else _NO_ROWS, counted)  # claims read in order
        events += [(np.array(rows, np.intp), reason, '') for reason, rows in counted.items()]
        if settled:
            # every sound frame is released as it comes and becomes the stream's time
            every, every_pgns, every_owner, released, emit = fa, pgns, owner, ok, None
            ref_ok = t_ok
            if t_ok.size:
                jumps.ref_ns = int(t_ok[-1])
        else:
            # the frames held before, then this run's sound ones, decided frame by frame's way
            held, held_owner = self._held_fa, self._held_owner
            d = jumps.decide(t_ok)
            every = FrameArrays.concat([held, fa.take(rows)])
            every_pgns = pgn_of(every.can_id.astype(np.uint32))
            every_owner = np.concatenate([held_owner, owner[rows]])
            released = d.verdict == RELEASED
            emit = np.full(d.at.shape[0], -1, np.intp)          # the frame whose arrival decides
            decided = d.at >= 0
            emit[decided] = rows[d.at[decided]]
            still = np.flatnonzero(d.verdict == HELD)
            self._held_fa, self._held_owner = every.take(still), every_owner[still]
            events.append((emit[d.verdict == REJECTED], 'time_jump', ''))
            ref_ok = d.ref_after
        # the stream's time after each frame: after its last sound frame so far, else as before the run
        if rows.size:
            last = np.searchsorted(rows, np.arange(n), 'right') - 1
            ref_after = np.where(last >= 0, ref_ok[np.maximum(last, 0)], ref0)
        else:
            ref_after = np.full(n, ref0, np.int64)
        ref_before = np.empty(n, np.int64)
        ref_before[0] = ref0
        ref_before[1:] = ref_after[:-1]

        def at(idx: NDArray[np.intp]) -> NDArray[np.intp]:
            return idx if emit is None else emit[idx]
        good = released
        if released.any():
            back, dup = self._time_verdicts(every, released)       # in arrival order: the order of release
            for m, reason in ((back, 'time_backwards'), (dup, 'duplicate')):
                if m.any():
                    events.append((at(np.flatnonzero(m)), reason, ''))
                    good = good & ~m
        names: list[str] = []                          # a sample's input, by its spec's number
        s_idx: list[NDArray[np.intp]] = []
        s_spec: list[NDArray[np.intp]] = []
        s_val: list[NDArray[np.float64]] = []
        for _, fields, unmapped in self._mapped_fields(every, good, every_pgns, every_owner):
            for f in fields:                          # numbered in the PGN's order: a frame's samples' order
                name = f.spec.name
                events += [(at(f.rows[m]), reason, name) for m, reason in (
                    (f.na, 'not_available'), (f.err, 'error_value'), (f.bad, 'out_of_range')) if m.any()]
                ok_f = f.good
                s_idx.append(f.rows[ok_f])
                s_spec.append(np.full(int(ok_f.sum()), len(names), np.intp))
                s_val.append(f.phys[ok_f])
                names.append(name)
            if unmapped.size:
                events.append((at(unmapped), 'unmapped', ''))
        self.frames_seen += n
        if not s_idx:
            return DecodedRun(t, ref_before, ref_after, _NO_ROWS, _NO_TIMES, _NO_ROWS, (), _NO_VALUES, events,
                              self.rejects, settled)
        idx, spec_no, value = np.concatenate(s_idx), np.concatenate(s_spec), np.concatenate(s_val)
        row = at(idx)
        order = np.lexsort((spec_no, idx, row))
        return DecodedRun(t, ref_before, ref_after, row[order], every.t_ns[idx[order]], spec_no[order], tuple(names),
                          value[order], events, self.rejects, settled)

    def _held_as_arrays(self) -> None:
        """Frames held by the frame path, handed to the array paths (with their owners)."""
        if self._held:
            self._held_fa = FrameArrays.concat([self._held_fa, FrameArrays.from_frames(f for f, _, _ in self._held)])
            self._held_owner = np.concatenate([self._held_owner, np.array([o for _, _, o in self._held], np.int16)])
            self._held = []
