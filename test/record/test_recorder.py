"""The MCAP recorder: ROS 2 profile, rotation, disk errors, SIGKILL and recover."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from steer_monitor.can import Frame, make_id
from steer_monitor.logfiles.mcapio import FRAME_TOPIC
from steer_monitor.record import Recorder, RecoverError, msgdef, recover
from test.conftest import fill

T0 = 1_767_225_600_000_000_000
DIAG = 'diagnostic_msgs/msg/DiagnosticArray'


def _diag_cdr(i: int) -> bytes:
    from mcap_ros2._dynamic import serialize_dynamic
    enc = serialize_dynamic(DIAG, msgdef(DIAG))[DIAG]
    return enc({'header': {'stamp': {'sec': i, 'nanosec': 0}, 'frame_id': ''},
                'status': [{'level': 1, 'name': 'steer_monitor: test', 'message': f'm{i}',
                            'hardware_id': 'hw', 'values': [{'key': 'k_mm', 'value': str(i)}]}]})


def _frame(i: int) -> Frame:
    return Frame(T0 + i * 1_000_000, make_id(2, 127245, 0x10), bytes([i % 256, 0, 1, 2, 3, 4, 255, 255]))


def _read_all(path: Path) -> dict[str, list]:
    from rosbags.highlevel import AnyReader
    out: dict[str, list] = {}
    with AnyReader([path]) as r:
        for conn, t, raw in r.messages():
            out.setdefault(conn.topic, []).append((t, r.deserialize(raw, conn.msgtype)))
    return out


def test_round_trip_read_by_rosbags_and_mcap(tmp_path):
    from mcap.reader import make_reader
    with Recorder(tmp_path) as rec:
        rec.add_topic('/diagnostics', DIAG, msgdef(DIAG))
        for i in range(500):
            rec.write_frame(_frame(i))
            if i % 50 == 0:
                rec.write('/diagnostics', _diag_cdr(i), T0 + i * 1_000_000)
    [path] = rec.files
    assert path.name == 'steer_monitor_20260101T000000Z_001.mcap'
    got = _read_all(path)
    assert len(got[FRAME_TOPIC]) == 500 and len(got['/diagnostics']) == 10
    assert got['/diagnostics'][3][1].status[0].values[0].value == '150'
    assert bytes(got[FRAME_TOPIC][7][1].data)[:1] == b'\x07'
    with open(path, 'rb') as fh:
        reader = make_reader(fh, validate_crcs=True)
        assert sum(1 for _ in reader.iter_messages()) == 510
        summary = reader.get_summary()
        header = reader.get_header()
    assert header.profile == 'ros2'
    assert {s.encoding for s in summary.schemas.values()} == {'ros2msg'}
    assert {c.message_encoding for c in summary.channels.values()} == {'cdr'}
    assert all('offered_qos_profiles' in c.metadata for c in summary.channels.values())
    assert {ci.compression for ci in summary.chunk_indexes} == {'zstd'}
    st = rec.status()
    assert st.ok and st.messages == 510 and st.dropped == 0


def test_frame_batches_are_recorded_and_counted(tmp_path):
    from mcap.reader import make_reader
    frames = [_frame(i) for i in range(1000)]
    with Recorder(tmp_path) as rec:
        for i in range(0, 1000, 256):
            rec.write_frames(frames[i:i + 256])
        rec.write_frames([])
        rec.write_frame(_frame(1000))
    [path] = rec.files
    with open(path, 'rb') as fh:
        got = [m.log_time for _, _, m in make_reader(fh, validate_crcs=True).iter_messages()]
    assert got == [f.t_ns for f in frames] + [_frame(1000).t_ns]
    st = rec.status()
    assert st.ok and st.messages == 1001 and st.failed == 0 and st.dropped == 0


def test_message_batches_are_recorded_read_by_rosbags_and_counted(tmp_path):
    """A batch of messages on two topics, the first of a file: their schemas and channels
    declared there; a topic never declared is refused by name."""
    with Recorder(tmp_path) as rec:
        rec.add_topic('/diagnostics', DIAG, msgdef(DIAG))
        rec.add_topic('/other', DIAG, msgdef(DIAG))
        rec.write_messages([('/diagnostics' if i % 3 else '/other', _diag_cdr(i), T0 + i) for i in range(30)])
        rec.write_messages([])
        rec.write_frames([_frame(0)])
        rec.write_messages([('/diagnostics', _diag_cdr(30), T0 + 30)])
    [path] = rec.files
    got = _read_all(path)
    assert [m.status[0].message for _, m in got['/diagnostics']] == [f'm{i}' for i in range(1, 30) if i % 3] + ['m30']
    assert [t for t, _ in got['/other']] == [T0 + i for i in range(0, 30, 3)]
    st = rec.status()
    assert st.ok and st.messages == 32 and st.failed == 0 and st.dropped == 0
    with Recorder(tmp_path / 'b') as rec:
        with pytest.raises(KeyError, match='topic /nowhere was not declared with add_topic'):
            rec.write_messages([('/nowhere', b'', T0)])
        with pytest.raises(KeyError, match='topic /nowhere was not declared'):
            rec.write('/nowhere', b'', T0)
        rec.write_frame(_frame(0))
    assert rec.status().messages == 1 and rec.status().failed == 0


def test_rotation_by_size_and_by_time(tmp_path):
    with Recorder(tmp_path / 'size', max_bytes=20_000, chunk_size=4096, flush_interval_s=0.0) as rec:
        for i in range(3000):
            rec.write_frame(_frame(i))
    assert len(rec.files) > 2
    assert sum(len(_read_all(p).get(FRAME_TOPIC, [])) for p in rec.files) == 3000
    clock = [0.0]
    with Recorder(tmp_path / 'time', max_seconds=10.0, clock=lambda: clock[0]) as rec2:
        for i in range(30):
            clock[0] = i * 1.0
            rec2.write_frame(_frame(i))
            time.sleep(0.002)
    assert len(rec2.files) == 3
    assert sum(len(_read_all(p)[FRAME_TOPIC]) for p in rec2.files) == 30


def _wait(cond, timeout=5.0):
    deadline = time.time() + timeout
    while not cond():
        assert time.time() < deadline, 'timed out'
        time.sleep(0.005)


def test_disk_full_is_reported_and_recording_resumes(tmp_path, monkeypatch):
    import builtins

    import steer_monitor.record.recorder as R
    opened: list[str] = []

    def first_file_on_dev_full(path, mode='r', *a, **k):      # the first file's writes fail with ENOSPC
        opened.append(str(path))
        if len(opened) == 1:
            with open(path, mode):                            # made, as on a full disk
                pass
            return builtins.open('/dev/full', 'wb')
        return builtins.open(path, mode, *a, **k)
    monkeypatch.setattr(R, 'open', first_file_on_dev_full, raising=False)
    clock = [0.0]
    told: list[str | None] = []
    rec = Recorder(tmp_path, retry_s=5.0, clock=lambda: clock[0], on_error=told.append)
    try:
        for i in range(200):
            rec.write_frame(_frame(i))
        _wait(lambda: rec.files and rec.queued == 0)
        time.sleep(0.2)  # the last batch taken is written (messages count only once flushed)
        clock[0] = 1.5   # the first flush hits the full device
        rec.write_frame(_frame(200))
        deadline = time.time() + 5
        while rec.status().ok and time.time() < deadline:
            time.sleep(0.01)
        st = rec.status()
        assert not st.ok and 'No space left on device' in st.message
        # nothing of the first file reached the device: it is removed, not left empty
        assert rec.status().files == 0 and not rec.files
        assert not Path(opened[0]).exists()
        clock[0] = 7.0   # past retry_s: a new file, but ERROR until a write reaches the disk
        for i in range(201, 260):
            rec.write_frame(_frame(i))
        _wait(lambda: rec.status().files == 1)
        assert not rec.status().ok
        clock[0] = 8.5   # the next flush succeeds
        rec.write_frame(_frame(260))
        deadline = time.time() + 5
        while not rec.status().ok and time.time() < deadline:
            time.sleep(0.01)
        assert rec.status().ok
    finally:
        rec.close()
    st = rec.status()
    assert st.failed > 0 and st.files == 1
    assert rec.files[0].name.endswith('_002.mcap')
    assert 0 < len(_read_all(rec.files[-1])[FRAME_TOPIC]) <= 60
    # told when writes began to fail and when they reached the disk again, not at each retry
    assert len(told) == 2 and 'No space left on device' in told[0] and told[1] is None, told


def test_full_tmpfs_keeps_one_file_retries_and_loses_nothing_written(small_tmpfs):
    """A real full file system: writes fail with ENOSPC; while it is full the recorder keeps
    ERROR, does not open a file per retry, its message count never falls; once space is
    freed it records again in one new file; the first file, recovered, holds every frame
    counted as written before the failure."""
    filler = small_tmpfs / 'filler.bin'
    filler.write_bytes(os.urandom(300 << 10))      # 300 KiB of the 512 taken: room for ~200 KiB
    clock = [0.0]
    rec = Recorder(small_tmpfs / 'rec', retry_s=5.0, chunk_size=16 << 10, clock=lambda: clock[0])
    seen: list[int] = []
    i = 0
    try:
        while rec.status().ok:                      # fill the disk, one flush a "second"
            for _ in range(2000):
                rec.write_frame(_frame(i))
                i += 1
            clock[0] += 1.5
            rec.write_frame(_frame(i))
            i += 1
            time.sleep(0.05)
            seen.append(rec.status().messages)
            assert i < 2_000_000, 'the disk never filled'
        written_before = rec.status().messages
        assert written_before > 0 and rec.status().files == 1
        assert 'No space left on device' in rec.status().message
        for _ in range(4):                          # retries while still full: no new file
            clock[0] += 6.0
            for _ in range(200):
                rec.write_frame(_frame(i))
                i += 1
            time.sleep(0.05)
            st = rec.status()
            seen.append(st.messages)
            assert not st.ok and st.files == 1, st
        filler.unlink()                             # space again
        clock[0] += 6.0
        for _ in range(300):
            rec.write_frame(_frame(i))
            i += 1
        _wait(lambda: rec.status().files == 2)
        clock[0] += 1.5
        rec.write_frame(_frame(i))
        i += 1
        _wait(lambda: rec.status().ok)
        seen.append(rec.status().messages)
    finally:
        rec.close()
    assert seen == sorted(seen), 'the message count fell'
    st = rec.status()
    assert st.files == 2 and st.failed > 0
    assert st.messages + st.failed + st.dropped == i
    first = recover(rec.files[0], small_tmpfs / 'first.recovered.mcap')
    assert first.messages == written_before
    assert len(_read_all(rec.files[1])[FRAME_TOPIC]) == st.messages - written_before


def test_a_disk_full_from_the_start_leaves_no_empty_file(full_tmpfs):
    """Not one chunk of the file reaches the disk: the recorder says so and removes the file
    it opened (an MCAP of no bytes that every reader refuses), and keeps no name of it."""
    clock = [0.0]
    rec = Recorder(full_tmpfs, retry_s=5.0, clock=lambda: clock[0])
    try:
        for i in range(500):
            rec.write_frame(_frame(i))
        _wait(lambda: rec.files and rec.queued == 0)
        time.sleep(0.2)  # the last batch taken is written before the clock moves
        clock[0] = 1.5   # the first flush meets the full disk
        rec.write_frame(_frame(500))
        _wait(lambda: not rec.status().ok)
    finally:
        rec.close()
    st = rec.status()
    assert 'No space left on device' in st.message
    assert st.files == 0 and st.messages == 0 and st.failed == 501
    assert sorted(p.name for p in full_tmpfs.iterdir()) == ['filler.bin']


def test_a_recording_already_there_is_never_overwritten(tmp_path):
    """A node restarted within the same second of data, or a second node with the same prefix
    in the directory: the next free number, never the file already there."""
    first = tmp_path / 'steer_monitor_20260101T000000Z_001.mcap'
    first.write_bytes(b'an earlier recording')
    with Recorder(tmp_path) as rec:
        for i in range(10):
            rec.write_frame(_frame(i))
    assert first.read_bytes() == b'an earlier recording'
    assert [p.name for p in rec.files] == ['steer_monitor_20260101T000000Z_002.mcap']
    assert len(_read_all(rec.files[0])[FRAME_TOPIC]) == 10


def test_read_only_location_is_reported_not_raised():
    rec = Recorder('/proc/steer_monitor_cannot_write_here')
    try:
        rec.write_frame(_frame(1))
        deadline = time.time() + 5
        while rec.status().ok and time.time() < deadline:
            time.sleep(0.01)
        st = rec.status()
        assert not st.ok and st.message.startswith('cannot record: ')
    finally:
        rec.close()


CHILD = r'''
import sys, time
sys.path.insert(0, {repo!r})
from steer_monitor.record import Recorder
from steer_monitor.can import Frame, make_id
rec = Recorder({dir!r}, flush_interval_s=1.0)
i = 0
while True:
    t = time.time_ns()
    rec.write_frame(Frame(t, make_id(2, 127245, 0x10), bytes(8)))
    i += 1
    if i == 50:
        print('started', flush=True)
    time.sleep(0.002)
'''


def test_sigkill_loses_at_most_the_last_second_and_recover_reads_the_rest(tmp_path):
    repo = str(Path(__file__).resolve().parents[2])
    child = subprocess.Popen([sys.executable, '-c', CHILD.format(repo=repo, dir=str(tmp_path))],
                             stdout=subprocess.PIPE, text=True)
    try:
        assert child.stdout.readline().strip() == 'started'
        time.sleep(3.3)
        killed_at = time.time_ns()
        os.kill(child.pid, signal.SIGKILL)
        child.wait(10)
    finally:
        if child.poll() is None:
            child.kill()
    [path] = list(tmp_path.glob('*.mcap'))
    result = recover(path)
    assert not result.complete and result.messages > 500
    lost_s = (killed_at - result.last_ns) / 1e9
    assert lost_s <= 1.25, f'lost {lost_s:.2f} s'
    assert len(_read_all(Path(result.output))[FRAME_TOPIC]) == result.messages


def test_recover_cli_and_errors(tmp_path, capsys):
    from steer_monitor.cli.main import main
    with Recorder(tmp_path) as rec:
        for i in range(100):
            rec.write_frame(_frame(i))
    assert main(['recover', str(rec.files[0]), '--json', '-']) == 0
    out = json.loads(capsys.readouterr().out)
    assert out['complete'] is True and out['messages'] == 100
    junk = tmp_path / 'junk.mcap'
    junk.write_bytes(b'not an mcap at all')
    with pytest.raises(RecoverError, match="junk.mcap is not an MCAP recording: it begins 'not an m', not the MCAP"):
        recover(junk)
    log = tmp_path / 'can0.log'
    log.write_text('(1772352000.008060) can0 09F10D10#00F80000FFFFFFFF\n')
    with pytest.raises(RecoverError, match=r"it begins '\(1772352' \(a candump log\?\).*read a candump log as it is"):
        recover(log)
    cut = tmp_path / 'cut.mcap'
    cut.write_bytes(rec.files[0].read_bytes()[:9])          # the magic, then the cut
    with pytest.raises(RecoverError, match=r'holds no readable MCAP records \(it ends inside a record\)'):
        recover(cut)
    assert main(['recover', str(tmp_path / 'missing.mcap')]) == 1
    assert 'cannot open' in capsys.readouterr().err


def test_every_file_says_what_it_was_made_with(tmp_path, r18_params):
    """Version, gear and the parameters as MCAP metadata in each file, also after rotation
    and after recover."""
    from mcap.reader import make_reader

    from steer_monitor.record.provenance import PARAMETERS_RECORD, RUN_RECORD, parameters_digest, run_metadata

    meta = run_metadata(r18_params, 'config/r18.yaml')
    with Recorder(tmp_path, max_bytes=20_000, chunk_size=4096, flush_interval_s=0.0, metadata=meta) as rec:
        for k in range(3000):
            rec.write_frame(_frame(k))
    assert len(rec.files) >= 2
    for path in rec.files:
        with open(path, 'rb') as fh:
            got = {m.name: m.metadata for m in make_reader(fh).iter_metadata()}
        assert got[RUN_RECORD]['gear'] == 'R-18' and got[RUN_RECORD]['parameters_sha256'] == parameters_digest(
            r18_params
        )
        assert got[RUN_RECORD]['parameters_file'] == 'config/r18.yaml'
        assert json.loads(got[PARAMETERS_RECORD]['gear.stock_to_ram_m']) == r18_params['gear.stock_to_ram_m']
    out = recover(rec.files[0], tmp_path / 'recovered.mcap')
    with open(out.output, 'rb') as fh:
        assert {m.name for m in make_reader(fh).iter_metadata()} == {RUN_RECORD, PARAMETERS_RECORD}


def _old_recordings(where: Path, sizes: list[int], prefix: str = 'steer_monitor') -> list[Path]:
    """Recordings an earlier run left, oldest first (their times a day apart, a day ago)."""
    paths = []
    for k, size in enumerate(sizes):
        p = where / f'{prefix}_2025120{k + 1}T000000Z_001.mcap'
        p.write_bytes(os.urandom(size))
        t = time.time() - 86400.0 * (len(sizes) - k + 1)
        os.utime(p, (t, t))
        paths.append(p)
    return paths


def _others(where: Path) -> list[Path]:
    """What the budget must never touch: the estimator's state, a recovered file, another
    prefix's recording, a directory named like a recording, a file named almost like one."""
    (where / 'steer_monitor_20250101T000000Z_009.mcap').mkdir()
    paths = [where / 'steer_monitor_estimator.npz', where / 'steer_monitor_20250101T000000Z_001.recovered.mcap',
             where / 'other_20250101T000000Z_001.mcap', where / 'steer_monitor_20250101T000000Z_001.mcap.bak']
    for p in paths:
        p.write_bytes(os.urandom(50_000))
        os.utime(p, (0, 0))
    return paths


def test_the_oldest_recordings_go_when_the_recordings_pass_their_total(tmp_path):
    old = _old_recordings(tmp_path, [40_000, 40_000, 40_000, 40_000])
    others = _others(tmp_path)
    told: list[tuple[Path, int, str]] = []
    with Recorder(tmp_path, max_total_bytes=150_000, chunk_size=4096, flush_interval_s=0.0,
                  on_removed=lambda *a: told.append(a)) as rec:
        for i in range(2000):
            rec.write_frame(_frame(i))
            if i % 100 == 0:
                time.sleep(0.002)          # a flush now and then, as the seconds of a node
    # opening the new file: 160 kB of old ones over 150 kB, the oldest goes; then the new file
    # (about 64 kB in the end) takes the 120 kB left over it again, and the next oldest goes
    assert [p.exists() for p in old] == [False, False, True, True]
    assert all(p.exists() for p in others)
    assert rec.status().removed == 2 == len(told)
    assert [(p, n) for p, n, _ in told] == [(old[0], 40_000), (old[1], 40_000)]
    assert all(why == 'the recordings took more than 0.00015 GB' for _, _, why in told)
    assert 30_000 < rec.files[0].stat().st_size < 70_000
    assert len(_read_all(rec.files[0])[FRAME_TOPIC]) == 2000


def test_a_recorder_rotating_over_its_budget_keeps_its_newest_files(tmp_path):
    with Recorder(tmp_path, max_bytes=20_000, max_total_bytes=60_000, chunk_size=4096, flush_interval_s=0.0) as rec:
        for i in range(6000):
            rec.write_frame(_frame(i))
    left = sorted(tmp_path.glob('*.mcap'))
    assert rec.status().removed > 0 and len(rec.files) == rec.status().removed + len(left)
    assert left == rec.files[-len(left):]                       # the newest stayed
    assert sum(p.stat().st_size for p in left[:-1]) <= 60_000   # the finished ones within the total
    frames = [m for p in left for _, m in _read_all(p)[FRAME_TOPIC]]
    assert frames[-1].data[0] == 5999 % 256                      # the last frame is there


def test_the_oldest_recordings_go_to_keep_the_disk_free_and_a_full_disk_records_again(small_tmpfs):
    """A real file system filled by earlier recordings: the recorder removes the oldest until
    the free space asked for is there, and records without an error."""
    import shutil
    old = _old_recordings(small_tmpfs, [90_000] * 5)
    fill(small_tmpfs)
    (small_tmpfs / 'filler.bin').unlink()
    others = _others_small(small_tmpfs)
    assert shutil.disk_usage(small_tmpfs).free < 110_000    # two must go for 200 kB, not three
    told: list[tuple[Path, int, str]] = []
    with Recorder(small_tmpfs, keep_free_bytes=200_000, chunk_size=4096, flush_interval_s=0.0,
                  on_removed=lambda *a: told.append(a)) as rec:
        for i in range(100):
            rec.write_frame(_frame(i))
    st = rec.status()
    assert st.ok and st.failed == 0 and st.messages == 100, st
    assert [p.exists() for p in old] == [False, False, True, True, True]
    assert all(p.exists() for p in others)
    assert [why for _, _, why in told] == ['less than 0.0002 GB was free on the disk'] * 2


def _others_small(where: Path) -> list[Path]:
    p = where / 'steer_monitor_estimator.npz'
    p.write_bytes(b'state')
    os.utime(p, (0, 0))
    return [p]


def test_without_a_budget_nothing_is_removed(small_tmpfs):
    old = _old_recordings(small_tmpfs, [90_000] * 5)
    with Recorder(small_tmpfs, chunk_size=4096, flush_interval_s=0.0) as rec:
        for i in range(100):
            rec.write_frame(_frame(i))
    assert all(p.exists() for p in old) and rec.status().removed == 0


def test_split_finishes_the_file_and_the_next_message_opens_another(tmp_path):
    with Recorder(tmp_path) as rec:
        rec.split()                                  # nothing open yet: nothing to finish
        for i in range(10):
            rec.write_frame(_frame(i))
        rec.split()
        rec.split()                                  # twice: still one new file, at the next message
        for i in range(10, 15):
            rec.write_frame(_frame(i))
    assert len(rec.files) == 2
    assert [len(_read_all(p)[FRAME_TOPIC]) for p in rec.files] == [10, 5]
    assert rec.status().messages == 15


def _mount_tmpfs(where: Path) -> None:
    done = subprocess.run(['mount', '-t', 'tmpfs', '-o', 'size=4m', 'tmpfs', str(where)], capture_output=True,
                          text=True, check=False)
    if done.returncode != 0:
        pytest.skip(f'cannot mount a tmpfs here: {done.stderr.strip() or done.returncode}')


def test_a_disk_unmounted_under_the_recorder_is_not_replaced_by_the_one_beneath(tmp_path):
    """The recording directory is on a disk of its own, which is unmounted while the node
    records (a USB disk pulled, a maintenance umount): the recorder must not make the directory
    again in the empty mount point, on the system's disk; it says where it is, and records
    again when the disk is mounted there again."""
    if os.geteuid() != 0:
        pytest.skip('mounting a tmpfs needs root; this test runs in CI as root')
    mnt = tmp_path / 'usb'
    mnt.mkdir()
    _mount_tmpfs(mnt)
    clock = [0.0]
    rec = Recorder(mnt / 'rec', retry_s=5.0, flush_interval_s=1.0, clock=lambda: clock[0])
    try:
        for i in range(100):
            rec.write_frame(_frame(i))
        _wait(lambda: rec.files and rec.queued == 0)
        time.sleep(0.2)      # the last batch taken is written before the clock moves
        clock[0] = 1.5
        rec.write_frame(_frame(100))
        _wait(lambda: rec.status().messages == 101)
        subprocess.run(['umount', '-l', str(mnt)], check=True)
        assert not (mnt / 'rec').exists()
        for step in range(4):                          # flushes and retries while it is away
            clock[0] += 6.0
            rec.write_frame(_frame(200 + step))
            _wait(lambda: not rec.status().ok)
            time.sleep(0.05)
        st = rec.status()
        assert 'is no longer on the disk mounted at' in st.message and str(mnt) in st.message, st
        assert not (mnt / 'rec').exists(), 'made again on the disk beneath the mount point'
        _mount_tmpfs(mnt)                               # back
        clock[0] += 6.0
        for i in range(300, 310):
            rec.write_frame(_frame(i))
        _wait(lambda: rec.status().files == 2)
        clock[0] += 1.5
        rec.write_frame(_frame(310))
        _wait(lambda: rec.status().ok)
    finally:
        rec.close()
        subprocess.run(['umount', '-l', str(mnt)], check=False)
    assert rec.files[1].parent == mnt / 'rec'


def test_a_recording_written_to_within_the_minute_is_not_removed_for_the_budget(tmp_path):
    """A second recorder with the same prefix in the directory: its open file (written to
    every second) is not taken for an old recording; the older ones go first, it stays."""
    old = _old_recordings(tmp_path, [40_000, 40_000])
    busy = tmp_path / 'steer_monitor_20251130T000000Z_001.mcap'    # named older, written to now
    busy.write_bytes(os.urandom(40_000))
    with Recorder(tmp_path, max_total_bytes=30_000, chunk_size=4096, flush_interval_s=0.0) as rec:
        for i in range(100):
            rec.write_frame(_frame(i))
    assert [p.exists() for p in old] == [False, False] and busy.exists()
    assert rec.status().removed == 2


def test_recover_takes_a_summary_only_when_its_crc_holds(tmp_path):
    """The summary's schemas and channels are taken before the data's only if the footer's
    CRC of it matches (mcap's reader does not check it): a flipped byte there, nothing taken."""
    import struct
    import zlib as _zlib

    from steer_monitor.record.recover import summary_definitions
    with Recorder(tmp_path, chunk_size=4096, flush_interval_s=0.0) as rec:
        for i in range(300):
            rec.write_frame(_frame(i))
    data = bytearray(rec.files[0].read_bytes())
    with open(rec.files[0], 'rb') as fh:
        assert [type(r).__name__ for r in summary_definitions(fh)] == ['Schema', 'Channel']
    start, _, crc = struct.unpack_from('<QQI', data, len(data) - 8 - 29 + 9)
    assert crc and _zlib.crc32(bytes(data[start:len(data) - 12])) == crc
    data[start + 20] ^= 0xFF                         # inside the summary's first record
    bad = tmp_path / 'bad_summary.mcap'
    bad.write_bytes(bytes(data))
    with open(bad, 'rb') as fh:
        assert summary_definitions(fh) == [] and fh.tell() == 0
