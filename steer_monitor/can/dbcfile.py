"""The messages and signals of a DBC file: what the codec needs of it, read without cantools.

Why not cantools here: the node reads the DBC on a vessel, whose install takes its Python
packages from the OS (rosdep, apt) and nothing from pip into the system Python, and no
distribution ROS 2 Jazzy or Kilted runs on packages cantools (nor textparser, its parser).
What the codec reads of a DBC is small and fixed by the format: each message (``BO_``) with
its identifier, name and length, each of its signals (``SG_``) with its bit position, size,
byte order, signedness, scale, offset and unit; and which signals are IEEE floats
(``SIG_VALTYPE_``) or multiplexed (``M``/``m<n>``), which the codec refuses. Everything else
(comments, attributes, value tables, nodes, Vector's message of independent signals) is passed
over. cantools stays the oracle: the
tests read the packaged DBC and generated ones with both and compare every field, and
compare the codec's decoding of random payloads with cantools' own.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, replace
from pathlib import Path

from steer_monitor.atomic import os_reason
from steer_monitor.errors import SteerMonitorError

__all__ = ['INDEPENDENT_SIGNALS', 'DbcError', 'DbcMessage', 'DbcSignal', 'parse_dbc', 'read_dbc']

#: the pseudo-message Vector's tools keep signals of no message in: not a frame (cantools
#: passes it over too)
INDEPENDENT_SIGNALS = 'VECTOR__INDEPENDENT_SIG_MSG'


class DbcError(SteerMonitorError):
    """The DBC cannot be read or holds what the codec does not support."""


@dataclass(frozen=True)
class DbcSignal:
    """One ``SG_`` line: bits counted as the DBC counts them (``start`` of a little-endian
    signal is its least significant bit, from bit 0 of byte 0)."""

    name: str
    start: int
    length: int
    little_endian: bool
    signed: bool
    scale: float
    offset: float
    minimum: float
    maximum: float
    unit: str
    multiplex: str | None = None     # 'M' (the multiplexer), 'm<n>' (multiplexed), None
    is_float: bool = False           # SIG_VALTYPE_ 1 or 2


@dataclass(frozen=True)
class DbcMessage:
    """One ``BO_`` line and its signals; ``frame_id`` without the extended flag (bit 31)."""

    frame_id: int
    name: str
    length: int
    extended: bool
    signals: tuple[DbcSignal, ...]


_NUMBER = r'[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?'
_BO = re.compile(r'BO_\s+(\d+)\s+(\w+)\s*:\s*(\d+)\s+\w+\s*$')
_SG = re.compile(rf'SG_\s+(\w+)\s*(M|m\d+M?)?\s*:\s*(\d+)\|(\d+)@([01])([-+])\s*\(\s*({_NUMBER})\s*,\s*({_NUMBER})\s*\)'
                 rf'\s*\[\s*({_NUMBER})\s*\|\s*({_NUMBER})\s*\]\s*"([^"]*)"(?:\s+[\w,\s]*)?$')
_VALTYPE = re.compile(r'SIG_VALTYPE_\s+(\d+)\s+(\w+)\s*:?\s*([0-3])\s*;')
#: a statement's keyword at the start of a line (DBC keywords are upper case, most end in _)
_KEYWORD = re.compile(r'[A-Z][A-Z0-9_]*\b')
#: a double-quoted string of the DBC (comments and attribute values may span lines)
_STRING = re.compile(r'"(?:[^"\\]|\\.)*"', re.DOTALL)


def _blank_strings(text: str) -> str:
    """``text`` with each quoted string's content blanked, its line breaks kept (so that a
    comment's text never reads as a statement, and line numbers stay right). The unit of a
    signal is kept: ``SG_`` lines are read from the original line."""
    return _STRING.sub(lambda m: '"' + re.sub(r'[^\n]', ' ', m.group(0)[1:-1]) + '"', text)


def parse_dbc(text: str, source: str = 'DBC') -> list[DbcMessage]:
    """The messages of the DBC ``text`` in file order; :class:`DbcError` naming ``source`` and
    the line for what does not read as DBC."""
    lines = text.splitlines()
    blanked = _blank_strings(text).splitlines()
    messages: list[tuple[int, str, int, bool, list[DbcSignal]]] = []
    floats: dict[tuple[int, str], bool] = {}
    current: list[DbcSignal] | None = None
    continuing = False          # inside a statement that runs over lines (ends with ';')
    symbols = False             # in NS_'s list of symbols (indented lines)
    for number, (line, plain) in enumerate(zip(lines, blanked), start=1):
        stripped = plain.strip()
        if not stripped or stripped.startswith('//'):
            continue
        if continuing:
            continuing = not stripped.endswith(';')
            continue
        if symbols and plain[:1].isspace():
            continue
        symbols = False
        if stripped.startswith('SG_ ') or stripped == 'SG_':
            if current is None:
                msg = f'{source} cannot be parsed: line {number}: a signal (SG_) outside a message (BO_)'
                raise DbcError(msg)
            current.append(_signal(line.strip(), source, number))
            continue
        if plain[:1].isspace() and current is not None and not stripped.startswith('BO_'):
            msg = f'{source} cannot be parsed: line {number}: {stripped[:60]!r} in a message is not a signal (SG_)'
            raise DbcError(msg)
        keyword = _KEYWORD.match(stripped)
        if keyword is None:
            msg = f'{source} cannot be parsed: line {number}: {stripped[:60]!r} is not a DBC statement'
            raise DbcError(msg)
        word = keyword.group(0)
        current = None
        if word == 'BO_':
            m = _BO.match(stripped)
            if m is None:
                msg = (f'{source} cannot be parsed: line {number}: a message (BO_) not of the form '
                       f'BO_ id name: length node')
                raise DbcError(msg)
            raw_id = int(m.group(1))
            current = []
            messages.append((raw_id, m.group(2), int(m.group(3)), bool(raw_id & 0x80000000), current))
        elif word == 'SIG_VALTYPE_':
            m = _VALTYPE.match(stripped)
            if m is not None:
                floats[(int(m.group(1)), m.group(2))] = m.group(3) in ('1', '2')
        elif word in ('CM_', 'BA_', 'BA_DEF_', 'BA_DEF_DEF_', 'VAL_', 'VAL_TABLE_', 'BO_TX_BU_', 'SG_MUL_VAL_',
                      'SIG_GROUP_', 'EV_', 'ENVVAR_DATA_', 'SGTYPE_', 'SIG_TYPE_REF_', 'BA_DEF_REL_', 'BA_REL_',
                      'BA_DEF_DEF_REL_', 'BU_SG_REL_', 'BU_EV_REL_', 'BU_BO_REL_', 'CAT_DEF_', 'CAT_',
                      'FILTER') and not stripped.endswith(';'):
            continuing = True
        elif word == 'NS_':
            symbols = True
    if not messages:
        msg = f'{source} cannot be parsed: it holds no message (BO_)'
        raise DbcError(msg)
    out = []
    for raw_id, name, length, extended, signals in messages:
        if name == INDEPENDENT_SIGNALS:
            continue
        sigs = tuple(replace(s, is_float=floats.get((raw_id, s.name), False)) for s in signals)
        out.append(DbcMessage(raw_id & 0x1FFFFFFF if extended else raw_id, name, length, extended, sigs))
    return out


def _signal(line: str, source: str, number: int) -> DbcSignal:
    m = _SG.match(line)
    if m is None:
        msg = (f'{source} cannot be parsed: line {number}: a signal (SG_) not of the form '
               f'SG_ name : start|length@order sign (scale,offset) [min|max] "unit" receivers')
        raise DbcError(msg)
    name, mux, start, length, order, sign, scale, offset, lo, hi, unit = m.groups()
    if int(length) < 1:
        msg = f'{source} cannot be parsed: line {number}: signal {name} has no bits'
        raise DbcError(msg)
    return DbcSignal(name, int(start), int(length), order == '1', sign == '-', float(scale), float(offset),
                     float(lo), float(hi), unit, mux)


def read_dbc(path: str | Path) -> list[DbcMessage]:
    """:func:`parse_dbc` of the file at ``path`` (UTF-8, or Latin-1 as older tools write);
    the OS's errors become :class:`DbcError`."""
    path = Path(path)
    try:
        data = path.read_bytes()
    except FileNotFoundError as exc:
        msg = f'cannot read DBC file {path}: no such file'
        raise DbcError(msg) from exc
    except OSError as exc:
        msg = f'cannot read DBC file {path}: {os_reason(exc)}'
        raise DbcError(msg) from exc
    try:
        text = data.decode('utf-8')
    except UnicodeDecodeError:
        text = data.decode('latin-1')
    return parse_dbc(text, f'DBC file {path}')
