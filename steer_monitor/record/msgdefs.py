"""ROS 2 message definitions in the concatenated ``ros2msg`` form MCAP schemas embed (as
rosbag2 writes them), read from the ``.msg`` files of the installed interface packages."""

from __future__ import annotations

import functools
import os
import re
import sys
from pathlib import Path

from steer_monitor.errors import SteerMonitorError
from steer_monitor.logfiles.typehash import SEPARATOR

__all__ = ['MsgdefError', 'msgdef']

PRIMITIVES = {'bool', 'byte', 'char', 'float32', 'float64', 'int8', 'uint8', 'int16', 'uint16',
              'int32', 'uint32', 'int64', 'uint64', 'string', 'wstring'}


class MsgdefError(SteerMonitorError):
    """A message definition cannot be found."""


def _share_dirs() -> list[Path]:
    dirs = [Path(p) / 'share' for p in os.environ.get('AMENT_PREFIX_PATH', '').split(os.pathsep) if p]
    dirs.append(Path(sys.prefix) / 'share')
    return dirs


def _msg_file(datatype: str) -> Path:
    pkg, _, name = datatype.partition('/msg/')
    for share in _share_dirs():
        path = share / pkg / 'msg' / f'{name}.msg'
        if path.is_file():
            return path
    msg = f'no definition of {datatype} found (looked in share/{pkg}/msg under: ' + \
        ', '.join(str(d) for d in _share_dirs()) + ')'
    raise MsgdefError(msg)


def _field_types(text: str, pkg: str) -> list[str]:
    out = []
    for line in text.splitlines():
        line = line.split('#', 1)[0].strip()
        if not line:
            continue
        if '=' in line:
            continue  # a constant: TYPE NAME=VALUE
        base = re.sub(r'(<=\d+)?(\[[^\]]*\])?$', '', line.split()[0])  # string<=5[] -> string
        if base in PRIMITIVES:
            continue
        if '/' not in base:
            base = f'{pkg}/{base}'
        parts = base.split('/')
        out.append(f'{parts[0]}/msg/{parts[-1]}')
    return out


@functools.cache
def msgdef(datatype: str) -> str:
    """``pkg/msg/Name`` -> its definition followed by every dependency's, depth first."""
    seen: list[str] = []
    texts: dict[str, str] = {}

    def visit(t: str) -> None:
        if t in texts:
            return
        text = _msg_file(t).read_text(encoding='utf-8')
        texts[t] = text
        seen.append(t)
        for dep in _field_types(text, t.split('/')[0]):
            visit(dep)

    visit(datatype)
    parts = [texts[datatype].rstrip('\n')]
    for t in seen[1:]:
        pkg, _, name = t.partition('/msg/')
        parts.append(f'{SEPARATOR}\nMSG: {pkg}/{name}\n{texts[t].rstrip(chr(10))}')
    return '\n'.join(parts) + '\n'
