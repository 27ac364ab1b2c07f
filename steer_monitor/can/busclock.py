"""Interface timestamps onto the host's clock, when the interface's are not UTC.

python-can promises "seconds since the epoch, in hardware where possible", and several
adapters do not keep it: gs_usb/candleLight counts from the adapter's power-up, PCAN-Basic
on some platforms from boot, IXXAT (python-can 4.6) reads 1.5 x the epoch plus the adapter's
uptime. Taken as they are, a node on such an adapter would stamp its states, diagnostics and
recordings in 1970 or in 2054, name its files so, and a fleet's wear trend would be dated
nonsense.

:class:`BusClock` maps each frame's interface time to the data time the pipeline uses, in
integer nanoseconds:

* ``bus``: the interface's time as it is (an adapter known to keep UTC);
* ``host``: the host's clock when the frame was read (any adapter; a frame's time then
  carries the reading's latency, up to the read batch);
* ``auto`` (default): the interface's time while it agrees with the host's; otherwise the
  interface's time plus an offset that puts it on the host's clock, so that the intervals
  between frames stay the adapter's (the rates and the 10 ms slots need those, not the
  reading's jitter). No adapter's clock is better than the host's (socketcan's *is* the host
  kernel's), so the host's is the reference. A frame is read after it arrived: its time may
  lag the host's by the reading's backlog (``behind_ns``, 60 s: far more than the kernel's
  queue holds), never lead it by more than the clocks' disagreement (``ahead_ns``, 1 s).
  Beyond either, at the first frame, the interface's clock is not UTC. Later, beyond either
  for ``confirm_ns`` (1 s) of the interface's time, its clock has restarted or stepped (an
  adapter reset, a counter wrap): the offset then moves by the step (counted in
  :attr:`BusClock.steps`; the frames of that second are given the host's reading time). A
  disagreement that ends sooner is the *host's* clock
  stepping (NTP, or an operator, setting it) while frames stamped before the step were still
  queued: socketcan's stamps are the host kernel's, so the frames after it agree again, and
  moving the offset for the few queued ones would have put every later frame off UTC by the
  step (the queued ones are given the host's reading time too, on its new time). Between steps, a relative clock's
  offset follows the host's at most ``slew`` (100
  ppm) of the time elapsed, about an adapter crystal's drift, so intervals change by no more
  than that; a clock taken as UTC is left as it is.

Pure: no python-can here; the caller passes both clocks.
"""

from __future__ import annotations

from dataclasses import dataclass

from steer_monitor.params import TIMESTAMP_MODES

__all__ = ['TIMESTAMP_MODES', 'BusClock']


@dataclass
class BusClock:
    """One bus opening's mapping (see the module docstring). ``relative``: None before the
    first frame, then whether the interface's times are taken as a clock of their own and
    put on the host's (always False in the ``bus`` and ``host`` modes)."""

    mode: str = 'auto'
    ahead_ns: int = 1_000_000_000
    behind_ns: int = 60_000_000_000
    slew: float = 1e-4
    confirm_ns: int = 1_000_000_000
    offset_ns: int = 0
    relative: bool | None = None
    steps: int = 0
    _last_bus_ns: int | None = None
    #: (interface time, lag) of the first frame of a disagreement not yet confirmed
    _suspect: tuple[int, int] | None = None

    def __post_init__(self) -> None:
        if self.mode not in TIMESTAMP_MODES:
            msg = f'timestamps mode {self.mode!r}: expected one of {", ".join(TIMESTAMP_MODES)}'
            raise ValueError(msg)

    def __call__(self, bus_ns: int, host_ns: int) -> int:
        """The data time [ns] of a frame the interface stamped ``bus_ns``, read at host time
        ``host_ns`` (both integer nanoseconds)."""
        if self.mode != 'auto':
            self.relative = False
            return bus_ns if self.mode == 'bus' else host_ns
        lag = host_ns - (bus_ns + self.offset_ns)          # > 0: the mapped time is behind the host's
        if self.relative is None:
            self.relative = not -self.ahead_ns <= lag <= self.behind_ns
            self.offset_ns = lag if self.relative else 0
        elif not -self.ahead_ns <= lag <= self.behind_ns:
            suspect = self._suspect
            if suspect is None or abs(lag - suspect[1]) > self.ahead_ns:
                self._suspect = (bus_ns, lag)             # a disagreement starts (or another one)
            elif bus_ns - suspect[0] >= self.confirm_ns:
                self.offset_ns += lag                     # it lasted: the interface's clock stepped
                self.steps += 1
                self.relative = True
                self._suspect = None
            if self._suspect is not None:
                # meanwhile the reading's time: right for either cause (the host's clock is the
                # reference), where the old offset would put an adapter's restarted clock hours
                # back for that second, which the pipeline would take for the clock set back
                self._last_bus_ns = bus_ns
                return host_ns
        else:
            self._suspect = None                          # a passing one: the host's clock stepped
            if self.relative and self._last_bus_ns is not None:
                room = int(self.slew * max(bus_ns - self._last_bus_ns, 0))
                self.offset_ns += max(-room, min(room, lag))
        self._last_bus_ns = bus_ns
        return bus_ns + self.offset_ns
