"""The live model's states as packed MCAP Message records, many at once.

A replay writes a hundred states per second of data, each a ``sensor_msgs/JointState`` (the
rudder) and, once the pressures are known, another of the load sharing's named values. Built one by
one (:func:`~steer_monitor.monitor.messages.state_messages`, the CDR encoders of
:mod:`~steer_monitor.record.cdr`, ``McapWriter.write_cdr``) they cost about 15 us each, a
sixth of a replay. Both messages have a fixed size, so here the records of a batch of states
are filled in by numpy into templates, and the writer appends them at once
(:meth:`~steer_monitor.logfiles.mcapio.McapWriter.write_records`).

The templates and the places of the fields in them are taken from the one-by-one path
itself (its bytes for a state of sentinel values), so the two cannot drift apart silently;
``test_staterecords`` checks the bytes are the same, record for record.
"""

from __future__ import annotations

import operator
import struct
from collections.abc import Sequence
from dataclasses import dataclass
from functools import cache

import numpy as np
from numpy.typing import NDArray

from steer_monitor.logfiles.mcapio import message_head
from steer_monitor.model.gear import Clearances, GearParams
from steer_monitor.model.loadshare import ShareScalar, load_sharing
from steer_monitor.monitor.live import LiveState
from steer_monitor.monitor.messages import state_messages
from steer_monitor.monitor.pipeline import StateOut
from steer_monitor.monitor.runfeed import StateRun
from steer_monitor.record.cdr import FAST_ENCODERS
from steer_monitor.rostime import SEC_MAX

__all__ = ['PackedStates', 'pack_states']


# sentinel values: a state whose every field has a bit pattern found once in its messages
_T_NS = 1_234_567_890 * 1_000_000_000 + 987_654_321
_ALPHA, _RATE, _TORQUE = 0.123456789012345, -0.0234567890123456, 345678.901234567
_SHARE = ShareScalar(lateral=11111.1234567891, axial=22222.1234567891, ram_force=33333.1234567891,
                     guide_force=44444.1234567891, k_gl=0.555551234567891, deflection=6.66661234567891e-4,
                     r_a=77777.1234567891, r_e=88888.1234567891, m_a=99999.1234567891, f_theta=1.0, f_z=1.0,
                     case=-3, stages=5)
_SHARE_FLOATS = ('lateral', 'ram_force', 'guide_force', 'k_gl', 'deflection', 'r_a', 'r_e', 'm_a', 'case', 'stages')
_share_floats = operator.attrgetter(*_SHARE_FLOATS)


@dataclass(frozen=True)
class _Layout:
    """One message type's record: the template (record header included) and where its fields
    are [byte offsets into the record]."""

    template: bytes
    sec: int
    floats: tuple[int, ...]


def _find(raw: bytes, packed: bytes) -> int:
    at = raw.find(packed)
    if at < 0 or raw.find(packed, at + 1) >= 0:
        msg = 'a sentinel is not found exactly once in a state message'
        raise AssertionError(msg)
    return at


@cache
def _layouts() -> tuple[_Layout, _Layout]:
    """The rudder's and the load sharing's JointState records of the sentinel state, and their
    fields' places."""
    state = LiveState(_T_NS, _ALPHA, _RATE, True, _TORQUE, _SHARE, Clearances(0.0, 0.0))
    (_, _, rudder), (_, _, share) = state_messages(StateOut(state))
    out = []
    for datatype, fields, floats in (('sensor_msgs/msg/JointState', rudder, (_ALPHA, _RATE, _TORQUE)),
                                     ('sensor_msgs/msg/JointState', share,
                                      tuple(float(getattr(_SHARE, k)) for k in _SHARE_FLOATS))):
        cdr = FAST_ENCODERS[datatype](fields)
        rec = message_head(0, 0, len(cdr)) + cdr
        sec, nsec = divmod(_T_NS, 1_000_000_000)
        places = tuple(_find(rec, struct.pack('<d', v)) for v in floats)
        out.append(_Layout(rec, _find(rec, struct.pack('<iI', sec, nsec)), places))
    return out[0], out[1]


@dataclass(frozen=True)
class PackedStates:
    """Records ready for ``McapWriter.write_records``: ``data`` holds record ``i`` at
    ``offsets[i]:offsets[i + 1]``, on ``channels[i]``, logged at ``log_times[i]`` [ns]."""

    data: bytes
    channels: NDArray[np.uint16]
    log_times: NDArray[np.int64]
    offsets: NDArray[np.int64]
    #: per state, the index of the record after its own (states have one record or two)
    state_ends: NDArray[np.int64]


def _fill(layout: _Layout, channel: int, t: NDArray[np.int64], floats: NDArray[np.float64],
          rec: NDArray[np.uint8]) -> None:
    """``n`` records from the template into ``rec`` ((n, record size), a view of the rows):
    channel, times, stamp, the floats ((n, k), in the layout's order)."""
    n = t.shape[0]
    assert rec.shape == (n, len(layout.template))
    rec[:] = np.frombuffer(layout.template, np.uint8)
    rec[:, 9:11] = np.frombuffer(np.uint16(channel).tobytes(), np.uint8)
    times = t.astype('<u8').view(np.uint8).reshape(n, 8)
    rec[:, 15:23] = times
    rec[:, 23:31] = times
    sec, nsec = np.divmod(t, 1_000_000_000)
    unset = (sec > SEC_MAX) | (sec < -SEC_MAX - 1)     # see rostime.ros_time
    stamp = np.empty(n, [('sec', '<i4'), ('nsec', '<u4')])
    stamp['sec'], stamp['nsec'] = np.where(unset, 0, sec), np.where(unset, 0, nsec)
    rec[:, layout.sec:layout.sec + 8] = stamp.view(np.uint8).reshape(n, 8)
    f = np.ascontiguousarray(floats, '<f8').view(np.uint8).reshape(n, len(layout.floats), 8)
    for k, at in enumerate(layout.floats):
        rec[:, at:at + 8] = f[:, k]


def _shares(shares: list[ShareScalar], given: NDArray[np.bool_], todo: NDArray[np.bool_],
            alpha: NDArray[np.float64], torque: NDArray[np.float64], two_z: NDArray[np.float64],
            z_gb: NDArray[np.float64], gear: GearParams | None) -> NDArray[np.float64]:
    """The load sharing of the states that carry one (``given``, their ``shares`` in order) or
    are to have theirs solved (``todo``), in state order: floats (m, 10) in the layout's order
    (the load case and stages as floats, as the message carries them). The states left to the
    caller (:meth:`~steer_monitor.monitor.live.LiveMonitor.slot_state`) are solved all at once
    by :func:`~steer_monitor.model.loadshare.load_sharing` (the live monitor's numbers, to the bit)."""
    has = given | todo
    m = int(np.count_nonzero(has))
    floats = np.empty((m, len(_SHARE_FLOATS)))
    mine, solved = given[has], todo[has]
    if mine.any():
        floats[mine] = np.array([_share_floats(x) for x in shares], float)
    if solved.any():
        assert gear is not None
        idx = np.flatnonzero(todo)
        ls = load_sharing(gear, alpha[idx], torque[idx], two_z[idx], z_gb[idx])
        floats[solved] = np.stack([getattr(ls, k) for k in _SHARE_FLOATS], axis=1)
    return floats


@dataclass
class _Columns:
    """States as columns: per state time, angle, rate, torque (0 where none), whether a torque
    was measured, the clearances; the load sharings the states carry, and where."""

    t: NDArray[np.int64]
    alpha: NDArray[np.float64]
    rate: NDArray[np.float64]
    torque: NDArray[np.float64]
    measured: NDArray[np.bool_]
    two_z: NDArray[np.float64]
    z_gb: NDArray[np.float64]
    given: NDArray[np.bool_]
    shares: list[ShareScalar]


def _columns(items: Sequence[LiveState | StateRun]) -> _Columns:
    """States given one by one and as columns, in order, as one set of columns."""
    parts: list[tuple[NDArray, ...]] = []
    shares: list[ShareScalar] = []
    single: list[LiveState] = []

    def singles() -> None:
        if single:
            k = len(single)
            parts.append((np.fromiter((s.t_ns for s in single), np.int64, k),
                          np.fromiter((s.alpha for s in single), float, k),
                          np.fromiter((s.rate for s in single), float, k),
                          np.fromiter((s.torque_measured or 0.0 for s in single), float, k),
                          np.fromiter((s.torque_measured is not None for s in single), bool, k),
                          np.fromiter((s.gaps.two_z for s in single), float, k),
                          np.fromiter((s.gaps.z_gb for s in single), float, k),
                          np.fromiter((s.share is not None for s in single), bool, k)))
            shares.extend(s.share for s in single if s.share is not None)
            single.clear()
    for item in items:
        if isinstance(item, StateRun):
            singles()
            k = len(item)
            parts.append((item.t_ns, item.alpha, item.rate, item.torque, np.ones(k, bool), item.two_z, item.z_gb,
                          np.zeros(k, bool)))
        else:
            single.append(item)
    singles()
    if not parts:
        parts.append((np.zeros(0, np.int64), *(np.zeros(0) for _ in range(3)), np.zeros(0, bool),
                      np.zeros(0), np.zeros(0), np.zeros(0, bool)))
    cols = [np.concatenate(c) for c in zip(*parts)]
    return _Columns(*cols, shares)


def pack_states(states: Sequence[LiveState | StateRun], rudder_channel: int, share_channel: int,
                gear: GearParams | None = None) -> PackedStates:
    """The records of ``states`` (one by one or as columns) in order: each state's rudder
    JointState, then its load sharing's when it has one; the same bytes as ``state_messages``
    encoded one by one. With ``gear``, a state whose load sharing was left to the caller
    (``share`` None, ``torque_measured`` set; every state of a
    :class:`~steer_monitor.monitor.runfeed.StateRun`) has it solved here: the bytes of the
    state the live monitor would have made."""
    joint, share = _layouts()
    c = _columns(states)
    t, alpha, rate, torque = c.t, c.alpha, c.rate, c.torque
    n = t.shape[0]
    given = c.given
    todo = np.zeros(n, bool)              # left to be solved here: only with the gear to solve them
    if gear is not None:
        todo = ~given & c.measured
    has = given | todo
    a, b = len(joint.template), len(share.template)
    # a row per state: its rudder record, then a load sharing's (dropped where it has none)
    rows = np.empty((n, a + b), np.uint8)
    _fill(joint, rudder_channel, t, np.stack([alpha, rate, np.copysign(torque, alpha)], axis=1), rows[:, :a])
    floats = np.zeros((n, len(_SHARE_FLOATS)))
    floats[has] = _shares(c.shares, given, todo, alpha, torque, c.two_z, c.z_gb, gear)
    _fill(share, share_channel, t, floats, rows[:, a:])
    keep = np.ones((n, a + b), bool)
    keep[~has, a:] = False
    per_state = np.where(has, 2, 1)
    ends = np.cumsum(per_state)                    # per state, the index of the record after its own
    kind = np.zeros(int(ends[-1]) if n else 0, bool)   # True: a load-sharing record
    kind[ends[has] - 1] = True
    offsets = np.zeros(kind.size + 1, np.int64)
    np.cumsum(np.where(kind, b, a), out=offsets[1:])
    channels = np.where(kind, share_channel, rudder_channel).astype(np.uint16)
    return PackedStates(rows[keep].tobytes(), channels, np.repeat(t, per_state), offsets, ends)
