"""The serialized setpoint reader (setpoints.StampedReader) against the
middleware's own serializer: the node subscribes its setpoints serialized and
reads the stamp and the numbers straight from the CDR bytes.
"""
from __future__ import annotations

import math
import random
import struct

import pytest
from geometry_msgs.msg import AccelStamped, PoseStamped, TwistStamped
from rclpy.serialization import serialize_message

from flight_sim_dynamics.ros.wire import (CDR_LE, StampedReader, read_pose_stamped,
                                          read_twist_stamped)

pytestmark = pytest.mark.ros

SPECIAL = (0.0, -0.0, 1e-300, -1e300, math.inf, -math.inf, math.nan, 5e-324)


def same(a: float, b: float) -> bool:
    """Equal, NaN included, -0.0 told from 0.0."""
    return struct.pack('<d', a) == struct.pack('<d', b) or (math.isnan(a) and math.isnan(b))


def pose_msg(frame: str, sec: int, nanosec: int, values: list[float]) -> PoseStamped:
    m = PoseStamped()
    m.header.frame_id = frame
    m.header.stamp.sec, m.header.stamp.nanosec = sec, nanosec
    p, o = m.pose.position, m.pose.orientation
    p.x, p.y, p.z, o.x, o.y, o.z, o.w = values
    return m


def rates_msg(kind: type, frame: str, sec: int, nanosec: int, values: list[float]):
    m = kind()
    m.header.frame_id = frame
    m.header.stamp.sec, m.header.stamp.nanosec = sec, nanosec
    body = m.twist if kind is TwistStamped else m.accel
    lin, ang = body.linear, body.angular
    lin.x, lin.y, lin.z, ang.x, ang.y, ang.z = values
    return m


def values(rng: random.Random, n: int) -> list[float]:
    return [rng.choice(SPECIAL) if rng.random() < 0.2 else rng.uniform(-1e3, 1e3)
            for _ in range(n)]


@pytest.mark.parametrize('frame_length', range(0, 18))
def test_pose_reader_matches_the_serializer(frame_length):
    """Every frame_id length (alignment of the doubles after it), extreme stamps
    and values (NaN, infinities, -0.0, denormals) read back exactly."""
    rng = random.Random(frame_length)
    for sec, nanosec in ((0, 0), (-5, 999_999_999), (2 ** 31 - 1, 2 ** 32 - 1),
                         (-2 ** 31, 1), (1_700_000_000, 123_456_789)):
        v = values(rng, 7)
        data = serialize_message(pose_msg('f' * frame_length, sec, nanosec, v))
        assert data[:2] == CDR_LE
        got_sec, got_nanosec, got = read_pose_stamped(data)
        assert (got_sec, got_nanosec) == (sec, nanosec)
        assert len(got) == 7 and all(same(a, b) for a, b in zip(got, v))


@pytest.mark.parametrize('kind', [TwistStamped, AccelStamped])
@pytest.mark.parametrize('frame', ['', 'a', 'simulator_base', 'é/ü', 'x' * 64])
def test_twist_and_accel_reader_matches_the_serializer(kind, frame):
    rng = random.Random(frame)
    v = values(rng, 6)
    data = serialize_message(rates_msg(kind, frame, 42, 7, v))
    sec, nanosec, got = read_twist_stamped(data)
    assert (sec, nanosec) == (42, 7)
    assert all(same(a, b) for a, b in zip(got, v))


def big_endian(data: bytes, count: int) -> bytes:
    """The same sample written big endian (as a big-endian machine would)."""
    sec, nanosec, length = struct.unpack_from('<iII', data, 4)
    offset = 16 + length
    offset += (4 - offset) % 8
    doubles = struct.unpack_from(f'<{count}d', data, offset)
    out = bytearray(data)
    out[0:2] = b'\x00\x00'
    struct.pack_into('>iII', out, 4, sec, nanosec, length)
    struct.pack_into(f'>{count}d', out, offset, *doubles)
    return bytes(out)


def test_big_endian_samples_are_read():
    v = [0.1, -0.2, 0.3, 0.0, 0.0, 0.38, 0.92]
    data = serialize_message(pose_msg('base', 3, 4, v))
    assert read_pose_stamped(big_endian(data, 7)) == (3, 4, tuple(v))


def test_other_encodings_are_left_to_the_caller():
    data = bytearray(serialize_message(pose_msg('base', 3, 4, [0.0] * 6 + [1.0])))
    for encapsulation in (b'\x00\x07', b'\x00\x06', b'\x00\x0b', b'\x01\x01'):
        data[0:2] = encapsulation
        assert read_pose_stamped(bytes(data)) is None


def test_truncated_sample_raises():
    data = serialize_message(pose_msg('base', 3, 4, [0.0] * 6 + [1.0]))
    with pytest.raises(struct.error):
        read_pose_stamped(data[:30])
    with pytest.raises(struct.error):
        StampedReader(7)(data[:10])
