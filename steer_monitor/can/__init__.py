"""The steering CAN bus: frames, the DBC codec, the signal map, decoding with rejects
counted per reason, the listen-only bus, and log files.

Pure parts (frames, codec, signals, decoder, rejects) import no python-can; the bus and the
log readers are the boundary where python-can, cantools and mcap errors become
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
