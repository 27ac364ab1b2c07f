"""The live bus: listen-only, the whole decode path on a virtual bus, reopen with backoff,
and a real socketcan vcan0 test where the kernel has it."""

from __future__ import annotations

import os
import socket
import threading
import uuid

import can
import pytest

from steer_monitor import sim
from steer_monitor.can import Decoder, RejectCounter, collect
from steer_monitor.can.bus import BusError, BusReader, ListenOnlyBus, ListenOnlyError
from steer_monitor.sim.playback import play


@pytest.fixture
def channel():
    return f'steer-test-{uuid.uuid4().hex[:8]}'


def test_listen_only_bus_refuses_to_send(channel):
    with ListenOnlyBus('virtual', channel) as bus:
        with pytest.raises(
            ListenOnlyError, match=f'steer_monitor only listens on virtual:{channel}; it never transmits'
        ):
            bus.send(can.Message(arbitration_id=1))
        assert bus.send_attempts == 1
    bus.close()  # idempotent
    assert bus.closed


def _short_sim(r18_params, db, smap, seconds=4.0):
    cfg = sim.SimConfig(program='hard_over_2', max_duration_s=seconds)
    return sim.run(r18_params, cfg, db, smap, seed=5).frames


def _read_all(db, smap, channel, expected, rejects):
    """Monitor side: BusReader + Decoder on a listen-only bus, in its own thread."""
    stop = threading.Event()
    samples = []
    seen = []
    bus_holder = {}

    def opener():
        bus_holder['bus'] = ListenOnlyBus('virtual', channel)
        return bus_holder['bus']

    reader = BusReader(opener, rejects, poll=0.05)
    decoder = Decoder(db, smap, rejects)
    ready = threading.Event()

    def run():
        it = reader.batches(stop)
        ready.set()
        for frames in it:
            for frame in frames:
                seen.append(frame)
                samples.extend(decoder.decode(frame))
            if len(seen) >= expected:
                stop.set()

    thread = threading.Thread(target=run, daemon=True)
    return thread, stop, ready, samples, seen, bus_holder


def test_whole_decode_path_on_virtual_bus_sends_nothing(r18_params, db, smap, channel):
    frames = _short_sim(r18_params, db, smap)
    rejects = RejectCounter()
    thread, stop, ready, samples, seen, holder = _read_all(db, smap, channel, len(frames), rejects)
    sniffer = can.Bus(interface='virtual', channel=channel)
    thread.start()
    ready.wait(2)
    while 'bus' not in holder:
        threading.Event().wait(0.01)
    sender = can.Bus(interface='virtual', channel=channel)
    try:
        assert play(frames, sender, speed_factor=0) == len(frames)
        thread.join(10)
        assert not thread.is_alive(), 'monitor did not see every frame'
        sniffed = 0
        while sniffer.recv(0.05) is not None:
            sniffed += 1
    finally:
        stop.set()
        sender.shutdown()
        sniffer.shutdown()
    assert len(seen) == len(frames)
    # Everything on the bus came from the simulator: the monitor sent zero frames.
    assert sniffed == len(frames)
    assert holder['bus'].send_attempts == 0
    assert rejects.snapshot().total == 0
    got = collect(samples, smap.names)
    assert len(got['rudder_angle']) > 30 and len(got['pressure_r2_port']) > 70


class FlakyBus:
    """A bus that fails on its second recv."""

    interface, channel = 'fake', 'flaky'

    def __init__(self):
        self.calls = 0
        self.closed = False

    def recv(self, timeout=None):
        self.calls += 1
        if self.calls == 2:
            raise BusError('CAN bus fake:flaky failed: cable pulled')
        from steer_monitor.can import Frame
        return Frame(self.calls, 0x1, b'')

    def close(self):
        self.closed = True


def _flaky_reader(frames_wanted: int, **kw) -> tuple[list, RejectCounter, list[float]]:
    """A reader over FlakyBus (each bus fails on its second recv) whose second and third
    opens fail, read until ``frames_wanted`` frames: (frames, rejects, waits)."""
    opens, waits = [], []

    def opener():
        opens.append(1)
        if len(opens) in (2, 3):
            raise BusError('cannot open CAN bus fake:flaky: no such device')
        return FlakyBus()

    rejects = RejectCounter()
    stop = threading.Event()
    reader = BusReader(opener, rejects, backoff_initial=0.5, backoff_max=4.0, sleep=waits.append, **kw)
    got = []
    for frames in reader.batches(stop):
        for frame in frames:
            got.append(frame)
            if len(got) == frames_wanted:
                stop.set()
    return got, rejects, waits


def test_reader_reopens_with_backoff():
    got, rejects, waits = _flaky_reader(2)
    snap = rejects.snapshot()
    assert snap.counts == {'bus_error': 3, 'bus_reopen': 1}
    assert snap.last['bus_error'] == 'the bus raised an error: cannot open CAN bus fake:flaky: no such device'
    assert waits == [0.5, 1.0, 2.0]  # doubling backoff
    assert len(got) == 2


def test_reader_tells_each_failure_once_until_the_bus_is_back():
    """``on_error`` hears a failure unlike the one before it: a bus that stays down with the same
    error is told once, not at every retry, and None when the bus is open again; then a new
    failure is told even if it reads as an earlier one."""
    told: list[str | None] = []
    got, rejects, waits = _flaky_reader(3, on_error=told.append)
    assert told == ['CAN bus fake:flaky failed: cable pulled', 'cannot open CAN bus fake:flaky: no such device',
                    None, 'CAN bus fake:flaky failed: cable pulled', None]
    assert waits == [0.5, 1.0, 2.0, 0.5]
    assert rejects.snapshot().counts == {'bus_error': 4, 'bus_reopen': 2} and len(got) == 3


class QueueBus:
    """A bus whose frames arrive in bursts: the first burst is there at once, each later one
    arrives while the reader pauses. Records the timeout of every recv."""

    interface, channel = 'fake', 'bursts'

    def __init__(self, bursts):
        from steer_monitor.can import Frame
        self.bursts = [[Frame(t, 0x1, b'') for t in burst] for burst in bursts]
        self.queue = self.bursts.pop(0)
        self.timeouts = []

    def arrive(self, seconds):
        if self.bursts:
            self.queue.extend(self.bursts.pop(0))

    def recv(self, timeout=None):
        self.timeouts.append(timeout)
        return self.queue.pop(0) if self.queue else None

    def close(self):
        pass


@pytest.mark.parametrize('batch', [0.0, 0.002])
def test_reader_takes_a_busy_bus_in_batches(batch):
    bus = QueueBus([[1, 2, 3], [4, 5], [6]])
    waits = []

    def sleep(seconds):
        waits.append(seconds)
        bus.arrive(seconds)

    stop = threading.Event()
    reader = BusReader(lambda: bus, RejectCounter(), poll=0.01, sleep=sleep, batch=batch)
    got = []
    for frames in reader.batches(stop):
        if not frames:              # the bus went quiet: the reader waited on it, then said so
            break
        got.append([f.t_ns for f in frames])
    if batch:
        # after a frame it takes what is there without waiting, as one list, pauses while a
        # batch gathers, and blocks on the bus again only when a pause brought nothing
        assert got == [[1, 2, 3], [4, 5], [6]]
        assert waits == [batch] * 3
        # blocks for 1; 2, 3, empty; pause; 4, 5, empty; pause; 6, empty; pause; empty; blocks
        assert bus.timeouts == [0.01] + [0.0] * 3 + [0.0] * 3 + [0.0] * 2 + [0.0] + [0.01]
    else:
        assert got == [[1, 2, 3]]   # what is there taken at once; nothing arrives without a pause
        assert waits == [] and bus.timeouts == [0.01] + [0.0] * 3 + [0.01]


def test_reader_gives_a_backlog_in_lists_of_at_most_max_batch():
    """A queue that filled while the reader was held up comes in lists of at most MAX_BATCH
    frames, none lost, in order."""
    from steer_monitor.can.bus import MAX_BATCH
    bus = QueueBus([list(range(2 * MAX_BATCH + 5))])
    stop = threading.Event()
    reader = BusReader(lambda: bus, RejectCounter(), poll=0.01, sleep=lambda s: None, batch=0.002)
    sizes, times = [], []
    for frames in reader.batches(stop):
        if not frames:
            break
        sizes.append(len(frames))
        times += [f.t_ns for f in frames]
    assert sizes == [MAX_BATCH, MAX_BATCH, 5]
    assert times == list(range(2 * MAX_BATCH + 5))


@pytest.mark.parametrize('batch', [-0.001, 0.01, 0.5])
def test_reader_batch_must_be_shorter_than_its_poll(batch):
    with pytest.raises(
        ValueError, match=f'read batch {batch:g} s must be at least 0 and shorter than the poll of 0.01 s'
    ):
        BusReader(lambda: None, RejectCounter(), poll=0.01, batch=batch)


def test_open_failure_is_a_clear_error():
    with pytest.raises(BusError, match='cannot open CAN bus nosuchinterface:can9'):
        ListenOnlyBus('nosuchinterface', 'can9')


def _vcan0_reason() -> str | None:
    if not hasattr(socket, 'AF_CAN'):
        return 'this kernel/Python has no SocketCAN (socket.AF_CAN missing)'
    if not os.path.exists('/sys/class/net/vcan0'):
        return 'no vcan0 interface (modprobe vcan; ip link add dev vcan0 type vcan; ip link set up vcan0)'
    return None


@pytest.mark.skipif(_vcan0_reason() is not None, reason=_vcan0_reason() or '')
def test_socketcan_vcan0_round_trip(r18_params, db, smap):
    frames = _short_sim(r18_params, db, smap, 2.0)
    rejects = RejectCounter()
    decoder = Decoder(db, smap, rejects)
    with ListenOnlyBus('socketcan', 'vcan0') as monitor:
        sender = can.Bus(interface='socketcan', channel='vcan0')
        try:
            play(frames, sender, speed_factor=0)
        finally:
            sender.shutdown()
        n = 0
        samples = []
        while (frame := monitor.recv(0.2)) is not None:
            n += 1
            samples.extend(decoder.decode(frame))
        assert monitor.send_attempts == 0
    assert n == len(frames)
    assert rejects.snapshot().total == 0
    assert len(collect(samples, smap.names)['rudder_angle']) > 10


def test_virtual_bus_says_it_has_no_controller_to_silence():
    from steer_monitor.can.bus import ListenOnlyBus
    with ListenOnlyBus('virtual', 'silent_check') as bus:
        assert bus.silent is None and 'no controller' in bus.silent_how


@pytest.mark.parametrize('interface,channel,refused', [
    ('virtual', 'x', None),
    ('socketcan', 'can0', 'socketcan:can0 is not known to be a vcan link'),
    ('pcan', 'PCAN_USBBUS1', 'pcan:PCAN_USBBUS1 is a hardware interface'),
])
def test_transmit_refusal(interface, channel, refused):
    from steer_monitor.can.bus import transmit_refusal
    got = transmit_refusal(interface, channel)
    assert (got is None) if refused is None else got.startswith(refused)


class _AdapterSincePowerUp:
    """A python-can bus whose timestamps count from the adapter's power-up (gs_usb), 10 ms
    apart from 1,000 s."""

    def __init__(self) -> None:
        self.t = 1000.0

    def recv(self, timeout=None):
        self.t += 0.01
        return can.Message(timestamp=self.t, arbitration_id=0x09F10D10, data=bytes(8), is_extended_id=True)

    def shutdown(self) -> None:
        pass


@pytest.mark.parametrize('mode', ['auto', 'bus', 'host'])
def test_frame_times_of_an_adapter_that_does_not_keep_utc(channel, mode):
    import time
    bus = ListenOnlyBus('virtual', channel, timestamps=mode)
    bus._bus.shutdown()
    bus._bus = _AdapterSincePowerUp()
    try:
        before = time.time_ns()
        frames = [bus.recv(0.1) for _ in range(5)]
        after = time.time_ns()
    finally:
        bus.close()
    t = [f.t_ns for f in frames]
    if mode == 'bus':                       # as the interface says: 1970
        assert t[0] == 1000_010_000_000
    else:                                   # on the host's clock (the first frame's reading)
        assert before <= t[0] <= after
    if mode != 'host':                      # the interface's intervals (to the 100 ppm slew in auto)
        assert all(abs(b - a - 10_000_000) <= 1_000 for a, b in zip(t, t[1:])), t
    assert bus.clock.relative is (mode == 'auto')
