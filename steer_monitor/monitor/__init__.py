"""The live monitor (pure): sample-by-sample model, performance tracking and diagnostics."""

from steer_monitor.monitor.diagnostics import (
    ERROR,
    OK,
    STALE,
    WARN,
    DiagnosticsBuilder,
    DiagnosticsConfig,
    Status,
)
from steer_monitor.monitor.live import LiveMonitor, LiveState

__all__ = ['ERROR', 'OK', 'STALE', 'WARN', 'DiagnosticsBuilder', 'DiagnosticsConfig',
           'LiveMonitor', 'LiveState', 'Status']
