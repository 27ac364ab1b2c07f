"""The controller's error state from SocketCAN's error frames (linux/can/error.h)."""

from __future__ import annotations

import pytest

from steer_monitor.can.buserrors import ACTIVE, BUS_OFF, PASSIVE, WARNING, BusErrors, decode_error_frame

CRTL, PROT, BUSOFF, RESTARTED, CNT, ACK = 0x004, 0x008, 0x040, 0x100, 0x200, 0x020
FLAG = 0x20000000


@pytest.mark.parametrize('can_id, data, state, bus_error, overflow, counters', [
    (CRTL | CNT, bytes([0, 0x10, 0, 0, 0, 0, 0, 130]), PASSIVE, (), False, (0, 130)),   # receiver passive
    (CRTL, bytes([0, 0x20]), PASSIVE, (), False, (None, None)),                          # transmitter passive
    (CRTL | CNT, bytes([0, 0x04, 0, 0, 0, 0, 0, 97]), WARNING, (), False, (0, 97)),
    (CRTL, bytes([0, 0x40]), ACTIVE, (), False, (None, None)),                           # back to active
    (CRTL, bytes([0, 0x01]), None, (), True, (None, None)),                              # receive overflow
    (BUSOFF | FLAG, b'', BUS_OFF, (), False, (None, None)),                               # the flag left on
    (RESTARTED, bytes(8), ACTIVE, (), False, (None, None)),
    (PROT | ACK, bytes(8), None, ('protocol', 'no acknowledgement'), False, (None, None)),
])
def test_an_error_frame_read(can_id, data, state, bus_error, overflow, counters):
    f = decode_error_frame(can_id, data)
    assert (f.state, f.bus_error, f.overflow, (f.tx_errors, f.rx_errors)) == (state, bus_error, overflow, counters)


def test_the_state_followed_with_its_times():
    e = BusErrors()
    e.feed(10, PROT, bytes(8))
    e.feed(20, CRTL | CNT, bytes([0, 0x04, 0, 0, 0, 0, 0, 100]))
    e.feed(30, CRTL | CNT, bytes([0, 0x10, 0, 0, 0, 0, 0, 128]))
    e.feed(35, CRTL | CNT, bytes([0, 0x10, 0, 0, 0, 0, 0, 129]))      # still passive: not a new episode
    assert (e.state, e.since_ns, e.passive, e.rx_errors, e.bus_errors, e.error_frames) == (PASSIVE, 30, 1, 129, 1, 4)
    e.feed(40, BUSOFF, bytes(8))
    e.feed(50, RESTARTED, bytes(8))
    e.feed(60, CRTL, bytes([0, 0x10]))
    assert (e.state, e.since_ns, e.passive, e.bus_off, e.restarts) == (PASSIVE, 60, 2, 1, 1)
    assert e.last_entered_ns == {WARNING: 20, PASSIVE: 60, BUS_OFF: 40, ACTIVE: 50}
