"""Interface timestamps onto the host's clock: UTC clocks left alone, adapters' own clocks
(since power-up, or years ahead) put on the host's with their intervals kept, drift followed
within the slew, a clock that restarts stepped once, a reading backlog never mistaken for a
step."""

from __future__ import annotations

import numpy as np
import pytest

from steer_monitor.can.busclock import TIMESTAMP_MODES, BusClock

HOST0 = 1_795_000_000_000_000_000          # the host clock at the first frame [ns]
S = 1_000_000_000


def _stream(bus0: int, n: int = 20_000, period: int = 10_000_000, rate: float = 1.0, latency: int = 300_000,
            seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """(interface times, host read times) of ``n`` frames ``period`` apart on the host clock;
    the interface's clock starts at ``bus0`` and runs ``rate`` times the host's; each frame is
    read 0..``latency`` ns after it arrived."""
    rng = np.random.default_rng(seed)
    arrive = HOST0 + np.arange(n, dtype=np.int64) * period
    bus = bus0 + np.round((arrive - HOST0) * rate).astype(np.int64)
    host = arrive + rng.integers(0, latency + 1, n)
    return bus, host


def _map(clock: BusClock, bus: np.ndarray, host: np.ndarray) -> np.ndarray:
    return np.array([clock(int(b), int(h)) for b, h in zip(bus, host)], dtype=np.int64)


@pytest.mark.parametrize('mode', TIMESTAMP_MODES)
def test_a_utc_interface_is_left_as_it_is(mode):
    bus, host = _stream(HOST0)
    clock = BusClock(mode)
    got = _map(clock, bus, host)
    assert np.array_equal(got, host if mode == 'host' else bus)
    assert clock.steps == 0 and clock.relative is False


@pytest.mark.parametrize('bus0', [1_000 * S,                                 # gs_usb: since the adapter's power-up
                                  int(1.5 * HOST0) + 142 * S])              # IXXAT: 1.5 x the epoch + uptime
def test_an_adapter_s_own_clock_is_put_on_the_host_s_with_its_intervals(bus0):
    bus, host = _stream(bus0)
    clock = BusClock()
    got = _map(clock, bus, host)
    assert clock.relative is True and clock.steps == 0
    assert abs(int(got[0]) - int(host[0])) == 0                 # anchored at the first frame's reading
    # the intervals are the interface's (a clock running with the host's: the slew only
    # takes the reading latency's drift, well under a microsecond per 10 ms)
    assert np.max(np.abs(np.diff(got) - np.diff(bus))) <= int(1e-4 * 10_000_000)
    assert np.max(np.abs(got - host)) < 2_000_000               # within the reading's latency and slew


@pytest.mark.parametrize('ppm', [-80.0, 50.0])
def test_a_drifting_adapter_clock_is_followed_within_the_slew(ppm):
    """A day at 1 frame/s, the adapter's crystal 50-80 ppm off (4-7 s a day): the mapped time
    stays within a few ms of the host's, and no interval changes by more than 100 ppm."""
    bus, host = _stream(5 * S, n=86_400, period=S, rate=1 + ppm * 1e-6)
    clock = BusClock()
    got = _map(clock, bus, host)
    assert clock.steps == 0
    assert np.max(np.abs(got - host)) < 5_000_000
    ratio = np.diff(got) / np.diff(bus)
    assert np.max(np.abs(ratio - 1)) <= 1e-4 + 1e-9


def test_a_clock_that_restarts_is_stepped_once():
    """The adapter is reset half-way: its clock starts again from 0. One step, once the new
    clock has lasted a second; the frames of that second get the host's reading time (with
    the old offset they would lie 1000 s back, which the pipeline would take for the clock set
    back), so every frame stays on the host's clock."""
    bus1, host1 = _stream(1_000 * S, n=1000)
    bus2, host2 = _stream(0, n=1000)
    host2 = host2 + (host1[-1] - HOST0) + 10_000_000
    clock = BusClock()
    got = _map(clock, np.concatenate([bus1, bus2]), np.concatenate([host1, host2]))
    assert clock.steps == 1
    assert np.max(np.abs(got - np.concatenate([host1, host2]))) < 2_000_000
    assert np.all(np.diff(got) > 0)


@pytest.mark.parametrize('step_s', [-10, -120, -20 * 365 * 86400, 10, 120])
@pytest.mark.parametrize('queued', [1, 8, 60])
def test_the_host_clock_stepping_with_frames_queued_is_not_the_interface_s(step_s, queued):
    """socketcan: the interface's stamps are the host kernel's. NTP (or an operator, or a GPS
    receiver's week rollover) steps the host clock while ``queued`` frames stamped before the
    step wait to be read: read after it, they disagree with the host by the step; the frames
    after agree again. The clock stays UTC with offset 0: every frame keeps its own stamp (the
    data time steps with the host's, as it must), none is moved by the step; the queued ones,
    read after it, get the reading's time."""
    bus, host = _stream(HOST0, n=3000)
    k = 1500
    bus[k:] += step_s * S                           # stamped after the step, by the stepped kernel clock
    host[k - queued:] += step_s * S                 # read after the step: the last queued ones too
    clock = BusClock()
    got = _map(clock, bus, host)
    queued_rows = np.arange(k - queued, k)
    rest = np.setdiff1d(np.arange(bus.size), queued_rows)
    # (a step forward under a minute is within a reading backlog: those keep their stamps too)
    read = host if not -1 <= step_s <= 60 else bus
    assert np.array_equal(got[rest], bus[rest]) and np.array_equal(got[queued_rows], read[queued_rows])
    assert clock.steps == 0 and clock.relative is False and clock.offset_ns == 0


def test_an_adapter_s_own_clock_follows_a_host_clock_step_once_it_lasts():
    """An adapter with a clock of its own (put on the host's): the host clock is set back
    2 minutes. The offset follows it after a second, once."""
    bus, host = _stream(1_000 * S, n=3000)
    host[1500:] -= 120 * S
    clock = BusClock()
    got = _map(clock, bus, host)
    assert clock.steps == 1 and clock.relative is True
    assert np.max(np.abs(got - host)[1600:]) < 2_000_000


def test_a_reading_backlog_is_not_a_step():
    """A UTC interface whose frames are read up to 30 s late (the node stalled): their own
    times are kept, not moved to the reading's."""
    bus, host = _stream(HOST0, n=3000)
    host = host + np.linspace(0, 30 * S, bus.size).astype(np.int64)
    clock = BusClock()
    assert np.array_equal(_map(clock, bus, host), bus)
    assert clock.steps == 0 and clock.relative is False


def test_a_clock_ahead_of_the_host_is_not_utc():
    """A frame cannot be read before it arrived: an interface time 2 s ahead of the host's
    is the interface's clock, not a backlog."""
    clock = BusClock()
    assert clock(HOST0 + 2 * S, HOST0) == HOST0 and clock.relative is True


def test_an_unknown_mode_is_refused():
    with pytest.raises(ValueError, match="timestamps mode 'gps': expected one of auto, bus, host"):
        BusClock('gps')
