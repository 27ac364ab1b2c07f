"""The DBC against CANboat's PGN database (``../shared/realbus/canboat.json``, read where it
lies, never copied): for every PGN the project decodes, each field's bit position, length,
resolution, sign and unit as CANboat has them from real devices."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

from test.conftest import SHARED

CANBOAT = SHARED / 'realbus' / 'canboat.json'


@pytest.fixture(scope='module')
def canboat() -> dict[int, dict]:
    if not CANBOAT.is_file():
        pytest.skip(f'{CANBOAT} is not here (../shared beside the repository holds it in CI)')
    doc = json.loads(Path(CANBOAT).read_text(encoding='utf-8'))
    out: dict[int, dict] = {}
    for p in doc['PGNs']:
        out.setdefault(int(p['PGN']), p)      # the first definition of a PGN (no proprietary variants here)
    return out


def _fields(db):
    for pgn, layout in sorted(db.by_pgn.items()):
        for name, f in layout.fields.items():
            yield pgn, layout, name, f


def test_every_decoded_pgn_is_in_canboat(db, canboat):
    for pgn, layout in db.by_pgn.items():
        assert pgn in canboat, pgn
        assert canboat[pgn].get('Length', 8) == layout.length, pgn


def test_every_field_matches_canboat(db, canboat):
    checked = 0
    for pgn, layout, name, f in _fields(db):
        ours = name.lower()
        theirs = {c['Id'].lower(): c for c in canboat[pgn]['Fields']}
        c = theirs.get(ours)
        assert c is not None, f'PGN {pgn} ({layout.name}): CANboat has no field {name} ({sorted(theirs)})'
        assert (f.start, f.length) == (c['BitOffset'], c['BitLength']), (pgn, name)
        assert math.isclose(f.scale, float(c.get('Resolution', 1)), rel_tol=1e-12), (pgn, name)
        assert f.offset == float(c.get('Offset', 0)), (pgn, name)
        if f.length > 1 and c.get('FieldType') == 'NUMBER':
            assert f.signed == bool(c.get('Signed')), (pgn, name)
        assert (f.unit or None) == (c.get('Unit') or None), (pgn, name, f.unit, c.get('Unit'))
        checked += 1
    assert checked >= 17


def test_the_pressure_source_the_map_takes_is_hydraulic(canboat, r18_params):
    """PGN 130314 on real buses is often a barometer (source 0, atmospheric): the packaged
    map takes the rams' pressures only from CANboat's 'hydraulic' source."""
    lookup = next(c['LookupEnumeration'] for c in canboat[130314]['Fields'] if c['Id'] == 'source')
    doc = json.loads(CANBOAT.read_text(encoding='utf-8'))
    values = {int(v['Value']): v['Name'] for e in doc['LookupEnumerations'] if e['Name'] == lookup
              for v in e['EnumValues']}
    for name in ('pressure_r1_stbd', 'pressure_r1_port', 'pressure_r2_stbd', 'pressure_r2_port'):
        src = r18_params[f'signals.{name}.source']
        assert values[src].lower().startswith('hydraulic'), (name, src, values[src])
        assert values[0].lower().startswith('atmospheric') and src != 0
