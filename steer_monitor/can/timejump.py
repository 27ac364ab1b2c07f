"""Timestamps that jump: a glitched frame or a host clock step must not poison a stream.

The frames of a bus arrive in time order, a few milliseconds apart. A frame whose time lies
more than ``max_jump_ns`` from the frame before it starts a *new chain*. A chain is held
until it has ``CONFIRM_FRAMES`` frames; then it is taken as the stream's new time (a clock
step, or a log that resumes after a pause) and all its frames are released. A chain that
ends (by another jump) before that is rejected as ``time_jump``, unless its end returns to
the established time, which then simply goes on: one far-future frame, or a short burst of
them, costs those frames only. The first frames of a stream form a chain too, so a glitched
first frame is not taken as the stream's time.

Only the times of frames that passed the structural checks (identifier, length) take part,
in arrival order over all identifiers. A confirmed step *back* in time is accepted here and
its frames are then refused per identifier as ``time_backwards`` until the clock passes the
last accepted time again: the decoder never reorders, and overlapping times would mix two
periods of data. Such steps are counted (:attr:`JumpFilter.steps_back`, with the last one's
size): the live node then starts its monitor again from the new time, as a restart would,
rather than refuse the data for as long as the clock was ahead.

:class:`JumpFilter` decides frame by frame (:meth:`JumpFilter.push`: a chain's frames wait for
its confirmation, at most ``CONFIRM_FRAMES`` frames), or a run or a log's block at a time with
frame by frame's answers kept per frame (:meth:`JumpFilter.decide`: push() where a chain is
held, the stretches of the established time between jumps at once; which frame's arrival
released or refused each, the stream's time after each). Pure Python and numpy.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

__all__ = ['CONFIRM_FRAMES', 'DEFAULT_MAX_JUMP_NS', 'HELD', 'NO_TIME', 'REJECTED', 'RELEASED', 'Decisions',
           'JumpFilter']

#: frames a new chain needs before its time is believed (about half a second of a steering bus)
CONFIRM_FRAMES = 50
DEFAULT_MAX_JUMP_NS = 5_000_000_000
RELEASED, HELD, REJECTED = 1, 0, -1
#: the stream's time before any chain has been confirmed, in an array of times [ns]
NO_TIME = np.iinfo(np.int64).min


@dataclass(frozen=True)
class Decisions:
    """:meth:`JumpFilter.decide`'s answer on ``h`` frames held before and ``n`` new ones, shapes
    (h + n,) over the held frames then the new: ``verdict`` (``RELEASED``, ``REJECTED`` or
    ``HELD``: still held after the last), ``at`` (the new frame whose arrival decided it, -1
    while held); per new frame, shape (n,), ``ref_after`` (the stream's time after it, ``NO_TIME``
    before any); ``step_back_at`` (the new frame that confirmed a step back in time, -1: none)."""

    verdict: NDArray[np.int8]
    at: NDArray[np.intp]
    ref_after: NDArray[np.int64]
    step_back_at: int


@dataclass
class JumpFilter:
    """Per-stream state of the jump rule (see the module docstring).

    ``ref_ns``: the time of the last released frame (None before the first confirmation);
    ``pending``: the times of the chain being held, in arrival order; ``steps_back``: the
    chains confirmed earlier than the time before them, ``step_back_ns`` by how much the
    last one went back.
    """

    max_jump_ns: int = DEFAULT_MAX_JUMP_NS
    confirm: int = CONFIRM_FRAMES
    ref_ns: int | None = None
    pending: list[int] = field(default_factory=list)
    steps_back: int = 0
    step_back_ns: int = 0

    def _new_time(self, first: int, last: int) -> None:
        """A chain from ``first`` to ``last`` is confirmed as the stream's time."""
        if self.ref_ns is not None and first < self.ref_ns:
            self.steps_back += 1
            self.step_back_ns = self.ref_ns - first
        self.ref_ns = last

    def _near(self, a: int, b: int) -> bool:
        return abs(a - b) <= self.max_jump_ns

    # --- frame by frame --------------------------------------------------------------------
    def push(self, t_ns: int) -> tuple[int, int]:
        """One frame's time. Returns (rejected, released): the number of held frames now
        rejected (the oldest ones) and the number now released, counting this frame last;
        a frame neither released nor rejected is held."""
        rejected = 0
        if self.pending:
            if self._near(t_ns, self.pending[-1]):
                self.pending.append(t_ns)
                return self._confirm_if_long(rejected)
            rejected = len(self.pending)
            self.pending = []
            if self.ref_ns is not None and self._near(t_ns, self.ref_ns):
                self.ref_ns = t_ns
                return rejected, 1
        elif self.ref_ns is not None and self._near(t_ns, self.ref_ns):
            self.ref_ns = t_ns
            return 0, 1
        self.pending = [t_ns]
        return self._confirm_if_long(rejected)

    def _confirm_if_long(self, rejected: int) -> tuple[int, int]:
        if len(self.pending) >= self.confirm:
            n = len(self.pending)
            self._new_time(self.pending[0], self.pending[-1])
            self.pending = []
            return rejected, n
        return rejected, 0

    def finish(self) -> int:
        """End of the stream: the held chain cannot be confirmed; returns how many frames of
        it are rejected."""
        n = len(self.pending)
        self.pending = []
        return n

    def decide(self, t_ns: NDArray[np.int64]) -> Decisions:
        """:meth:`push` of each time of ``t_ns`` in turn, its answers kept per frame: which frame's
        arrival released or rejected each of the frames held (:attr:`pending`, first) and each new
        one, and the stream's time after each. Frame by frame where a chain is held; the
        stretches of the established time between jumps at once."""
        t = np.asarray(t_ns, np.int64)
        h, n = len(self.pending), t.size
        verdict = np.zeros(h + n, np.int8)
        at = np.full(h + n, -1, np.intp)
        ref_after = np.full(n, NO_TIME, np.int64)
        step_back_at = -1
        jump_after = np.flatnonzero(np.abs(np.diff(t)) > self.max_jump_ns) + 1    # frames far from the one before
        chain = list(range(h))          # the held frames, by their place over held then new
        i = 0
        while i < n:
            if not chain and self.ref_ns is not None and self._near(int(t[i]), self.ref_ns):
                # the established time goes on to the next jump: each frame released as it comes
                nxt = int(np.searchsorted(jump_after, i, 'right'))
                k = int(jump_after[nxt]) if nxt < jump_after.size else n
                verdict[h + i:h + k] = RELEASED
                at[h + i:h + k] = np.arange(i, k)
                ref_after[i:k] = t[i:k]
                self.ref_ns = int(t[k - 1])
                i = k
                continue
            steps = self.steps_back
            rejected, released = self.push(int(t[i]))
            gone, chain = chain[:rejected], chain[rejected:] + [h + i]
            verdict[gone] = REJECTED
            at[gone] = i
            if released:
                freed, chain = chain[len(chain) - released:], chain[:len(chain) - released]
                verdict[freed] = RELEASED
                at[freed] = i
            if self.ref_ns is not None:
                ref_after[i] = self.ref_ns
            if self.steps_back != steps and step_back_at < 0:
                step_back_at = i
            i += 1
        return Decisions(verdict, at, ref_after, step_back_at)
