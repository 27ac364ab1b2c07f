"""MCAP recording of raw frames and published topics, and recovery after a crash."""

from steer_monitor.record.msgdefs import MsgdefError, msgdef
from steer_monitor.record.recorder import Recorder, RecorderStatus
from steer_monitor.record.recover import RecoverError, RecoverResult, recover

__all__ = ['MsgdefError', 'Recorder', 'RecorderStatus', 'RecoverError', 'RecoverResult', 'msgdef', 'recover']
