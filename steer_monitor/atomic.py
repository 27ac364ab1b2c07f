"""Outputs written whole or not at all: a temporary name beside the target, renamed at the end.

A reader (or a later run) never sees a half-written JSON, page, plot or MCAP: the bytes go to
``.<stem>.<pid>.tmp<suffix>`` in the target's directory, are flushed, and replace the target with
``os.replace`` (atomic on POSIX within one file system). On any error the temporary file is
removed and an :class:`~steer_monitor.errors.OutputError` names the target and what the
system said (no such directory, permission denied, disk full, ...).

A writer killed outright (SIGKILL, the OOM killer, a power cut) cannot remove its temporary;
the next write of the same target removes the temporaries of that target whose process no
longer runs on this machine and that nobody has written to for ``STALE_AFTER_S`` (a writer on
another machine sharing the directory keeps writing its own), so a day-long replay killed
twice does not leave gigabytes hidden beside its output.

A target that is a link is written through it: the file it points to is replaced (beside
itself) and the link stays. A target that exists and is no file at all (a terminal,
``/dev/stdout``, a named pipe, ``/dev/null``) is a stream: it cannot be replaced whole, and
renaming over it would swap the device or pipe for a file (as root, ``/dev/full`` became a
regular file). It is written straight through, and what the system says (``/dev/full``: no
space left) is the error.

No output replaces what a command was made from or what the package ships, unless the user
says so (``--force``): inside :func:`command_scope`, every file the command reads (its logs,
its parameters file: :func:`note_input`) is refused as a target, and so, always, is an
existing file of the installed package's ``config/`` (the parameters every command and
``ros2 run`` read when given none).
"""

from __future__ import annotations

import contextlib
import contextvars
import errno
import os
import re
import stat
import subprocess
import time
from collections.abc import Iterable, Iterator, Mapping
from pathlib import Path
from typing import IO, Any

from steer_monitor.errors import OutputError
from steer_monitor.resources import config_dirs, source_dirs

__all__ = [
    'STALE_AFTER_S',
    'atomic_path',
    'atomic_write',
    'check_target',
    'command_scope',
    'ensure_dir',
    'output_dir',
    'is_stream',
    'note_input',
    'os_reason',
    'remove_stale_temporaries',
    'temporary_name',
    'write_bytes',
    'write_files',
    'write_text',
]

#: a temporary not written to for this long, of a process that no longer runs, is debris [s]
STALE_AFTER_S = 600.0


def os_reason(exc: OSError) -> str:
    """The system's words for an OS error, without the file name (the caller names it): the
    C library's text for its errno (libraries such as pyarrow put their own sentence around
    it in ``strerror``), else ``strerror``, else the error's type."""
    if isinstance(exc.errno, int) and exc.errno > 0:
        return os.strerror(exc.errno)
    return exc.strerror or type(exc).__name__


def ensure_dir(path: str | Path) -> Path:
    """Create an output directory (and parents); :class:`OutputError` when it cannot be."""
    p = Path(path)
    try:
        p.mkdir(parents=True, exist_ok=True)
    except FileExistsError as exc:
        msg = f'cannot write into {p}: it exists and is not a directory'
        raise OutputError(msg) from exc
    except OSError as exc:
        msg = f'cannot create the output directory {p}: {os_reason(exc)}'
        raise OutputError(msg) from exc
    return p


@contextlib.contextmanager
def output_dir(path: str | Path) -> Iterator[Path]:
    """:func:`ensure_dir` for a command's output directory, removed again (with the parents it
    made) when the command fails before writing anything into it: a failed run leaves no empty
    directory behind to pass for a result."""
    p = Path(path)
    made = []
    for parent in [p, *p.parents]:
        if parent.exists() or parent == parent.parent:
            break
        made.append(parent)
    out = ensure_dir(p)
    try:
        yield out
    except BaseException:
        for d in made:
            with contextlib.suppress(OSError):
                d.rmdir()             # only if empty
        raise


def is_stream(path: str | Path) -> bool:
    """Whether ``path`` (through links) exists and is neither a regular file nor a directory:
    a terminal, a pipe, a socket or a device, written straight through rather than replaced."""
    try:
        mode = os.stat(path).st_mode
    except (OSError, ValueError):
        return False
    return not (stat.S_ISREG(mode) or stat.S_ISDIR(mode))


class _Scope:
    """What one command has read, and whether it may write over it."""

    def __init__(self, force: bool) -> None:
        self.force = force
        self.inputs: list[Path] = []


_SCOPE: contextvars.ContextVar[_Scope | None] = contextvars.ContextVar('steer_monitor_output_scope', default=None)


@contextlib.contextmanager
def command_scope(force: bool = False) -> Iterator[None]:
    """One command's run: the inputs it notes (:func:`note_input`) are refused as outputs,
    and so are the package's own files, unless ``force``."""
    token = _SCOPE.set(_Scope(force))
    try:
        yield
    finally:
        _SCOPE.reset(token)


def note_input(path: str | Path | None) -> None:
    """Record that the running command reads ``path`` (nothing outside a command's scope)."""
    scope = _SCOPE.get()
    if scope is not None and path is not None:
        scope.inputs.append(Path(path))


def _forced() -> bool:
    """Whether the running command was told ``--force`` (may write over its inputs)."""
    scope = _SCOPE.get()
    return scope is not None and scope.force


def _protected(target: Path, inputs: Iterable[str | Path | None]) -> str | None:
    """Why ``target`` must not be written over (None: it may be): an input of the command,
    or an existing file of the installed package's configuration."""
    scope = _SCOPE.get()
    for source in [*inputs, *(scope.inputs if scope is not None else ())]:
        if source is not None and _same_file(target, Path(source)):
            return f'it is the input {source}'
    try:
        if not target.is_file():
            return None
        real = Path(os.path.realpath(target))
    except (OSError, ValueError):
        return None
    for directory in config_dirs():
        with contextlib.suppress(OSError, ValueError):
            if real.is_relative_to(Path(os.path.realpath(directory))):
                return f'it is a file of the installed package ({directory})'
    return None


def _protected_source(target: Path) -> str | None:
    """Why ``target`` is the package's or its source checkout's own (:func:`_in_source`)."""
    if is_stream(target):
        return None
    with contextlib.suppress(OSError, ValueError):
        return _in_source(Path(os.path.realpath(target.parent)) / target.name)
    return None


#: files of a source checkout a command never writes over unasked, where git cannot say what it tracks
_SOURCE_PARTS = frozenset({'docs', 'config', 'test', 'bench', 'launch', 'resource', 'systemd', '.ci', 'steer_monitor'})
_SOURCE_SUFFIXES = frozenset({'.md', '.py', '.txt', '.xml', '.cfg', '.toml', '.yaml', '.yml', '.json'})


def _in_source(where: Path) -> str | None:
    """Why ``where`` (resolved) is the package's or its source checkout's own (None: it is not):
    anything inside the package, and in a checkout (an editable install) a file git tracks
    there (without git: an existing file of its source folders or a top-level source file)."""
    dirs = source_dirs()
    pkg = Path(os.path.realpath(dirs[0]))
    if where.is_relative_to(pkg):
        return f'it is inside the installed steer_monitor package ({dirs[0]})'
    if len(dirs) < 2:
        return None
    root = Path(os.path.realpath(dirs[1]))
    if not where.is_relative_to(root) or not where.is_file():
        return None
    rel = where.relative_to(root)
    tracked: bool | None = None
    with contextlib.suppress(OSError, subprocess.SubprocessError):
        done = subprocess.run(['git', '-C', str(root), 'ls-files', '--error-unmatch', '--', str(rel)],
                              capture_output=True, timeout=10, check=False)
        tracked = done.returncode == 0 if done.returncode in (0, 1) else None
    if tracked is None:
        tracked = rel.parts[0] in _SOURCE_PARTS or (len(rel.parts) == 1 and (
            rel.suffix in _SOURCE_SUFFIXES or rel.name == 'Makefile'))
    return f'it is a file of the steer_monitor source checkout ({root})' if tracked else None


def _resolved(path: str | Path) -> Path:
    """The path a write of ``path`` replaces: a link's target (so the link stays), else
    ``path`` itself."""
    p = Path(path)
    try:
        return Path(os.path.realpath(p)) if p.is_symlink() else p
    except OSError:         # e.g. a name too long: the write names it
        return p


def check_target(path: str | Path, inputs: Iterable[str | Path | None] = ()) -> None:
    """:class:`OutputError` now if ``path`` cannot be written later (a directory, no parent
    directory, a parent without write permission), or if it is one of the command's
    ``inputs`` (a log, a parameters file: written, the output would replace what it was made
    from), an input the running command noted (:func:`note_input`) or an existing packaged
    file, unless the command was given ``--force``: commands that work for minutes before
    they write check their outputs first."""
    target = Path(path)
    reason = None if _forced() else (_protected(target, inputs) or _protected_source(target))
    if reason is not None:
        msg = f'cannot write {target}: {reason}; give another output, or --force to replace it'
        raise OutputError(msg)
    if is_stream(target):
        if not os.access(target, os.W_OK):
            msg = f'cannot write {target}: {os.strerror(errno.EACCES)}'
            raise OutputError(msg)
        return
    target = _resolved(target)
    try:
        is_dir, parent_is_dir = target.is_dir(), target.parent.is_dir()
    except OSError as exc:          # e.g. a name too long for the file system
        msg = f'cannot write {target}: {os_reason(exc)}'
        raise OutputError(msg) from exc
    if is_dir:
        msg = f'cannot write {target}: it is a directory'
        raise OutputError(msg)
    if not parent_is_dir:
        msg = f'cannot write {target}: no directory {target.parent}'
        raise OutputError(msg)
    if not os.access(target.parent, os.W_OK):
        msg = f'cannot write {target}: {target.parent} is not writable'
        raise OutputError(msg)


def _same_file(a: Path, b: Path) -> bool:
    """Whether two paths name one file (through links, ``..`` and the like); False when
    either does not exist."""
    try:
        return os.path.samefile(a, b)
    except (OSError, ValueError):
        return False


NAME_MAX = 255      # bytes in one file name on the file systems a log goes to (ext4, xfs, btrfs, tmpfs)


def temporary_name(name: str, pid: int | None = None) -> str:
    """``.<stem>.<pid>.tmp<suffix>`` for a target named ``name`` written by process ``pid``
    (default: this one), its stem shortened so that the temporary name is no longer than the
    target's could be (a target whose own name the file system takes must not fail for its
    temporary's)."""
    p = Path(name)
    tail = f'.{os.getpid() if pid is None else pid}.tmp{p.suffix}'
    room = NAME_MAX - 1 - len(tail.encode())
    stem = p.stem.encode()[:room].decode(errors='ignore')    # a character cut in two is left out
    return f'.{stem}{tail}'


def _running(pid: int) -> bool:
    """Whether a process ``pid`` runs on this machine (one of another user counts)."""
    if pid <= 0:
        return False
    try:
        os.kill(pid, 0)
    except PermissionError:
        return True
    except (ProcessLookupError, OverflowError):
        return False
    return True


def remove_stale_temporaries(path: str | Path, stale_after_s: float = STALE_AFTER_S) -> int:
    """Remove the temporaries of target ``path`` that writers killed mid-write left (see the
    module docstring); returns how many. Never raises: what cannot be listed or removed stays."""
    target = Path(path)
    pattern = re.compile(r'\.(\d+)\.tmp' + re.escape(target.suffix) + r'$')
    now = time.time()
    removed = 0
    try:
        names = [e.name for e in os.scandir(target.parent) if e.name.startswith('.')]
    except OSError:
        return 0
    for name in names:
        m = pattern.search(name)
        if m is None:
            continue
        pid = int(m.group(1))
        if pid == os.getpid() or name != temporary_name(target.name, pid) or _running(pid):
            continue
        tmp = target.parent / name
        with contextlib.suppress(OSError):
            st = tmp.lstat()
            if now - st.st_mtime >= stale_after_s and not tmp.is_dir():
                tmp.unlink()
                removed += 1
    return removed


@contextlib.contextmanager
def atomic_path(path: str | Path) -> Iterator[Path]:
    """A temporary path to write ``path``'s content to (by any writer, e.g. matplotlib);
    renamed to ``path`` when the block ends without an exception, removed otherwise."""
    target = Path(path)
    check_target(target)
    if is_stream(target):
        try:
            yield target
        except OSError as exc:      # a full device, a closed pipe
            msg = f'cannot write {target}: {os_reason(exc)}'
            raise OutputError(msg) from exc
        return
    target = _resolved(target)
    remove_stale_temporaries(target)
    # the suffix kept last, for writers that choose the format by it (.log, .mcap)
    tmp = target.with_name(temporary_name(target.name))
    try:
        yield tmp
        os.replace(tmp, target)
    except OSError as exc:
        with contextlib.suppress(OSError):
            tmp.unlink()
        msg = f'cannot write {target}: {os_reason(exc)}'
        raise OutputError(msg) from exc
    except BaseException:
        with contextlib.suppress(OSError):
            tmp.unlink()
        raise


@contextlib.contextmanager
def atomic_write(path: str | Path, mode: str = 'w', **kwargs: Any) -> Iterator[IO[Any]]:
    """``open(path, mode)`` written through :func:`atomic_path` (flushed and fsynced before
    the rename, so a crash leaves the old file or the new one; a stream is flushed only)."""
    with atomic_path(path) as tmp:
        try:
            fh = open(tmp, mode, **kwargs)
        except OSError as exc:
            msg = f'cannot write {path}: {os_reason(exc)}'
            raise OutputError(msg) from exc
        try:
            with fh:
                yield fh
                fh.flush()
                if not is_stream(tmp):
                    os.fsync(fh.fileno())
        except OSError as exc:          # a stream's own error (a full device, a closed pipe)
            msg = f'cannot write {path}: {os_reason(exc)}'
            raise OutputError(msg) from exc


def write_text(path: str | Path, text: str) -> None:
    """Write a UTF-8 text file atomically."""
    with atomic_write(path, 'w', encoding='utf-8') as fh:
        fh.write(text)


def write_bytes(path: str | Path, data: bytes) -> None:
    """Write a binary file atomically."""
    with atomic_write(path, 'wb') as fh:
        fh.write(data)


def write_files(files: Mapping[str | Path, bytes]) -> None:
    """Write several files all or none: each to its temporary name, flushed and synced, before
    any is renamed (a full disk or a missing permission fails there, every temporary is
    removed and the files already there are untouched); then all renamed, in the reverse of
    the mapping's order, so that the first named (a page, say, before the plots it goes with)
    appears last."""
    done: list[tuple[Path, Path]] = []         # (temporary, target) of each temporary made
    streams: list[tuple[Path, bytes]] = []      # written straight through once the rest is made
    target = Path()
    try:
        for path, data in files.items():
            target = Path(path)
            check_target(target)
            if is_stream(target):
                streams.append((target, data))
                continue
            target = _resolved(target)
            remove_stale_temporaries(target)
            tmp = target.with_name(temporary_name(target.name))
            with open(tmp, 'wb') as fh:
                done.append((tmp, target))
                fh.write(data)
                fh.flush()
                os.fsync(fh.fileno())
        for target, data in streams:
            with open(target, 'wb') as fh:
                fh.write(data)
        for tmp, target in reversed(done):
            os.replace(tmp, target)
    except BaseException as exc:
        for tmp, _ in done:
            with contextlib.suppress(OSError):
                tmp.unlink()
        if isinstance(exc, OSError):
            msg = f'cannot write {target}: {os_reason(exc)}'
            raise OutputError(msg) from exc
        raise
