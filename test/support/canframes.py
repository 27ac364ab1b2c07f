"""CAN frames built for the tests: the steering PGNs' frames from raw field values, address
claims, and decoding by both paths (frame by frame, arrays) compared."""

from __future__ import annotations

import numpy as np

from steer_monitor.can import Decoder, Frame, FrameArrays, collect, make_id
from steer_monitor.can.codec import CanDatabase

__all__ = ['AUTOPILOT', 'OTHER', 'T0', 'assert_same', 'both', 'claim', 'payload', 'pressure', 'rudder']

T0 = 1_767_225_600_000_000_000


def payload(db, pgn, **raw):
    layout = db.message(pgn)
    full = {name: np.array([raw.get(name, f.not_available)], np.int64) for name, f in layout.fields.items()}
    return CanDatabase.encode(layout, full, 1)[0].tobytes()


def rudder(db, t, position, order=0, instance=0, priority=2, source=0x10):
    return Frame(t, make_id(priority, 127245, source),
                 payload(db, 127245, Instance=instance, DirectionOrder=0, AngleOrder=order, Position=position))


def pressure(db, t, instance, raw_0p1pa, source_field=4, priority=5, sa=0x20):
    return Frame(t, make_id(priority, 130314, sa),
                 payload(db, 130314, SID=1, Instance=instance, Source=source_field, Pressure=raw_0p1pa))


def both(db, smap, frames):
    """(samples, snapshot) from the per-frame path and from the array path."""
    d1 = Decoder(db, smap)
    samples = [s for f in frames for s in d1.decode(f)] + d1.finish()
    per_frame = collect(samples, smap.names)
    d2 = Decoder(db, smap)
    arrays = d2.decode_arrays(FrameArrays.from_frames(frames), final=True)
    return (per_frame, d1.rejects.snapshot()), (arrays, d2.rejects.snapshot())


def assert_same(a, b):
    (sa, ra), (sb, rb) = a, b
    assert ra.counts == rb.counts
    assert ra.by_signal == rb.by_signal
    for name in sa:
        order_a = np.lexsort((sa[name].value, sa[name].t_ns))
        order_b = np.lexsort((sb[name].value, sb[name].t_ns))
        assert np.array_equal(sa[name].t_ns[order_a], sb[name].t_ns[order_b]), name
        assert np.array_equal(sa[name].value[order_a], sb[name].value[order_b]), name


AUTOPILOT = 0xC0508C002FB89064          # a NAME from the Suster Anna capture (address 13)
OTHER = 0xC03282002221B0B1


def claim(t, address, name, priority=6):
    return Frame(t, (priority << 26) | (0xEEFF << 8) | address, name.to_bytes(8, 'little'))
