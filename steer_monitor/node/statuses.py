"""The node's own statuses beside the monitor's: its CAN bus and its recording. Pure (from
what the bus handle, the reader and the recorder report)."""

from __future__ import annotations

from steer_monitor.can.busclock import BusClock
from steer_monitor.monitor.diagnostics import ERROR, OK, WARN, Status, status_name
from steer_monitor.params import NODE_NAME
from steer_monitor.record.recorder import RecorderStatus

__all__ = ['bus_status', 'clock_words', 'recording_status']


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


def bus_status(interface: str, silent: bool | None, how: str, frame_times: str, went_back: int, last_error: str,
               hardware_id: str, node_name: str = NODE_NAME) -> Status:
    """The node's status of its bus ``interface`` ('kind:channel'): whether the controller is
    silent (listen-only; ``how`` says how it is known), what the frames' times are, how often
    they went back, the last bus error. WARN when the controller is known to acknowledge frames."""
    values = (('interface', interface),
              ('controller_silent', {True: 'yes', False: 'no', None: 'unknown'}[silent]),
              ('controller_mode', how), ('frame_times', frame_times),
              ('frame_time_went_back', str(went_back)),
              ('last_bus_error', last_error or 'none'))
    level = WARN if silent is False else OK
    message = how if silent is not None else f'listen-only cannot be confirmed: {how}'
    return Status(status_name(node_name, 'CAN bus'), level, message, hardware_id, values)


def recording_status(st: RecorderStatus, hardware_id: str, node_name: str = NODE_NAME) -> Status:
    """The node's status of its recording: the file, how many, messages written, failed,
    dropped and files removed; ERROR while it cannot record."""
    values = (('recording_file', st.current_file or 'n/a'), ('recording_files', str(st.files)),
              ('recording_messages', str(st.messages)), ('recording_failed', str(st.failed)),
              ('recording_dropped', str(st.dropped)), ('recording_removed', str(st.removed)))
    return Status(status_name(node_name, 'recording'), OK if st.ok else ERROR, st.message, hardware_id, values)
