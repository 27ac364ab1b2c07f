"""Play simulated frames onto a python-can bus in (scaled) real time.

This is the simulator's own bus handle, not the monitor's: the simulated sensors transmit.
"""

from __future__ import annotations

import threading
import time
from typing import Any

from steer_monitor.can.bus import BusError, message_from_frame
from steer_monitor.can.frames import FrameArrays

__all__ = ['play']


def play(frames: FrameArrays, bus: Any, speed_factor: float = 1.0,
         stop: threading.Event | None = None) -> int:
    """Send ``frames`` on ``bus`` paced at ``speed_factor`` x real time (0: as fast as
    possible). Stops early when ``stop`` is set. Returns frames sent."""
    import can

    if len(frames) == 0:
        return 0
    t0_sim = int(frames.t_ns[0])
    t0 = time.monotonic()
    sent = 0
    for i in range(len(frames)):  # one at a time: a long run does not hold every frame as an object
        frame = frames.frame(i)
        if stop is not None and stop.is_set():
            break
        if speed_factor > 0:
            due = t0 + (frame.t_ns - t0_sim) / 1e9 / speed_factor
            delay = due - time.monotonic()
            if delay > 0:
                if stop is not None:
                    if stop.wait(delay):
                        break
                else:
                    time.sleep(delay)
        try:
            bus.send(message_from_frame(frame))
        except can.CanError as exc:
            msg = f'simulator cannot send on the bus: {exc}'
            raise BusError(msg) from exc
        sent += 1
    return sent
