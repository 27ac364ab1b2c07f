"""The real NMEA 2000 captures of ``../shared/realbus`` (skipped where they are not here) and
their CANboat rows."""

from __future__ import annotations

import csv

import pytest

from test.conftest import SHARED

__all__ = ['MERRIMAC', 'REALBUS', 'SUSTERANNA', 'SUSTERANNA_2020', 'canboat_rows', 'capture']

REALBUS = SHARED / 'realbus'
SUSTERANNA = REALBUS / 'susteranna-actisense-serial.raw'
SUSTERANNA_2020 = REALBUS / 'susteranna2020.raw'
MERRIMAC = REALBUS / 'merrimac-ydwg-2020.raw'


def capture(path):
    if not path.is_file():
        pytest.skip(f'{path} is not here (../shared beside the repository holds it in CI)')
    return path


def canboat_rows(path):
    rows = []
    with open(path, newline='') as fh:
        for row in csv.reader(fh):
            if row and not row[0].startswith('#'):
                rows.append(row)
    return rows
