"""Devices by NAME: the NAME's fields (against CANboat's layout), who holds which address,
and the decoder following a device that takes another address, in both paths."""

from __future__ import annotations

import dataclasses
import json

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from steer_monitor.can import SignalMap, make_id
from steer_monitor.can.devices import CANNOT_CLAIM, DeviceName, DeviceTable, format_name, parse_name
from test.support.canframes import AUTOPILOT, OTHER, T0, assert_same, both, claim, rudder
from test.support.captures import REALBUS, SUSTERANNA, canboat_rows, capture


@pytest.mark.parametrize('text, name', [('C0508C002FB89064', AUTOPILOT), ('0xc0508c002fb89064', AUTOPILOT),
                                        ('1', 1)])
def test_parse_name(text, name):
    assert parse_name(text) == name
    assert parse_name(format_name(name)) == name


@pytest.mark.parametrize('text', ['', '0x', 'xyz', '1' * 17, 'C0508C00 2FB89064'])
def test_parse_name_refuses(text):
    with pytest.raises(ValueError, match='expected a device NAME as 16 hex digits'):
        parse_name(text)


def test_name_fields_match_canboat_layout():
    """Each field of real NAMEs, decoded by the bit offsets and lengths of canboat.json."""
    capture(SUSTERANNA)
    doc = json.loads((REALBUS / 'canboat.json').read_text())
    layout = next(p for p in doc['PGNs'] if p['PGN'] == 60928)['Fields']
    bits = {f['Id']: (f['BitOffset'], f['BitLength']) for f in layout}
    rows = [r for r in canboat_rows(SUSTERANNA) if r[2] == '60928']
    assert len(rows) == 44
    for r in rows:
        data = bytes(int(b, 16) for b in r[6:])
        word = int.from_bytes(data, 'little')
        field = {fid: (word >> off) & ((1 << n) - 1) for fid, (off, n) in bits.items()}.__getitem__
        d = DeviceName.from_data(data)
        assert d.unique_number == field('uniqueNumber')
        assert d.manufacturer_code == field('manufacturerCode')
        assert d.device_instance == field('deviceInstanceLower') | field('deviceInstanceUpper') << 3
        assert d.device_function == field('deviceFunction')
        assert d.device_class == field('deviceClass')
        assert d.system_instance == field('systemInstance')
        assert d.industry_group == field('industryGroup')
        assert d.arbitrary_address_capable == bool(field('arbitraryAddressCapable'))


def test_table_follows_claims_conflicts_and_cannot_claim():
    t = DeviceTable()
    t.seed(13, AUTOPILOT)
    assert t.address_of(AUTOPILOT) == 13
    t.seed(20, AUTOPILOT)                     # a seed never moves a known device
    assert t.address_of(AUTOPILOT) == 13
    t.claim(13, OTHER)                        # OTHER wins 13: AUTOPILOT has no address for now
    assert t.name_at(13) == OTHER and t.address_of(AUTOPILOT) is None
    t.claim(14, AUTOPILOT)
    assert t.name_at(14) == AUTOPILOT and t.address_of(AUTOPILOT) == 14
    t.claim(CANNOT_CLAIM, AUTOPILOT)
    assert t.address_of(AUTOPILOT) is None and t.name_at(14) is None


def _by_name(smap, name, address=-1, instance=0):
    specs = tuple(dataclasses.replace(s, device_name=name, address=address, instance=instance)
                  if s.name == 'rudder_angle' else s for s in smap.specs)
    return SignalMap(specs, smap.max_jump_ns)


def test_decoder_follows_a_device_that_changes_address(db, smap):
    m = _by_name(smap, AUTOPILOT)
    frames = [rudder(db, T0, 100, source=13),                         # before any claim: not its own yet
              claim(T0 + 1, 13, AUTOPILOT),
              rudder(db, T0 + 10, 200, source=13),
              claim(T0 + 20, 13, OTHER),                              # conflict: OTHER takes 13
              rudder(db, T0 + 30, 300, source=13),                    # OTHER's: not the rudder
              claim(T0 + 40, 14, AUTOPILOT),
              rudder(db, T0 + 50, 400, source=14)]
    a, b = both(db, m, frames)
    assert_same(a, b)
    samples, snap = a
    assert list(samples['rudder_angle'].value) == pytest.approx([0.02, 0.04])
    assert snap.counts['address_claim'] == 3
    assert len(samples['rudder_order']) == 4      # instance 0 from any device: all four frames


def test_seeded_address_is_used_until_a_claim_says_otherwise(db, smap):
    m = _by_name(smap, AUTOPILOT, address=13)
    frames = [rudder(db, T0, 100, source=13), claim(T0 + 1, 20, AUTOPILOT), rudder(db, T0 + 10, 200, source=13),
              rudder(db, T0 + 20, 300, source=20)]
    a, b = both(db, m, frames)
    assert_same(a, b)
    assert list(a[0]['rudder_angle'].value) == pytest.approx([0.01, 0.03])


def test_instance_255_is_any_for_a_bound_input_only(db, smap):
    by_address = SignalMap(tuple(dataclasses.replace(s, address=13) if s.name == 'rudder_angle' else s
                                 for s in smap.specs), smap.max_jump_ns)
    frames = [rudder(db, T0, 100, instance=255, source=13), rudder(db, T0 + 10, 200, instance=255, source=14)]
    a, b = both(db, by_address, frames)
    assert_same(a, b)
    assert list(a[0]['rudder_angle'].value) == pytest.approx([0.01])
    a, b = both(db, smap, frames)                # not bound: instance 0 wanted, 255 is not it
    assert_same(a, b)
    assert len(a[0]['rudder_angle']) == 0 and a[1].counts['unmapped'] == 2


def test_owner_is_the_one_at_arrival_even_for_frames_held_after_a_jump(db, smap):
    """A chain after a time jump is held; a claim arriving meanwhile does not change whose
    its frames were (both paths)."""
    m = _by_name(smap, AUTOPILOT, address=13)
    jump = 60 * 10 ** 9
    frames = [rudder(db, T0 + i * 10 ** 8, 100 + i, source=13) for i in range(60)]
    frames += [rudder(db, T0 + jump + i * 10 ** 8, 200 + i, source=13) for i in range(10)]
    frames += [claim(T0 + jump + 10 ** 9 + 1, 13, OTHER)]
    frames += [rudder(db, T0 + jump + 10 ** 9 + i * 10 ** 8, 300 + i, source=13) for i in range(2, 60)]
    a, b = both(db, m, frames)
    assert_same(a, b)
    got = a[0]['rudder_angle'].value
    assert len(got) == 70                       # the 10 held frames were the autopilot's when they came
    assert len(a[0]['rudder_order']) == 128     # instance 0 from anyone: every frame
    assert frames[0].can_id == make_id(2, 127245, 13)


_events = st.lists(st.tuples(st.sampled_from(['claim', 'rudder']), st.integers(0, 2000), st.sampled_from([13, 14, 20]),
                             st.sampled_from([AUTOPILOT, OTHER]), st.sampled_from([0, 1, 255])),
                   min_size=1, max_size=60)


@settings(max_examples=200, deadline=None)
@given(events=_events, seeded=st.booleans())
def test_fuzz_device_following_paths_agree(db, smap, events, seeded):
    m = _by_name(smap, AUTOPILOT, address=13 if seeded else -1, instance=0)
    frames = [
        claim(T0 + i * 10**6, a, n)
        if kind == 'claim'
        # times rising: no time rejects
        else rudder(db, T0 + i * 10**6, t, instance=inst, source=a)
        for i, (kind, t, a, n, inst) in enumerate(events)
    ]
    a, b = both(db, m, frames)
    assert_same(a, b)
    # by hand: the device table, frame by frame
    table = DeviceTable()
    if seeded:
        table.seed(13, AUTOPILOT)
    want = 0
    for f, (kind, *_rest) in zip(frames, events):
        if kind == 'claim':
            table.claim(f.can_id & 0xFF, int.from_bytes(f.data, 'little'))
        elif table.name_at(f.can_id & 0xFF) == AUTOPILOT and _rest[3] in (0, 255):
            want += 1
    assert len(a[0]['rudder_angle']) == want
