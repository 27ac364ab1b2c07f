"""The CAN controller's error state from SocketCAN's error frames. Pure.

SocketCAN reports what happens to the controller as error frames (``linux/can/error.h``;
python-can's socketcan bus asks for all of them): the error class in the CAN id, the
controller's state in data byte 1, its transmit and receive error counters in bytes 6 and 7.
A controller goes *error-warning* at 96 errors counted, *error-passive* at 128 (it no longer
signals errors on the bus), *bus-off* at 256 transmit errors (it takes no part in the bus until
restarted). A listen-only controller never transmits, so bus-off is rare; error-passive says
its receiver sees a damaged bus (termination, wiring, a wrong bit rate, a failing node).

:class:`BusErrors` follows the state and counts what happened with the data time of each
change, for the node's ``CAN bus`` status.
"""

from __future__ import annotations

from dataclasses import dataclass, field

__all__ = ['ACTIVE', 'BUS_OFF', 'PASSIVE', 'WARNING', 'BusErrors', 'ErrorFrame', 'decode_error_frame']

# error classes in the CAN id of an error frame (linux/can/error.h)
CAN_ERR_TX_TIMEOUT = 0x001
CAN_ERR_LOSTARB = 0x002
CAN_ERR_CRTL = 0x004
CAN_ERR_PROT = 0x008
CAN_ERR_TRX = 0x010
CAN_ERR_ACK = 0x020
CAN_ERR_BUSOFF = 0x040
CAN_ERR_BUSERROR = 0x080
CAN_ERR_RESTARTED = 0x100
CAN_ERR_CNT = 0x200
# controller status in data[1] with CAN_ERR_CRTL
CAN_ERR_CRTL_RX_OVERFLOW = 0x01
CAN_ERR_CRTL_TX_OVERFLOW = 0x02
CAN_ERR_CRTL_RX_WARNING = 0x04
CAN_ERR_CRTL_TX_WARNING = 0x08
CAN_ERR_CRTL_RX_PASSIVE = 0x10
CAN_ERR_CRTL_TX_PASSIVE = 0x20
CAN_ERR_CRTL_ACTIVE = 0x40

ACTIVE, WARNING, PASSIVE, BUS_OFF = 'error-active', 'error-warning', 'error-passive', 'bus-off'

#: error classes that are errors seen on the bus (the frame damaged or not acknowledged)
_BUS_ERROR_CLASSES = {CAN_ERR_PROT: 'protocol', CAN_ERR_TRX: 'transceiver', CAN_ERR_ACK: 'no acknowledgement',
                      CAN_ERR_BUSERROR: 'bus error', CAN_ERR_LOSTARB: 'arbitration lost',
                      CAN_ERR_TX_TIMEOUT: 'transmit timeout'}


@dataclass(frozen=True)
class ErrorFrame:
    """One error frame: the controller state it reports (None: none), whether it reports
    errors seen on the bus (``bus_error``: their kinds), a receive overflow (frames lost in
    the controller), and the error counters where given."""

    state: str | None
    bus_error: tuple[str, ...]
    overflow: bool
    tx_errors: int | None
    rx_errors: int | None


def decode_error_frame(can_id: int, data: bytes) -> ErrorFrame:
    """An error frame's meaning from its CAN id (the error class bits, the error flag taken off
    or not) and its data (8 bytes; shorter is read as zeros)."""
    d = bytes(data) + bytes(max(0, 8 - len(data)))
    cls = can_id & 0x1FFFFFFF
    state = None
    if cls & CAN_ERR_BUSOFF:
        state = BUS_OFF
    elif cls & CAN_ERR_CRTL and d[1] & (CAN_ERR_CRTL_RX_PASSIVE | CAN_ERR_CRTL_TX_PASSIVE):
        state = PASSIVE
    elif cls & CAN_ERR_CRTL and d[1] & (CAN_ERR_CRTL_RX_WARNING | CAN_ERR_CRTL_TX_WARNING):
        state = WARNING
    elif cls & CAN_ERR_RESTARTED or (cls & CAN_ERR_CRTL and d[1] & CAN_ERR_CRTL_ACTIVE):
        state = ACTIVE
    kinds = tuple(words for bit, words in _BUS_ERROR_CLASSES.items() if cls & bit)
    overflow = bool(cls & CAN_ERR_CRTL and d[1] & (CAN_ERR_CRTL_RX_OVERFLOW | CAN_ERR_CRTL_TX_OVERFLOW))
    counted = bool(cls & CAN_ERR_CNT)
    return ErrorFrame(state, kinds, overflow, d[6] if counted else None, d[7] if counted else None)


@dataclass
class BusErrors:
    """The controller's state from the error frames fed, and what happened: error frames,
    errors seen on the bus, overflows, times error-passive and bus-off, restarts; the data
    time [ns] each state was last entered and since when the present one holds."""

    state: str = ACTIVE
    since_ns: int | None = None
    error_frames: int = 0
    bus_errors: int = 0
    overflows: int = 0
    passive: int = 0
    bus_off: int = 0
    restarts: int = 0
    tx_errors: int | None = None
    rx_errors: int | None = None
    last_entered_ns: dict[str, int] = field(default_factory=dict)

    def feed(self, t_ns: int, can_id: int, data: bytes) -> None:
        """One error frame at data time ``t_ns``."""
        f = decode_error_frame(can_id, data)
        self.error_frames += 1
        self.bus_errors += bool(f.bus_error)
        self.overflows += f.overflow
        if f.tx_errors is not None:
            self.tx_errors, self.rx_errors = f.tx_errors, f.rx_errors
        if can_id & CAN_ERR_RESTARTED:
            self.restarts += 1
        if f.state is not None and f.state != self.state:
            self.state, self.since_ns = f.state, t_ns
            self.last_entered_ns[f.state] = t_ns
            self.passive += f.state == PASSIVE
            self.bus_off += f.state == BUS_OFF
