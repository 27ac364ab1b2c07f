"""The direct CDR encoders give the generic encoder's bytes."""

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
ARRAYS = [
    {'layout': {'dim': [{'label': 'lateral_n,ram_force_n', 'size': 2, 'stride': 2}], 'data_offset': 0},
     'data': [1.0, math.nan]},
    {'layout': {'dim': [], 'data_offset': 3}, 'data': []},
    {'layout': {'dim': [{'label': 'x', 'size': 1, 'stride': 1}, {'label': 'yz', 'size': 9, 'stride': 3}],
                'data_offset': 0}, 'data': [float(i) for i in range(9)]},
]


@pytest.mark.parametrize('fields', JOINT)
def test_joint_state_matches_the_generic_encoder(fields):
    dt = 'sensor_msgs/msg/JointState'
    assert FAST_ENCODERS[dt](fields) == _generic(dt)(fields)


@pytest.mark.parametrize('fields', ARRAYS)
def test_float64_multiarray_matches_the_generic_encoder(fields):
    dt = 'std_msgs/msg/Float64MultiArray'
    assert FAST_ENCODERS[dt](fields) == _generic(dt)(fields)


def test_rclpy_serializes_the_same_message():
    """The node records rclpy's serialization; replay writes these bytes. They decode to the
    same values (rclpy leaves its alignment padding unset, so the padding bytes may differ).
    The messages the monitor publishes, that is: no empty sequences of doubles, which
    Fast-CDR pads differently."""
    from mcap_ros2._dynamic import generate_dynamic
    from rclpy.serialization import serialize_message

    from steer_monitor.node.rosmsg import to_ros
    for dt, cases in (('sensor_msgs/msg/JointState', JOINT[:1]), ('std_msgs/msg/Float64MultiArray', ARRAYS[::2])):
        decode = generate_dynamic(dt, msgdef(dt))[dt]
        for fields in cases:
            ours, theirs = FAST_ENCODERS[dt](fields), serialize_message(to_ros(dt, fields))
            assert repr(decode(ours)) == repr(decode(theirs))
