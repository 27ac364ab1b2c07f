"""The names of the log formats and compressions every reader takes: one list, for the readers
and for the words of the commands' help (no import of the readers themselves)."""

from __future__ import annotations

__all__ = ['COMPRESSIONS', 'FORMATS', 'formats_text']

#: format name -> what a user calls it
FORMATS = {'candump': 'candump -L', 'asc': 'Vector ASC', 'blf': 'Vector BLF', 'mcap': 'MCAP',
           'canboat': 'CANboat plain (actisense-serial)', 'ydwg': 'Yacht Devices YDWG raw'}
#: the compressions every format may come in
COMPRESSIONS = ('gzip', 'xz', 'bzip2', 'zstd')


def formats_text() -> str:
    """The formats and compressions in a user's words, for a command's help."""
    return (', '.join(FORMATS.values()) + '; each also ' + ', '.join(COMPRESSIONS[:-1]) + ' or '
            + COMPRESSIONS[-1] + ' compressed')
