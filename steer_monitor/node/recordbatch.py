"""The raw frames on their way to the recorder, in batches. Pure of ROS.

Each read of the bus is recorded, but one queue entry per read would cost the recorder's
thread a wake-up every few milliseconds: frames are gathered and handed over at most
:data:`RECORD_BATCH` at a time or :data:`RECORD_BATCH_NS` after the first of a batch came,
and whatever is held when the bus goes quiet. Where the data time goes back (the monitor
starts again), the frames before the step end the current file and the rest begin the next
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

    def split(self) -> None: ...


class RecordBatches:
    """Frames gathered for ``recorder`` (see the module). Not thread-safe: the reader thread's."""

    def __init__(self, recorder: FrameRecorder, max_frames: int = RECORD_BATCH,
                 max_age_ns: int = RECORD_BATCH_NS) -> None:
        self.recorder = recorder
        self.max_frames, self.max_age_ns = max_frames, max_age_ns
        self._held: list[Frame] = []
        self._since = 0

    def add(self, frames: list[Frame], now_ns: int) -> int:
        """A read's frames, received at ``now_ns`` (monotonic [ns]); returns where they begin
        among those held (for :meth:`split`)."""
        cut = len(self._held)
        if frames:
            if not self._held:
                self._since = now_ns
            self._held += frames
        return cut

    def split(self, upto: int, now_ns: int) -> None:
        """The first ``upto`` frames held end the current file; the rest begin the next."""
        self.recorder.write_frames(self._held[:upto])
        self.recorder.split()
        self._held, self._since = self._held[upto:], now_ns

    def hand_over_if_due(self, quiet: bool, now_ns: int) -> None:
        """Hand what is held over when the batch is full, old enough, or the bus ``quiet``."""
        held = self._held
        if held and (quiet or len(held) >= self.max_frames or now_ns - self._since >= self.max_age_ns):
            self.recorder.write_frames(held)
            self._held = []

    def close(self) -> None:
        """Hand over what is held. Idempotent."""
        if self._held:
            self.recorder.write_frames(self._held)
            self._held = []
