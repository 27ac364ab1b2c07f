"""The numpy codec against cantools, frame ids, sentinels, and DBC errors."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from steer_monitor.can.codec import CanDatabase, DbcError, load_dbc
from steer_monitor.can.frames import make_id, pgn_of, priority_of, source_of

PGNS = (127245, 130314, 128259, 130316)


@pytest.mark.parametrize(
    'priority,pgn,source', [(2, 127245, 0x10), (7, 130314, 0xFE), (0, 128259, 0), (5, 130316, 0x40)]
)
def test_id_round_trip(priority, pgn, source):
    can_id = make_id(priority, pgn, source)
    assert (priority_of(can_id), pgn_of(can_id), source_of(can_id)) == (priority, pgn, source)


def test_pdu1_pgn_drops_destination():
    # PGN 59904 (ISO request, PDU1): the low byte of the PGN field is a destination address.
    assert pgn_of(make_id(6, 59904 | 0x23, 0x10)) == 59904


@settings(max_examples=300, deadline=None)
@given(pgn=st.sampled_from(PGNS), payloads=st.lists(st.binary(min_size=8, max_size=8), min_size=1, max_size=20))
def test_numpy_extract_equals_cantools(db, pgn, payloads):
    layout = db.message(pgn)
    data = np.frombuffer(b''.join(payloads), np.uint8).reshape(-1, 8)
    words = CanDatabase.words(data)
    for name, f in layout.fields.items():
        values = CanDatabase.extract(f, words)
        for i, p in enumerate(payloads):
            assert values[i] == CanDatabase.decode_raw(layout, p)[name]


@settings(max_examples=200, deadline=None)
@given(data=st.data())
def test_numpy_encode_equals_cantools(db, data):
    pgn = data.draw(st.sampled_from(PGNS))
    layout = db.message(pgn)
    raw = {}
    for name, f in layout.fields.items():
        lo, hi = (-(1 << (f.length - 1)), (1 << (f.length - 1)) - 1) if f.signed else (0, f.mask)
        raw[name] = np.array([data.draw(st.integers(lo, hi))], np.int64)
    ours = CanDatabase.encode(layout, raw, 1)[0].tobytes()
    theirs = layout.message.encode({k: int(v[0]) for k, v in raw.items()}, scaling=False, padding=True, strict=False)
    assert ours == theirs


@pytest.mark.parametrize('length,signed,na,err', [(16, True, 0x7FFF, 0x7FFE), (16, False, 0xFFFF, 0xFFFE),
                                                  (24, False, 0xFFFFFF, 0xFFFFFE), (32, True, 0x7FFFFFFF, 0x7FFFFFFE),
                                                  (3, False, 7, 6)])
def test_sentinels(length, signed, na, err):
    from steer_monitor.can.codec import FieldLayout
    f = FieldLayout('x', 0, length, signed, 1.0, 0.0, '')
    assert (f.not_available, f.error) == (na, err)


def test_encode_refuses_out_of_range(db):
    layout = db.message(127245)
    with pytest.raises(ValueError, match=r'Rudder.Position: raw value outside -32768..32767'):
        CanDatabase.encode(layout, {'Position': np.array([40000])}, 1)


@pytest.mark.parametrize('text,msg', [
    ('VERSION ""\nBO_ 2314276300 Rudder: 8 X\n SG_ Position : 39|16@0- (0.0001,0) [0|0] "rad" X\n',
     'is big-endian'),
    ('VERSION ""\nBO_ 100 Short: 8 X\n SG_ A : 0|8@1+ (1,0) [0|0] "" X\n', 'has an 11-bit identifier'),
    ('this is not a dbc', 'cannot be parsed'),
])
def test_bad_dbc(tmp_path, text, msg):
    path = tmp_path / 'bad.dbc'
    path.write_text(text)
    with pytest.raises(DbcError, match=msg):
        load_dbc(path)


def test_missing_dbc(tmp_path):
    with pytest.raises(DbcError, match='no such file'):
        load_dbc(tmp_path / 'nope.dbc')
