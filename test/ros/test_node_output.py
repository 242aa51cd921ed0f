"""The node's reused output messages (node.JointStateOutput): a serialized
template whose stamp and values are overwritten in place every cycle must read
back, cycle after cycle, as the JointState it stands for (no rclpy context or
node process needed).
"""
from __future__ import annotations

import math
import random

import pytest
from rclpy.serialization import deserialize_message, serialize_message
from sensor_msgs.msg import JointState

from flight_sim_dynamics.core.model import JOINT_NAMES, LEG_NAMES
from flight_sim_dynamics.ros.wire import JointStateOutput

pytestmark = pytest.mark.ros


def expected(names, frame, sec, nanosec, arrays) -> JointState:
    msg = JointState()
    msg.name = list(names)
    msg.header.frame_id = frame
    msg.header.stamp.sec, msg.header.stamp.nanosec = sec, nanosec
    for field, values in zip(('position', 'velocity', 'effort'), arrays):
        setattr(msg, field, [float(v) for v in values])
    return msg


def as_message(out) -> JointState:
    """What a subscriber gets from one fill()."""
    return deserialize_message(out, JointState) if isinstance(out, bytes) else out


@pytest.mark.parametrize('names, frame, arrays', [
    (LEG_NAMES, 'simulator_base', 3),          # actuator_states
    (JOINT_NAMES, 'simulator_base', 2),        # joint_states: effort empty
    (LEG_NAMES, '', 3),
    (JOINT_NAMES, 'a/much/longer/frame_id_than_usual', 2),
    (('only',), 'x', 1),
])
def test_serialized_output_reads_back_every_cycle(names, frame, arrays):
    out = JointStateOutput(names, frame, arrays)
    assert out.raw            # the middleware's encoding is understood here
    rng = random.Random(len(frame) + arrays)
    stamps = [(1_700_000_000 + k, (k * 1_000_003) % 1_000_000_000) for k in range(50)]
    stamps += [(0, 0), (-1, 999_999_999), (2 ** 31 - 1, 2 ** 32 - 1)]
    for sec, nanosec in stamps:
        values = [[rng.uniform(-1e4, 1e4) for _ in names] for _ in range(arrays)]
        data = out.fill(sec, nanosec, *values)
        assert isinstance(data, bytes)
        want = expected(names, frame, sec, nanosec, values)
        assert deserialize_message(data, JointState) == want
        # the same bytes the middleware would have written for that message
        assert data == serialize_message(want)


def test_values_of_a_cycle_never_leak_into_the_next():
    out = JointStateOutput(LEG_NAMES, 'simulator_base', 3)
    first = out.fill(1, 2, [1.0, 2.0, 3.0], [4.0, 5.0, 6.0], [7.0, 8.0, 9.0])
    second = out.fill(3, 4, [0.0] * 3, [-0.0] * 3, [math.pi] * 3)
    assert deserialize_message(first, JointState).position.tolist() == [1.0, 2.0, 3.0]
    msg = deserialize_message(second, JointState)
    assert (msg.header.stamp.sec, msg.header.stamp.nanosec) == (3, 4)
    assert msg.position.tolist() == [0.0] * 3 and msg.effort.tolist() == [math.pi] * 3


def test_message_fallback_gives_the_same_message():
    """When the encoding is not understood, fill() returns the reused message
    object: the same content."""
    raw = JointStateOutput(JOINT_NAMES, 'simulator_base', 2)
    plain = JointStateOutput(JOINT_NAMES, 'simulator_base', 2)
    plain.raw = False
    for k in range(3):
        values = [[k + i * 0.25 for i in range(12)], [-k - i * 0.5 for i in range(12)]]
        msg = plain.fill(10 + k, 20 + k, *values)
        assert isinstance(msg, JointState) and msg is plain.msg      # reused
        assert as_message(raw.fill(10 + k, 20 + k, *values)) == msg
        assert len(msg.effort) == 0


def test_wrong_number_of_values_raises():
    out = JointStateOutput(LEG_NAMES, 'simulator_base', 3)
    with pytest.raises(Exception):
        out.fill(0, 0, [1.0, 2.0], [1.0, 2.0, 3.0], [1.0, 2.0, 3.0])


def test_fallback_field_extraction_matches_the_reader():
    """A setpoint in an encoding the reader does not know is deserialized and
    its fields taken from the message: the same numbers as the reader's."""
    from geometry_msgs.msg import AccelStamped, PoseStamped, TwistStamped

    from flight_sim_dynamics.ros.wire import _pose_fields, _rate_fields
    from flight_sim_dynamics.ros.wire import read_pose_stamped, read_twist_stamped

    pose = PoseStamped()
    pose.header.stamp.sec, pose.header.stamp.nanosec = 12, 34
    pose.header.frame_id = 'base'
    p, o = pose.pose.position, pose.pose.orientation
    p.x, p.y, p.z, o.x, o.y, o.z, o.w = 0.1, 0.2, 0.3, 0.0, 0.0, 0.6, 0.8
    assert _pose_fields(pose) == read_pose_stamped(serialize_message(pose))
    for kind in (TwistStamped, AccelStamped):
        msg = kind()
        msg.header.stamp.sec, msg.header.stamp.nanosec = -3, 5
        body = msg.twist if kind is TwistStamped else msg.accel
        body.linear.x, body.linear.y, body.linear.z = 1.0, 2.0, 3.0
        body.angular.x, body.angular.y, body.angular.z = 4.0, 5.0, 6.0
        assert _rate_fields(msg) == read_twist_stamped(serialize_message(msg))
