"""What ``monitor.launch.py`` makes of its arguments. Pure (no ROS import), so it is tested
without ``launch``.

A launch argument given overrides the parameters file; one left empty leaves the file's value:
ROS 2 applies a node's parameter sources in order, the last winning, so the overrides go after
the file and only those given go at all.
"""

from __future__ import annotations

from typing import Any

__all__ = ['monitor_parameters', 'truthy']

#: launch argument -> the parameter it overrides
OVERRIDES = (('interface', 'can.interface'), ('channel', 'can.channel'))


def monitor_parameters(params_file: str, **given: str) -> list[Any]:
    """The monitor node's ``parameters``: the file, then the arguments of :data:`OVERRIDES`
    given a value (``interface='socketcan'``)."""
    unknown = set(given) - {arg for arg, _ in OVERRIDES}
    if unknown:
        raise TypeError(f'not an overriding launch argument: {", ".join(sorted(unknown))}')
    overrides = {key: given[arg] for arg, key in OVERRIDES if given.get(arg)}
    return [params_file, overrides] if overrides else [params_file]


def truthy(text: str) -> bool:
    """A boolean launch argument as launch's IfCondition reads one (true/false, 1/0, any case)."""
    word = text.strip().lower()
    if word in ('true', '1'):
        return True
    if word in ('false', '0'):
        return False
    raise ValueError(f'expected true or false, got {text!r}')
