"""The node's own statuses beside the monitor's: its CAN bus and its recording. Pure (from
what the bus handle, the reader and the recorder report)."""

from __future__ import annotations

from steer_monitor.can.busclock import BusClock
from steer_monitor.can.buserrors import BUS_OFF, PASSIVE, BusErrors
from steer_monitor.monitor.diagnostics import ERROR, OK, WARN, Status, status_name
from steer_monitor.params import NODE_NAME
from steer_monitor.record.recorder import RecorderStatus
from steer_monitor.utc import utc_json, utc_text

__all__ = ['bus_status', 'clock_words', 'controller_words', 'recording_status']


def clock_words(clock: BusClock | None) -> str:
    """What the frames' times are, in words (``clock``: the bus handle's; None: not reported)."""
    if clock is None or clock.relative is None:
        return 'no frame yet' if clock is not None else 'not reported'
    if clock.mode != 'auto':
        text = {'bus': "the interface's (can.timestamps: bus)", 'host': 'the host clock when read '
                '(can.timestamps: host)'}[clock.mode]
    elif clock.relative:
        text = (f"the interface's clock is not UTC ({clock.offset_ns / 1e9:+.3f} s from the host's): its "
                "intervals are kept, put on the host clock")
    else:
        text = "the interface's (UTC, as the host clock)"
    if clock.steps:
        text += f'; it stepped {clock.steps} time(s)'
    return text


def _utc(t_ns: int | None) -> str:
    return 'never' if t_ns is None else utc_json(t_ns) or 'n/a'


def _when(t_ns: int | None) -> str:
    return 'an unknown time' if t_ns is None else utc_text(t_ns)


def controller_words(e: BusErrors) -> tuple[int, str]:
    """The controller's error state as a level and words: ERROR while bus-off (it takes no part
    in the bus until restarted), WARN while error-passive (its receiver sees a damaged bus),
    OK otherwise, naming the last time either happened."""
    if e.state == BUS_OFF:
        return ERROR, (f'controller BUS-OFF since {_when(e.since_ns)}: it receives nothing until restarted '
                       '(ip link set <channel> type can restart-ms 100); look at the bus wiring and termination')
    if e.state == PASSIVE:
        return WARN, (f'controller error-passive since {_when(e.since_ns)}: it sees errors on the bus '
                      f'({e.bus_errors} error frames with bus errors): termination, wiring, bit rate or a failing node')
    if e.passive or e.bus_off:
        last = max(e.last_entered_ns.get(PASSIVE, 0), e.last_entered_ns.get(BUS_OFF, 0))
        return OK, (f'controller {e.state}; error-passive {e.passive} and bus-off {e.bus_off} time(s), the last '
                    f'at {_when(last)}')
    if e.error_frames:
        return OK, f'controller {e.state}; {e.error_frames} error frame(s)'
    return OK, ''


def bus_status(interface: str, silent: bool | None, how: str, frame_times: str, went_back: int, last_error: str,
               hardware_id: str, node_name: str = NODE_NAME, errors: BusErrors | None = None) -> Status:
    """The node's status of its bus ``interface`` ('kind:channel'): whether the controller is
    silent (listen-only; ``how`` says how it is known), what the frames' times are, how often
    they went back, the last bus error, and the controller's error state from the error frames
    (``errors``: :func:`controller_words`). WARN when the controller is known to acknowledge
    frames or is error-passive, ERROR while it is bus-off."""
    e = errors if errors is not None else BusErrors()
    values = (('interface', interface),
              ('controller_silent', {True: 'yes', False: 'no', None: 'unknown'}[silent]),
              ('controller_mode', how), ('frame_times', frame_times),
              ('frame_time_went_back', str(went_back)),
              ('last_bus_error', last_error or 'none'),
              ('controller_state', e.state), ('controller_state_since_utc', _utc(e.since_ns)),
              ('error_frames', str(e.error_frames)), ('error_frames_bus_errors', str(e.bus_errors)),
              ('controller_overflows', str(e.overflows)),
              ('error_passive_times', str(e.passive)), ('last_error_passive_utc', _utc(e.last_entered_ns.get(PASSIVE))),
              ('bus_off_times', str(e.bus_off)), ('last_bus_off_utc', _utc(e.last_entered_ns.get(BUS_OFF))),
              ('controller_restarts', str(e.restarts)),
              ('tx_error_counter', 'n/a' if e.tx_errors is None else str(e.tx_errors)),
              ('rx_error_counter', 'n/a' if e.rx_errors is None else str(e.rx_errors)))
    level = WARN if silent is False else OK
    message = how if silent is not None else f'listen-only cannot be confirmed: {how}'
    state_level, words = controller_words(e)
    if words:
        message = f'{words}; {message}' if state_level > OK else f'{message}; {words}'
    return Status(status_name(node_name, 'CAN bus'), max(level, state_level), message, hardware_id, values)


def recording_status(st: RecorderStatus, hardware_id: str, node_name: str = NODE_NAME) -> Status:
    """The node's status of its recording: the file, how many, messages written, failed,
    dropped and files removed; ERROR while it cannot record."""
    values = (('recording_file', st.current_file or 'n/a'), ('recording_files', str(st.files)),
              ('recording_messages', str(st.messages)), ('recording_failed', str(st.failed)),
              ('recording_dropped', str(st.dropped)), ('recording_removed', str(st.removed)))
    return Status(status_name(node_name, 'recording'), OK if st.ok else ERROR, st.message, hardware_id, values)
