"""The one-message setpoint input (``platform_setpoint``, a
trajectory_msgs/JointTrajectory): the serialized reader
(setpoints.TrajectoryReader) against the middleware's own serializer and
deserializer, and the point-by-point checks (setpoints.platform_setpoints).
"""
from __future__ import annotations

import math
import struct

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from rclpy.serialization import deserialize_message, serialize_message
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

from flight_sim_dynamics.ros.diagnostics import ERROR, CycleStats
from flight_sim_dynamics.ros.inputs import (ABSURD_ACCELERATION, BAD_SETPOINT, NON_FINITE,
                                            PLATFORM, PLATFORM_DOF_NAMES, STAMP_BACKWARDS,
                                            STAMP_REPEATED, PlatformPoint, SetpointError,
                                            Trajectory, TrajectoryPoint, platform_dof_order,
                                            platform_setpoints)
from flight_sim_dynamics.ros.wire import CDR_LE, TrajectoryReader, read_joint_trajectory

pytestmark = pytest.mark.ros

INT32 = st.integers(-2 ** 31, 2 ** 31 - 1)
UINT32 = st.integers(0, 2 ** 32 - 1)
DOUBLES = st.floats(allow_nan=True, allow_infinity=True, width=64)
# characters a ROS string field holds: no NUL, no lone surrogates (multi-byte
# UTF-8 ones move the alignment of what follows as much as ASCII ones)
CHARS = st.characters(blacklist_categories=('Cs',), blacklist_characters='\x00')
NAMES = st.lists(st.one_of(st.sampled_from(PLATFORM_DOF_NAMES), st.text(CHARS, max_size=12)),
                 max_size=4)
FRAMES = st.text(CHARS, max_size=20)


def same(a: float, b: float) -> bool:
    """Equal, NaN included, -0.0 told from 0.0."""
    return struct.pack('<d', a) == struct.pack('<d', b) or (math.isnan(a) and math.isnan(b))


def same_values(a, b) -> bool:
    return len(a) == len(b) and all(same(x, y) for x, y in zip(a, b))


def message(frame: str, sec: int, nanosec: int, names: list[str],
            points: list[tuple[list[float], list[float], list[float], list[float], int, int]]
            ) -> JointTrajectory:
    msg = JointTrajectory()
    msg.header.frame_id = frame
    msg.header.stamp.sec, msg.header.stamp.nanosec = sec, nanosec
    msg.joint_names = names
    for positions, velocities, accelerations, effort, t_sec, t_nanosec in points:
        point = JointTrajectoryPoint()
        point.positions, point.velocities = positions, velocities
        point.accelerations, point.effort = accelerations, effort
        point.time_from_start.sec, point.time_from_start.nanosec = t_sec, t_nanosec
        msg.points.append(point)
    return msg


def fields_of(msg: JointTrajectory) -> Trajectory:
    """The fields the reader must return, from the message object."""
    from flight_sim_dynamics.ros.wire import _trajectory_fields
    return _trajectory_fields(msg)


def equal(got: Trajectory, want: Trajectory) -> bool:
    if (got.sec, got.nanosec, got.joint_names) != (want.sec, want.nanosec, want.joint_names):
        return False
    if len(got.points) != len(want.points):
        return False
    for a, b in zip(got.points, want.points):
        if (a.sec, a.nanosec) != (b.sec, b.nanosec):
            return False
        if not all(same_values(x, y) for x, y in zip(a[:4], b[:4])):
            return False
    return True


def encode(msg: JointTrajectory, order: str) -> bytes:
    """The message serialized as plain CDR (XCDR1) in byte order ``order``
    ('<' or '>'), written here independently of the middleware (zero padding,
    nothing after the message): the way a big-endian machine writes it."""
    out = bytearray(b'\x00\x01\x00\x00' if order == '<' else b'\x00\x00\x00\x00')

    def align(n: int) -> None:
        out.extend(b'\x00' * ((-(len(out) - 4)) % n))

    def put(fmt: str, *values) -> None:
        align(struct.calcsize(fmt[-1]))          # the element type's size
        out.extend(struct.pack(order + fmt, *values))

    def string(text: str) -> None:
        raw = text.encode() + b'\x00'
        put('I', len(raw))
        out.extend(raw)

    put('i', msg.header.stamp.sec)
    put('I', msg.header.stamp.nanosec)
    string(msg.header.frame_id)
    put('I', len(msg.joint_names))
    for name in msg.joint_names:
        string(name)
    put('I', len(msg.points))
    for point in msg.points:
        for values in (point.positions, point.velocities, point.accelerations, point.effort):
            put('I', len(values))
            if len(values):
                put(f'{len(values)}d', *values)
        put('i', point.time_from_start.sec)
        put('I', point.time_from_start.nanosec)
    return bytes(out)


sequences = st.lists(DOUBLES, max_size=5)
points_strategy = st.lists(st.tuples(sequences, sequences, sequences, sequences, INT32, UINT32),
                           max_size=4)
messages = st.builds(message, FRAMES, INT32, UINT32, NAMES, points_strategy)


# ----------------------------------------------------------------------------
# The reader against the serializer
# ----------------------------------------------------------------------------
@settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(messages)
def test_reader_matches_the_serializer(msg):
    """Random frame_ids (every alignment of what follows), names, 0..4 points,
    sequences of 0..5 doubles (NaN, infinities included), stamps and
    time_from_start: the reader returns the deserialized message's fields."""
    data = serialize_message(msg)
    assert data[:2] == CDR_LE
    want = fields_of(deserialize_message(data, JointTrajectory))
    got = read_joint_trajectory(data)
    assert equal(got, want), (got, want)
    assert equal(TrajectoryReader()(data), want)        # without the names cache too


@settings(max_examples=100, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(messages)
def test_reader_reads_both_byte_orders(msg):
    """A big-endian sample (as a big-endian machine writes it) reads the same
    as the little-endian one; the test's own encoder is checked against the
    middleware's deserializer first."""
    want = fields_of(msg)
    little, big = encode(msg, '<'), encode(msg, '>')
    assert equal(fields_of(deserialize_message(little, JointTrajectory)), want)
    assert equal(read_joint_trajectory(little), want)
    assert equal(read_joint_trajectory(big), want)


@pytest.mark.parametrize('frame_length', range(0, 9))
def test_every_alignment_of_the_usual_message(frame_length):
    """The usual message (three names, one point of 3 + 3 + 3 numbers) after
    frame_ids of every length modulo 8, read repeatedly (names cache)."""
    reader = TrajectoryReader()
    for k in range(3):
        msg = message('f' * frame_length, 1_700_000_000 + k, 5, ['heave', 'roll', 'surge'],
                      [([0.1, 0.2, 0.3 + k], [1.0, -2.0, 3.0], [], [], 0, 0)])
        data = serialize_message(msg)
        assert equal(reader(data), fields_of(msg))


def test_names_cache_follows_the_names():
    """The cached names are used only for the bytes they came from: names
    that change (same lengths, other letters; other lengths) are read anew,
    whatever the padding bytes hold."""
    reader = TrajectoryReader()
    base = ['surge', 'heave', 'roll']
    for names in (base, ['surgf', 'heave', 'roll'], base, ['surge', 'heave', 'rol'],
                  ['surge', 'heave', 'roll', 'x'], [], base):
        msg = message('base', 1, 2, names, [([1.0, 2.0, 3.0], [], [], [], 0, 0)])
        for data in (serialize_message(msg), encode(msg, '<')):
            got = reader(data)
            assert got.joint_names == tuple(names)
            assert got.points[0].positions == (1.0, 2.0, 3.0)
    # the same names in the other byte order
    msg = message('base', 1, 2, base, [([1.0, 2.0, 3.0], [], [], [], 0, 0)])
    assert reader(encode(msg, '>')).joint_names == tuple(base)
    assert reader(encode(msg, '<')).joint_names == tuple(base)


def test_other_encodings_are_left_to_the_caller():
    data = bytearray(serialize_message(message('base', 3, 4, list(PLATFORM_DOF_NAMES),
                                               [([0.0] * 3, [], [], [], 0, 0)])))
    for encapsulation in (b'\x00\x07', b'\x00\x06', b'\x00\x0b', b'\x01\x01'):
        data[0:2] = encapsulation
        assert read_joint_trajectory(bytes(data)) is None


@settings(max_examples=50, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(messages)
def test_truncated_samples_raise(msg):
    """Every truncation of a sample raises struct.error (never an index error,
    never a wrong message); bytes after the message are ignored."""
    for order in ('<', '>'):
        data = encode(msg, order)
        for cut in range(len(data)):
            with pytest.raises(struct.error):
                read_joint_trajectory(data[:cut])
        assert equal(read_joint_trajectory(data + b'\xff' * 13), fields_of(msg))


def test_inconsistent_counts_raise_quickly():
    """Counts far beyond the bytes there are (garbage, or a hostile writer)
    raise without allocating or looping over them."""
    msg = message('', 0, 0, ['surge'], [([1.0], [], [], [], 0, 0)])
    data = bytearray(encode(msg, '<'))
    huge = struct.pack('<I', 2 ** 32 - 1)
    for at in (12,            # frame_id length
               20,            # joint_names count
               24,            # the name's length
               36,            # points count
               40):           # positions count
        bad = bytearray(data)
        bad[at:at + 4] = huge
        with pytest.raises(struct.error):
            read_joint_trajectory(bytes(bad))


def test_fallback_field_extraction_matches_the_reader():
    msg = message('base', -3, 7, ['roll', 'surge', 'heave'],
                  [([1.0, 2.0, 3.0], [4.0, 5.0, 6.0], [], [], 1, 2),
                   ([1.5, 2.5, 3.5], [], [7.0, 8.0, 9.0], [], 3, 4)])
    assert fields_of(msg) == read_joint_trajectory(serialize_message(msg))


# ----------------------------------------------------------------------------
# platform_setpoints: names, lengths, numbers, stamps
# ----------------------------------------------------------------------------
def trajectory(points, names=PLATFORM_DOF_NAMES, sec=100, nanosec=0) -> Trajectory:
    return Trajectory(sec, nanosec, tuple(names), tuple(
        TrajectoryPoint(tuple(p), tuple(v), tuple(a), tuple(e), s, ns)
        for p, v, a, e, s, ns in points))


def point(p=(0.01, 0.02, 0.03), v=(), a=(), e=(), sec=0, nanosec=0):
    return (p, v, a, e, sec, nanosec)


def test_joint_names_in_any_order():
    """The names give the order of the numbers: the pose is (surge, heave,
    roll) whatever the order; sway, pitch and yaw are 0."""
    for names in (('surge', 'heave', 'roll'), ('roll', 'surge', 'heave'),
                  ('heave', 'roll', 'surge')):
        value = {'surge': 0.01, 'heave': 0.02, 'roll': 0.03}
        rate = {'surge': 0.1, 'heave': 0.2, 'roll': 0.3}
        acc = {'surge': 1.0, 'heave': 2.0, 'roll': 3.0}
        (sp,) = platform_setpoints(trajectory(
            [point([value[n] for n in names], [rate[n] for n in names],
                   [acc[n] for n in names])], names), 50.0, 100.0)
        assert isinstance(sp, PlatformPoint)
        assert sp.pose.q == (0.01, 0.02, 0.03) and sp.twist.q == (0.1, 0.2, 0.3)
        assert sp.accel.q == (1.0, 2.0, 3.0)
        assert (sp.pose.sway, sp.pose.pitch, sp.pose.yaw) == (0.0, 0.0, 0.0)
        assert (sp.twist.sway, sp.twist.pitch, sp.twist.yaw) == (0.0, 0.0, 0.0)
        assert platform_dof_order(names) == tuple(names.index(n) for n in PLATFORM_DOF_NAMES)


@pytest.mark.parametrize('names', [(), ('surge', 'heave'), ('surge', 'heave', 'yaw'),
                                   ('surge', 'heave', 'roll', 'pitch'),
                                   ('surge', 'surge', 'roll'), ('Surge', 'heave', 'roll'),
                                   ('x' * 1000, 'heave', 'roll')])
def test_wrong_joint_names_reject_the_message(names):
    with pytest.raises(SetpointError) as info:
        platform_setpoints(trajectory([point()], names), 50.0, 100.0)
    assert info.value.reason == BAD_SETPOINT
    text = str(info.value)
    assert 'joint_names' in text and 'surge, heave, roll' in text
    assert len(text) < 300, 'a long name is cut in the message'
    if names:
        assert repr(names[0])[:15] in text


def test_no_points_rejects_the_message():
    with pytest.raises(SetpointError) as info:
        platform_setpoints(trajectory([]), 50.0, 100.0)
    assert info.value.reason == BAD_SETPOINT and 'points' in str(info.value)


@pytest.mark.parametrize('bad, reason, words', [
    (point(p=(0.1, 0.2)), BAD_SETPOINT, ('positions', 'got 2', '0.2')),
    (point(p=()), BAD_SETPOINT, ('positions', 'got 0')),
    (point(p=(0.0,) * 4), BAD_SETPOINT, ('positions', 'got 4')),
    (point(v=(0.1,)), BAD_SETPOINT, ('velocities', 'or empty', 'got 1')),
    (point(a=(0.0,) * 6), BAD_SETPOINT, ('accelerations', 'got 6')),
    (point(e=(1.0, 2.0, 3.0)), BAD_SETPOINT, ('effort', 'empty', 'got 3')),
    (point(sec=-1), BAD_SETPOINT, ('time_from_start', 'got -1 s', 'sec -1')),
    (point(sec=-1, nanosec=999_999_999), BAD_SETPOINT, ('time_from_start', '-1e-09 s')),
    (point(p=(math.nan, 0.0, 0.0)), NON_FINITE, ('positions', 'nan')),
    (point(v=(0.0, math.inf, 0.0)), NON_FINITE, ('velocities', 'inf')),
    (point(a=(0.0, 0.0, -math.inf)), NON_FINITE, ('accelerations', 'inf')),
    (point(a=(0.0, 51.0, 0.0)), ABSURD_ACCELERATION, ('input.max_linear_acceleration',)),
    (point(a=(0.0, 0.0, 101.0)), ABSURD_ACCELERATION, ('input.max_angular_acceleration',)),
])
def test_a_bad_point_rejects_that_point_only(bad, reason, words):
    """Each bad point is an error item naming the point and what was wrong;
    the points around it are still setpoints."""
    items = platform_setpoints(trajectory([point(), bad, point(nanosec=20)]), 50.0, 100.0)
    assert isinstance(items[0], PlatformPoint) and isinstance(items[2], PlatformPoint)
    error = items[1]
    assert isinstance(error, SetpointError) and error.reason == reason
    text = str(error)
    assert text.startswith('point 1')
    for word in words:
        assert word in text, (word, text)


def test_overflowing_sum_is_no_error():
    """Finite numbers whose sum overflows are not 'non-finite'."""
    (item,) = platform_setpoints(trajectory([point(p=(1e308, 1e308, 0.0))]), 50.0, 100.0)
    assert isinstance(item, PlatformPoint) and item.pose.q == (1e308, 1e308, 0.0)


def test_stamps_are_header_plus_time_from_start():
    items = platform_setpoints(trajectory(
        [point(), point(nanosec=5_000_000), point(sec=1, nanosec=999_999_999)],
        sec=100, nanosec=999_000_000), 50.0, 100.0)
    assert [i.stamp_ns for i in items] == [100_999_000_000, 101_004_000_000, 102_998_999_999]
    assert [i.header for i in items] == [(100, 999_000_000), (101, 4_000_000),
                                         (102, 998_999_999)]
    # time_from_start 0: the header stamp as received (even a non-normalised one)
    (item,) = platform_setpoints(trajectory([point()], sec=5, nanosec=1_500_000_000),
                                 50.0, 100.0)
    assert item.header == (5, 1_500_000_000) and item.stamp_ns == 6_500_000_000
    # beyond int32 seconds
    (item,) = platform_setpoints(trajectory([point(sec=10)], sec=2 ** 31 - 5), 50.0, 100.0)
    assert isinstance(item, SetpointError) and item.reason == BAD_SETPOINT
    assert 'builtin_interfaces/Time' in str(item)


def test_points_must_be_in_increasing_stamp_order():
    items = platform_setpoints(trajectory(
        [point(nanosec=10), point(nanosec=10), point(nanosec=5), point(nanosec=20),
         point(p=(math.nan, 0.0, 0.0), nanosec=30), point(nanosec=25), point(nanosec=31)]),
        50.0, 100.0)
    kinds = [i.reason if isinstance(i, SetpointError) else 'ok' for i in items]
    # a rejected point's stamp still counts for the order of the next
    assert kinds == ['ok', STAMP_REPEATED, STAMP_BACKWARDS, 'ok', NON_FINITE,
                     STAMP_BACKWARDS, 'ok']
    assert 'previous point' in str(items[1])


def test_missing_rates_and_accelerations_are_none():
    (item,) = platform_setpoints(trajectory([point()]), 50.0, 100.0)
    assert item.twist is None and item.accel is None
    (item,) = platform_setpoints(trajectory([point(v=(1.0, 2.0, 3.0))]), 50.0, 100.0)
    assert item.twist.q == (1.0, 2.0, 3.0) and item.accel is None


def test_diagnostics_count_the_new_input_and_reason():
    """``received platform_setpoint`` counts messages; ``bad_setpoint`` is a
    rejection reason of its own that makes the level ERROR; the other keys
    are unchanged."""
    stats = CycleStats()
    stats.received[PLATFORM] += 2
    stats.reject(BAD_SETPOINT, 'platform_setpoint rejected: points is empty')
    level, message, values = stats.report(1.0)
    d = dict(values)
    assert level == ERROR and 'bad_setpoint' in message
    assert d['received platform_setpoint'] == '2' and d['rejected bad_setpoint'] == '1'
    assert d['received pose'] == d['received twist'] == d['received accel'] == '0'
    assert list(d).index('received platform_setpoint') == list(d).index('received accel') + 1
