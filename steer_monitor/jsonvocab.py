"""The words of the JSON every command writes (docs/json.md), and an estimate in text.

An estimate is ``{"value", "ci95": [lo, hi], "bounded"}`` (plus ``"level"`` where a limit
judges it): ``value`` is the best estimate, ``ci95`` its 95 % interval, ``bounded`` false
when an end is open. An estimate the data bound from one side only is no point value: its
``value`` is null and the open end of ``ci95`` is null (``{"value": null, "ci95": [0.197,
null], "bounded": false}``: at least 0.197). One bounded from neither side is all null.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

__all__ = ['estimate_text']


def _decimals(x: float) -> int:
    """The decimals ``x`` is written with in the JSON (its digits after the point, at most 10)."""
    if not math.isfinite(x):
        return 0
    text = f'{abs(x):.10f}'.rstrip('0')
    return len(text) - text.index('.') - 1


def estimate_text(d: Mapping[str, Any], unit: str = '', digits: int | None = None) -> str:
    """An estimate of the JSON vocabulary as a person reads it: ``0.245 mm [0.232 .. 0.261]``,
    ``>= 0.197 mm (lower bound only)``, ``<= 0.1 (upper bound only)``, ``not determined``.
    ``digits``: decimals shown (None: as many as the JSON gives the value and its interval's
    ends, the same for the three, so that ``0.27`` rounded to four decimals reads ``0.2700
    [0.2629 .. 0.2836]``, not as a coarser value than its interval)."""
    value = d.get('value')
    lo, hi = d.get('ci95', (None, None))
    if digits is None:
        digits = max((_decimals(x) for x in (value, lo, hi) if x is not None), default=0)

    def num(x: float) -> str:
        return f'{x:.{digits}f}'
    u = f' {unit}' if unit else ''
    if value is None or lo is None or hi is None:
        if lo is not None and hi is None:
            return f'>= {num(lo)}{u} (lower bound only)'
        if hi is not None and lo is None:
            return f'<= {num(hi)}{u} (upper bound only)'
        if value is None:
            return 'not determined'
    return f"{num(value)}{u} [{'-' if lo is None else num(lo)} .. {'unbounded' if hi is None else num(hi)}]"
