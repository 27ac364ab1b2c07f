"""The codec (one frame with Python integers, arrays with numpy) against cantools, frame ids,
sentinels, and DBC errors."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from steer_monitor.can.codec import CanDatabase, DbcError, load_dbc
from steer_monitor.can.frames import make_id, pgn_of, priority_of, source_of
from test.conftest import PKG

PGNS = (127245, 130314, 128259, 130316)
DBC = PKG / 'config' / 'nmea2000_steering.dbc'


@pytest.fixture(scope='module')
def theirs() -> dict:
    """cantools' messages of the packaged DBC, by PGN: the oracle."""
    import cantools
    return {pgn_of(m.frame_id): m for m in cantools.database.load_file(str(DBC), database_format='dbc').messages}


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
def test_one_frame_and_numpy_decode_as_cantools(db, theirs, pgn, payloads):
    layout = db.message(pgn)
    data = np.frombuffer(b''.join(payloads), np.uint8).reshape(-1, 8)
    words = CanDatabase.words(data)
    for p in payloads:
        assert CanDatabase.decode_raw(layout, p) == theirs[pgn].decode(p, decode_choices=False, scaling=False)
    for name, f in layout.fields.items():
        values = CanDatabase.extract(f, words)
        for i, p in enumerate(payloads):
            assert values[i] == CanDatabase.decode_raw(layout, p)[name]


@settings(max_examples=200, deadline=None)
@given(data=st.data())
def test_numpy_encode_equals_cantools(db, theirs, data):
    pgn = data.draw(st.sampled_from(PGNS))
    layout = db.message(pgn)
    raw = {}
    for name, f in layout.fields.items():
        lo, hi = (-(1 << (f.length - 1)), (1 << (f.length - 1)) - 1) if f.signed else (0, f.mask)
        raw[name] = np.array([data.draw(st.integers(lo, hi))], np.int64)
    ours = CanDatabase.encode(layout, raw, 1)[0].tobytes()
    expected = theirs[pgn].encode({k: int(v[0]) for k, v in raw.items()}, scaling=False, padding=True, strict=False)
    assert ours == expected


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
     'signal Rudder.Position is big-endian'),
    ('VERSION ""\nBO_ 100 Short: 8 X\n SG_ A : 0|8@1+ (1,0) [0|0] "" X\n', 'message Short has an 11-bit identifier'),
    ('this is not a dbc', r'bad.dbc cannot be parsed: line 1: .this is not a dbc. is not a DBC statement'),
    ('VERSION ""\n SG_ A : 0|8@1+ (1,0) [0|0] "" X\n', r'line 2: a signal \(SG_\) outside a message'),
    ('VERSION ""\nBO_ 2314276300 Rudder 8 X\n', r'line 2: a message \(BO_\) not of the form'),
    ('VERSION ""\nBO_ 2314276300 Rudder: 8 X\n SG_ Position : 32|16@1- (0.0001) [0|0] "rad" X\n',
     r'line 3: a signal \(SG_\) not of the form'),
    ('VERSION ""\nBO_ 2314276300 Rudder: 8 X\n SG_ P : 32|32@1- (1,0) [0|0] "" X\n\nSIG_VALTYPE_ 2314276300 P : 1;\n',
     'signal Rudder.P is an IEEE float'),
    ('VERSION ""\nBO_ 2314276300 Rudder: 8 X\n SG_ M M : 0|8@1+ (1,0) [0|0] "" X\n'
     ' SG_ P m1 : 8|8@1+ (1,0) [0|0] "" X\n',
     'signal Rudder.M is multiplexed'),
    ('VERSION ""\nBU_: X\n', 'it holds no message'),
])
def test_bad_dbc(tmp_path, text, msg):
    path = tmp_path / 'bad.dbc'
    path.write_text(text)
    with pytest.raises(DbcError, match=msg):
        load_dbc(path)


def test_missing_dbc(tmp_path):
    with pytest.raises(DbcError, match='no such file'):
        load_dbc(tmp_path / 'nope.dbc')


def _fields(messages) -> list[tuple]:
    """What the codec reads of each message and signal, from ours or cantools' records."""
    out = []
    for m in messages:
        extended = m.extended if hasattr(m, 'extended') else m.is_extended_frame
        sigs = []
        for s in m.signals:
            little = s.little_endian if hasattr(s, 'little_endian') else s.byte_order == 'little_endian'
            signed = s.signed if hasattr(s, 'little_endian') else s.is_signed
            mux = s.multiplex if hasattr(s, 'little_endian') else (
                'M' if s.is_multiplexer else None if s.multiplexer_ids is None else f'm{s.multiplexer_ids[0]}')
            sigs.append((s.name, s.start, s.length, little, signed, float(s.scale), float(s.offset),
                         float(s.minimum or 0.0), float(s.maximum or 0.0), s.unit or '', mux, bool(s.is_float)))
        out.append((m.frame_id, m.name, m.length, extended, sorted(sigs)))
    return out


def test_the_packaged_dbc_reads_as_cantools_reads_it():
    import cantools

    from steer_monitor.can.dbcfile import read_dbc
    ours = read_dbc(DBC)
    assert len(ours) == 4
    assert _fields(ours) == _fields(cantools.database.load_file(str(DBC), database_format='dbc').messages)


@st.composite
def _databases(draw):
    """A DBC as cantools writes it: extended and standard messages, signals of either byte
    order, signed or not, of several scales and offsets, float signals, and comments that run
    over lines and hold what looks like a message."""
    import cantools
    from cantools.database.conversion import BaseConversion
    messages = []
    for k in range(draw(st.integers(1, 4))):
        extended = draw(st.booleans())
        frame_id = draw(st.integers(0, 0x1FFFFFFF if extended else 0x7FF))
        signals = []
        byte = 0
        for j in range(draw(st.integers(1, 5))):
            if byte >= 8:
                break
            nbytes = draw(st.integers(1, min(4, 8 - byte)))
            length = draw(st.integers(8 * nbytes - 7, 8 * nbytes))
            little = draw(st.booleans())
            is_float = length == 32 and draw(st.booleans())
            scale = draw(st.sampled_from([1, 0.1, 0.0001, 2.5, 1e-6]))
            offset = draw(st.sampled_from([0, -40, 0.5, 1000]))
            signals.append(cantools.database.can.Signal(
                name=f'S{k}_{j}', start=8 * byte if little else 8 * byte + 7, length=length,
                byte_order='little_endian' if little else 'big_endian', is_signed=draw(st.booleans()),
                conversion=BaseConversion.factory(scale=scale, offset=offset, is_float=is_float),
                minimum=draw(st.sampled_from([None, -5.0, 0.0])), maximum=draw(st.sampled_from([None, 100.0])),
                unit=draw(st.sampled_from([None, 'rad', 'Pa', 'm/s'])),
                comment=draw(st.sampled_from([None, 'line one\nBO_ 12 Fake: 8 X\n SG_ x', 'a "quoted" word']))))
            byte += nbytes
        messages.append(cantools.database.can.Message(
            frame_id=frame_id, name=f'M{k}', length=8, signals=signals, is_extended_frame=extended,
            comment=draw(st.sampled_from([None, 'two\nlines; BO_ 1 X: 8 Y']))))
    names = {m.frame_id if not m.is_extended_frame else m.frame_id | 0x80000000 for m in messages}
    if len(names) < len(messages):
        messages = messages[:1]
    return cantools.database.can.Database(messages)


@settings(max_examples=150, deadline=None)
@given(database=_databases())
def test_a_dbc_cantools_writes_reads_as_cantools_reads_it(database):
    import cantools

    from steer_monitor.can.dbcfile import parse_dbc
    text = database.as_dbc_string()
    assert _fields(parse_dbc(text)) == _fields(cantools.database.load_string(text, database_format='dbc').messages)


def test_the_message_of_independent_signals_is_no_message():
    """Vector's tools keep signals of no message in a pseudo-message; it is no frame, for cantools
    as for the reader."""
    import cantools

    from steer_monitor.can.dbcfile import parse_dbc
    text = (DBC.read_text() + '\nBO_ 3221225472 VECTOR__INDEPENDENT_SIG_MSG: 0 Vector__XXX\n'
            ' SG_ Spare : 0|8@1+ (1,0) [0|0] "" Vector__XXX\n')
    ours = parse_dbc(text)
    assert [m.name for m in ours] == ['Rudder', 'ActualPressure', 'SpeedWaterReferenced', 'TemperatureExtendedRange']
    assert _fields(ours) == _fields(cantools.database.load_string(text, database_format='dbc').messages)
