"""diagnostic_aggregator's rules, written again from its sources as a test oracle (ros/diagnostics,
diagnostic_aggregator: ``aggregator.cpp``, ``analyzer_group.cpp``, ``generic_analyzer.cpp``,
``generic_analyzer_base.hpp``, ``status_item.cpp``), so the packaged analyzer is judged by the
aggregator's rules, not by the monitor's idea of them:

* the aggregator node is named ``analyzers`` and takes every parameter given to it; ``path`` is
  the base path, each other top-level name with a ``type`` is an analyzer;
* a GenericAnalyzer takes a status whose name matches a ``regex``, equals a ``name``, begins with
  a ``startswith`` or contains a ``contains`` entry (``expected`` names do not match by
  themselves: in ROS 2 they are only made items at start-up, level STALE, message "Missing");
* an item not updated for ``timeout`` seconds (5 unless set) is stale, shown at level STALE;
* a group's level is the most severe of its items'; a stale item makes it STALE, and a STALE
  group with any item neither STALE nor stale reads ERROR ("the header is not stale unless all
  items are"); the same rule again for the group of groups under the base path;
* the top-level state is the most severe level of all statuses the aggregator publishes,
  ERROR when some are STALE and some are not.
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from typing import Any

__all__ = ['AGGREGATOR_NODE', 'ERROR', 'OK', 'STALE', 'WARN', 'Aggregator', 'GenericAnalyzer', 'rcl_parameters']

OK, WARN, ERROR, STALE = 0, 1, 2, 3
#: the name aggregator_node gives its node (Aggregator's constructor)
AGGREGATOR_NODE = 'analyzers'
GENERIC = 'diagnostic_aggregator/GenericAnalyzer'


def _flat(d: Mapping[str, Any], head: str = '') -> dict[str, Any]:
    out: dict[str, Any] = {}
    for key, value in d.items():
        if isinstance(value, Mapping):
            out.update(_flat(value, f'{head}{key}.'))
        else:
            out[f'{head}{key}'] = value
    return out


def rcl_parameters(doc: Mapping[str, Any], node_fqn: str) -> dict[str, Any]:
    """The parameters (flat, dotted) a node of fully qualified name ``node_fqn`` takes from a
    parameters file's document, as rcl's parameter parser matches its keys: ``/**``, ``/*``,
    then the node's own name (with or without the leading slash); a key for another node gives
    it nothing. Later keys win."""
    name = node_fqn.rsplit('/', 1)[-1]
    out: dict[str, Any] = {}
    for key in ('/**', '/*', name, node_fqn.lstrip('/'), node_fqn):
        entry = doc.get(key)
        if isinstance(entry, Mapping) and isinstance(entry.get('ros__parameters'), Mapping):
            out.update(_flat(entry['ros__parameters']))
    return out


@dataclass
class _Item:
    level: int
    message: str
    t_s: float


class GenericAnalyzer:
    """One GenericAnalyzer from its parameters ``params`` (flat, relative to its own key)."""

    def __init__(self, params: Mapping[str, Any], t0_s: float) -> None:
        if params.get('type') != GENERIC:
            raise ValueError(f'not a GenericAnalyzer: {params.get("type")!r}')
        self.path = str(params['path'])
        self.timeout = float(params.get('timeout', 5.0))
        self.names = list(params.get('name', []))
        self.startswith = list(params.get('startswith', []))
        self.contains = list(params.get('contains', []))
        self.regex = [re.compile(r) for r in params.get('regex', [])]
        expected = list(params.get('expected', []))
        if not (expected or self.names or self.startswith or self.contains or self.regex):
            raise ValueError(f'analyzer {self.path}: no way of matching a status')
        self.items = {name: _Item(STALE, 'Missing', t0_s) for name in expected}

    def match(self, name: str) -> bool:
        return (any(r.fullmatch(name) for r in self.regex) or name in self.names
                or any(name.startswith(s) for s in self.startswith) or any(c in name for c in self.contains))

    def analyze(self, name: str, level: int, message: str, t_s: float) -> None:
        self.items[name] = _Item(level, message, t_s)

    def report(self, t_s: float) -> list[tuple[str, int, str]]:
        """(name, level, message): the group's header first, then each item as published."""
        level, all_stale, out = OK, True, []
        for name, item in self.items.items():
            stale = self.timeout > 0 and t_s - item.t_s > self.timeout
            level = max(level, item.level)
            all_stale = all_stale and (item.level == STALE or stale)
            out.append((name, STALE if stale else item.level, item.message))
            if stale:
                level = STALE
        if all_stale:
            level = STALE
        elif level == STALE:
            level = ERROR
        return [(self.path, level, ''), *out]


class Aggregator:
    """The aggregator node with the parameters ``params`` (flat, as :func:`rcl_parameters`
    gives them), started at ``t0_s``."""

    def __init__(self, params: Mapping[str, Any], t0_s: float = 0.0) -> None:
        self.base = str(params.get('path', ''))
        keys = sorted({k.split('.', 1)[0] for k in params if k.endswith('.type')})
        self.analyzers = {k: GenericAnalyzer({n[len(k) + 1:]: v for n, v in params.items()
                                              if n.startswith(k + '.')}, t0_s) for k in keys}
        self.other: dict[str, _Item] = {}

    def feed(self, statuses: Iterable[Any], t_s: float) -> None:
        """One DiagnosticArray's statuses (anything with name, level and message)."""
        for st in statuses:
            took = False
            for a in self.analyzers.values():
                if a.match(st.name):
                    a.analyze(st.name, int(st.level), st.message, t_s)
                    took = True
            if not took:
                self.other[st.name] = _Item(int(st.level), st.message, t_s)

    def report(self, t_s: float) -> tuple[dict[str, int], int]:
        """({path: level} of every group and of the base path, the top-level state)."""
        groups: dict[str, int] = {}
        levels: list[int] = []
        level, all_stale = OK, True
        for a in self.analyzers.values():
            rows = a.report(t_s)
            levels += [lv for _, lv, _ in rows]
            groups[f'/{self.base}/{a.path}' if self.base else f'/{a.path}'] = rows[0][1]
            level = max(level, rows[0][1])
            all_stale = all_stale and rows[0][1] == STALE
        if level == STALE and not all_stale:
            level = ERROR
        if self.base:
            groups[f'/{self.base}'] = level
            levels.append(level)
        # the Other analyzer: what no analyzer took, dropped once stale (timeout 5 s, discard_stale)
        levels += [it.level for it in self.other.values() if t_s - it.t_s <= 5.0]
        top = max(levels, default=-1)
        if top < 0 or (top > ERROR and min(levels) <= ERROR):
            top = ERROR
        return groups, top
