"""Data times as text: ISO 8601 UTC, to the second (``2026-11-26T14:03:00Z``), and back. Pure."""

from __future__ import annotations

import datetime

__all__ = ['parse_utc', 'time_json', 'utc_json', 'utc_text']


def utc_text(t_ns: int) -> str:
    """A data time [ns since the epoch] as ISO 8601 UTC to the second (``...T14:03:00Z``)."""
    return datetime.datetime.fromtimestamp(t_ns // 1_000_000_000, datetime.UTC).strftime('%Y-%m-%dT%H:%M:%SZ')


def utc_json(t_ns: int | None) -> str | None:
    """A time for JSON's ``*_utc`` keys: ISO 8601 UTC to the millisecond
    (``2026-11-26T14:03:00.008Z``); None for None or a time beyond what a calendar date holds
    (year 1..9999: the ``*_ns`` key beside it still says it)."""
    if t_ns is None:
        return None
    try:
        t = datetime.datetime.fromtimestamp(t_ns // 1_000_000 / 1e3, datetime.UTC)
    except (ValueError, OverflowError, OSError):
        return None
    return t.strftime('%Y-%m-%dT%H:%M:%S.') + f'{t.microsecond // 1000:03d}Z'


def time_json(name: str, t_ns: int | None) -> dict[str, str | int | None]:
    """A time in the JSON vocabulary (docs/json.md): ``{name}_utc`` (:func:`utc_json`) and
    ``{name}_ns``."""
    return {f'{name}_utc': utc_json(t_ns), f'{name}_ns': t_ns}


def parse_utc(text: str) -> int:
    """An ISO 8601 time (``2026-11-26T14:03:00Z``, ``2026-11-26 14:03``, an offset such as
    ``+01:00``; without a zone it is UTC) as ns since the epoch. Raises ValueError naming the
    text when it is not one."""
    try:
        t = datetime.datetime.fromisoformat(text.strip().replace('Z', '+00:00').replace('z', '+00:00'))
    except ValueError:
        msg = f'{text!r} is not an ISO 8601 time such as 2026-11-26T14:03:00Z'
        raise ValueError(msg) from None
    if t.tzinfo is None:
        t = t.replace(tzinfo=datetime.UTC)
    delta = t - datetime.datetime(1970, 1, 1, tzinfo=datetime.UTC)
    return (delta.days * 86_400 + delta.seconds) * 1_000_000_000 + delta.microseconds * 1000
