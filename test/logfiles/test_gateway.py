"""Gateway logs (CANboat plain, YDWG raw): formats told by content, frames rebuilt, what is not
a frame counted; and the real captures of ``../shared/realbus`` through both decode paths."""

from __future__ import annotations

import datetime
import os

import numpy as np
import pytest

from steer_monitor.can import Decoder, FrameArrays, RejectCounter, collect, make_id, pgn_of
from steer_monitor.can.busconfig import load_setup
from steer_monitor.logfiles.blocks import iter_log, iter_log_blocks, read_log_fast
from steer_monitor.logfiles.gateway import canboat_id, ydwg_date
from steer_monitor.logfiles.logs import LogError, log_format
from test.conftest import PKG
from test.support.captures import MERRIMAC, SUSTERANNA, SUSTERANNA_2020, canboat_rows, capture

DAY = datetime.date(2020, 8, 22)


# --- formats ------------------------------------------------------------------------------
@pytest.mark.parametrize('name, text, fmt', [
    ('a.raw', '2016-04-09T16:41:09.078Z,3,127257,17,255,8,00,ff,7f,52,00,21,fe,ff\n', 'canboat'),
    ('a.log', '2011-11-24-22:42:04.388,2,127250,36,255,8,00,ce,76,ff,7f,ff,7f,fd\n', 'canboat'),
    ('a.raw', '00:29:58.617 R 0DFF180D A2 8C 50 C0 FF FF FF FF\n', 'ydwg'),
    ('a.txt', '(1745600961.335462) can0 11FC1063#003DFFFF02000100\n', 'candump'),
    ('a.raw', '# comment\n\n(0.352000) vcan0 09F20101#601A00B706670D0B\n', 'candump'),
    ('a.log', '', 'candump'),                       # empty: the suffix says
    ('a.asc', 'date Mon Jan 1 00:00:00.000 am 2024\nbase hex  timestamps absolute\n', 'asc'),
])
def test_format_by_content_then_suffix(tmp_path, name, text, fmt):
    path = tmp_path / name
    path.write_text(text)
    assert log_format(path) == fmt


def test_unknown_content_and_suffix_is_one_clear_error(tmp_path):
    path = tmp_path / 'notes.raw'
    path.write_text('this is not a log\n')
    with pytest.raises(LogError, match=r"notes.raw: unsupported log format '.raw': its content is none of"):
        list(iter_log(path))


@pytest.mark.parametrize('prio, pgn, src, dst', [(2, 127245, 13, 255), (6, 60928, 16, 255), (6, 59904, 3, 35),
                                                  (3, 126208, 25, 17), (7, 130314, 0, 255)])
def test_canboat_id_puts_the_destination_in_pdu1(prio, pgn, src, dst):
    can_id = canboat_id(prio, pgn, src, dst)
    assert int(pgn_of(can_id)) == pgn
    assert can_id & 0xFF == src
    assert (can_id >> 26) & 7 == prio
    pf = (pgn >> 8) & 0xFF
    if pf < 240:
        assert (can_id >> 8) & 0xFF == dst
    else:
        assert can_id == make_id(prio, pgn, src)


@pytest.mark.parametrize('line, reason, text', [
    ('2016-04-09T16:41:09.078Z,3,127257,17,255,8,00,ff,7f', 'malformed_record', 'length 8 with 3 bytes'),
    ('2016-04-09T16:41:09.078Z,3,127257,17,255,2,00,zz', 'malformed_record', 'x.raw line 2'),
    ('2016-13-09T16:41:09.078Z,3,127257,17,255,1,00', 'malformed_record', 'timestamp'),
    ('2016-04-09T16:41:09.078Z,9,127257,17,255,1,00', 'malformed_record', 'priority 9'),
    ('2016-04-09T16:41:09.078Z,0,262161,0,0,2,01,0e', 'gateway_record', 'PGN 262161 from source 0'),
    ('2016-04-09T16:41:09.079Z,7,126720,16,255,9,11,99,a2,23,01,01,18,00,99', 'multi_frame',
     'PGN 126720 from source 16, 9 bytes'),
])
def test_canboat_lines_that_are_no_frame_are_counted(tmp_path, line, reason, text):
    path = tmp_path / 'x.raw'
    path.write_text('2016-04-09T16:41:09.000Z,2,127245,13,255,8,ff,f8,ff,7f,10,00,ff,ff\n' + line + '\n')
    r = RejectCounter()
    frames = list(iter_log(path, r))
    assert len(frames) == 1 and frames[0].can_id == make_id(2, 127245, 13)
    assert frames[0].t_ns == int(datetime.datetime(2016, 4, 9, 16, 41, 9, tzinfo=datetime.UTC).timestamp()) * 10 ** 9
    assert r.snapshot().counts == {reason: 1}
    assert text in r.snapshot().last[reason]


def test_canboat_time_forms_agree(tmp_path):
    path = tmp_path / 'x.raw'
    path.write_text('2016-04-09T16:41:09.078Z,2,127245,13,255,1,ff\n2016-04-09-16:41:09.078,2,127245,13,255,1,fe\n')
    a, b = list(iter_log(path))
    assert a.t_ns == b.t_ns == int(datetime.datetime(2016, 4, 9, 16, 41, 9, 78000,
                                                      tzinfo=datetime.UTC).timestamp() * 1e6) * 1000


def test_ydwg_midnight_is_the_next_day_and_a_step_back_stays(tmp_path):
    path = tmp_path / 'x.raw'
    path.write_text('23:59:59.900 R 09F10D0D FF F8 FF 7F 10 00 FF FF\n'
                    '00:00:00.100 R 09F10D0D FF F8 FF 7F 11 00 FF FF\n'
                    '00:00:00.050 T 09F10D0D FF F8 FF 7F 12 00 FF FF\n'
                    '25:00:00.000 R 09F10D0D FF\n'
                    '00:00:01.000 R 09F10D0D FF F8 FF 7F 13 00 FF\n')
    r = RejectCounter()
    frames = list(iter_log(path, r, datetime.date(2024, 2, 28)))
    midnight = int(datetime.datetime(2024, 2, 29, tzinfo=datetime.UTC).timestamp()) * 10 ** 9
    assert [f.t_ns - midnight for f in frames] == [-100_000_000, 100_000_000, 50_000_000, 1_000_000_000]
    assert [len(f.data) for f in frames] == [8, 8, 8, 7]
    assert r.snapshot().counts == {'malformed_record': 1}
    assert "time of day '25:00:00.000'" in r.snapshot().last['malformed_record']


def test_ydwg_date_given_then_file_name_then_modification_time(tmp_path):
    named = tmp_path / 'boat-2021-07-04.raw'
    named.write_text('')
    assert ydwg_date(named) == (datetime.date(2021, 7, 4), 'the file name')
    assert ydwg_date(named, DAY) == (DAY, 'given')
    plain = tmp_path / 'ydwg-2020.raw'
    plain.write_text('')
    t = datetime.datetime(2019, 5, 6, 12, tzinfo=datetime.UTC).timestamp()
    os.utime(plain, (t, t))
    assert ydwg_date(plain) == (datetime.date(2019, 5, 6), "the file's modification time")


# --- the real captures --------------------------------------------------------------------
def test_a_real_canboat_capture_becomes_its_frames():
    path = capture(SUSTERANNA)
    rows = canboat_rows(path)
    single = [r for r in rows if int(r[2]) <= 0x3FFFF and int(r[5]) <= 8]
    r = RejectCounter()
    frames = list(iter_log(path, r))
    assert len(frames) == len(single) == 8850
    assert r.snapshot().counts == {'multi_frame': sum(int(x[5]) > 8 and int(x[2]) <= 0x3FFFF for x in rows),
                                   'gateway_record': sum(int(x[2]) > 0x3FFFF for x in rows)}
    for f, row in zip(frames[:200], single[:200]):
        assert int(pgn_of(f.can_id)) == int(row[2]) and f.can_id & 0xFF == int(row[3])
        assert f.data == bytes(int(b, 16) for b in row[6:])


def test_a_real_ydwg_capture_becomes_its_frames():
    path = capture(MERRIMAC)
    lines = [ln.split() for ln in path.read_text().splitlines() if ln.strip()]
    r = RejectCounter()
    frames = list(iter_log(path, r, DAY))
    assert len(frames) == len(lines) == 914
    assert r.snapshot().counts == {}
    for f, ln in zip(frames, lines):
        assert f.can_id == int(ln[2], 16) and f.data == bytes(int(b, 16) for b in ln[3:])
    t = np.array([f.t_ns for f in frames])
    start = int(datetime.datetime(2020, 8, 22, 0, 29, 58, 617000, tzinfo=datetime.UTC).timestamp() * 1e3)
    assert t[0] == start * 1_000_000
    assert (t[-1] - t[0]) == 2_523_000_000          # 00:29:58.617 .. 00:30:01.140


@pytest.mark.parametrize('path', [SUSTERANNA, SUSTERANNA_2020, MERRIMAC], ids=lambda p: p.name)
def test_block_reader_gives_the_frame_readers_frames(path):
    capture(path)
    r1, r2 = RejectCounter(), RejectCounter()
    fa = FrameArrays.from_frames(iter_log(path, r1, DAY))
    fb = read_log_fast(path, r2, DAY)
    assert np.array_equal(fa.t_ns, fb.t_ns) and np.array_equal(fa.can_id, fb.can_id)
    assert np.array_equal(fa.data, fb.data) and np.array_equal(fa.dlc, fb.dlc)
    assert r1.snapshot().counts == r2.snapshot().counts


def _rudder_config(tmp_path, address):
    """The packaged parameters with the rudder mapped by address, any instance."""
    text = (PKG / 'config' / 'r18.yaml').read_text()
    text = text.replace('rudder_angle:     {pgn: 127245, field: Position, instance: 0, source: -1, rate_hz: 10.0}',
                        f'rudder_angle:     {{pgn: 127245, field: Position, instance: -1, source: -1, '
                        f'address: {address}, rate_hz: 10.0}}')
    path = tmp_path / 'vessel.yaml'
    path.write_text(text)
    (tmp_path / 'nmea2000_steering.dbc').write_text((PKG / 'config' / 'nmea2000_steering.dbc').read_text())
    return path


@pytest.mark.parametrize('path, address, samples', [(SUSTERANNA, 26, 256), (SUSTERANNA_2020, 32, 117),
                                                     (MERRIMAC, 13, 13)], ids=lambda x: getattr(x, 'name', x))
def test_both_decode_paths_give_the_same_samples_and_rejects(tmp_path, path, address, samples):
    capture(path)
    _, _, db, smap = load_setup(_rudder_config(tmp_path, address))
    r1 = RejectCounter()
    d1 = Decoder(db, smap, r1)
    s1 = collect([s for f in iter_log(path, r1, DAY) for s in d1.decode(f)] + d1.finish(), smap.names)
    r2 = RejectCounter()
    d2 = Decoder(db, smap, r2)
    parts = [d2.decode_arrays(b) for b in iter_log_blocks(path, r2, DAY)] + \
        [d2.decode_arrays(FrameArrays.empty(), final=True)]
    assert r1.snapshot().counts == r2.snapshot().counts
    for name in smap.names:
        t2 = np.concatenate([p[name].t_ns for p in parts])
        v2 = np.concatenate([p[name].value for p in parts])
        assert np.array_equal(np.sort(s1[name].t_ns), np.sort(t2)), name
        assert np.array_equal(np.sort(s1[name].value), np.sort(v2)), name
    assert len(s1['rudder_angle']) == samples
    # every frame is a sample's or counted under a reason (field-level reasons aside)
    counts = r1.snapshot().counts
    frame_level = sum(n for k, n in counts.items()
                      if k not in ('not_available', 'error_value', 'out_of_range', 'malformed_record',
                                   'multi_frame', 'gateway_record'))
    frames = d1.frames_seen
    mapped = 0
    for f in iter_log(path, None, DAY):
        if int(pgn_of(f.can_id)) == 127245 and f.can_id & 0xFF == address:
            mapped += 1
        elif int(pgn_of(f.can_id)) == 128259:
            mapped += 1                     # ship_speed: any source
    assert frames == frame_level + mapped
