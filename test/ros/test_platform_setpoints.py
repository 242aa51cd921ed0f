"""The one-message setpoint input (``platform_setpoint``, a
trajectory_msgs/JointTrajectory): the point-by-point checks
(messages.platform_setpoints).
"""
from __future__ import annotations

import math

import pytest
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

from flight_sim_dynamics.ros.diagnostics import CycleStats
from flight_sim_dynamics.ros.messages import (ABSURD_ACCELERATION, BAD_SETPOINT, ERROR, NON_FINITE,
                                              PLATFORM, STAMP_BACKWARDS, STAMP_REPEATED,
                                              PlatformPoint, SetpointError, platform_dof_order,
                                              pose_map)
from flight_sim_dynamics.ros.messages import platform_setpoints as machine_setpoints
from flight_sim_dynamics.machines import FLIGHT_SIMULATOR

#: The 3-DOF machine's coordinates, the joint names of its platform_setpoint.
PLATFORM_DOF_NAMES = FLIGHT_SIMULATOR.coordinates


def platform_setpoints(msg, *args):
    """The points of a 3-DOF machine's message."""
    return machine_setpoints(msg, pose_map(FLIGHT_SIMULATOR), *args)


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


# ----------------------------------------------------------------------------
# platform_setpoints: names, lengths, numbers, stamps
# ----------------------------------------------------------------------------
def trajectory(points, names=PLATFORM_DOF_NAMES, sec=100, nanosec=0) -> JointTrajectory:
    return message('', sec, nanosec, list(names), [
        (list(p), list(v), list(a), list(e), s, ns) for p, v, a, e, s, ns in points])


def point(p=(0.01, 0.02, 0.03), v=(), a=(), e=(), sec=0, nanosec=0):
    return (p, v, a, e, sec, nanosec)


def test_joint_names_in_any_order():
    """The names give the order of the numbers: the pose is (surge, heave,
    roll) whatever the order."""
    for names in (('surge', 'heave', 'roll'), ('roll', 'surge', 'heave'),
                  ('heave', 'roll', 'surge')):
        value = {'surge': 0.01, 'heave': 0.02, 'roll': 0.03}
        rate = {'surge': 0.1, 'heave': 0.2, 'roll': 0.3}
        acc = {'surge': 1.0, 'heave': 2.0, 'roll': 3.0}
        (sp,) = platform_setpoints(trajectory(
            [point([value[n] for n in names], [rate[n] for n in names],
                   [acc[n] for n in names])], names), 50.0, 100.0)
        assert isinstance(sp, PlatformPoint)
        assert sp.pose == (0.01, 0.02, 0.03) and sp.twist == (0.1, 0.2, 0.3)
        assert sp.accel == (1.0, 2.0, 3.0)
        assert platform_dof_order(names, PLATFORM_DOF_NAMES) == tuple(
            names.index(n) for n in PLATFORM_DOF_NAMES)


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
    assert isinstance(item, PlatformPoint) and item.pose == (1e308, 1e308, 0.0)


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
    assert item.twist == (1.0, 2.0, 3.0) and item.accel is None


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
