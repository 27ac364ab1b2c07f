"""The node's own statuses: its CAN bus (the controller's mode, the frames' clock) and its recording."""

from __future__ import annotations

from steer_monitor.can.busclock import BusClock
from steer_monitor.monitor.diagnostics import ERROR, OK, WARN
from steer_monitor.node.statuses import bus_status, clock_words, recording_status
from steer_monitor.record.recorder import RecorderStatus

T = 1_767_225_600_000_000_000


def test_the_frames_clock_in_words():
    assert clock_words(None) == 'not reported'
    assert clock_words(BusClock()) == 'no frame yet'
    utc = BusClock()
    utc(T, T + 1_000_000)
    assert clock_words(utc) == "the interface's (UTC, as the host clock)"
    uptime = BusClock()
    uptime(1_000_000_000_000, T)                       # an adapter counting from power-up
    assert clock_words(uptime).startswith("the interface's clock is not UTC (")
    assert clock_words(uptime).endswith('s from the host\'s): its intervals are kept, put on the host clock')
    for mode, words in (('bus', "the interface's (can.timestamps: bus)"),
                        ('host', 'the host clock when read (can.timestamps: host)')):
        clock = BusClock(mode)
        clock(T, T)
        assert clock_words(clock) == words


def test_a_controller_that_acknowledges_frames_warns():
    st = bus_status('socketcan:can0', False, 'can0 is NOT listen-only', 'no frame yet', 0, '', 'gear')
    assert st.level == WARN and st.message == 'can0 is NOT listen-only'
    assert dict(st.values)['controller_silent'] == 'no' and dict(st.values)['last_bus_error'] == 'none'
    st = bus_status('virtual:x', None, 'virtual: no controller', 'no frame yet', 2, 'cable pulled', 'gear')
    assert st.level == OK and st.message == 'listen-only cannot be confirmed: virtual: no controller'
    assert dict(st.values)['frame_time_went_back'] == '2' and dict(st.values)['last_bus_error'] == 'cable pulled'


def test_a_recording_that_cannot_write_is_an_error():
    good = RecorderStatus(True, 'recording', '/rec/a.mcap', 1, 10, 0, 0)
    bad = RecorderStatus(False, 'cannot record: disk full', '/rec/a.mcap', 1, 10, 0, 5)
    assert recording_status(good, 'gear').level == OK
    st = recording_status(bad, 'gear')
    assert st.level == ERROR and st.message == 'cannot record: disk full' and dict(st.values)['recording_failed'] == '5'


def test_the_controller_error_state_in_the_bus_status():
    """Error-passive is WARN, bus-off ERROR, each with its UTC time; back to error-active it is
    OK again and the episodes stay counted."""
    from steer_monitor.can.buserrors import BusErrors
    e = BusErrors()
    st = bus_status('socketcan:can0', True, 'can0 is listen-only (set on the link)', 'host', 0, '', 'gear', errors=e)
    assert st.level == OK and st.value('controller_state') == 'error-active' and st.value('error_frames') == '0'
    e.feed(T, 0x004 | 0x200, bytes([0, 0x10, 0, 0, 0, 0, 0, 128]))        # receiver error-passive
    st = bus_status('socketcan:can0', True, 'can0 is listen-only (set on the link)', 'host', 0, '', 'gear', errors=e)
    assert st.level == WARN and st.message.startswith('controller error-passive since 2026-01-01T00:00:00')
    assert st.value('rx_error_counter') == '128' and st.value('error_passive_times') == '1'
    e.feed(T + 10**9, 0x040, bytes(8))
    st = bus_status('socketcan:can0', True, 'can0 is listen-only (set on the link)', 'host', 0, '', 'gear', errors=e)
    assert st.level == ERROR and st.message.startswith('controller BUS-OFF since 2026-01-01T00:00:01')
    assert st.value('last_bus_off_utc').startswith('2026-01-01T00:00:01')
    e.feed(T + 2 * 10**9, 0x100, bytes(8))
    st = bus_status('socketcan:can0', True, 'can0 is listen-only (set on the link)', 'host', 0, '', 'gear', errors=e)
    assert st.level == OK and st.value('controller_restarts') == '1'
    assert st.message.endswith('controller error-active; error-passive 1 and bus-off 1 time(s), the last at '
                               '2026-01-01T00:00:01Z'), st.message
