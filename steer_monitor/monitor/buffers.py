"""Fixed-size buffers of the live monitor's rows. Pure.

:class:`RowRing` keeps the last rows of a stream in one numpy array written in place;
:class:`HeldSamples` keeps pressure samples held until the rudder's angle past them is known.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

__all__ = ['HeldSamples', 'RowRing']


class RowRing:
    """The last ``cap`` rows of a stream of rows of ``width`` floats, in one numpy array
    written in place (numpy reads it as it is, where a deque of tuples took 0.4 ms a second
    to convert): the next row at ``next``, ``kept`` rows held. Rows pushed together lie
    where pushing them one by one would put them."""

    def __init__(self, cap: int, width: int) -> None:
        self.data = np.zeros((cap, width))
        self.next = 0
        self.kept = 0

    def push(self, block: NDArray[np.float64]) -> None:
        """Rows (n, width) after those held."""
        cap, total = self.data.shape[0], block.shape[0]
        block = block[-cap:]
        k = block.shape[0]
        start = (self.next + total - k) % cap
        head = min(k, cap - start)
        self.data[start:start + head] = block[:head]
        self.data[:k - head] = block[head:]
        self.next = (start + k) % cap
        self.kept = min(self.kept + total, cap)

    def clear(self) -> None:
        self.next = self.kept = 0

    def rows(self) -> NDArray[np.float64]:
        """The rows held (kept, width), in the order they lie (a view)."""
        return self.data[:self.kept]

    def ordered(self) -> NDArray[np.float64]:
        """The rows held (kept, width), oldest first (a copy)."""
        return self.data[(np.arange(self.kept) + (self.next - self.kept)) % self.data.shape[0]]


class HeldSamples:
    """Pressure samples held for the residual and not yet released, in the order held: their
    times (n,) [ns] and four pressures (n, 4) [Pa] in one buffer (released from the front, the
    rest moved down when the buffer is full, the buffer grown when that is not room enough),
    those held one by one kept in lists until read."""

    def __init__(self) -> None:
        self.t = np.zeros(1024, np.int64)
        self.p = np.zeros((1024, 4))
        self.lo = self.hi = 0
        self._one_t: list[int] = []
        self._one_p: list[float] = []

    def __len__(self) -> int:
        return self.hi - self.lo + len(self._one_t)

    def add_one(self, t_ns: int, pressures: list[float]) -> None:
        """One sample held (four pressures [Pa])."""
        self._one_t.append(t_ns)
        self._one_p.extend(pressures)

    def add(self, times: NDArray[np.int64], pressures: NDArray[np.float64]) -> None:
        """Samples held after those held so far (times (n,), pressures (n, 4))."""
        self._loose()
        n = times.shape[0]
        if self.hi + n > self.t.shape[0]:
            live = self.hi - self.lo
            cap = self.t.shape[0]
            if live + n > cap:
                cap = max(2 * cap, live + n)
                t, p = np.zeros(cap, np.int64), np.zeros((cap, 4))
            else:
                t, p = self.t, self.p
            t[:live] = self.t[self.lo:self.hi]
            p[:live] = self.p[self.lo:self.hi]
            self.t, self.p, self.lo, self.hi = t, p, 0, live
        self.t[self.hi:self.hi + n] = times
        self.p[self.hi:self.hi + n] = pressures
        self.hi += n

    def _loose(self) -> None:
        if self._one_t:
            t, p = np.array(self._one_t, np.int64), np.array(self._one_p, float).reshape(-1, 4)
            self._one_t.clear()
            self._one_p.clear()
            self.add(t, p)

    def view(self) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
        """The samples held (times (n,), pressures (n, 4)), views valid until the next change."""
        self._loose()
        return self.t[self.lo:self.hi], self.p[self.lo:self.hi]

    def release(self, k: int) -> None:
        """The oldest ``k`` samples let go."""
        self._loose()
        self.lo += k
        if self.lo >= self.hi:
            self.lo = self.hi = 0
