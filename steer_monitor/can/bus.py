"""The live bus: python-can behind a handle that cannot transmit, and a reader that
reopens a failed bus with backoff.

The monitor only listens. :class:`ListenOnlyBus` has no working ``send``: it raises
:class:`ListenOnlyError` and counts the attempt, so a test can prove no frame left. It puts
the frames' times on the host's clock where the interface's are not UTC
(:mod:`~steer_monitor.can.busclock`).
"""

from __future__ import annotations

import dataclasses
import threading
import time
from collections.abc import Callable, Iterator
from typing import Any

from steer_monitor.can.busclock import BusClock
from steer_monitor.can.frames import Frame
from steer_monitor.can.rejects import RejectCounter
from steer_monitor.errors import SteerMonitorError

__all__ = ['MAX_BATCH', 'BusError', 'BusReader', 'ListenOnlyBus', 'ListenOnlyError', 'frame_from_message',
           'message_from_frame', 'socketcan_listen_only', 'transmit_refusal']

#: frames given as one list at most: a queue that filled while the reader was held up (a
#: full bus at 2,000 frames/s for two seconds) comes in lists of this many, so the monitor's
#: outputs are published as it goes, not after the whole backlog
MAX_BATCH = 4096


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


#: python-can interfaces whose constructor takes a listen-only (silent) option, and how
_SILENT_KWARGS: dict[str, dict[str, Any]] = {
    'slcan': {'listen_only': True},
    'vector': {'listen_only': True},
    'nixnet': {'listen_only': True},
    'kvaser': {'driver_mode': False},        # canlib.DRIVER_MODE_SILENT
}


def _link_info(channel: str) -> dict[str, Any] | None:
    """``linkinfo`` of a network link from ``ip -details -json link show`` (None: no ``ip``,
    no such link, or no answer)."""
    import json
    import shutil
    import subprocess
    ip = shutil.which('ip')
    if ip is None:
        return None
    try:
        done = subprocess.run([ip, '-details', '-json', 'link', 'show', 'dev', channel], capture_output=True,
                              text=True, timeout=2.0, check=False)
        info = json.loads(done.stdout)[0].get('linkinfo')
    except (OSError, subprocess.SubprocessError, ValueError, LookupError, TypeError, AttributeError):
        return None
    return info if isinstance(info, dict) else None


def socketcan_listen_only(channel: str) -> bool | None:
    """Whether a socketcan link is in listen-only mode (``ip link set CH type can listen-only
    on``); None when it cannot be told or the link has no CAN controller (vcan)."""
    info = _link_info(channel)
    if info is None or info.get('info_kind') != 'can':
        return None
    return 'LISTEN-ONLY' in (info.get('info_data') or {}).get('ctrlmode', [])


def transmit_refusal(interface: str, channel: str) -> str | None:
    """Why frames may not be sent onto ``interface:channel`` without the user saying it is
    meant (None: a bus no vessel hears: python-can's ``virtual``, or a socketcan link whose
    kind the kernel reports as ``vcan``)."""
    if interface == 'virtual':
        return None
    if interface == 'socketcan':
        info = _link_info(channel)
        if info is not None and info.get('info_kind') == 'vcan':
            return None
        kind = 'cannot be read' if info is None else f"is {info.get('info_kind') or 'not a virtual link'}"
        return f'socketcan:{channel} is not known to be a vcan link (its kind {kind})'
    return f'{interface}:{channel} is a hardware interface'


class ListenOnlyBus:
    """A python-can bus the monitor can only read from. Context manager; close is idempotent.

    Besides refusing ``send``, it asks the interface to keep the controller silent (no
    acknowledgements, no error frames) where python-can offers that: the ``listen_only`` or
    ``driver_mode`` option (slcan, vector, nixnet, kvaser), the passive state (pcan, systec).
    socketcan sets it on the link, outside the program; it is read back. ``silent`` says
    what holds: True (the controller is silent), False (it is not: it acknowledges frames),
    None (cannot be told, or no controller: virtual, vcan); ``silent_how`` says how in words.
    """

    def __init__(self, interface: str, channel: str, bitrate: int | None = None, timestamps: str = 'auto',
                 **kwargs: Any) -> None:
        import can
        self.interface = interface
        self.channel = channel
        self.send_attempts = 0
        #: the frames' times onto the host's clock where the interface's are not UTC
        #: (:mod:`~steer_monitor.can.busclock`; ``timestamps``: auto, bus or host)
        self.clock = BusClock(timestamps)
        options: dict[str, Any] = dict(kwargs)
        if bitrate is not None and interface not in ('virtual', 'socketcan'):
            options['bitrate'] = bitrate  # socketcan takes the bit rate from the link
        silent_kwargs = _SILENT_KWARGS.get(interface, {})
        if interface == 'systec':
            silent_kwargs = {'state': can.BusState.PASSIVE}
        try:
            self._bus = can.Bus(interface=interface, channel=channel, receive_own_messages=False,
                                **options, **silent_kwargs)
        except (can.CanError, OSError, ValueError, ImportError, NotImplementedError, TypeError) as exc:
            msg = f'cannot open CAN bus {interface}:{channel}: {exc}'
            raise BusError(msg) from exc
        self._closed = False
        self.silent: bool | None = None
        if silent_kwargs:
            self.silent, self.silent_how = True, f'listen-only asked of the {interface} interface'
        elif interface == 'pcan':
            try:
                self._bus.state = can.BusState.PASSIVE
                self.silent, self.silent_how = True, 'pcan set to listen-only (passive)'
            except (can.CanError, NotImplementedError, OSError) as exc:
                self.silent, self.silent_how = False, f'pcan refused listen-only: {exc}'
        elif interface == 'socketcan':
            self.silent = socketcan_listen_only(channel)
            self.silent_how = {True: f'{channel} is listen-only (set on the link)',
                               False: f'{channel} is NOT listen-only: its controller acknowledges frames '
                                      f'(ip link set {channel} type can listen-only on)',
                               None: f'{channel}: no CAN controller, or its mode cannot be read'}[self.silent]
        else:
            self.silent_how = f'{interface}: no controller or no listen-only option in python-can'

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
        if msg_ is None:
            return None
        frame = frame_from_message(msg_, self.channel)
        t_ns = self.clock(frame.t_ns, time.time_ns())
        return frame if t_ns == frame.t_ns else dataclasses.replace(frame, t_ns=t_ns)

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

    Frames come in lists (:meth:`batches`): with ``batch`` > 0 [s], a busy bus is read every
    ``batch`` seconds: after a frame, whatever has arrived is taken without waiting, then the
    reader pauses ``batch`` seconds and takes what came meanwhile, until a pause brings nothing;
    then it blocks on the bus again. Frames wait in the interface's receive queue (the kernel's
    socket buffer on socketcan) for at most about ``batch``: on a bus at 2,000 frames/s the
    reader wakes ~1/``batch`` times a second instead of once a frame, and the monitor takes
    each list as one run (most of a frame's cost in Python is per call). 0: no pause, each
    wake-up's frames a list.
    """

    def __init__(self, opener: Callable[[], ListenOnlyBus], rejects: RejectCounter,
                 backoff_initial: float = 0.5, backoff_max: float = 10.0,
                 poll: float = 0.2, sleep: Callable[[float], Any] | None = None, batch: float = 0.0,
                 on_open: Callable[[ListenOnlyBus], None] | None = None,
                 on_error: Callable[[str | None], None] | None = None) -> None:
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
        self._on_open = on_open          # hears each bus opened (e.g. to report its listen-only mode)
        self._on_error = on_error        # hears a failure unlike the one before it, None when the bus is back
        self._reported = ''              # the failure last told to on_error since the bus was last open
        self.bus: ListenOnlyBus | None = None
        self.last_error = ''

    def _failed(self, exc: BusError, backoff: float, stop: threading.Event) -> float:
        """Count a failure, tell ``on_error`` unless it is the one told last (a bus that stays
        down is told once, not every backoff), wait ``backoff``; the next backoff."""
        text = str(exc)
        self.last_error = text
        self.rejects.add('bus_error', text)
        if self._on_error is not None and text != self._reported:
            self._on_error(text)
        self._reported = text
        self._wait(backoff, stop)
        return min(backoff * 2, self.backoff_max)

    def _wait(self, seconds: float, stop: threading.Event) -> None:
        if self._sleep is not None:
            self._sleep(seconds)
        else:
            stop.wait(seconds)

    def batches(self, stop: threading.Event) -> Iterator[list[Frame]]:
        """What the bus holds, as lists of frames in the order received, until ``stop`` is
        set: after a frame, whatever has arrived is taken without waiting and given as one
        list (at most :data:`MAX_BATCH` frames); then, with ``batch`` > 0, the reader pauses
        ``batch`` seconds and takes what came meanwhile, until a pause brings nothing and it
        blocks on the bus again. An empty list after each ``poll`` seconds without a frame,
        so the caller can do time-based work while the bus is quiet."""
        backoff = self.backoff_initial
        failed = False
        draining = False       # a pause came after frames: take what is there without waiting
        try:
            while not stop.is_set():
                if self.bus is None:
                    try:
                        self.bus = self._opener()
                    except BusError as exc:
                        failed = True
                        backoff = self._failed(exc, backoff, stop)
                        continue
                    if self._on_open is not None:
                        self._on_open(self.bus)
                    if failed:
                        self.rejects.add('bus_reopen', f'{self.bus.interface}:{self.bus.channel}')
                        failed = False
                        self._reported = ''
                        if self._on_error is not None:
                            self._on_error(None)
                    backoff = self.backoff_initial
                got: list[Frame] = []
                try:
                    frame = self.bus.recv(0.0 if draining else self.poll)
                    while frame is not None:
                        got.append(frame)
                        if len(got) >= MAX_BATCH:
                            break
                        frame = self.bus.recv(0.0)
                except BusError as exc:
                    self.bus.close()
                    self.bus = None
                    failed = True
                    draining = False
                    if got:
                        yield got          # what was read before the failure is not lost
                        if stop.is_set():
                            break
                    backoff = self._failed(exc, backoff, stop)
                    continue
                if got:
                    yield got
                    if len(got) < MAX_BATCH and self.batch > 0:
                        self._wait(self.batch, stop)      # the queue is empty: let the next batch gather
                    draining = self.batch > 0
                elif draining:             # a pause brought nothing: wait on the bus again
                    draining = False
                else:
                    yield got
        finally:
            self.close()

    def close(self) -> None:
        if self.bus is not None:
            self.bus.close()
            self.bus = None
