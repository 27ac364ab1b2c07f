"""The direct CDR encoder gives the generic encoder's bytes, and rclpy reads them."""

from __future__ import annotations

import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

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
    """rclpy's own serialization of the typed message and the CDR the node publishes, records
    and a replay writes decode to the same values (rclpy leaves its alignment padding unset,
    so the padding bytes may differ).
    The rudder's message, that is: Fast-CDR pads an empty sequence of doubles where the
    generic encoder does not (see the next test)."""
    from mcap_ros2._dynamic import generate_dynamic
    from rclpy.serialization import serialize_message

    from test.node.rosref import to_ros
    dt = 'sensor_msgs/msg/JointState'
    decode = generate_dynamic(dt, msgdef(dt))[dt]
    for fields in JOINT[:1]:
        ours, theirs = FAST_ENCODERS[dt](fields), serialize_message(to_ros(dt, fields))
        assert repr(decode(ours)) == repr(decode(theirs))


DIAGNOSTICS = [
    {'header': {'stamp': {'sec': 1_700_000_000, 'nanosec': 0}, 'frame_id': ''}, 'status': []},
    {
        'header': {'stamp': {'sec': 1_700_000_001, 'nanosec': 5}, 'frame_id': 'x'},
        'status': [
            {
                'level': 0,
                'name': 'steer_monitor: CAN input',
                'message': 'ok',
                'hardware_id': 'r18',
                'values': [{'key': 'rate_hz', 'value': '10.0'}, {'key': '', 'value': ''}],
            },
            {'level': 2, 'name': 'b', 'message': 'd\u00e9j\u00e0 vu \u00b0', 'hardware_id': '', 'values': []},
            {'level': 3, 'name': '', 'message': 'abc', 'hardware_id': 'ab', 'values': [{'key': 'k', 'value': 'vv'}]},
        ],
    },
]


@pytest.mark.parametrize('fields', DIAGNOSTICS)
def test_diagnostic_array_matches_the_generic_encoder(fields):
    dt = 'diagnostic_msgs/msg/DiagnosticArray'
    assert FAST_ENCODERS[dt](fields) == _generic(dt)(fields)


_TEXT = st.text(max_size=12)
_STATUS = st.fixed_dictionaries({
    'level': st.integers(0, 3), 'name': _TEXT, 'message': _TEXT, 'hardware_id': _TEXT,
    'values': st.lists(st.fixed_dictionaries({'key': _TEXT, 'value': _TEXT}), max_size=4)})


@settings(max_examples=200, deadline=None)
@given(frame_id=_TEXT, status=st.lists(_STATUS, max_size=5))
def test_any_diagnostic_array_matches_the_generic_encoder(frame_id, status):
    dt = 'diagnostic_msgs/msg/DiagnosticArray'
    fields = {'header': {'stamp': {'sec': 1_700_000_000, 'nanosec': 7}, 'frame_id': frame_id}, 'status': status}
    assert FAST_ENCODERS[dt](fields) == _generic(dt)(fields)


def test_strings_past_the_kept_ones_are_encoded_the_same():
    """The encoders keep the CDR of at most MAX_STRINGS texts: a round of more distinct texts
    than that, encoded twice (the second time partly from what was kept), is the generic
    encoder's both times."""
    from steer_monitor.record.cdr import MAX_STRINGS
    dt = 'diagnostic_msgs/msg/DiagnosticArray'
    values = [{'key': f'k{i}', 'value': f'v{i} \u00b0'} for i in range(MAX_STRINGS)]
    fields = {'header': {'stamp': {'sec': 1, 'nanosec': 2}, 'frame_id': 'x'},
              'status': [{'level': 0, 'name': 'n', 'message': 'm', 'hardware_id': 'h', 'values': values}]}
    want = _generic(dt)(fields)
    assert FAST_ENCODERS[dt](fields) == want
    assert FAST_ENCODERS[dt](fields) == want


@pytest.mark.parametrize('text', ['', 'estimated', 'configured', '\u00e9'])
def test_string_matches_the_generic_encoder(text):
    dt = 'std_msgs/msg/String'
    assert FAST_ENCODERS[dt]({'data': text}) == _generic(dt)({'data': text})


def _typed_fields(key: str) -> tuple[str, dict]:
    """(datatype, fields) of the monitor's own message ``key``, built as the node builds it."""
    from steer_monitor.model.gear import Clearances
    from steer_monitor.monitor.messages import TOPICS, diag_messages, state_messages
    from steer_monitor.monitor.pipeline import DiagOut
    if key == 'clearances':
        interval = {'2z': (0.2e-3, None), 'zgb': (0.24e-3, 0.27e-3)}
        out = DiagOut(1_700_000_000_250_000_000, (), Clearances(0.6e-3, 0.25e-3), interval, 'estimated')
        fields = next(f for k, _, f in diag_messages(out) if k == key)
    else:
        from steer_monitor.model.loadshare import ShareScalar
        from steer_monitor.monitor.live import LiveState
        from steer_monitor.monitor.pipeline import StateOut
        share = ShareScalar(lateral=1e5, axial=3e5, ram_force=6e4, guide_force=4e4, k_gl=0.4, deflection=1e-4,
                            r_a=5e4, r_e=1e4, m_a=2e3, f_theta=7e4, f_z=9e4, case=-3, stages=5)
        st = LiveState(1_700_000_000_250_000_000, 0.3, 0.01, True, 1e6, share, Clearances(0.6e-3, 0.25e-3))
        fields = next(f for k, _, f in state_messages(StateOut(st)) if k == key)
    return TOPICS[key][1], fields


NAMED = ['load_sharing', 'clearances']


@pytest.mark.parametrize('key', NAMED)
def test_named_values_match_the_generic_encoder(key):
    """The load sharing and the clearances as ``sensor_msgs/JointState`` named values: our
    encoder against mcap-ros2-support's (empty velocity and effort, every alignment of what
    follows the frame id)."""
    dt, fields = _typed_fields(key)
    assert dt == 'sensor_msgs/msg/JointState'
    assert FAST_ENCODERS[dt](fields) == _generic(dt)(fields)
    for frame_id in ('', 'a', 'abcdefg'):
        f = dict(fields, header=dict(fields['header'], frame_id=frame_id))
        assert FAST_ENCODERS[dt](f) == _generic(dt)(f)


@pytest.mark.parametrize('key', NAMED)
def test_rclpy_and_rosbags_read_the_named_values(key):
    """What replay writes and the node records (the same encoder), rclpy (Fast-CDR, what
    ``ros2 bag play`` hands on) and rosbags read back to the same values by name; what rclpy
    makes of the node's published message reads back the same in rclpy (Fast-CDR pads the
    empty velocity and effort, which rosbags refuses as trailing bytes: hence the node records
    with this encoder)."""
    from rclpy.serialization import deserialize_message, serialize_message
    from rosbags.typesys import Stores, get_typestore

    from steer_monitor.monitor.messages import CLEARANCE_NAMES, LOAD_SHARING_NAMES
    from steer_monitor.node.rosmsg import message_class
    from test.node.rosref import to_ros
    dt, fields = _typed_fields(key)
    msg = deserialize_message(FAST_ENCODERS[dt](fields), message_class(dt))
    assert (msg.header.stamp.sec, msg.header.stamp.nanosec) == (1_700_000_000, 250_000_000)
    assert msg.header.frame_id == 'steering_gear'
    store = get_typestore(Stores.ROS2_KILTED)
    again = store.deserialize_cdr(FAST_ENCODERS[dt](fields), dt)
    published = deserialize_message(serialize_message(to_ros(dt, fields)), message_class(dt))
    assert list(published.position)[:2] == list(msg.position)[:2] and list(published.name) == list(msg.name)
    for got in (msg, again):
        values = dict(zip(got.name, got.position))
        assert len(got.velocity) == len(got.effort) == 0
        if key == 'clearances':
            assert list(got.name) == list(CLEARANCE_NAMES)
            assert [values[k] for k in ('gap_2z_m', 'gap_2z_lo_m')] == [0.6e-3, 0.2e-3]
            assert math.isnan(values['gap_2z_hi_m'])
            assert [values[k] for k in ('gap_zgb_m', 'gap_zgb_lo_m', 'gap_zgb_hi_m')] == [0.25e-3, 0.24e-3, 0.27e-3]
        else:
            assert list(got.name) == list(LOAD_SHARING_NAMES)
            assert [values[k] for k in LOAD_SHARING_NAMES] == [1e5, 6e4, 4e4, 0.4, 1e-4, 5e4, 1e4, 2e3, -3.0, 5.0]
