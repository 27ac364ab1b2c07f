"""The steering CAN bus: frames, the DBC codec, the signal map, the devices, decoding with
rejects counted per reason, the bus clock and time-jump rule, and the listen-only bus.

Log files are :mod:`steer_monitor.logfiles`; discovering a bus's streams from a log is
:mod:`steer_monitor.ashore.discovery`. Pure parts (frames, codec, signals, decoder, rejects)
import no python-can; the bus is the boundary where python-can's errors become
steer_monitor errors.
"""

from steer_monitor.can.codec import CanDatabase, DbcError, load_dbc
from steer_monitor.can.decoder import Decoder, Sample, Series, SignalSet, collect
from steer_monitor.can.frames import Frame, FrameArrays, make_id, pgn_of
from steer_monitor.can.rejects import REASONS, RejectCounter, RejectSnapshot
from steer_monitor.can.signals import INPUTS, PRESSURE_INPUTS, SignalMap, SignalSpec

__all__ = [
    'CanDatabase',
    'DbcError',
    'Decoder',
    'Frame',
    'FrameArrays',
    'INPUTS',
    'PRESSURE_INPUTS',
    'REASONS',
    'RejectCounter',
    'RejectSnapshot',
    'Sample',
    'Series',
    'SignalMap',
    'SignalSet',
    'SignalSpec',
    'collect',
    'load_dbc',
    'make_id',
    'pgn_of',
]
