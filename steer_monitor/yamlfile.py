"""Reading the YAML files a user gives (parameters, chains) without surprises.

A parameters file is small and plain. Refused, each with one line naming the file:
non-UTF-8 bytes (with their offset), files over ``MAX_BYTES``, YAML aliases (``*name``:
an alias bomb expands a few lines into billions of nodes when walked), nesting deeper than
the parser's recursion allows, and anything PyYAML cannot parse.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import yaml

from steer_monitor.atomic import note_input
from steer_monitor.errors import ParameterError

__all__ = ['MAX_BYTES', 'load_yaml']

MAX_BYTES = 1 << 20


class _Loader(yaml.SafeLoader):
    """The safe loader, refusing aliases."""

    def compose_node(self, parent: Any, index: Any) -> Any:
        if self.check_event(yaml.AliasEvent):
            event = self.peek_event()
            msg = 'YAML aliases (*name) are not accepted'
            raise yaml.composer.ComposerError(None, None, msg, event.start_mark)
        return super().compose_node(parent, index)


def load_yaml(path: str | Path, what: str) -> Any:
    """The document in ``path``; :class:`ParameterError` naming ``what`` (e.g. "parameters
    file") and the path when it cannot be read as plain YAML."""
    path = Path(path)
    note_input(path)
    try:
        with open(path, 'rb') as fh:
            raw = fh.read(MAX_BYTES + 1)
    except OSError as exc:
        msg = f'cannot read {what} {path}: {exc.strerror or exc}'
        raise ParameterError(msg) from exc
    if len(raw) > MAX_BYTES:
        msg = f'{what} {path} is over {MAX_BYTES // 1024} KiB; it cannot be a parameters file'
        raise ParameterError(msg)
    try:
        text = raw.decode('utf-8')
    except UnicodeDecodeError as exc:
        msg = f'{what} {path} is not UTF-8 text (byte 0x{raw[exc.start]:02X} at offset {exc.start})'
        raise ParameterError(msg) from exc
    try:
        return yaml.load(text, Loader=_Loader)  # noqa: S506 - _Loader is the safe loader without aliases
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        where = f' (line {mark.line + 1}, column {mark.column + 1})' if mark is not None else ''
        msg = f'{what} {path} is not valid YAML: {exc.problem or exc.context}{where}'
        raise ParameterError(msg) from exc
    except yaml.YAMLError as exc:
        msg = f'{what} {path} is not valid YAML: ' + ' '.join(str(exc).split())
        raise ParameterError(msg) from exc
    except RecursionError as exc:
        msg = f'{what} {path} is nested too deeply to be a parameters file'
        raise ParameterError(msg) from exc
