"""The direct CDR encoder gives the generic encoder's bytes, and rclpy reads them."""

from __future__ import annotations

import math

import pytest

from steer_monitor.record import msgdef
from steer_monitor.record.cdr import FAST_ENCODERS


def _generic(datatype: str):
    from mcap_ros2._dynamic import serialize_dynamic
    return serialize_dynamic(datatype, msgdef(datatype))[datatype]


JOINT = [
    {'header': {'stamp': {'sec': 1_700_000_000, 'nanosec': 123_456_789}, 'frame_id': 'rudder_stock'},
     'name': ['rudder'], 'position': [0.5], 'velocity': [-0.01], 'effort': [1.25e6]},
    {'header': {'stamp': {'sec': 0, 'nanosec': 0}, 'frame_id': ''},
     'name': [], 'position': [], 'velocity': [], 'effort': []},
    {'header': {'stamp': {'sec': -5, 'nanosec': 1}, 'frame_id': 'ab'},
     'name': ['a', 'bcd', ''], 'position': [1.0, 2.0, math.nan], 'velocity': [math.inf], 'effort': []},
]


@pytest.mark.parametrize('fields', JOINT)
def test_joint_state_matches_the_generic_encoder(fields):
    dt = 'sensor_msgs/msg/JointState'
    assert FAST_ENCODERS[dt](fields) == _generic(dt)(fields)


def test_rclpy_serializes_the_same_message():
    """The node records rclpy's serialization; replay writes these bytes. They decode to the
    same values (rclpy leaves its alignment padding unset, so the padding bytes may differ).
    The rudder's message, that is: Fast-CDR pads an empty sequence of doubles where the
    generic encoder does not (see the next test)."""
    from mcap_ros2._dynamic import generate_dynamic
    from rclpy.serialization import serialize_message

    from steer_monitor.node.rosmsg import to_ros
    dt = 'sensor_msgs/msg/JointState'
    decode = generate_dynamic(dt, msgdef(dt))[dt]
    for fields in JOINT[:1]:
        ours, theirs = FAST_ENCODERS[dt](fields), serialize_message(to_ros(dt, fields))
        assert repr(decode(ours)) == repr(decode(theirs))


@pytest.mark.parametrize('key', ['load_sharing', 'clearances'])
def test_rclpy_reads_the_named_values_replay_writes(key):
    """The load sharing and the clearances are JointStates with ``velocity`` and ``effort``
    NaN: what replay writes, rclpy (Fast-CDR, what ``ros2 bag play`` hands on) reads back
    to the same names and values, and what the node records (rclpy's bytes), rosbags reads
    (it refused the node's recording when they were empty: Fast-CDR pads those)."""
    from rclpy.serialization import deserialize_message
    from sensor_msgs.msg import JointState

    from steer_monitor.model.gear import Gaps
    from steer_monitor.monitor.messages import CLEARANCE_LABELS, LOAD_LABELS, diag_messages, state_messages
    from steer_monitor.monitor.pipeline import DiagOut
    if key == 'clearances':
        interval = {'2z': (0.2e-3, None), 'zgb': (0.24e-3, 0.27e-3)}
        out = DiagOut(1_700_000_000_250_000_000, (), Gaps(0.6e-3, 0.25e-3), interval, 'estimated')
        fields = next(f for k, _, f in diag_messages(out) if k == key)
        labels, values = CLEARANCE_LABELS, [0.6e-3, 0.2e-3, math.nan, 0.0, 0.25e-3, 0.24e-3, 0.27e-3, 1.0]
    else:
        from steer_monitor.model.loadshare import ShareScalar
        from steer_monitor.monitor.live import LiveState
        from steer_monitor.monitor.pipeline import StateOut
        share = ShareScalar(lateral=1e5, axial=3e5, ram_force=6e4, guide_force=4e4, k_gl=0.4, deflection=1e-4,
                            r_a=5e4, r_e=1e4, m_a=2e3, f_theta=7e4, f_z=9e4, case=3, stages=5)
        st = LiveState(1_700_000_000_250_000_000, 0.3, 0.01, True, 1e6, share, Gaps(0.6e-3, 0.25e-3))
        fields = next(f for k, _, f in state_messages(StateOut(st)) if k == key)
        labels, values = LOAD_LABELS, [1e5, 6e4, 4e4, 0.4, 1e-4, 5e4, 1e4, 2e3, 3.0]
    msg = deserialize_message(FAST_ENCODERS['sensor_msgs/msg/JointState'](fields), JointState)
    assert list(msg.name) == list(labels)
    assert len(msg.velocity) == len(msg.effort) == len(labels)
    assert all(math.isnan(v) for v in (*msg.velocity, *msg.effort))
    from rclpy.serialization import serialize_message
    from rosbags.typesys import Stores, get_typestore

    from steer_monitor.node.rosmsg import to_ros
    dt = 'sensor_msgs/msg/JointState'
    again = get_typestore(Stores.ROS2_KILTED).deserialize_cdr(serialize_message(to_ros(dt, fields)), dt)
    assert list(again.name) == list(labels)
    assert (msg.header.stamp.sec, msg.header.stamp.nanosec) == (1_700_000_000, 250_000_000)
    assert all(a == b or (math.isnan(a) and math.isnan(b)) for a, b in zip(msg.position, values, strict=True))
