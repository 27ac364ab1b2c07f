"""Discovery: streams and devices of real and made-up buses, and the proposal's rules."""

from __future__ import annotations

import datetime
from collections import defaultdict

import pytest

from steer_monitor.ashore.discovery import Discovery, propose
from steer_monitor.can import Frame, FrameArrays
from steer_monitor.can.signals import REQUIRED
from steer_monitor.logfiles.blocks import iter_log_blocks
from test.support.canframes import AUTOPILOT, OTHER, T0, claim, pressure, rudder
from test.support.captures import MERRIMAC, SUSTERANNA, SUSTERANNA_2020, canboat_rows, capture


def discovered(db, path, date=None):
    d = Discovery(db)
    for block in iter_log_blocks(path, None, date):
        d.add(block)
    return d


def test_streams_of_a_real_capture_count_its_lines(db):
    """Frames, span and rate per (PGN, source) against the capture read with the csv module."""
    capture(SUSTERANNA)
    d = discovered(db, SUSTERANNA)
    want: dict[tuple[int, int], list[str]] = defaultdict(list)
    for r in canboat_rows(SUSTERANNA):
        if int(r[2]) <= 0x3FFFF and int(r[5]) <= 8:
            want[(int(r[2]), int(r[3]))].append(r[0])
    got: dict[tuple[int, int], int] = defaultdict(int)
    for s in d.streams.values():
        got[(s.pgn, s.source)] += s.frames
    assert dict(got) == {k: len(v) for k, v in want.items()}
    rudder26 = d.streams[(127245, 26, 255)]
    stamps = sorted(want[(127245, 26)])
    first = datetime.datetime.fromisoformat(stamps[0].replace('Z', '+00:00'))
    last = datetime.datetime.fromisoformat(stamps[-1].replace('Z', '+00:00'))
    assert rudder26.rate_hz == pytest.approx((len(stamps) - 1) / (last - first).total_seconds(), rel=1e-9)
    assert rudder26.fields['Position'].valid == 256
    assert rudder26.fields['Position'].min == pytest.approx(0.0972)
    assert d.streams[(127245, 14, 255)].fields['Position'].not_available == 138
    assert d.streams[(130314, 28, 0)].fields['Source'].max == 0
    assert len(d.devices) == len({r[6:].__str__() for r in canboat_rows(SUSTERANNA) if r[2] == '60928'})


@pytest.mark.parametrize('path, rudder_address, date', [(SUSTERANNA, 26, None), (SUSTERANNA_2020, 32, None),
                                                         (MERRIMAC, 13, datetime.date(2020, 8, 22))],
                         ids=lambda x: getattr(x, 'name', str(x)))
def test_proposal_on_real_buses(db, smap, path, rudder_address, date):
    capture(path)
    proposed, notes = propose(discovered(db, path, date), smap, REQUIRED)
    assert proposed['rudder_angle']['address'] == rudder_address
    assert proposed['rudder_angle']['instance'] == -1          # the sensor says 255
    assert any('instance 255' in n for n in notes)
    for name in ('pressure_r1_stbd', 'pressure_r1_port', 'pressure_r2_stbd', 'pressure_r2_port'):
        assert proposed[name]['source'] == 4                    # never the barometer
        assert proposed[name]['address'] == -1                 # kept as given: nothing hydraulic here
    assert proposed['oil_temperature']['pgn'] == 0


def test_barometer_is_named_and_never_a_chamber(db, smap):
    capture(SUSTERANNA)
    proposed, notes = propose(discovered(db, SUSTERANNA), smap, REQUIRED)
    assert any('address 28 instance 0 is atmospheric (pressure source 0): a barometer, never a ram chamber' in n
               for n in notes)
    assert all(v['address'] != 28 for v in proposed.values())


def _bus(db):
    frames = [claim(T0, 13, AUTOPILOT), claim(T0 + 1, 20, OTHER)]
    for k in range(50):
        t = T0 + 10 + k * 100_000_000
        frames.append(rudder(db, t, 100 + k, instance=255, source=13))
        if k % 2:
            frames.append(rudder(db, t + 1, 50, instance=0, source=20))
        for inst in (3, 1, 0, 2):
            frames.append(pressure(db, t + 2 + inst, inst, 10_000_000 + inst, sa=40))
        frames.append(pressure(db, t + 9, 0, 1_013_000, source_field=0, sa=41))
    return FrameArrays.from_frames(sorted(frames, key=lambda f: f.t_ns))


def test_rules_on_a_made_up_bus(db, smap):
    d = Discovery(db)
    d.add(_bus(db))
    proposed, notes = propose(d, smap, REQUIRED)
    r = proposed['rudder_angle']
    assert (r['address'], r['instance'], r['device_name']) == (13, -1, f'{AUTOPILOT:016X}')
    ambiguity = [n for n in notes if n.startswith('rudder_angle: 2 senders')]
    assert len(ambiguity) == 1 and 'took address 13 instance 255 (50 valid' in ambiguity[0]
    assert 'not taken: address 20 instance 0 (25 valid' in ambiguity[0]
    chambers = [proposed[n] for n in ('pressure_r1_stbd', 'pressure_r1_port', 'pressure_r2_stbd', 'pressure_r2_port')]
    assert [(c['address'], c['instance'], c['source']) for c in chambers] == [(40, i, 4) for i in range(4)]
    assert any('address 41 instance 0 is atmospheric' in n for n in notes)
    assert any('chambers assigned in the order of the instances' in n for n in notes)
    assert proposed['ship_speed']['pgn'] == 0 and proposed['oil_temperature']['pgn'] == 0
    assert d.devices[AUTOPILOT].source == 13 and d.devices[OTHER].addresses == [20]


def test_an_empty_block_and_odd_frames_are_counted(db):
    d = Discovery(db)
    d.add(FrameArrays.empty())
    assert d.frames == 0 and not d.streams
    d.add(FrameArrays.from_frames([Frame(T0, 0x123, b'\x01', is_extended=False),
                                   Frame(T0 + 1, 0, b'', is_error=True),
                                   rudder(db, T0 + 2, 5, source=7)]))
    assert d.frames == 3 and dict(d.skipped) == {'error_frame': 1, 'remote_frame': 0, 'not_extended': 1}
    assert list(d.streams) == [(127245, 7, 0)]
