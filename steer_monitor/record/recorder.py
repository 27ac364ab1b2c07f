"""Recording raw frames and published messages to rotating MCAP files, on a thread of its own.

* profile ``ros2``, ``cdr`` messages, ``ros2msg`` schemas, ``offered_qos_profiles`` on every
  channel, zstd chunks, CRCs;
* a new file when the current one passes a size or an age;
* the chunk in progress is closed and written out every ``flush_interval_s`` (1 s), so a
  SIGKILL loses at most the last second, and ``steer-monitor recover`` makes the rest readable;
* every file is finished on :meth:`Recorder.close` (the node calls it on SIGINT/SIGTERM);
* a full or read-only disk does not stop the caller: the recorder reports the error in its
  status (a diagnostic ERROR until a write reaches the disk again), counts what it could not
  write, and every ``retry_s`` seconds looks whether the directory takes data again (free
  space for two chunks, write permission) before it opens a file, so a full disk is not
  filled with empty files. The file that failed is cut back to its last complete chunk
  (``recover`` makes it readable), or removed if no chunk of it reached the disk; nothing
  flushed before the failure is lost;
* a directory on a disk of its own (a USB disk, a second drive) that is unmounted is not made
  again on the disk beneath (filling the system's disk through an empty mount point): the
  recorder keeps the mount the directory was on when it first wrote there, reports an error
  while the directory is elsewhere (checked at every flush and before a file is opened) and
  records again once the disk is mounted there again;
* ``messages`` counts what reached the disk, so it never falls; ``failed`` what was lost;
* a budget for the directory: the oldest finished recordings of this prefix in it (made by
  this recorder or an earlier one; nothing else there) are removed while the recordings take
  more than ``max_total_bytes`` or the file system has less than ``keep_free_bytes`` free,
  checked at every flush, so a node that records a busy bus for months (0.28 GB an hour
  measured at a full NMEA 2000 bus) keeps the newest and never fills the disk with its own.
  The file being written is never removed, nor one written to in the last minute (another
  recorder's with the same prefix); ``removed`` counts what was.

Callers hand over already-serialized CDR (``write``, or ``write_messages`` for a batch) or
frames (``write_frame``, or ``write_frames`` for a batch); a batch is one queue entry, its
records packed at once. Nothing here imports rclpy.
"""

from __future__ import annotations

import contextlib
import errno
import os
import queue
import re
import stat
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from steer_monitor.can.frames import Frame
from steer_monitor.logfiles.mcapio import DEFAULT_QOS, FRAME_DATATYPE, FRAME_MSGDEF, FRAME_TOPIC, McapWriter

__all__ = ['Recorder', 'RecorderStatus']


_SPLIT: Any = object()    # as a queue entry's topic: finish the current file
_MESSAGES: Any = object()  # as a queue entry's topic: a list of (topic, CDR, log time)
#: a recording written to within this long is not removed for the budget (a second node with
#: the same prefix in the directory may be writing it) [s]
BUSY_S = 60.0


@dataclass(frozen=True)
class RecorderStatus:
    """What the recorder reports: ``ok`` False from a failed write until a write reaches the
    disk again; ``files`` the recordings made (a file the disk was too full to take any of
    is removed and not counted); ``messages`` written to disk (never falls), ``failed`` lost
    to write errors, ``dropped`` lost to a full queue; ``removed`` the oldest recordings
    removed to keep the directory's budget (``files`` still counts those this recorder made)."""

    ok: bool
    message: str
    current_file: str | None
    files: int
    messages: int
    dropped: int
    failed: int
    removed: int = 0

    def lost(self) -> str | None:
        """What was not recorded, in a phrase (None when nothing was lost)."""
        parts = ([f'{self.failed} could not be written'] if self.failed else []) + \
                ([f'{self.dropped} were dropped (the queue was full)'] if self.dropped else [])
        return f'{" and ".join(parts)} of {self.messages + self.failed + self.dropped} messages' if parts else None


class _Topic:
    __slots__ = ('datatype', 'msgdef', 'qos')

    def __init__(self, datatype: str, msgdef: str, qos: str) -> None:
        self.datatype, self.msgdef, self.qos = datatype, msgdef, qos


class Recorder:
    """Rotating MCAP recorder. Context manager; :meth:`close` is idempotent."""

    def __init__(self, directory: str | Path, prefix: str = 'steer_monitor', max_bytes: int = 512 << 20,
                 max_seconds: float = 3600.0, flush_interval_s: float = 1.0, retry_s: float = 5.0,
                 queue_size: int = 200_000, chunk_size: int = 1 << 20,
                 clock: Callable[[], float] = time.monotonic,
                 metadata: dict[str, dict[str, str]] | None = None,
                 on_error: Callable[[str | None], None] | None = None,
                 max_total_bytes: int = 0, keep_free_bytes: int = 0,
                 on_removed: Callable[[Path, int, str], None] | None = None) -> None:
        self.directory = Path(directory)
        #: the budget (0: none): recordings in all, and free space to leave on the file system [bytes]
        self.max_total_bytes = max_total_bytes
        self.keep_free_bytes = keep_free_bytes
        #: hears, on the writer thread, each recording removed for the budget: path, size, why
        self._on_removed = on_removed
        self._finished: list[tuple[Path, int]] | None = None   # oldest first; None: not looked yet
        self._finished_bytes = 0
        self.removed = 0
        self._mount: Path | None = None     # where the directory's file system is mounted, once written to
        #: hears, on the writer thread, each change between recording and not: the error's text
        #: when writes start to fail, None when one reaches the disk again (not every retry)
        self._on_error = on_error
        #: MCAP metadata records written at the start of every file (name -> string map)
        self.metadata = dict(metadata or {})
        self.prefix = prefix
        self.max_bytes = max_bytes
        self.max_seconds = max_seconds
        self.flush_interval_s = flush_interval_s
        self.retry_s = retry_s
        self.chunk_size = chunk_size
        self._clock = clock
        self._queue: queue.Queue[tuple[str, Any, int] | None] = queue.Queue(queue_size)
        self._topics: dict[str, _Topic] = {}
        self._lock = threading.Lock()
        self._writer: Any = None
        self._stream: Any = None
        self._opened_at = 0.0
        self._last_flush = 0.0
        self._next_retry = 0.0
        self._index = 0
        self.files: list[Path] = []
        self.messages = 0
        self.dropped = 0
        self.failed = 0
        self._pending = 0  # added to the writer but not yet flushed to the file
        self._good_offset = 0  # bytes of the current file known to be written whole
        self._error: str | None = None
        self._closed = False
        self.add_topic(FRAME_TOPIC, FRAME_DATATYPE, FRAME_MSGDEF)
        self._thread = threading.Thread(target=self._run, name='steer_monitor-recorder', daemon=True)
        self._thread.start()

    # --- caller side (any thread) --------------------------------------------------------
    def add_topic(self, topic: str, datatype: str, msgdef: str, qos: str = DEFAULT_QOS) -> None:
        """Declare a topic before writing to it."""
        with self._lock:
            self._topics[topic] = _Topic(datatype, msgdef, qos)

    def write(self, topic: str, cdr: bytes, log_time_ns: int) -> None:
        """Queue one serialized message; never blocks (a full queue counts as dropped). A
        topic not declared (:meth:`add_topic`) raises ``KeyError`` here, not on the writer."""
        self._declared(topic)
        self._put((topic, cdr, log_time_ns))

    def write_frame(self, frame: Frame) -> None:
        """Queue one raw CAN frame (recorded as can_msgs/msg/Frame)."""
        self._put((FRAME_TOPIC, frame, frame.t_ns))

    def write_frames(self, frames: list[Frame]) -> None:
        """Queue a batch of raw CAN frames (one queue entry; written in one go)."""
        if frames:
            self._put((FRAME_TOPIC, frames, frames[0].t_ns))

    def write_messages(self, messages: list[tuple[str, bytes, int]]) -> None:
        """Queue many serialized messages (topic, CDR, log time [ns]) as one entry, written
        in one go; never blocks. A topic not declared raises ``KeyError`` (see :meth:`write`)."""
        if messages:
            for topic in {m[0] for m in messages}:
                self._declared(topic)
            self._put((_MESSAGES, messages, messages[0][2]))

    def _declared(self, topic: str) -> None:
        if topic not in self._topics:
            msg = f'topic {topic} was not declared with add_topic'
            raise KeyError(msg)

    def split(self) -> None:
        """Finish the current file after what is queued; the next message opens a new one
        (the node's data time went back: each file keeps its messages in time order)."""
        self._put((_SPLIT, None, 0))

    def _put(self, item: tuple[str, Any, int]) -> None:
        if self._closed:
            return
        try:
            self._queue.put_nowait(item)
        except queue.Full:
            self.dropped += 1

    @property
    def queued(self) -> int:
        """Entries waiting for the writer thread (approximate while it runs)."""
        return self._queue.qsize()

    def status(self) -> RecorderStatus:
        with self._lock:
            current = str(self.files[-1]) if self._writer is not None and self.files else None
            if self._closed:
                message = (f'closed after {len(self.files)} file(s)'
                           + (f'; the last writes failed: {self._error}' if self._error is not None else ''))
            elif self._error is not None:
                message = f'cannot record: {self._error}; retrying every {self.retry_s:g} s'
            elif current is None:
                message = 'waiting for the first message'
            else:
                message = f'recording to {current}'
            return RecorderStatus(self._error is None, message, current, len(self.files), self.messages,
                                  self.dropped, self.failed, self.removed)

    def close(self) -> None:
        """Write out what is queued, finish the current file, stop the thread."""
        if self._closed:
            return
        self._closed = True
        self._queue.put(None)
        self._thread.join()

    def __enter__(self) -> Recorder:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # --- writer thread -------------------------------------------------------------------
    def _run(self) -> None:
        get, get_nowait = self._queue.get, self._queue.get_nowait
        while True:
            try:
                batch = [get(timeout=0.1)]
            except queue.Empty:
                batch = []
            try:  # take what else is queued without waiting
                while len(batch) < 4096:
                    batch.append(get_nowait())
            except queue.Empty:
                pass
            now = self._clock()
            done = False
            for item in batch:
                if item is None:
                    done = True
                    break
                self._write_item(*item, now=now)
            if done:
                break
            if self._writer is not None and now - self._last_flush >= self.flush_interval_s:
                self._guard(self._flush)
                self._last_flush = now
        self._guard(self._finish)

    def _guard(self, fn: Callable[[], None]) -> bool:
        try:
            fn()
        except OSError as exc:
            self._fail(exc)
            return False
        return True

    def _set_error(self, text: str | None) -> None:
        """The error now (None: writes reach the disk); ``on_error`` hears a change of state."""
        with self._lock:
            was, self._error = self._error, text
        if self._on_error is not None and (was is None) != (text is None):
            self._on_error(text)

    def _fail(self, exc: OSError) -> None:
        with self._lock:
            # what was buffered for the file is lost with it
            self.failed += self._pending
            self._pending = 0
        self._set_error(f'{exc.strerror or exc}' + (f': {exc.filename}' if exc.filename else ''))
        stream = self._stream
        self._writer = self._stream = None
        if stream is not None:
            try:        # closing writes out what the buffer holds, as far as it goes ...
                stream.close()
            except OSError:
                pass
            self._cut_back()
        self._next_retry = self._clock() + self.retry_s

    def _cut_back(self) -> None:
        """After a failed write, cut the current file back to its last whole chunk, so
        :func:`~steer_monitor.record.recover` reads it cleanly; a file none of whose bytes
        were known to be written (the disk was full from its start) is removed instead, since
        it holds nothing a reader could use, and leaves :attr:`files`."""
        path = self.files[-1]
        try:
            if self._good_offset > 0:
                os.truncate(path, self._good_offset)
                if self._finished is not None:
                    self._add_finished(path)
                return
            path.unlink()
        except OSError:
            return
        with self._lock:
            self.files.pop()

    # --- the directory's budget ----------------------------------------------------------
    def _own(self) -> re.Pattern[str]:
        return re.compile(re.escape(self.prefix) + r'_\d{8}T\d{6}Z_\d{3,}\.mcap')

    def _scan_finished(self) -> None:
        """The recordings of this prefix already in the directory, oldest first (by the time
        they were last written, then by name)."""
        own = self._own()
        found: list[tuple[float, str, int]] = []
        try:
            with os.scandir(self.directory) as entries:
                for e in entries:
                    if own.fullmatch(e.name) and e.is_file(follow_symlinks=False):
                        with contextlib.suppress(OSError):
                            st = e.stat(follow_symlinks=False)
                            found.append((st.st_mtime, e.name, st.st_size))
        except OSError:
            found = []
        found.sort()
        self._finished = [(self.directory / name, size) for _, name, size in found]
        self._finished_bytes = sum(size for _, size in self._finished)

    def _add_finished(self, path: Path) -> None:
        assert self._finished is not None
        with contextlib.suppress(OSError):
            size = path.stat().st_size
            self._finished.append((path, size))
            self._finished_bytes += size

    def _keep_budget(self) -> None:
        """Remove the oldest finished recordings while over the budget. The free space is read
        once and what each removal frees is added to it (a file another process still holds
        open frees nothing yet; reading the free space again would remove the next one too).
        The directory's recordings are looked up the first time."""
        if not (self.max_total_bytes or self.keep_free_bytes):
            return
        if self._finished is None:
            self._scan_finished()
        if not self._finished:
            return
        current = self._stream.tell() if self._stream is not None else 0
        free = None
        if self.keep_free_bytes:
            try:
                st = os.statvfs(self.directory)
                free = st.f_bavail * st.f_frsize
            except OSError:
                free = None
        k = 0
        while k < len(self._finished):
            over_total = self.max_total_bytes and self._finished_bytes + current > self.max_total_bytes
            short = free is not None and free < self.keep_free_bytes
            if not (over_total or short):
                return
            path, size = self._finished[k]
            try:
                if path not in self.files and time.time() - path.stat().st_mtime < BUSY_S:
                    k += 1                   # written to just now: another recorder's open file
                    continue
                path.unlink()
            except FileNotFoundError:
                freed = 0                    # removed by someone else meanwhile
            except OSError:
                return                       # cannot be removed (permission): the budget waits
            else:
                freed = size
            self._finished.pop(k)
            self._finished_bytes -= size
            if free is not None:
                free += freed
            if freed:
                with self._lock:
                    self.removed += 1
                if self._on_removed is not None:
                    why = (f'the recordings took more than {self.max_total_bytes / 1e9:g} GB' if over_total
                           else f'less than {self.keep_free_bytes / 1e9:g} GB was free on the disk')
                    self._on_removed(path, size, why)

    # --- the directory's disk ------------------------------------------------------------
    def _ensure_directory(self) -> None:
        """Make the directory if need be, on the file system it was first written on; an
        ``OSError`` (ENODEV) naming both mounts if that file system is no longer there."""
        if self._mount is None:
            self.directory.mkdir(parents=True, exist_ok=True)
            self._mount = _mount_point(self.directory)
            return
        now = _mount_point(self.directory)
        if now != self._mount:
            raise OSError(errno.ENODEV, f'{self.directory} is no longer on the disk mounted at {self._mount} '
                                        f'(it would be on {now}; unmounted?)')
        self.directory.mkdir(parents=True, exist_ok=True)

    def _check_stream_directory(self) -> None:
        """The file being written is still the one at its name: a disk unmounted lazily (or a
        file removed by hand) keeps taking writes into a file nobody can reach again. Compared
        by inode, which overlay file systems keep (their directories' device may differ)."""
        fst = os.fstat(self._stream.fileno())
        if not stat.S_ISREG(fst.st_mode):
            return
        path = self.files[-1]
        try:
            st = os.stat(path)
        except FileNotFoundError:
            same = False
        else:
            same = (st.st_dev, st.st_ino) == (fst.st_dev, fst.st_ino)
        if not same:
            raise OSError(errno.ENODEV, f'{path} is no longer in {self.directory} (its disk unmounted, '
                                        'or the file removed?)')

    def _can_write(self) -> bool:
        """Whether the directory takes data again: writable, with room for two chunks (after
        removing old recordings, if the budget asks for it)."""
        try:
            self._ensure_directory()
            self._keep_budget()
            st = os.statvfs(self.directory)
        except OSError as exc:
            self._set_error(exc.strerror if exc.errno == errno.ENODEV else f'{exc.strerror or exc}: {self.directory}')
            return False
        if not os.access(self.directory, os.W_OK):
            self._set_error(f'not writable: {self.directory}')
            return False
        if st.f_bavail * st.f_frsize < 2 * self.chunk_size + (64 << 10):
            self._set_error(f'No space left on device: {self.directory} has {st.f_bavail * st.f_frsize} bytes free')
            return False
        return True

    def _write_item(self, topic: str, payload: Any, log_time_ns: int, now: float) -> None:
        if topic is _SPLIT:
            if self._writer is not None:
                self._guard(self._finish)
            return
        count = len(payload) if isinstance(payload, list) else 1   # a batch of frames or one message
        if self._writer is None:
            if self._error is not None and (now < self._next_retry or not self._can_write()):
                if now >= self._next_retry:
                    self._next_retry = now + self.retry_s
                self.failed += count
                return
            if not self._guard(lambda: self._open(log_time_ns, now)):
                self.failed += count
                return
        elif now - self._opened_at >= self.max_seconds or self._stream.tell() >= self.max_bytes:
            if not (self._guard(self._finish) and self._guard(lambda: self._open(log_time_ns, now))):
                self.failed += count
                return
        ok = self._guard(lambda: self._add(topic, payload, log_time_ns))
        if ok:
            self._pending += count
        else:
            self.failed += count

    def _open(self, log_time_ns: int, now: float) -> None:
        self._ensure_directory()
        self._keep_budget()
        stamp = datetime.fromtimestamp(log_time_ns / 1e9, tz=UTC).strftime('%Y%m%dT%H%M%SZ')
        while True:     # never over a recording already there (a restart in the same second, a second node)
            self._index += 1
            path = self.directory / f'{self.prefix}_{stamp}_{self._index:03d}.mcap'
            try:
                stream = open(path, 'xb')
                break
            except FileExistsError:
                continue
        try:
            writer = McapWriter(stream, chunk_size=self.chunk_size)
            for name, data in self.metadata.items():
                writer.add_metadata(name, data)
        except BaseException:
            with contextlib.suppress(OSError):
                stream.close()
            with contextlib.suppress(OSError):
                path.unlink()           # nothing in it a reader could use
            raise
        with self._lock:
            self._stream, self._writer = stream, writer
            self.files.append(path)
        self._good_offset = 0
        self._opened_at = self._last_flush = now

    def _add(self, topic: str, payload: Any, log_time_ns: int) -> None:
        if topic == FRAME_TOPIC and isinstance(payload, list):
            self._writer.write_frames(payload)
            return
        if topic == FRAME_TOPIC and isinstance(payload, Frame):
            self._writer.write_frame(payload)
            return
        if topic is _MESSAGES:
            topics = [m[0] for m in payload]
            for name in dict.fromkeys(topics):
                self._declare(name)
            self._writer.write_messages(topics, [m[1] for m in payload], [m[2] for m in payload])
            return
        self._declare(topic)
        self._writer.write_cdr(topic, payload, log_time_ns)

    def _declare(self, topic: str) -> None:
        """The topic's schema and channel in the current file."""
        with self._lock:
            t = self._topics.get(topic)
        if t is None:
            msg = f'topic {topic} was not declared with add_topic'
            raise KeyError(msg)
        self._writer.add_schema(t.datatype, t.msgdef)
        self._writer.add_channel(topic, t.datatype, t.qos)

    def _flush(self) -> None:
        self._check_stream_directory()
        self._writer.flush()
        self._stream.flush()
        with self._lock:        # on disk (or in the page cache): counted, and the error is over
            self.messages += self._pending
            self._pending = 0
        self._set_error(None)
        self._good_offset = self._stream.tell()
        self._keep_budget()

    def _finish(self) -> None:
        if self._writer is None:
            return
        writer, stream = self._writer, self._stream
        self._writer = self._stream = None
        try:
            writer.close()  # finishes the MCAP; the stream stays ours to sync and close
            stream.flush()
            os.fsync(stream.fileno())
            with self._lock:
                self.messages += self._pending
                self._pending = 0
            self._set_error(None)
        except OSError:
            self._stream = stream      # _fail cuts it back to its last whole chunk and closes it
            raise
        else:
            stream.close()
            if self._finished is not None and self.files:
                self._add_finished(self.files[-1])


def _mount_point(path: Path) -> Path:
    """The mount point of the file system ``path`` is on, or would be made on (its nearest
    existing ancestor's): the highest ancestor on the same device."""
    p = Path(os.path.realpath(path))
    while not p.exists() and p.parent != p:
        p = p.parent
    dev = os.stat(p).st_dev
    while p.parent != p and os.stat(p.parent).st_dev == dev:
        p = p.parent
    return p
