"""The error hierarchy of steer_monitor.

Every error the package raises on purpose derives from :class:`SteerMonitorError`, so a
caller can catch one type at the boundary. Third-party errors are converted where they
enter (file readers, buses), never passed through raw.
"""

from __future__ import annotations

__all__ = [
    'FitError',
    'InputError',
    'ModelError',
    'OutputError',
    'ParameterError',
    'SteerMonitorError',
]


class SteerMonitorError(Exception):
    """Base of all steer_monitor errors."""


class ParameterError(SteerMonitorError, ValueError):
    """A parameter or configuration value is missing, of the wrong type or out of range.

    The message names the parameter (its dotted key) and what was wrong with it.
    """


class FitError(SteerMonitorError, ValueError):
    """An ISO 286 fit designation cannot be parsed or lies outside the supported tables."""


class ModelError(SteerMonitorError, ValueError):
    """The physical model cannot be evaluated for the given inputs (e.g. the ram buckles)."""


class InputError(SteerMonitorError, ValueError):
    """An input file cannot be read as what it claims to be (the message names the file)."""


class OutputError(SteerMonitorError):
    """An output cannot be written (no such directory, permission denied, disk full...);
    the message names the path. Nothing half-written is left under that name."""
