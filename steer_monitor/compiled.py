"""The compiled loops: numba where it is installed, the same functions interpreted where not.

The model's element function, the estimator's walks over samples and the live monitor's
instants are plain Python loops over numpy arrays, written so that numba compiles them. numba
is optional: Ubuntu 24.04, on which ROS 2 Jazzy and Kilted run, packages no ``python3-numba``
(Debian 12 and 13 do), and a vessel's install takes nothing from pip into the system Python.
Without it every one of those functions runs as written, giving the same answers; what
changes is the time (``docs/vessel.md`` has the figures and the commands): the live model's CPU
at the full bus rate is the same, an analysis takes ten to fifty times as long. So long that a
node without numba runs no analysis (an interpreted one holds up the bus reader: frames are
lost); the commands ashore run them, slower.

:func:`njit` is the one way the package compiles a function; :data:`COMPILED` says which way
it went, and :func:`interpreted_note` is the line the commands say when numba is missing.
"""

from __future__ import annotations

import importlib.util
from collections.abc import Callable
from typing import Any, TypeVar

__all__ = ['COMPILED', 'INTERPRETED', 'interpreted_note', 'njit']

F = TypeVar('F', bound=Callable[..., Any])

#: whether numba is installed (found without importing it: it loads about 70 MB, which a
#: command that never runs a compiled loop does not pay for)
COMPILED: bool = importlib.util.find_spec('numba') is not None


def njit(**options: Any) -> Callable[[F], F]:
    """``numba.njit(**options)`` where numba is installed; else a decorator that returns the
    function as it is (interpreted: the same results, the loops at Python's speed)."""
    if not COMPILED:
        return _as_written
    import numba
    return numba.njit(**options)


def _as_written(func: F) -> F:
    return func


#: what a user is told when numba is missing
INTERPRETED = ('numba is not installed: the model and the estimator run interpreted, with the same answers, '
               'each analysis ten to fifty times as long (install python3-numba where the OS packages it, or '
               'numba in the environment the command runs in)')


def interpreted_note() -> str | None:
    """:data:`INTERPRETED` when numba is missing, None when it is there."""
    return None if COMPILED else INTERPRETED
