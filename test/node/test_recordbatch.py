"""The raw frames' batches for the recorder: handed over full, old or when the bus is quiet,
split where the data time went back, nothing lost."""

from __future__ import annotations

from steer_monitor.can.frames import Frame
from steer_monitor.node.recordbatch import RecordBatches


class Recorder:
    def __init__(self) -> None:
        self.files: list[list[int]] = [[]]
        self.entries = 0

    def write_frames(self, frames):
        self.entries += 1
        self.files[-1] += [f.t_ns for f in frames]

    def split(self):
        self.files.append([])


def _frames(a, b):
    return [Frame(t, 0x100, b'') for t in range(a, b)]


def test_batches_are_handed_over_full_old_or_when_quiet():
    rec = Recorder()
    b = RecordBatches(rec, max_frames=10, max_age_ns=1000)
    b.add(_frames(0, 4), 0)
    b.hand_over_if_due(False, 10)
    assert rec.entries == 0                        # neither full nor old
    b.add(_frames(4, 12), 20)
    b.hand_over_if_due(False, 20)
    assert rec.entries == 1 and rec.files == [list(range(12))]     # full
    b.add(_frames(12, 13), 30)
    b.hand_over_if_due(False, 1029)
    assert rec.entries == 1
    b.hand_over_if_due(False, 1030)                # old: 1,000 ns after its first frame came
    assert rec.entries == 2
    b.add(_frames(13, 14), 2000)
    b.hand_over_if_due(True, 2001)                 # the bus went quiet
    assert rec.files == [list(range(14))]
    b.close()
    b.close()
    assert rec.entries == 3


def test_a_split_puts_the_frames_before_it_in_one_file_and_the_rest_in_the_next():
    rec = Recorder()
    b = RecordBatches(rec, max_frames=100, max_age_ns=10**9)
    b.add(_frames(0, 5), 0)
    cut = b.add(_frames(5, 12), 10)                # a read whose third frame confirmed the step
    assert cut == 5
    b.split(cut + 3, 10)
    b.add(_frames(12, 15), 20)
    b.close()
    assert rec.files == [list(range(8)), list(range(8, 15))]
