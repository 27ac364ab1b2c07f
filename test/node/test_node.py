"""The node end to end: simulator -> virtual CAN -> node -> /diagnostics, recording, shutdown.

The node's behaviour is tested on the data clock: a voyage is put on the bus at once, its
frames keeping their stamps, and the node takes it as fast as it reads (:class:`FastRun`);
what it published and recorded is then read by data time. Only the silence the node judges on
the wall clock (STALE) has a short real-time test.

One module of some 700 lines: the node started in-process or as a process, its bus and its
recordings are the fixtures every test here shares."""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import threading
import time
import uuid
from collections.abc import Callable
from pathlib import Path

import can
import pytest

from steer_monitor import sim
from steer_monitor.sim.playback import play
from test.ashore.replay_reference import reference_replay
from test.conftest import PKG, R18_YAML

pytestmark = pytest.mark.slow

OK, WARN, ERROR, STALE = 0, 1, 2, 3


class Harness:
    """rclpy context, the monitor node, a listener and an executor thread."""

    def __init__(self, tmp: Path, channel: str, extra: dict | None = None) -> None:
        import rclpy
        from diagnostic_msgs.msg import DiagnosticArray
        from rclpy.executors import SingleThreadedExecutor
        from sensor_msgs.msg import JointState

        from steer_monitor.node.monitor_node import MonitorNode
        from steer_monitor.node.params_ros import overrides_from_file

        self.context = rclpy.Context()
        rclpy.init(context=self.context)
        overrides = overrides_from_file(str(R18_YAML), {
            'can.interface': 'virtual', 'can.channel': channel, 'recording.directory': str(tmp),
            'estimator.state_file': str(tmp / 'estimator.npz'),
            # the tests play a minute of helm in real time: an analysis after 30 s of motion
            'estimator.first_motion_s': 30.0, **(extra or {})})
        self.node = MonitorNode(parameter_overrides=overrides, context=self.context)
        self.listener = rclpy.create_node('diag_listener', context=self.context)
        self.diags: list = []
        self.loads: list = []
        self.listener.create_subscription(DiagnosticArray, '/diagnostics', self.diags.append, 10)
        self.listener.create_subscription(JointState, '/steer_monitor/load_sharing', self.loads.append, 10)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self.executor.add_node(self.listener)
        self.thread = threading.Thread(target=self.executor.spin, daemon=True)
        self.thread.start()

    def latest(self) -> dict[str, object]:
        return {s.name: s for s in self.diags[-1].status}

    def wait_for(self, cond, timeout: float) -> dict[str, object]:
        deadline = time.time() + timeout
        while time.time() < deadline:
            if self.diags and cond(self.latest()):
                return self.latest()
            time.sleep(0.1)
        raise AssertionError(f'timed out; last: {[(k, v.level, v.message) for k, v in self.latest().items()]}')

    def close(self) -> None:
        self.executor.shutdown()
        self.node.close()
        self.listener.destroy_node()
        self.context.try_shutdown()


def _values(status) -> dict[str, str]:
    return {kv.key: kv.value for kv in status.values}


def _level(status) -> int:
    return status.level[0] if isinstance(status.level, bytes) else int(status.level)


# --- the node on the data clock: a voyage fed as fast as the node reads it -----------------
#: the voyage the data-clock tests share: a hard-over both ways (its analysis after 30 s of
#: motion), then the rudder held, so the data runs on past the analysis's apply time
FAST_PROGRAM = 'hard_over_2,hold:40'


class FastRun:
    """What one node made of :data:`FAST_PROGRAM`, fed on a virtual bus as fast as it reads
    (the frames keep their own stamps, ``can.timestamps: bus``: every decision the node takes
    is on them, so the outputs do not depend on how fast it ran): its recording, the frames
    sent and those a second listener on the bus saw, the analyses' state file and the finding
    it held when closed, the load-sharing messages it published."""

    def __init__(self, tmp: Path, r18_params, can_db) -> None:
        db, smap = can_db
        start = (time.time_ns() // 1_000_000_000 + 2) * 1_000_000_000    # the data a little ahead of the host clock
        self.frames = sim.run(r18_params, sim.SimConfig(program=FAST_PROGRAM, start_ns=start), db, smap, seed=3).frames
        channel = f'fast-{uuid.uuid4().hex[:8]}'
        self.tmp = tmp
        h = Harness(tmp, channel, {'can.timestamps': 'bus'})
        sniffer = can.Bus(interface='virtual', channel=channel)
        sender = can.Bus(interface='virtual', channel=channel, preserve_timestamps=True)
        try:
            assert play(self.frames, sender, 0.0) == len(self.frames)
            deadline = time.time() + 120
            while h.node.frames_received < len(self.frames) and time.time() < deadline:
                time.sleep(0.05)
            self.received = h.node.frames_received
            self.sniffed = 0
            while sniffer.recv(0.05) is not None:
                self.sniffed += 1
        finally:
            sender.shutdown()
            sniffer.shutdown()
            h.close()
        self.finding = h.node.analyst.finding
        self.state_file = tmp / 'estimator.npz'
        self.loads = [dict(zip(m.name, m.position)) for m in h.loads]
        [self.recording] = list(tmp.glob('*.mcap'))


@pytest.fixture(scope='module')
def fast_run(tmp_path_factory, r18_params, can_db) -> FastRun:
    return FastRun(tmp_path_factory.mktemp('fast'), r18_params, can_db)


def _diagnostics(path: Path) -> dict[int, dict[str, object]]:
    """The recorded diagnostics of each whole second of data: time [ns] -> status name ->
    status (the node's wall-clock ones while the bus was silent left out)."""
    return {t: {st.name: st for st in msg.status} for t, msg in sorted(_by_topic(path)['/diagnostics'].items())
            if t % 1_000_000_000 == 0}


def test_the_node_takes_every_frame_and_sends_none(fast_run):
    """Every frame on the bus reached the node; a second listener saw only the simulator's:
    the node transmitted nothing."""
    assert fast_run.received == len(fast_run.frames)
    assert fast_run.sniffed == len(fast_run.frames)


def test_the_node_publishes_its_statuses_named_and_levelled(fast_run, r18_params):
    """After the hard-overs: every status there, in order; the inputs at rate; the hard-over
    timed as the simulated gear takes it (25.5 s with two pumps); the guide beam's onset the
    model's for the clearances in use; the residual small; the recording OK."""
    from steer_monitor.model.gear import Clearances
    from steer_monitor.params import gear_from_params
    from steer_monitor.studies.tables import loadshare_rows
    diags = _diagnostics(fast_run.recording)
    last = diags[max(diags)]
    assert list(last) == ['steer_monitor: CAN input', 'steer_monitor: clearances', 'steer_monitor: guide beam',
                          'steer_monitor: steering performance', 'steer_monitor: model health', 'steer_monitor: rams',
                          'steer_monitor: CAN bus', 'steer_monitor: recording']
    assert _level(last['steer_monitor: CAN input']) == OK
    bus = _values(last['steer_monitor: CAN bus'])     # a virtual bus: no controller to make silent
    assert _level(last['steer_monitor: CAN bus']) == OK and bus['controller_silent'] == 'unknown'
    assert bus['last_bus_error'] == 'none' and bus['frame_times'] == "the interface's (can.timestamps: bus)"
    perf = last['steer_monitor: steering performance']
    assert _level(perf) == OK and float(_values(perf)['hard_over_s']) == pytest.approx(25.5, abs=0.6)
    cl = _values(last['steer_monitor: clearances'])
    in_use = Clearances.from_mm(float(cl['clearance_2z_mm']), float(cl['clearance_zgb_mm']))
    sweep, _ = loadshare_rows(gear_from_params(r18_params), in_use, None, 0.1)
    assert float(_values(last['steer_monitor: guide beam'])['guide_onset_deg']) == pytest.approx(
        sweep['landmarks']['guide_onset_deg'], abs=0.6)
    health = _values(last['steer_monitor: model health'])
    assert _level(last['steer_monitor: model health']) == OK, health
    assert int(health['residual_samples']) < 600 or float(health['residual_rms_bar']) < 3.0, health
    assert _level(last['steer_monitor: recording']) == OK


def test_the_nodes_load_sharing_is_published_by_name(fast_run):
    """The load sharing's named values reach a subscriber: the guide beam's share by name,
    consistent with the forces."""
    assert fast_run.loads and any(v['k_gl'] > 0 for v in fast_run.loads)
    for v in fast_run.loads[-50:]:
        assert 0 <= v['k_gl'] <= 1 and 1 <= v['load_case'] <= 6, v
        assert v['guide_force_n'] == pytest.approx(v['k_gl'] * v['lateral_n'], rel=1e-9, abs=1e-6), v


def test_the_nodes_analysis_reaches_its_outputs(fast_run):
    """The analysis at 30 s of motion replaces the configured clearances at its apply time
    (20 s of data after its job started): the clearances estimated, whole and consistent.
    (Their coverage of the truth is the accuracy studies'; that the node publishes what its
    estimator gives on its data is the replay test's.)"""
    diags = _diagnostics(fast_run.recording)
    estimated = [t for t, d in diags.items()
                 if _values(d['steer_monitor: clearances'])['clearance_source'] == 'estimated']
    assert estimated and fast_run.finding is not None
    assert estimated[0] >= fast_run.finding.t_ns + 20_000_000_000
    cl = _values(diags[estimated[-1]]['steer_monitor: clearances'])
    lo, hi = float(cl['clearance_zgb_lo_mm']), float(cl['clearance_zgb_hi_mm'])
    assert 0.0 <= lo <= float(cl['clearance_zgb_mm']) <= hi
    assert cl['clearance_2z_hi_mm'] == 'n/a' and float(cl['clearance_2z_lo_mm']) <= 0.6     # a bound only
    k_lo, k_hi = float(cl['k_gl_max_lo']), float(cl['k_gl_max_hi'])
    assert 0.0 <= k_lo <= float(cl['k_gl_max_estimated']) <= k_hi <= 1.0


def test_a_restarted_node_starts_from_the_saved_analysis(fast_run, tmp_path):
    """The analyses' state was saved on close; a node started on it publishes its clearances
    from its first diagnostics."""
    assert fast_run.state_file.exists()
    h = Harness(tmp_path, f'steer-{uuid.uuid4().hex[:8]}', {'estimator.state_file': str(fast_run.state_file)})
    try:
        cl = _values(h.wait_for(lambda x: True, 10.0)['steer_monitor: clearances'])
    finally:
        h.close()
    assert cl['clearance_source'] == 'estimated'
    assert float(cl['clearance_zgb_mm']) == pytest.approx(fast_run.finding.z_gb.value * 1e3, abs=1e-3)


def test_the_recording_holds_every_topic_read_by_rosbags(fast_run):
    """Every topic, every message decoded by rosbags (an independent reader); CRCs valid; every
    frame recorded."""
    from mcap.reader import make_reader
    from rosbags.highlevel import AnyReader
    with open(fast_run.recording, 'rb') as fh:
        reader = make_reader(fh, validate_crcs=True)
        n = sum(1 for _ in reader.iter_messages())
        topics = {c.topic for c in reader.get_summary().channels.values()}
    assert topics == {'/steering_can/rx', '/diagnostics', '/steer_monitor/rudder', '/steer_monitor/load_sharing',
                      '/steer_monitor/clearances', '/steer_monitor/clearance_source'}
    decoded = frames = 0
    with AnyReader([fast_run.recording]) as r:
        for conn, _, raw in r.messages():
            r.deserialize(raw, conn.msgtype)
            decoded += 1
            frames += conn.topic == '/steering_can/rx'
    assert decoded == n and frames == len(fast_run.frames)


def test_a_replay_of_the_nodes_recording_publishes_what_the_node_published(fast_run, tmp_path):
    """Replay of the recorded frames, with the node's parameters: the same states, load sharing,
    diagnostics (the node's own two statuses aside) and clearances at every data time, and the
    replay's file the per-frame reference's, byte for byte."""
    from steer_monitor.ashore.replay import replay
    config = tmp_path / 'r18.yaml'                 # the node's parameters (the harness's first analysis)
    config.write_text(R18_YAML.read_text().replace('first_motion_s: 240.0', 'first_motion_s: 30.0'))
    assert 'first_motion_s: 30.0' in config.read_text()
    replayed = replay([fast_run.recording], tmp_path / 'replay.mcap', config)
    assert replayed.errors == [] and replayed.frames == len(fast_run.frames)
    live, again = _by_topic(fast_run.recording), _by_topic(tmp_path / 'replay.mcap')
    for topic in ('/steer_monitor/rudder', '/steer_monitor/load_sharing'):
        assert set(live[topic]) == set(again[topic]), topic
        assert all(_same(live[topic][t], again[topic][t]) for t in live[topic]), topic
    # every whole second of data; the node's others are its wall-clock ones while the bus was
    # silent (before the voyage came, on a loaded machine), which a replay has no reason to make
    seconds = {t for t in live['/diagnostics'] if t % 1_000_000_000 == 0}
    assert seconds == set(again['/diagnostics']) and len(seconds) > 80
    for t in seconds:
        recorded = [st for st in live['/diagnostics'][t].status
                    if st.name not in ('steer_monitor: recording', 'steer_monitor: CAN bus')]   # the node's own
        assert _same(recorded, again['/diagnostics'][t].status), t
        for topic in ('/steer_monitor/clearances', '/steer_monitor/clearance_source'):
            assert _same(live[topic][t], again[topic][t]), (topic, t)
    assert any(m.data == 'estimated' for m in again['/steer_monitor/clearance_source'].values())
    reference_replay([fast_run.recording], tmp_path / 'reference.mcap', config)
    assert (tmp_path / 'reference.mcap').read_bytes() == (tmp_path / 'replay.mcap').read_bytes()


def test_a_silent_bus_shows_stale_and_a_live_one_ok_again(tmp_path, r18_params, can_db):
    """The real-time smoke test: a few seconds of the gear played in real time on a virtual
    bus (its frames stamped by the bus, on the host clock); silent past the silence limit
    (2 s), the inputs are STALE on the wall clock; played again, OK."""
    db, smap = can_db
    channel = f'steer-{uuid.uuid4().hex[:8]}'
    run = sim.run(r18_params, sim.SimConfig(program='hold:3'), db, smap, seed=4).frames
    h = Harness(tmp_path, channel)
    sender = can.Bus(interface='virtual', channel=channel)
    try:
        play(run, sender, 1.0)
        d = h.wait_for(lambda x: _level(x['steer_monitor: CAN input']) == OK, 4.0)
        assert _values(d['steer_monitor: CAN bus'])['frame_times'] == "the interface's (UTC, as the host clock)"
        h.wait_for(lambda x: _level(x['steer_monitor: CAN input']) == STALE, 6.0)
        play(run, sender, 1.0)
        h.wait_for(lambda x: _level(x['steer_monitor: CAN input']) == OK, 4.0)
    finally:
        sender.shutdown()
        h.close()


def _by_topic(path: Path) -> dict[str, dict[int, object]]:
    """topic -> log time -> decoded message (frames left out)."""
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory
    out: dict[str, dict[int, object]] = {}
    with open(path, 'rb') as fh:
        for _, channel, message, msg in make_reader(fh, decoder_factories=[DecoderFactory()]).iter_decoded_messages():
            if channel.topic != '/steering_can/rx':
                out.setdefault(channel.topic, {})[message.log_time] = msg
    return out


def _same(a: object, b: object) -> bool:
    """Equal field by field, NaN equal to NaN."""
    if isinstance(a, float) and isinstance(b, float):
        return a == b or (a != a and b != b)
    if isinstance(a, (list, tuple)) and isinstance(b, (list, tuple)):
        return len(a) == len(b) and all(_same(x, y) for x, y in zip(a, b))
    if hasattr(a, '__slots__') and type(a).__name__ == type(b).__name__:
        return all(_same(getattr(a, f), getattr(b, f)) for f in a.__slots__)
    return a == b


def _node_cmd(tmp: Path, *extra: str) -> list[str]:
    return [sys.executable, '-m', 'steer_monitor.node.monitor_node', '--ros-args', '--params-file', str(R18_YAML),
            '-p', 'can.interface:=virtual', '-p', f'can.channel:=sub-{uuid.uuid4().hex[:6]}',
            '-p', f'recording.directory:={tmp}', *extra]


def _env() -> dict[str, str]:
    env = dict(os.environ, ROS_AUTOMATIC_DISCOVERY_RANGE='LOCALHOST')
    env['PYTHONPATH'] = str(PKG) + os.pathsep + env.get('PYTHONPATH', '')
    return env


@pytest.mark.parametrize('sig', [signal.SIGTERM, signal.SIGINT])
def test_signal_finishes_the_recording(tmp_path, sig):
    from mcap.reader import make_reader
    proc = subprocess.Popen(_node_cmd(tmp_path), env=_env(), stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.time() + 20
        while not list(tmp_path.glob('*.mcap')) and time.time() < deadline:
            time.sleep(0.1)
        time.sleep(2.5)  # a few diagnostics
        proc.send_signal(sig)
        assert proc.wait(15) == 0, proc.stderr.read()
    finally:
        if proc.poll() is None:
            proc.kill()
    [path] = list(tmp_path.glob('*.mcap'))
    with open(path, 'rb') as fh:
        reader = make_reader(fh, validate_crcs=True)
        summary = reader.get_summary()
        diags = sum(1 for _ in reader.iter_messages(topics=['/diagnostics']))
    assert summary is not None and diags >= 2


@pytest.mark.parametrize('override,name', [
    ('gear.stock_to_ram_m:=-1.0', 'gear.stock_to_ram_m'),
    ('gear.rams:=2.5', 'gear.rams'),
    ('can.dbc_file:=missing.dbc', 'missing.dbc'),
    ('signals.rudder_angle.field:=Nope', 'signals.rudder_angle.field'),
    ('gear.bogus_m:=1.0', 'gear.bogus_m'),
    ('can.timestamps:=gps', "parameter can.timestamps: expected one of auto, bus, host, got 'gps'"),
    ('recording.max_file_mb:=64', 'recording.max_file_mb: expected double, got 64 (ROS reads a whole number as an '
                                  'integer: write 64.0)'),
])
def test_bad_parameter_stops_the_node_naming_it(tmp_path, override, name):
    proc = subprocess.run(_node_cmd(tmp_path, '-p', override), env=_env(), capture_output=True, text=True, timeout=60)
    assert proc.returncode == 2
    assert 'steer_monitor: cannot start:' in proc.stderr and name in proc.stderr


@pytest.mark.parametrize('kind,given,why', [
    ('double', 3, 'ROS reads a whole number as an integer: write 3.0'),
    ('double', -5, 'ROS reads a whole number as an integer: write -5.0'),
    ('double_array', [0, 10, 35], 'ROS reads whole numbers as integers: write [0.0, 10.0, 35.0]'),
    ('double', 'abc', 'rclpy says'),
    ('double', True, 'rclpy says'),
    ('double_array', [1.5, 2], 'rclpy says'),
    ('integer', 2.5, 'rclpy says'),
])
def test_why_a_value_of_the_wrong_type_was_refused(kind, given, why):
    from steer_monitor.node.params_ros import why_refused
    assert why_refused(kind, given, ValueError('rclpy says')) == why


def test_without_ros_messages_the_node_says_so(tmp_path):
    """A ROS 2 install without a message package the node publishes (not sourced, or broken):
    one line naming it, exit 2, no traceback, and no recording opened."""
    cmd = _node_cmd(tmp_path)
    blocked = ("import sys; sys.modules['sensor_msgs'] = None; "   # import of it fails
               "from steer_monitor.node.monitor_node import main; sys.exit(main(sys.argv))")
    proc = subprocess.run([sys.executable, '-c', blocked, *cmd[3:]], env=_env(), capture_output=True, text=True,
                          timeout=60)
    assert proc.returncode == 2, proc.stderr
    assert 'Traceback' not in proc.stderr
    [line] = [ln for ln in proc.stderr.splitlines() if 'steer_monitor: cannot start:' in ln]
    assert 'cannot import sensor_msgs' in line and 'source /opt/ros/' in line
    assert list(tmp_path.glob('*.mcap')) == []


def test_without_a_parameters_file_the_packaged_one_is_used(tmp_path):
    """``ros2 run steer_monitor monitor`` with no --params-file: the packaged R-18 parameters,
    said in the log, not a failure on the first required parameter."""
    cmd = [sys.executable, '-m', 'steer_monitor.node.monitor_node', '--ros-args',
           '-p', 'can.interface:=virtual', '-p', f'can.channel:=bare-{uuid.uuid4().hex[:6]}',
           '-p', f'recording.directory:={tmp_path}']
    proc = subprocess.Popen(cmd, env=_env(), stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.time() + 20
        while not list(tmp_path.glob('*.mcap')) and time.time() < deadline:
            time.sleep(0.1)
        time.sleep(1.0)
        proc.send_signal(signal.SIGINT)
        assert proc.wait(15) == 0
        err = proc.stderr.read()
    finally:
        if proc.poll() is None:
            proc.kill()
    assert 'no gear parameters given: using the packaged parameters file' in err and 'r18.yaml' in err
    assert list(tmp_path.glob('*.mcap'))


def _node_stderr(cmd: list[str], seconds: float, mcap_in: Path | None = None,
                 until: Callable[[], bool] | None = None) -> str:
    """Run the node ``seconds`` (counted from its first MCAP in ``mcap_in`` when given, or from
    when ``until`` holds: both waited for up to 20 s), stop it with SIGINT (exit 0 asserted) and
    give what it wrote to stderr."""
    proc = subprocess.Popen(cmd, env=_env(), stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.time() + 20
        while mcap_in is not None and not list(mcap_in.glob('*.mcap')) and time.time() < deadline:
            time.sleep(0.1)
        while until is not None and not until() and time.time() < deadline:
            time.sleep(0.1)
        time.sleep(seconds)
        proc.send_signal(signal.SIGINT)
        rc = proc.wait(15)
        err = proc.stderr.read()
        assert rc == 0, err[-2000:]
        return err
    finally:
        if proc.poll() is None:
            proc.kill()


def test_a_bus_that_cannot_be_opened_is_said_in_the_log_once(tmp_path):
    """The node keeps running (the bus may come later: it retries with backoff), and the log
    says why it hears nothing, once, not at every retry."""
    err = _node_stderr(_node_cmd(tmp_path, '-p', 'can.interface:=nosuch', '-p', 'can.reopen_backoff_initial_s:=0.1',
                                 '-p', 'can.reopen_backoff_max_s:=0.2'), 2.0, tmp_path)   # ten retries and more
    told = [ln for ln in err.splitlines() if 'cannot open CAN bus nosuch:' in ln]
    assert len(told) == 1 and '[WARN]' in told[0] and 'trying again every 0.2 s at most' in told[0], err


def test_a_recording_that_cannot_be_written_is_said_in_the_log_once(tmp_path):
    """Recording into a directory that cannot be made: the node runs on (diagnostics, topics),
    and the log says the recording fails, once, not at every retry."""
    (tmp_path / 'plain').write_text('x')
    err = _node_stderr(_node_cmd(tmp_path, '-p', f'recording.directory:={tmp_path / "plain" / "sub"}',
                                 '-p', f'estimator.state_file:={tmp_path / "estimator.npz"}'),
                       8.0)             # past the recorder's 5 s retry
    told = [ln for ln in err.splitlines() if 'cannot record:' in ln]
    assert len(told) == 1 and '[ERROR]' in told[0] and 'Not a directory' in told[0], err
    # and on closing, what was lost in all
    lost = [ln for ln in err.splitlines() if 'recording:' in ln]
    assert len(lost) == 1 and '[WARN]' in lost[0], err
    assert re.search(r'recording: (\d+) could not be written of \1 messages; closed after 0 file\(s\); '
                     r'the last writes failed: Not a directory', lost[0]), err


def test_the_oldest_recordings_are_removed_beyond_the_budget_and_said_in_the_log(tmp_path):
    """recording.max_total_gb reaches the recorder: of three earlier recordings of 600 kB, the
    two oldest go when the node starts recording with a budget of 1 MB; each is in the log."""
    old = []
    for k in range(3):
        p = tmp_path / f'steer_monitor_2025120{k + 1}T000000Z_001.mcap'
        p.write_bytes(os.urandom(600_000))
        os.utime(p, (1e9 + k, 1e9 + k))
        old.append(p)
    err = _node_stderr(_node_cmd(tmp_path, '-p', 'recording.max_file_mb:=0.25', '-p', 'recording.max_total_gb:=0.001',
                                 '-p', 'recording.keep_free_gb:=0.0',     # whatever this disk has free
                                 '-p', f'estimator.state_file:={tmp_path / "estimator.npz"}'), 1.0,
                       until=lambda: not old[1].exists())
    assert [p.exists() for p in old] == [False, False, True], err
    told = [ln for ln in err.splitlines() if 'removed the oldest recording' in ln]
    assert len(told) == 2 and all('[INFO]' in ln for ln in told), err
    assert f'removed the oldest recording {old[0]} (0.6 MB): the recordings took more than 0.001 GB' in told[0]


def test_a_line_logged_while_closing_after_a_signal_is_not_followed_by_rcl_complaints(tmp_path):
    """SIGINT shuts ROS down before the node closes; what the node logs then (here: the
    analyses' state it cannot save) is printed, without rcl's 'Failed to publish log message
    to rosout'."""
    (tmp_path / 'plain').write_text('x')
    err = _node_stderr(_node_cmd(tmp_path, '-p', f'estimator.state_file:={tmp_path / "plain" / "sub" / "e.npz"}'),
                       1.0, tmp_path)
    assert "cannot save the analyses' state" in err and 'Not a directory' in err, err
    assert 'rosout' not in err, err

def test_an_analysis_state_that_cannot_be_saved_is_said_once_until_it_can(tmp_path, capfd):
    (tmp_path / 'plain').write_text('x')
    h = Harness(tmp_path, f'save-{uuid.uuid4().hex[:6]}',
                {'estimator.state_file': str(tmp_path / 'plain' / 'sub' / 'estimator.npz')})
    try:
        for _ in range(3):
            h.node.save_analyses()
        (tmp_path / 'plain').unlink()           # the directory can be made now
        h.node.save_analyses()
        h.node.save_analyses()
    finally:
        h.close()
    err = capfd.readouterr().err.splitlines()
    failed = [ln for ln in err if "cannot save the analyses' state" in ln]
    again = [ln for ln in err if 'saved to' in ln and 'again' in ln]
    assert len(failed) == 1 and 'Not a directory' in failed[0] and len(again) == 1, err
    assert (tmp_path / 'plain' / 'sub' / 'estimator.npz').is_file()


def test_a_defect_that_recurs_every_frame_is_logged_at_most_every_ten_seconds(tmp_path, capfd):
    """The reader guards each read of the bus against a defect and goes on; a defect hit by
    every read would put a line per read in the log (hundreds a second on a full bus): throttled."""
    from steer_monitor.errors import SteerMonitorError
    channel = f'defect-{uuid.uuid4().hex[:6]}'
    h = Harness(tmp_path, channel)

    def broken(frames, see=None, **kw):
        raise SteerMonitorError('a defect')
    h.node.pipeline.feed_frames = broken
    sender = can.Bus(interface='virtual', channel=channel)
    try:
        for i in range(200):
            sender.send(can.Message(arbitration_id=0x09F10D01 + i % 4, data=bytes(8), is_extended_id=True))
        deadline = time.time() + 10
        while h.node.frames_received < 200 and time.time() < deadline:
            time.sleep(0.05)
        assert h.node.frames_received == 200
    finally:
        sender.shutdown()
        h.close()
    lines = [ln for ln in capfd.readouterr().err.splitlines() if 'frames not processed: a defect' in ln]
    assert len(lines) == 1, lines


def _paced_adapter(monkeypatch, frames: list, stamp, speed: float = 1.0) -> None:
    """The node's bus replaced by one that gives ``frames`` paced in real time (``speed`` times
    as fast), each stamped ``stamp(i, frame)`` [s], as an adapter would."""
    import steer_monitor.node.monitor_node as M
    from steer_monitor.can.bus import message_from_frame
    t0 = frames[0].t_ns

    class Paced:
        def __init__(self) -> None:
            self.i, self.start = 0, time.monotonic()

        def recv(self, timeout=None):
            if self.i >= len(frames):
                time.sleep(timeout or 0.01)
                return None
            f = frames[self.i]
            wait = self.start + (f.t_ns - t0) / 1e9 / speed - time.monotonic()
            if timeout is not None and wait > timeout:     # not due within the timeout: none, as a bus says
                time.sleep(timeout)
                return None
            time.sleep(max(0.0, wait))
            msg = message_from_frame(f)
            msg.timestamp = stamp(self.i, f)
            self.i += 1
            return msg

        def shutdown(self) -> None:
            pass

    class Adapter(M.ListenOnlyBus):
        def __init__(self, *a, **k) -> None:
            super().__init__(*a, **k)
            self._bus.shutdown()
            self._bus = Paced()

    monkeypatch.setattr(M, 'ListenOnlyBus', Adapter)


def test_an_adapter_whose_clock_is_not_utc_is_put_on_the_host_clock(tmp_path, capfd, monkeypatch, r18_params,
                                                                     db, smap):
    """An adapter that stamps frames from its power-up (gs_usb/candleLight): the node's states
    and diagnostics are dated by the host's clock, not 1970; the CAN bus status and one
    warning say so."""
    frames = list(sim.run(r18_params, sim.SimConfig(program='hold:3'), db, smap, seed=5).frames.frames())
    t0 = frames[0].t_ns
    _paced_adapter(monkeypatch, frames, lambda i, f: 1000.0 + (f.t_ns - t0) / 1e9)   # seconds since power-up
    h = Harness(tmp_path, f'clock-{uuid.uuid4().hex[:6]}')
    try:
        start = time.time_ns()
        d = h.wait_for(lambda d: 'not UTC' in _values(d['steer_monitor: CAN bus'])['frame_times'], 20.0)
        stamp = h.diags[-1].header.stamp
        bus = _values(d['steer_monitor: CAN bus'])
    finally:
        h.close()
    assert abs(stamp.sec * 1e9 + stamp.nanosec - start) < 30e9, stamp      # today, not 1970
    assert bus['frame_times'].startswith("the interface's clock is not UTC (+"), bus
    told = [ln for ln in capfd.readouterr().err.splitlines() if 'CAN frame times:' in ln]
    assert len(told) == 1 and '[WARN]' in told[0], told


def test_a_host_clock_set_back_restarts_the_monitor_in_place(tmp_path, capfd, monkeypatch, r18_params, db, smap):
    """The frames' time goes back an hour half-way (NTP setting back a clock that ran ahead):
    the node goes on publishing states from the new time (before, it refused every frame as
    time_backwards until the clock caught up: an hour of nothing), says so once, and records
    on in a second file, each file holding one time (the estimator's part:
    test_analyst.s restart test)."""
    from mcap.reader import make_reader
    frames = list(sim.run(r18_params, sim.SimConfig(program='hold:8'), db, smap, seed=6).frames.frames())
    t0, half = frames[0].t_ns, len(frames) // 2
    back = 3600 * 10**9
    _paced_adapter(monkeypatch, frames, lambda i, f: (f.t_ns - (back if i >= half else 0)) / 1e9, speed=4.0)
    h = Harness(tmp_path, f'back-{uuid.uuid4().hex[:6]}', {'can.timestamps': 'bus', 'recording.keep_free_gb': 0.0})
    try:
        deadline = time.time() + 30
        while h.node.frames_received < len(frames) and time.time() < deadline:
            time.sleep(0.1)
        time.sleep(1.0)
        restarts = getattr(h.node, 'restarts', None)
        bus = _values(h.latest()['steer_monitor: CAN bus'])
    finally:
        h.close()
    stamps = [m.header.stamp.sec * 10**9 + m.header.stamp.nanosec for m in h.loads]
    before = [t for t in stamps if t >= t0]
    after = [t for t in stamps if t < t0]
    assert before and after, (len(before), len(after))
    assert restarts == 1 and bus['frame_time_went_back'] == '1'
    # the states go on after the step, at the rate they came before it
    assert len(after) > 0.6 * len(before), (len(before), len(after))
    assert max(after) > frames[-1].t_ns - back - 2 * 10**9
    told = [ln for ln in capfd.readouterr().err.splitlines() if 'time went back' in ln]
    assert len(told) == 1 and '[WARN]' in told[0] and '3600.' in told[0], told
    files = sorted(tmp_path.glob('*.mcap'), key=lambda p: p.stat().st_mtime)
    assert len(files) == 2, files
    got = []
    for path in files:
        with open(path, 'rb') as fh:
            got.append([(ch.topic, m.log_time) for _, ch, m in make_reader(fh).iter_messages(log_time_order=False)])
    # each file holds one time: the second only the new one; the first the old one and at most
    # the frames that confirmed the step (recorded before it was known)
    # (the bus quiet at the end, the node takes the seconds to the wall clock's: the idle ones)
    old_time = [x for x in got[1] if t0 <= x[1] <= frames[-1].t_ns + 2 * 10**9]
    assert not old_time and got[1][0][1] < t0, old_time[:3]
    late = [(topic, t) for topic, t in got[0] if t < t0]
    assert all(topic == '/steering_can/rx' for topic, _ in late) and len(late) <= 60, late[:5]


def test_the_analysis_state_is_not_saved_onto_the_disk_beneath_an_unmounted_one(tmp_path):
    """The state file lives in the recording directory; on a disk unmounted while the node
    runs, a save made the directory again on the system's disk under the empty mount point.
    Now the save fails (said once) and nothing is made there."""
    if os.geteuid() != 0:
        pytest.skip('mounting a tmpfs needs root; this test runs in CI as root')
    mnt = tmp_path / 'usb'
    mnt.mkdir()
    done = subprocess.run(['mount', '-t', 'tmpfs', '-o', 'size=4m', 'tmpfs', str(mnt)], capture_output=True,
                          text=True, check=False)
    if done.returncode != 0:
        pytest.skip(f'cannot mount a tmpfs here: {done.stderr.strip()}')
    h = None
    try:
        h = Harness(mnt / 'rec', f'umount-{uuid.uuid4().hex[:6]}',
                    {'estimator.state_file': 'steer_monitor_estimator.npz', 'recording.enabled': False})
        h.node.save_analyses()
        assert (mnt / 'rec' / 'steer_monitor_estimator.npz').exists()
        subprocess.run(['umount', '-l', str(mnt)], check=True)
        h.node.save_analyses()
        assert not (mnt / 'rec').exists()
        assert f'no directory {mnt / "rec"}' in (h.node.save_error or '')
    finally:
        if h is not None:
            h.close()
        subprocess.run(['umount', '-l', str(mnt)], check=False)


def test_a_signal_while_starting_leaves_no_recording_unfinished(tmp_path, monkeypatch):
    """Ctrl-C as the node loads (under load, seconds after its recorder opened) raised out of
    its constructor and left the recording open: the threads started are stopped and the MCAP
    is finished, readable by an independent reader."""
    import rclpy
    from rosbags.highlevel import AnyReader

    from steer_monitor.can.frames import Frame
    from steer_monitor.node.monitor_node import MonitorNode
    from steer_monitor.node.params_ros import overrides_from_file

    def interrupted(self):          # the recorder holds a frame by then: its file is open
        self.recorder.write_frame(Frame(1_767_225_600_000_000_000, 0x09F10D10, bytes(8)))
        time.sleep(0.5)
        assert list(tmp_path.glob('*.mcap*')) or list(tmp_path.glob('.*')), 'the recorder opened no file'
        raise KeyboardInterrupt
    monkeypatch.setattr(MonitorNode, '_start_analyst', interrupted)
    context = rclpy.Context()
    rclpy.init(context=context)
    try:
        overrides = overrides_from_file(str(R18_YAML), {
            'can.interface': 'virtual', 'can.channel': f'start-{uuid.uuid4().hex[:6]}',
            'recording.directory': str(tmp_path), 'estimator.state_file': str(tmp_path / 'estimator.npz')})
        with pytest.raises(KeyboardInterrupt):
            MonitorNode(parameter_overrides=overrides, context=context)
    finally:
        rclpy.shutdown(context=context)
    (rec,) = list(tmp_path.glob('*.mcap'))
    with AnyReader([rec]) as reader:        # finished: its summary and footer are there
        assert reader.connections is not None
    assert not [p for p in tmp_path.iterdir() if p.name.startswith('.')]


def test_a_signal_that_races_the_executors_wait_set_is_a_clean_stop(tmp_path, monkeypatch):
    """SIGINT's shutdown arriving while the executor builds its wait set makes rclpy raise its
    RCLError ("the given context is not valid") rather than ExternalShutdownException: the node
    stops as on any signal: exit 0, closed."""
    import rclpy
    from rclpy.executors import SingleThreadedExecutor

    from steer_monitor.node.monitor_node import main

    def spin(self) -> None:
        rclpy.shutdown()                   # what rclpy's signal handler does
        raise RuntimeError('failed to initialize wait set: the given context is not valid, either rcl_init() '
                           'was not called or rcl_shutdown() was called.')
    monkeypatch.setattr(SingleThreadedExecutor, 'spin', spin)
    assert main(['monitor', *_node_cmd(tmp_path)[3:]]) == 0
    assert not rclpy.ok()


def test_without_numba_the_node_runs_no_analysis_and_says_why(tmp_path):
    """numba hidden: the node starts, says once in its log that its analyses are off and why,
    records, and its model health says the same; nothing interpreted holds up its bus reader."""
    from steer_monitor.node.monitor_node import ANALYSES_OFF_WITHOUT_NUMBA
    cmd = _node_cmd(tmp_path)
    hidden = ("import sys; sys.modules['numba'] = None; "
              "from steer_monitor.node.monitor_node import main; sys.exit(main(sys.argv))")
    err = _node_stderr([sys.executable, '-c', hidden, *cmd[3:]], 2.5, mcap_in=tmp_path)
    said = [ln for ln in err.splitlines() if 'numba is not installed' in ln]
    assert len(said) == 1 and said[0].startswith('[WARN]') and said[0].endswith(ANALYSES_OFF_WITHOUT_NUMBA)
    [recording] = list(tmp_path.glob('*.mcap'))
    health = [st for msg in _by_topic(recording)['/diagnostics'].values() for st in msg.status
              if st.name == 'steer_monitor: model health']
    assert health and {st.message for st in health} == {f'not judged: {ANALYSES_OFF_WITHOUT_NUMBA}'}
