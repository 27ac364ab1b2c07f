"""The raw frames and the published messages on their way to the recorder, in batches. Pure
of ROS.

Each read of the bus is recorded, and each state or diagnostic the reader thread publishes,
but one queue entry per read or per message would cost the recorder's thread a wake-up and
a record built alone every few milliseconds: they are gathered and handed over at most
:data:`RECORD_BATCH` frames at a time or :data:`RECORD_BATCH_NS` after the first of a batch
came, and whatever is held when the bus goes quiet; the frames and the messages as one entry
each, the records of each packed at once. Where the data time goes back (the monitor starts
again), what came before the step ends the current file and the rest begins the next
(:meth:`RecordBatches.split`).
"""

from __future__ import annotations

from typing import Protocol

from steer_monitor.can.frames import Frame

__all__ = ['RECORD_BATCH', 'RECORD_BATCH_NS', 'FrameRecorder', 'RecordBatches']

RECORD_BATCH = 256
RECORD_BATCH_NS = 50_000_000


class FrameRecorder(Protocol):
    """What the batches need of a recorder (:class:`~steer_monitor.record.recorder.Recorder`)."""

    def write_frames(self, frames: list[Frame]) -> None: ...

    def write_messages(self, messages: list[tuple[str, bytes, int]]) -> None: ...

    def split(self) -> None: ...


class RecordBatches:
    """Frames and messages gathered for ``recorder`` (see the module). Not thread-safe: the
    reader thread's (a message published on another thread goes to the recorder itself)."""

    def __init__(self, recorder: FrameRecorder, max_frames: int = RECORD_BATCH,
                 max_age_ns: int = RECORD_BATCH_NS) -> None:
        self.recorder = recorder
        self.max_frames, self.max_age_ns = max_frames, max_age_ns
        self._held: list[Frame] = []
        self._messages: list[tuple[str, bytes, int]] = []
        self._since = 0

    def add(self, frames: list[Frame], now_ns: int) -> int:
        """A read's frames, received at ``now_ns`` (monotonic [ns]); returns where they begin
        among those held (for :meth:`split`)."""
        cut = len(self._held)
        if frames:
            if not self._held and not self._messages:
                self._since = now_ns
            self._held += frames
        return cut

    def add_message(self, topic: str, cdr: bytes, log_time_ns: int, now_ns: int) -> None:
        """A message published (its topic, CDR, log time [ns]) at ``now_ns`` (monotonic [ns])."""
        if not self._held and not self._messages:
            self._since = now_ns
        self._messages.append((topic, cdr, log_time_ns))

    def _hand_over(self, frames: list[Frame]) -> None:
        if frames:
            self.recorder.write_frames(frames)
        if self._messages:
            self.recorder.write_messages(self._messages)
            self._messages = []

    def split(self, upto: int, now_ns: int) -> None:
        """The first ``upto`` frames held and every message end the current file; the rest
        of the frames begin the next."""
        self._hand_over(self._held[:upto])
        self.recorder.split()
        self._held, self._since = self._held[upto:], now_ns

    def hand_over_if_due(self, quiet: bool, now_ns: int) -> None:
        """Hand what is held over when the batch is full, old enough, or the bus ``quiet``."""
        held = self._held
        if (held or self._messages) and (quiet or len(held) >= self.max_frames
                                         or now_ns - self._since >= self.max_age_ns):
            self._hand_over(held)
            self._held = []

    def close(self) -> None:
        """Hand over what is held. Idempotent."""
        self._hand_over(self._held)
        self._held = []
