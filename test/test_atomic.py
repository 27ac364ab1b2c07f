"""Outputs written whole or not at all."""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import pytest

from steer_monitor import atomic
from steer_monitor.atomic import (
    NAME_MAX,
    STALE_AFTER_S,
    atomic_path,
    atomic_write,
    ensure_dir,
    os_reason,
    remove_stale_temporaries,
    temporary_name,
    write_bytes,
    write_files,
    write_text,
)
from steer_monitor.errors import OutputError


def test_write_replaces_whole_and_leaves_no_temporary(tmp_path):
    target = tmp_path / 'a.json'
    target.write_text('old')
    write_text(target, 'new')
    assert target.read_text() == 'new'
    write_bytes(tmp_path / 'b.png', b'\x89PNG')
    assert sorted(p.name for p in tmp_path.iterdir()) == ['a.json', 'b.png']


def test_an_error_midway_keeps_the_old_file(tmp_path):
    target = tmp_path / 'a.json'
    target.write_text('old')
    with pytest.raises(RuntimeError, match='midway'):
        with atomic_write(target) as fh:
            fh.write('half')
            raise RuntimeError('midway')
    assert target.read_text() == 'old'
    assert [p.name for p in tmp_path.iterdir()] == ['a.json']


def test_the_temporary_keeps_the_suffix(tmp_path):
    with atomic_path(tmp_path / 'x.mcap') as tmp:
        assert tmp.suffix == '.mcap' and tmp.parent == tmp_path and tmp.name.startswith('.x.')
        tmp.write_bytes(b'1')
    assert (tmp_path / 'x.mcap').read_bytes() == b'1'


@pytest.mark.parametrize('where,message', [
    ('missing/dir/a.json', 'cannot write {p}: no directory'),
    ('adir', 'cannot write {p}: it is a directory'),
])
def test_bad_targets_are_named(tmp_path, where, message):
    (tmp_path / 'adir').mkdir()
    p = tmp_path / where
    with pytest.raises(OutputError) as err:
        write_text(p, 'x')
    assert str(err.value).startswith(message.format(p=p))


def test_ensure_dir(tmp_path):
    assert ensure_dir(tmp_path / 'a' / 'b').is_dir()
    (tmp_path / 'f').write_text('x')
    with pytest.raises(OutputError, match='it exists and is not a directory'):
        ensure_dir(tmp_path / 'f')
    with pytest.raises(OutputError, match='cannot create the output directory .*Not a directory'):
        ensure_dir(tmp_path / 'f' / 'g')


def test_a_read_only_directory(tmp_path):
    import os
    d = tmp_path / 'ro'
    d.mkdir()
    d.chmod(0o500)
    try:
        if os.access(d, os.W_OK):
            pytest.skip('running as a user the permission bits do not stop (root)')
        with pytest.raises(OutputError, match='Permission denied'):
            write_text(d / 'a.txt', 'x')
    finally:
        d.chmod(0o700)


@pytest.mark.parametrize('name', ['s' * 251 + '.log', 'å' * 125 + '.mcap', 'x' * 255, 'short.json'])
def test_a_name_the_file_system_takes_is_written_whatever_its_temporary(tmp_path, name):
    """The temporary's stem is shortened to fit; the target keeps its whole name."""
    assert len(temporary_name(name).encode()) <= NAME_MAX
    assert temporary_name(name).endswith('.tmp' + Path(name).suffix)
    write_text(tmp_path / name, 'x')
    assert [p.name for p in tmp_path.iterdir()] == [name]


def test_a_name_too_long_for_the_file_system_is_named(tmp_path):
    target = tmp_path / ('s' * 256 + '.log')
    with pytest.raises(OutputError, match=f'cannot write {target}: File name too long'):
        write_text(target, 'x')
    assert list(tmp_path.iterdir()) == []


def test_a_full_disk_is_named_and_the_old_file_kept(small_tmpfs):
    from test.conftest import fill
    target = small_tmpfs / 'out.json'
    write_text(target, 'old')
    fill(small_tmpfs)
    with pytest.raises(OutputError, match=r'^cannot write .*out\.json: No space left on device$'):
        write_text(target, 'new' * 100_000)
    assert target.read_text() == 'old'
    assert sorted(p.name for p in small_tmpfs.iterdir()) == ['filler.bin', 'out.json']


@pytest.mark.parametrize('exc,reason', [
    (OSError(28, 'No space left on device'), 'No space left on device'),
    # pyarrow's wording around the errno
    (OSError(28, 'Error writing bytes to file. Detail: [errno 28] No space left on device'), 'No space left on device'),
    (OSError('no errno here'), 'OSError'),
    (OSError(None, 'its own words'), 'its own words'),
])
def test_the_reason_is_the_system_s_words(exc, reason):
    assert os_reason(exc) == reason


def test_files_written_together_appear_together_first_named_last(tmp_path, monkeypatch):
    import os
    renamed: list[str] = []
    real = os.replace
    monkeypatch.setattr(os, 'replace', lambda a, b: (renamed.append(Path(b).name), real(a, b))[1])
    write_files({tmp_path / 'index.html': b'page', tmp_path / 'a.png': b'A', tmp_path / 'b.png': b'B'})
    assert renamed == ['b.png', 'a.png', 'index.html']
    assert sorted(p.name for p in tmp_path.iterdir()) == ['a.png', 'b.png', 'index.html']
    assert (tmp_path / 'index.html').read_bytes() == b'page'


def test_files_written_together_none_if_the_disk_fills(small_tmpfs):
    """The second file does not fit: neither is written, the earlier ones stay as they were."""
    from test.conftest import fill
    write_files({small_tmpfs / 'index.html': b'old page', small_tmpfs / 'a.png': b'old A'})
    fill(small_tmpfs)
    import os
    os.truncate(small_tmpfs / 'filler.bin', os.path.getsize(small_tmpfs / 'filler.bin') - 8192)  # room for one
    with pytest.raises(OutputError, match=r'^cannot write .*a\.png: No space left on device$'):
        write_files({small_tmpfs / 'index.html': b'new page', small_tmpfs / 'a.png': b'x' * 100_000})
    assert (small_tmpfs / 'index.html').read_bytes() == b'old page'
    assert (small_tmpfs / 'a.png').read_bytes() == b'old A'
    assert sorted(p.name for p in small_tmpfs.iterdir()) == ['a.png', 'filler.bin', 'index.html']



def _dead_pid() -> int:
    done = subprocess.run([sys.executable, '-c', 'import os; print(os.getpid())'], capture_output=True, text=True,
                          check=True)
    pid = int(done.stdout)
    assert not atomic._running(pid)
    return pid


@pytest.mark.parametrize('write', [
    lambda target: write_text(target, 'new'),
    lambda target: write_files({target: b'new'}),
], ids=['atomic_path', 'write_files'])
def test_a_killed_writers_temporary_is_removed_by_the_next_write_of_its_target(tmp_path, write):
    target = tmp_path / 'replay.mcap'
    dead, old = _dead_pid(), time.time() - 2 * STALE_AFTER_S
    debris = tmp_path / temporary_name(target.name, dead)
    kept = {
        'running': tmp_path / temporary_name(target.name, os.getppid()),       # a writer still at work
        'fresh': tmp_path / temporary_name(target.name, dead + 1_000_000),     # written to just now
        'other target': tmp_path / temporary_name('other.mcap', dead),
        'other suffix': tmp_path / temporary_name('replay.log', dead),
        'not ours': tmp_path / f'.replay.{dead}.tmp.mcap.bak',
    }
    for p in [debris, *kept.values()]:
        p.write_bytes(b'half')
        if p != kept['fresh']:
            os.utime(p, (old, old))
    write(target)
    assert target.read_text() == 'new'
    assert not debris.exists()
    assert {k for k, p in kept.items() if p.exists()} == set(kept)


def test_removing_stale_temporaries_never_raises(tmp_path):
    assert remove_stale_temporaries(tmp_path / 'no' / 'such' / 'dir.mcap') == 0
    long_name = 'x' * 250 + '.mcap'         # the temporary's stem is cut; still recognised
    dead = _dead_pid()
    debris = tmp_path / temporary_name(long_name, dead)
    debris.write_bytes(b'half')
    os.utime(debris, (0, 0))
    assert remove_stale_temporaries(tmp_path / long_name) == 1 and not debris.exists()


@pytest.fixture
def full_device(tmp_path):
    """A device like /dev/full (every write: no space left) in ``tmp_path``: replacing it by
    mistake harms nothing (root and a file system that allows devices; skipped otherwise)."""
    import stat
    if os.geteuid() != 0:
        pytest.skip('making a device node needs root; the test runs in CI as root')
    node = tmp_path / 'full'
    os.mknod(node, 0o666 | stat.S_IFCHR, os.makedev(1, 7))
    try:
        with open(node, 'wb') as fh:
            fh.write(b'x')
    except OSError as exc:
        if exc.errno != 28:
            pytest.skip(f'devices cannot be used on {tmp_path}: {os_reason(exc)}')
    return node


def _is_char_device(path: Path) -> bool:
    import stat
    return stat.S_ISCHR(os.lstat(path).st_mode)


@pytest.mark.parametrize('write', [
    lambda p: write_text(p, '{}'),
    lambda p: write_files({p: b'{}'}),
    'atomic_path',
])
def test_a_device_is_written_through_not_replaced(full_device, write):
    """As root, renaming over /dev/full made it a regular file and the write 'succeeded'."""
    with pytest.raises(OutputError, match=r'^cannot write .*full: No space left on device$'):
        if write == 'atomic_path':
            with atomic_path(full_device) as p:
                p.write_bytes(b'{}')
        else:
            write(full_device)
    assert _is_char_device(full_device)
    assert sorted(p.name for p in full_device.parent.iterdir()) == ['full']


def _fifo_reader(fifo: Path) -> tuple[Any, list[bytes]]:
    import threading
    got: list[bytes] = []
    thread = threading.Thread(target=lambda: got.append(fifo.read_bytes()), daemon=True)
    thread.start()
    return thread, got


@pytest.mark.parametrize('how', ['text', 'files', 'path'])
def test_a_named_pipe_is_written_through(tmp_path, how):
    fifo = tmp_path / 'out.json'
    os.mkfifo(fifo)
    assert atomic.is_stream(fifo) and not atomic.is_stream(tmp_path) and not atomic.is_stream(tmp_path / 'no')
    thread, got = _fifo_reader(fifo)
    if how == 'text':
        write_text(fifo, '{"a": 1}')
    elif how == 'files':
        write_files({tmp_path / 'page.html': b'page', fifo: b'{"a": 1}'})
        assert (tmp_path / 'page.html').read_bytes() == b'page'
    else:
        with atomic_path(fifo) as p:
            assert p == fifo
            p.write_bytes(b'{"a": 1}')
    thread.join(10)
    assert got == [b'{"a": 1}']
    assert fifo.is_fifo()


def test_a_link_is_written_through_and_stays_a_link(tmp_path):
    (tmp_path / 'runs').mkdir()
    real = tmp_path / 'runs' / 'a.json'
    real.write_text('old')
    link = tmp_path / 'latest.json'
    link.symlink_to(Path('runs') / 'a.json')
    write_text(link, 'new')
    assert link.is_symlink() and real.read_text() == 'new'
    dangling = tmp_path / 'next.json'
    dangling.symlink_to(Path('runs') / 'b.json')
    write_files({dangling: b'made'})
    assert dangling.is_symlink() and (tmp_path / 'runs' / 'b.json').read_bytes() == b'made'
    assert sorted(p.name for p in (tmp_path / 'runs').iterdir()) == ['a.json', 'b.json']


def test_no_command_writes_over_the_repository_or_into_the_package(capsys):
    """A study's default output once replaced docs/accuracy.md (127 lines became 33): a file the
    source checkout tracks, and anything inside the package, is written only with --force."""
    from steer_monitor.atomic import check_target
    from steer_monitor.cli.main import main
    from steer_monitor.errors import OutputError
    from steer_monitor.resources import source_dirs

    root = source_dirs()[-1]
    for target in (root / 'docs' / 'accuracy.md', root / 'README.md'):
        if target.is_file():
            with pytest.raises(OutputError, match='it is a file of the steer_monitor source checkout'):
                check_target(target)
    with pytest.raises(OutputError, match='it is inside the installed steer_monitor package'):
        check_target(source_dirs()[0] / 'new_output.log')
    before = (root / 'README.md').read_bytes()
    assert main(['accuracy', '--off-grid', '1', '--programmes', 'manoeuvres', '--out', str(root / 'README.md')]) == 1
    assert 'cannot write' in capsys.readouterr().err and (root / 'README.md').read_bytes() == before
