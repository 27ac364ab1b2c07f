"""Two gears on one ship: two monitors of different names in one ROS context, their parameters
from one file keyed by node name, each with its own statuses and topics; a late subscriber gets
each one's clearances at once (transient_local); a renamed node without parameters refuses."""

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
        params['estimator']['enabled'] = False
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
        start = (time.time_ns() // 1_000_000_000 + 2) * 1_000_000_000
        frames = {}
        for k, name in enumerate(NAMES):      # the port gear swings once, the starboard twice
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
        # each took its own bus's frames: one hard-over on the port gear's, two on the starboard's
        assert nodes['port_gear'].frames_received < nodes['stbd_gear'].frames_received
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
        executor.shutdown()
    finally:
        for n in nodes.values():
            n.close()
        context.try_shutdown()
