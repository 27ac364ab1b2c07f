"""The live bus: python-can behind a handle that cannot transmit, and a reader that
reopens a failed bus with backoff.

The monitor only listens. :class:`ListenOnlyBus` has no working ``send``: it raises
:class:`ListenOnlyError` and counts the attempt, so a test can prove no frame left.
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Iterator
from typing import Any

from steer_monitor.can.frames import Frame
from steer_monitor.can.rejects import RejectCounter
from steer_monitor.errors import SteerMonitorError

__all__ = ['BusError', 'BusReader', 'ListenOnlyBus', 'ListenOnlyError', 'frame_from_message',
           'message_from_frame']


class BusError(SteerMonitorError):
    """The CAN bus cannot be opened or read."""


class ListenOnlyError(SteerMonitorError):
    """Something asked the monitor's bus handle to transmit."""


def frame_from_message(msg: Any, channel: str = '') -> Frame:
    """python-can Message -> Frame; float seconds are kept to the microsecond."""
    ts = msg.timestamp or 0.0
    return Frame(t_ns=round(ts * 1e6) * 1000, can_id=int(msg.arbitration_id), data=bytes(msg.data),
                 is_extended=bool(msg.is_extended_id), is_error=bool(msg.is_error_frame),
                 is_remote=bool(msg.is_remote_frame),
                 channel=str(msg.channel) if msg.channel is not None else channel)


def message_from_frame(frame: Frame) -> Any:
    """Frame -> python-can Message (for writers and the simulator's own bus)."""
    import can
    return can.Message(timestamp=frame.t_ns / 1e9, arbitration_id=frame.can_id,
                       is_extended_id=frame.is_extended, is_error_frame=frame.is_error,
                       is_remote_frame=frame.is_remote, dlc=len(frame.data), data=frame.data,
                       channel=frame.channel or None)


class ListenOnlyBus:
    """A python-can bus the monitor can only read from. Context manager; close is idempotent."""

    def __init__(self, interface: str, channel: str, bitrate: int | None = None, **kwargs: Any) -> None:
        import can
        self.interface = interface
        self.channel = channel
        self.send_attempts = 0
        options: dict[str, Any] = dict(kwargs)
        if bitrate is not None and interface not in ('virtual', 'socketcan'):
            options['bitrate'] = bitrate  # socketcan takes the bit rate from the link
        try:
            self._bus = can.Bus(interface=interface, channel=channel, receive_own_messages=False, **options)
        except (can.CanError, OSError, ValueError, ImportError, NotImplementedError) as exc:
            msg = f'cannot open CAN bus {interface}:{channel}: {exc}'
            raise BusError(msg) from exc
        self._closed = False

    def send(self, *args: Any, **kwargs: Any) -> None:
        """Refuse: the monitor never transmits on the steering bus."""
        self.send_attempts += 1
        msg = (f'steer_monitor only listens on {self.interface}:{self.channel}; '
               'it never transmits on the steering bus')
        raise ListenOnlyError(msg)

    def recv(self, timeout: float | None = None) -> Frame | None:
        """The next frame, or None after ``timeout`` seconds. Bus failures raise BusError."""
        import can
        if self._closed:
            msg = f'CAN bus {self.interface}:{self.channel} is closed'
            raise BusError(msg)
        try:
            msg_ = self._bus.recv(timeout)
        except (can.CanError, OSError, ValueError) as exc:
            msg = f'CAN bus {self.interface}:{self.channel} failed: {exc}'
            raise BusError(msg) from exc
        return None if msg_ is None else frame_from_message(msg_, self.channel)

    def close(self) -> None:
        if not self._closed:
            self._closed = True
            self._bus.shutdown()

    @property
    def closed(self) -> bool:
        return self._closed

    def __enter__(self) -> ListenOnlyBus:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


class BusReader:
    """Frames from a bus that may fail: on an error it counts ``bus_error``, closes, waits
    (backoff doubling from ``backoff_initial`` to ``backoff_max`` seconds), reopens and counts
    ``bus_reopen``. Runs until ``stop`` is set.

    With ``batch`` > 0 [s], a busy bus is read in batches: after a frame, whatever has
    arrived is taken without waiting, then the reader pauses ``batch`` seconds and takes what
    came meanwhile, until a pause brings nothing; then it blocks on the bus again. Frames wait
    in the interface's receive queue (the kernel's socket buffer on socketcan) for at most
    about ``batch``: on a bus at 2,000 frames/s the reader wakes ~1/``batch`` times a second
    instead of once a frame, which is most of a frame's cost in Python. 0: wake for each frame.
    """

    def __init__(self, opener: Callable[[], ListenOnlyBus], rejects: RejectCounter,
                 backoff_initial: float = 0.5, backoff_max: float = 10.0,
                 poll: float = 0.2, sleep: Callable[[float], Any] | None = None, batch: float = 0.0) -> None:
        if not (0.0 <= batch < poll):
            msg = f'read batch {batch:g} s must be at least 0 and shorter than the poll of {poll:g} s'
            raise ValueError(msg)
        self._opener = opener
        self.rejects = rejects
        self.backoff_initial = backoff_initial
        self.backoff_max = backoff_max
        self.poll = poll
        self.batch = batch
        self._sleep = sleep
        self.bus: ListenOnlyBus | None = None
        self.last_error = ''

    def _wait(self, seconds: float, stop: threading.Event) -> None:
        if self._sleep is not None:
            self._sleep(seconds)
        else:
            stop.wait(seconds)

    def frames(self, stop: threading.Event, idle: bool = False) -> Iterator[Frame | None]:
        """Frames until ``stop`` is set. With ``idle``, also yields None after each ``poll``
        seconds without a frame, so the caller can do time-based work while the bus is quiet."""
        backoff = self.backoff_initial
        failed = False
        draining = False       # batched reading: take what is there without waiting
        got = False            # ... and a frame came since the last pause
        try:
            while not stop.is_set():
                if self.bus is None:
                    try:
                        self.bus = self._opener()
                    except BusError as exc:
                        self.last_error = str(exc)
                        self.rejects.add('bus_error', str(exc))
                        failed = True
                        self._wait(backoff, stop)
                        backoff = min(backoff * 2, self.backoff_max)
                        continue
                    if failed:
                        self.rejects.add('bus_reopen', f'{self.bus.interface}:{self.bus.channel}')
                        failed = False
                    backoff = self.backoff_initial
                try:
                    frame = self.bus.recv(0.0 if draining else self.poll)
                except BusError as exc:
                    self.last_error = str(exc)
                    self.rejects.add('bus_error', str(exc))
                    self.bus.close()
                    self.bus = None
                    failed = True
                    draining = False
                    self._wait(backoff, stop)
                    backoff = min(backoff * 2, self.backoff_max)
                    continue
                if frame is not None:
                    draining = got = self.batch > 0
                    yield frame
                elif draining:
                    if got:                # the queue is empty: let the next batch gather
                        got = False
                        self._wait(self.batch, stop)
                    else:                  # a pause brought nothing: wait on the bus again
                        draining = False
                elif idle:
                    yield None
        finally:
            self.close()

    def close(self) -> None:
        if self.bus is not None:
            self.bus.close()
            self.bus = None
