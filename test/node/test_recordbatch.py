"""The raw frames' and the published messages' batches for the recorder: handed over full, old
or when the bus is quiet, split where the data time went back, nothing lost."""

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

    def write_messages(self, messages):
        self.entries += 1
        self.files[-1] += [topic for topic, _, _ in messages]

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


def test_messages_go_with_the_frames_held_and_alone_when_no_frame_is():
    rec = Recorder()
    b = RecordBatches(rec, max_frames=10, max_age_ns=1000)
    b.add_message('/a', b'x', 5, 100)              # the first of a batch: its age counts from here
    b.add(_frames(0, 2), 200)
    b.hand_over_if_due(False, 1099)
    assert rec.entries == 0
    b.hand_over_if_due(False, 1100)
    assert rec.files == [[0, 1, '/a']] and rec.entries == 2      # the frames, then the messages
    b.add_message('/b', b'y', 6, 2000)
    b.hand_over_if_due(True, 2001)                 # quiet: the message alone
    assert rec.files == [[0, 1, '/a', '/b']] and rec.entries == 3
    b.hand_over_if_due(True, 2002)                 # nothing held: nothing handed over
    assert rec.entries == 3


def test_a_split_ends_the_file_with_the_messages_published_before_it():
    rec = Recorder()
    b = RecordBatches(rec, max_frames=100, max_age_ns=10**9)
    cut = b.add(_frames(0, 6), 0)
    b.add_message('/old', b'', 3, 0)               # the old time's last state
    b.split(cut + 4, 10)
    b.add_message('/new', b'', 1, 10)              # the new monitor's first
    b.close()
    b.close()
    assert rec.files == [[0, 1, 2, 3, '/old'], [4, 5, '/new']]
