"""NMEA 2000 gateway logs: CANboat's plain text and Yacht Devices' YDWG raw, as CAN frames.

Most logs taken on vessels come from a gateway, not a CAN interface:

* **CANboat plain** (written by canboat's ``actisense-serial`` and ``analyzer``, also the
  ``PLAIN_MIX_FAST`` form): ``timestamp,prio,pgn,src,dst,len,b0,b1,...`` with ``timestamp``
  ``2016-04-09T16:41:09.078Z`` (or ``2016-04-09-16:41:09.078``; UTC), bytes in hex. A line
  of up to 8 bytes is one CAN frame; its 29-bit identifier is rebuilt from priority, PGN,
  source and (for PDU1 PGNs, PDU format below 240) destination. A line of more than 8
  bytes is a multi-frame PGN the gateway reassembled (fast packet, ISO transport): counted
  as ``multi_frame`` (the DBC maps single frames only). A PGN beyond the 18-bit NMEA 2000
  range is the gateway's own record (Actisense status, 262161 and the like):
  ``gateway_record``.
* **YDWG raw** (Yacht Devices YDWG-02/YDEN-02): ``hh:mm:ss.ddd R 19F51323 01 02 ...``, one
  CAN frame a line, ``R`` received or ``T`` sent by the gateway. Only the time of day is
  written: the date of the first line comes from the caller (``--date``), a date in the
  file name, or the file's modification date, in that order (:func:`ydwg_date` says which);
  a time of day more than 12 h earlier than the line before is the next day (midnight),
  a smaller step back stays a step back, for the decoder to count.

Lines that do not parse are ``malformed_record``, as in candump files. No maintained library
reads these formats into CAN frames (python-can reads candump, ASC, BLF, TRC, MF4 and its
CSV/SQLite; canboat itself is C), so they are parsed here, one line at a time: gateway logs
are small (a 250 kbit/s NMEA 2000 bus carries at most ~2,000 frames a second).
"""

from __future__ import annotations

import os
import re
from collections.abc import Iterable, Iterator
from datetime import UTC, date, datetime
from pathlib import Path

from steer_monitor.can.frames import Frame
from steer_monitor.can.rejects import RejectCounter

__all__ = ['CANBOAT_LINE', 'YDWG_LINE', 'canboat_frames', 'canboat_id', 'ydwg_date', 'ydwg_frames']

#: a CANboat plain line, for recognising the format by its content
CANBOAT_LINE = re.compile(r'^\d{4}-\d\d-\d\d[T-]\d\d:\d\d:\d\d(\.\d+)?Z?\s*,\s*\d+\s*,\s*\d+\s*,')
#: a YDWG raw line, likewise
YDWG_LINE = re.compile(r'^\d\d:\d\d:\d\d\.\d{1,3} [RT] [0-9A-Fa-f]{3,8}( [0-9A-Fa-f]{2}){0,8}\s*$')

_CANBOAT_TIME = re.compile(r'^(\d{4})-(\d\d)-(\d\d)[T-](\d\d):(\d\d):(\d\d)(?:\.(\d{1,9}))?Z?$')
_YDWG = re.compile(r'^(\d\d):(\d\d):(\d\d)\.(\d{1,3}) ([RT]) ([0-9A-Fa-f]{3,8})((?: [0-9A-Fa-f]{2}){0,8})\s*$')
_NAME_DATE = re.compile(r'(?<!\d)(\d{4})-?(\d\d)-?(\d\d)(?!\d)')
_DAY_NS = 86_400_000_000_000
_HALF_DAY_NS = _DAY_NS // 2
_MAX_PGN = 0x3FFFF


def _bad(rejects: RejectCounter | None, path: Path, lineno: int, why: str) -> None:
    if rejects is not None:
        rejects.add('malformed_record', f'{path.name} line {lineno}: {why}')


def canboat_id(prio: int, pgn: int, src: int, dst: int) -> int:
    """The 29-bit identifier of a frame given as priority, PGN, source and destination (the
    destination goes into the PDU-specific byte of a PDU1 PGN, PDU format below 240)."""
    pf = (pgn >> 8) & 0xFF
    if pf < 240:
        pgn = (pgn & 0x3FF00) | dst
    return (prio << 26) | (pgn << 8) | src


def _canboat_time(text: str) -> int | None:
    m = _CANBOAT_TIME.match(text)
    if m is None:
        return None
    y, mo, d, h, mi, s, frac = m.groups()
    try:
        base = datetime(int(y), int(mo), int(d), int(h), int(mi), int(s), tzinfo=UTC)
    except ValueError:
        return None
    return int(base.timestamp()) * 1_000_000_000 + int((frac or '0').ljust(9, '0'))


def canboat_frames(lines: Iterable[bytes], path: Path, rejects: RejectCounter | None) -> Iterator[Frame]:
    """The CAN frames of a CANboat plain log's lines; what is not a frame is counted."""
    for lineno, raw in enumerate(lines, 1):
        line = raw.decode('ascii', 'replace').strip()
        if not line or line.startswith('#'):
            continue
        parts = [p.strip() for p in line.split(',')]
        if len(parts) < 6:
            _bad(rejects, path, lineno, f'{line[:60]!r}')
            continue
        t_ns = _canboat_time(parts[0])
        try:
            prio, pgn, src, dst, length = (int(p) for p in parts[1:6])
            data = bytes(int(b, 16) for b in parts[6:])
        except ValueError:
            _bad(rejects, path, lineno, f'{line[:60]!r}')
            continue
        if t_ns is None:
            _bad(rejects, path, lineno, f'timestamp {parts[0][:40]!r}')
            continue
        if pgn > _MAX_PGN:
            if rejects is not None:
                rejects.add('gateway_record', f'{path.name} line {lineno}: PGN {pgn} from source {src}')
            continue
        if not (0 <= prio <= 7 and 0 <= src <= 255 and 0 <= dst <= 255) or length != len(data) \
                or any(b > 255 for b in data):
            _bad(rejects, path, lineno, f'priority {prio}, source {src}, destination {dst}, length {length} '
                                        f'with {len(data)} bytes')
            continue
        if length > 8:
            if rejects is not None:
                rejects.add('multi_frame', f'{path.name} line {lineno}: PGN {pgn} from source {src}, '
                                           f'{length} bytes')
            continue
        yield Frame(t_ns=t_ns, can_id=canboat_id(prio, pgn, src, dst), data=data, is_extended=True,
                    is_error=False, is_remote=False, channel='')


def ydwg_date(path: str | Path, given: date | None = None) -> tuple[date, str]:
    """The date of a YDWG log's first line, and where it came from: ``given``, else a date
    written in the file name (``2020-08-22`` or ``20200822``), else the file's modification
    date (UTC). Raises OSError when the file cannot be looked at."""
    path = Path(path)
    if given is not None:
        return given, 'given'
    for m in _NAME_DATE.finditer(path.name):
        try:
            return date(int(m[1]), int(m[2]), int(m[3])), 'the file name'
        except ValueError:
            continue
    mtime = os.stat(path).st_mtime
    return datetime.fromtimestamp(mtime, tz=UTC).date(), "the file's modification time"


def ydwg_frames(lines: Iterable[bytes], path: Path, day: date, rejects: RejectCounter | None) -> Iterator[Frame]:
    """The CAN frames of a YDWG raw log's lines; the first line is on ``day`` (UTC)."""
    day_ns = int(datetime(day.year, day.month, day.day, tzinfo=UTC).timestamp()) * 1_000_000_000
    prev_tod: int | None = None
    for lineno, raw in enumerate(lines, 1):
        line = raw.decode('ascii', 'replace').strip()
        if not line or line.startswith('#'):
            continue
        m = _YDWG.match(line)
        if m is None:
            _bad(rejects, path, lineno, f'{line[:60]!r}')
            continue
        h, mi, s, ms, _direction, ident, body = m.groups()
        if int(h) > 23 or int(mi) > 59 or int(s) > 60:
            _bad(rejects, path, lineno, f'time of day {line[:12]!r}')
            continue
        tod = ((int(h) * 60 + int(mi)) * 60 + int(s)) * 1_000_000_000 + int(ms.ljust(3, '0')) * 1_000_000
        if prev_tod is not None and tod < prev_tod - _HALF_DAY_NS:
            day_ns += _DAY_NS           # past midnight
        prev_tod = tod
        extended = len(ident) == 8
        can_id = int(ident, 16)
        if can_id > (0x1FFFFFFF if extended else 0x7FF):
            _bad(rejects, path, lineno, f'identifier {ident}')
            continue
        yield Frame(t_ns=day_ns + tod, can_id=can_id, data=bytes.fromhex(body.replace(' ', '')),
                    is_extended=extended, is_error=False, is_remote=False, channel='')
