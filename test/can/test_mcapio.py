"""The packed can_msgs/msg/Frame CDR against the generic ROS 2 encoder."""

from __future__ import annotations

from hypothesis import given, settings
from hypothesis import strategies as st
from mcap_ros2._dynamic import serialize_dynamic

from steer_monitor.can import Frame
from steer_monitor.can.mcapio import FRAME_DATATYPE, FRAME_MSGDEF, frame_cdr, frame_message

ENCODE = serialize_dynamic(FRAME_DATATYPE, FRAME_MSGDEF)[FRAME_DATATYPE]


@settings(max_examples=300, deadline=None)
@given(t=st.integers(0, 2**62), can_id=st.integers(0, 0x1FFFFFFF), data=st.binary(max_size=8),
       ext=st.booleans(), err=st.booleans(), rtr=st.booleans(),
       frame_id=st.text(alphabet='abcdefgh_/', max_size=12))
def test_packed_cdr_equals_generic_encoder(t, can_id, data, ext, err, rtr, frame_id):
    f = Frame(t % (2**31 * 10**9), can_id, data, ext, err, rtr)
    assert frame_cdr(f, frame_id) == ENCODE(frame_message(f, frame_id))
