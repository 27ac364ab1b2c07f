"""Aligned text tables for people: the commands' and the studies' printed answers."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, TextIO

__all__ = ['table']


def table(headers: Sequence[str], rows: Sequence[Sequence[Any]], out: TextIO) -> None:
    """Write a text table: first column left-aligned (names), the rest right-aligned."""
    cells = [[str(h) for h in headers]] + [[str(c) for c in r] for r in rows]
    widths = [max(len(r[i]) for r in cells) for i in range(len(headers))]
    for k, row in enumerate(cells):
        line = [c.ljust(w) if i == 0 else c.rjust(w) for i, (c, w) in enumerate(zip(row, widths))]
        out.write('  '.join(line).rstrip() + '\n')
        if k == 0:
            out.write('  '.join('-' * w for w in widths) + '\n')
