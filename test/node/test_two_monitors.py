"""Two gears on one ship: two monitors of different names in one ROS context, their parameters
from one file keyed by node name, each with its own statuses and topics; a late subscriber gets
each one's clearances at once (transient_local); a renamed node without parameters refuses; an
error frame on one bus (its controller error-passive) is that monitor's WARN alone."""

from __future__ import annotations

import threading
import time
import uuid
from pathlib import Path

import can
import pytest
import yaml

from steer_monitor import sim
from steer_monitor.errors import ParameterError
from steer_monitor.sim.playback import play
from test.conftest import R18_YAML

pytestmark = pytest.mark.slow

NAMES = ('port_gear', 'stbd_gear')


def _level(status) -> int:
    return status.level[0] if isinstance(status.level, bytes) else int(status.level)


def _params_file(tmp: Path, channels: dict[str, str]) -> Path:
    """One parameters file with an entry per monitor: the R-18 gear, each its own bus,
    recording directory and hardware id."""
    doc = yaml.safe_load(R18_YAML.read_text(encoding='utf-8'))
    out = {}
    for name in NAMES:
        params = yaml.safe_load(yaml.safe_dump(doc['steer_monitor']['ros__parameters']))
        params['can'].update({'interface': 'virtual', 'channel': channels[name], 'timestamps': 'bus'})
        params['recording']['directory'] = str(tmp / name)
        params['node']['hardware_id'] = f'{name} R-18'
        params['estimator']['enabled'] = name == 'stbd_gear'      # the port gear's analyses off
        params['estimator']['state_file'] = str(tmp / name / 'estimator.npz')
        out[name] = {'ros__parameters': params}
    path = tmp / 'vessel.yaml'
    path.write_text(yaml.safe_dump(out), encoding='utf-8')
    return path


def test_two_monitors_side_by_side(tmp_path, r18_params, can_db):
    import rclpy
    from diagnostic_msgs.msg import DiagnosticArray
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
    from sensor_msgs.msg import JointState

    from steer_monitor.node.monitor_node import MonitorNode

    db, smap = can_db
    channels = {name: f'{name}-{uuid.uuid4().hex[:8]}' for name in NAMES}
    path = _params_file(tmp_path, channels)
    context = rclpy.Context()
    rclpy.init(args=['--ros-args', '--params-file', str(path)], context=context)
    nodes = {}
    try:
        with pytest.raises(ParameterError, match='node aft_gear: no gear parameters for it: give it a parameters '
                                                 'file with an entry "aft_gear:"'):
            MonitorNode('aft_gear', context=context)
        nodes = {name: MonitorNode(name, context=context) for name in NAMES}
        listener = rclpy.create_node('two_gears_listener', context=context)
        diags: list = []
        listener.create_subscription(DiagnosticArray, '/diagnostics', diags.append, 50)
        executor = SingleThreadedExecutor(context=context)
        for n in (*nodes.values(), listener):
            executor.add_node(n)
        spin = threading.Thread(target=executor.spin, daemon=True)
        spin.start()
        # an analysis asked for before any data: it runs at the first second of data
        from std_srvs.srv import Trigger
        client = listener.create_client(Trigger, '/stbd_gear/analyse_now')
        assert client.wait_for_service(timeout_sec=10.0)
        future = client.call_async(Trigger.Request())
        deadline = time.time() + 10
        while not future.done() and time.time() < deadline:
            time.sleep(0.02)
        assert future.result().success, future.result().message
        start = (time.time_ns() // 1_000_000_000 + 2) * 1_000_000_000
        frames = {}
        for k, name in enumerate(NAMES):      # the port gear on one pump, the starboard on two
            program = 'hard_over_1' if k == 0 else 'hard_over_2'
            frames[name] = sim.run(r18_params, sim.SimConfig(program=program, start_ns=start), db, smap,
                                   seed=6710 + k).frames
            sender = can.Bus(interface='virtual', channel=channels[name], preserve_timestamps=True)
            try:
                assert play(frames[name], sender, 0.0) == len(frames[name])
            finally:
                sender.shutdown()
        deadline = time.time() + 120
        while time.time() < deadline and any(nodes[n].frames_received < len(frames[n]) for n in NAMES):
            time.sleep(0.05)
        assert all(nodes[n].frames_received == len(frames[n]) for n in NAMES)
        time.sleep(1.0)
        statuses = {st.name: st for msg in list(diags) for st in msg.status}
        for name in NAMES:
            own = {k: v for k, v in statuses.items() if k.startswith(f'{name}: ')}
            assert {k.split(': ', 1)[1] for k in own} == {'CAN input', 'clearances', 'guide beam',
                                                           'steering performance', 'model health', 'rams',
                                                           'CAN bus', 'recording'}
            assert {st.hardware_id for st in own.values()} == {f'{name} R-18'}
            bus = {kv.key: kv.value for kv in own[f'{name}: CAN bus'].values}
            assert bus['interface'] == f'virtual:{channels[name]}'
        assert not [k for k in statuses if k.startswith('steer_monitor:')]
        # each took its own bus's frames: a hard-over with one pump on the port gear's, with two on
        # the starboard's (twice as fast: fewer frames)
        assert nodes['port_gear'].frames_received > nodes['stbd_gear'].frames_received
        # acting on one monitor: a threshold set (the next status judged by it), a parameter that
        # shapes what it reads refused with a reason, the recording split, the analyses off here
        from rcl_interfaces.msg import Parameter, ParameterType, ParameterValue
        from rcl_interfaces.srv import SetParameters

        def call(srv_type, name, request):
            client = listener.create_client(srv_type, name)
            assert client.wait_for_service(timeout_sec=10.0), name
            future = client.call_async(request)
            deadline = time.time() + 10
            while not future.done() and time.time() < deadline:
                time.sleep(0.02)
            return future.result()

        def double(name, value):
            return Parameter(name=name, value=ParameterValue(type=ParameterType.PARAMETER_DOUBLE, double_value=value))

        [ok, ro, out] = call(SetParameters, '/port_gear/set_parameters', SetParameters.Request(parameters=[
            double('clearances.limit_zgb_mm', 0.3)])).results + \
            call(SetParameters, '/port_gear/set_parameters', SetParameters.Request(parameters=[
                Parameter(name='can.channel', value=ParameterValue(type=ParameterType.PARAMETER_STRING,
                                                                  string_value='can9'))])).results + \
            call(SetParameters, '/port_gear/set_parameters', SetParameters.Request(parameters=[
                double('diagnostics.clearance_warn_share', 1.5)])).results
        assert ok.successful and not ro.successful and not out.successful
        assert 'read-only' in ro.reason or 'read only' in ro.reason, ro.reason
        assert nodes['port_gear'].params['clearances.limit_zgb_mm'] == 0.3
        assert nodes['port_gear'].params['can.channel'] == channels['port_gear']
        assert nodes['port_gear'].diag.cfg.limit_zgb == pytest.approx(0.3e-3)
        assert nodes['stbd_gear'].diag.cfg.limit_zgb == pytest.approx(0.25e-3)
        split = call(Trigger, '/port_gear/split_recording', Trigger.Request())
        assert split.success and 'new file' in split.message
        off = call(Trigger, '/port_gear/analyse_now', Trigger.Request())
        assert not off.success and off.message == 'the analyses are off (estimator.enabled: false)'
        assert nodes['stbd_gear'].analyst.jobs_made >= 1       # the one asked for, at the first second
        saved = call(Trigger, '/stbd_gear/save_state', Trigger.Request())
        assert saved.success and saved.message == f'saved to {tmp_path / "stbd_gear" / "estimator.npz"}'
        assert (tmp_path / 'stbd_gear' / 'estimator.npz').is_file()
        # the type hashes the graph gives for the monitor's publishers (rmw's, from the type support)
        hashes = {topic: next(str(i.topic_type_hash) for i in listener.get_publishers_info_by_topic(topic))
                  for topic in ('/port_gear/clearances', '/diagnostics')}
        # a dashboard started now gets each gear's clearances at once
        late = rclpy.create_node('late_dashboard', context=context)
        latched = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL,
                             reliability=ReliabilityPolicy.RELIABLE)
        got: dict[str, list] = {name: [] for name in NAMES}
        for name in NAMES:
            late.create_subscription(JointState, f'/{name}/clearances', got[name].append, latched)
        executor.add_node(late)
        deadline = time.time() + 10
        while time.time() < deadline and not all(got.values()):
            time.sleep(0.05)
        assert all(len(v) == 1 for v in got.values()), {k: len(v) for k, v in got.items()}
        assert list(got['port_gear'][0].name)[:1] == ['gap_2z_m']
        for name in NAMES:
            assert list((tmp_path / name).glob('*.mcap'))
        # the port gear's controller goes error-passive: SocketCAN's error frame, on its bus only
        t_err = int(frames['port_gear'].t_ns[-1]) + 500_000_000
        sender = can.Bus(interface='virtual', channel=channels['port_gear'], preserve_timestamps=True)
        try:
            sender.send(can.Message(timestamp=t_err / 1e9, arbitration_id=0x004 | 0x200, is_extended_id=False,
                                    is_error_frame=True, data=bytes([0, 0x10, 0, 0, 0, 0, 0, 130])))
        finally:
            sender.shutdown()
        deadline = time.time() + 10
        bus = None
        while time.time() < deadline:
            seen = {st.name: st for msg in list(diags) for st in msg.status}
            bus = seen['port_gear: CAN bus']
            if _level(bus) == 1:
                break
            time.sleep(0.1)
        assert bus is not None and _level(bus) == 1 and bus.message.startswith('controller error-passive since '), bus
        assert {kv.key: kv.value for kv in bus.values}['rx_error_counter'] == '130'
        assert _level(seen['stbd_gear: CAN bus']) == 0
        executor.shutdown()
    finally:
        for n in nodes.values():
            n.close()
        context.try_shutdown()
    # each recording, finished, is what rosbag2 writes: the latched topics offered transient_local,
    # the type hashes the live publishers gave the graph, the messages counted in its rosbag2 record
    from mcap.reader import make_reader
    recordings = sorted((tmp_path / 'port_gear').glob('*.mcap'))
    assert len(recordings) == 2         # split on request
    recording = recordings[0]
    with open(recording, 'rb') as fh:
        reader = make_reader(fh)
        channels = {c.topic: c for c in reader.get_summary().channels.values()}
        counts = dict(reader.get_summary().statistics.channel_message_counts)
        bag = yaml.safe_load({m.name: m.metadata for m in reader.iter_metadata()}['rosbag2']['serialized_metadata'])
    assert yaml.safe_load(channels['/port_gear/clearances'].metadata['offered_qos_profiles'])[0]['durability'] == \
        'transient_local'
    assert channels['/port_gear/clearances'].metadata['topic_type_hash'] == hashes['/port_gear/clearances']
    assert channels['/diagnostics'].metadata['topic_type_hash'] == hashes['/diagnostics']
    assert {t['topic_metadata']['name']: t['message_count'] for t in bag['topics_with_message_count']} == \
        {c.topic: counts.get(cid, 0) for cid, c in reader.get_summary().channels.items()}
    assert bag['relative_file_paths'] == []        # rosbag2 names the file it opens
