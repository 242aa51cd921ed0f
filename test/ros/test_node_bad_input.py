"""Bad input never takes the node down.

Each bad setpoint (on the three topics, and on platform_setpoint) is
followed by a valid one that must be answered exactly;
no NaN or infinity is ever published; nothing is published for a rejected
setpoint (an unreachable pose publishes nothing: docs/node.md); every
rejection is counted in /diagnostics and logged (throttled).
"""
from __future__ import annotations

import math
import re

import numpy as np
import pytest

import flight_sim_dynamics as fsd
from flight_sim_dynamics.machines.staicu.trajectories import paper_example
from node_harness import Client, all_finite, stamp_ns

pytestmark = pytest.mark.ros

NAN, INF = math.nan, math.inf
STEP = 5_000_000                                 # 5 ms between stamps
BASE = 1_500_000_000 * 1_000_000_000   # in the past: not a future stamp


Q, QD, QDD = (v[0] for v in paper_example('general', np.array([1.2])))

# (name, reason counter, how to send it at stamp s: f(client, s, last_valid_stamp))
BAD_INPUTS = [
    ('nan position', 'non_finite',
     lambda c, s, last: c.send(s, Q, QD, QDD, raw={'pose.position.x': NAN})),
    ('inf heave', 'non_finite',
     lambda c, s, last: c.send(s, Q, QD, QDD, raw={'pose.position.z': INF})),
    ('nan quaternion', 'non_finite',
     lambda c, s, last: c.send(s, Q, QD, QDD, quaternion=(NAN, 0.0, 0.0, 1.0))),
    ('inf twist', 'non_finite',
     lambda c, s, last: c.send(s, Q, QD, QDD, raw={'twist.linear.z': -INF})),
    ('nan accel', 'non_finite',
     lambda c, s, last: c.send(s, Q, QD, QDD, raw={'accel.angular.x': NAN})),
    ('zero quaternion', 'bad_quaternion',
     lambda c, s, last: c.send(s, Q, QD, QDD, quaternion=(0.0, 0.0, 0.0, 0.0))),
    ('non-unit quaternion', 'bad_quaternion',
     lambda c, s, last: c.send(s, Q, QD, QDD, quaternion=(0.0, 0.0, 0.0, 2.0))),
    ('unreachable pose (heave -0.5 m)', 'unreachable',
     lambda c, s, last: c.send(s, (0.0, -0.5, 0.0), (0, 0, 0), (0, 0, 0))),
    ('unreachable pose (surge 0.3 m)', 'unreachable',
     lambda c, s, last: c.send(s, (0.3, 0.0, 0.0), (0, 0, 0), (0, 0, 0))),
    ('repeated stamp', 'stamp_repeated',
     lambda c, s, last: c.send(last, Q, QD, QDD, order='tap')),
    ('stamp going backwards', 'stamp_backwards',
     lambda c, s, last: c.send(last - 10 * STEP, Q, QD, QDD, order='tap')),
    ('twist with no pose', 'no_pose',
     lambda c, s, last: c.send(s, Q, QD, None, order='t')),
    ('accel with no pose', 'no_pose',
     lambda c, s, last: c.send(s, Q, None, QDD, order='a')),
    ('absurd acceleration (1000 m/s^2)', 'absurd_acceleration',
     lambda c, s, last: c.send(s, Q, QD, (0.0, 1000.0, 0.0))),
    ('absurd roll acceleration (1e6 rad/s^2)', 'absurd_acceleration',
     lambda c, s, last: c.send(s, Q, QD, (0.0, 0.0, 1e6))),
]


def reject_each_then_answer(client, model, bad_inputs, send_valid, stamp: int
                            ) -> tuple[dict, dict]:
    """Send a valid setpoint at ``stamp``, then for each (name, reason, send)
    of ``bad_inputs`` the bad input followed by a valid setpoint
    (``send_valid(client, stamp)``), checking that exactly the valid one is
    answered, exactly. Returns the /diagnostics values before and after (once
    every rejection is counted), having checked each reason's counter."""
    expected = fsd.solve(model, Q, QD, QDD)
    before = client.wait_diagnostics(lambda v: 'rejected bad_setpoint' in v, timeout=3.0)
    n = len(client.actuator)
    send_valid(client, stamp)                                   # a valid start
    assert client.wait_actuator(n + 1)
    last_valid = stamp
    expected_counts: dict[str, int] = {}
    for name, reason, send in bad_inputs:
        stamp += STEP
        n = len(client.actuator)
        send(client, stamp, last_valid)
        stamp += STEP
        send_valid(client, stamp)                               # the next valid setpoint
        assert client.wait_actuator(n + 1, timeout=3.0), f'{name}: valid setpoint not answered'
        client.spin_until(lambda: False, 0.02)
        answered = [m for _, m in client.actuator[n:]]
        assert [stamp_ns(m) for m in answered] == [stamp], \
            f'{name}: expected one answer for the valid setpoint only'
        np.testing.assert_allclose(answered[0].effort, expected.force, rtol=0, atol=1e-9,
                                   err_msg=name)
        last_valid = stamp
        expected_counts[reason] = expected_counts.get(reason, 0) + 1

    after = client.wait_diagnostics(
        lambda v: int(v['rejected total']) >= int(before['rejected total']) + len(bad_inputs),
        timeout=3.0)
    for reason, count in expected_counts.items():
        got = int(after[f'rejected {reason}']) - int(before[f'rejected {reason}'])
        assert got == count, f'counter rejected {reason}: {got} != {count}'
    return before, after


def test_each_bad_input_is_rejected_and_the_next_setpoint_answered(client, model):
    before, after = reject_each_then_answer(
        client, model, BAD_INPUTS, lambda c, s: c.send(s, Q, QD, QDD, order='tap'), BASE)
    # The twist and accel of a repeated / backwards setpoint are reported as
    # 'late' (they carry the stamp of an answered setpoint): 2 messages each.
    late = int(after['rejected late']) - int(before['rejected late'])
    assert late == 4
    assert int(after['rejected total']) - int(before['rejected total']) == len(BAD_INPUTS) + late
    assert all(all_finite(m) for _, m in client.actuator)
    assert all(all_finite(m) for m in client.joints)


def test_absurd_estimated_acceleration_rejected(client, model):
    """A pose jump in a pose-only stream gives an absurd estimated acceleration:
    rejected, and it leaves no trace: the next pose-only setpoint is answered
    with estimates that ignore it. (The second of the stream is not answered:
    warming up.)"""
    stamp = BASE + 10_000_000_000
    n = len(client.actuator)
    before = client.wait_diagnostics(lambda v: 'rejected absurd_acceleration' in v, 3.0)
    client.send(stamp, (0.0, 0.0, 0.0), order='p')              # at rest
    client.send(stamp + STEP, (0.0, 0.0, 0.0), order='p')       # warming up
    client.send(stamp + 2 * STEP, (0.0, 0.1, 0.0), order='p')   # 0.1 m in 5 ms: absurd
    client.send(stamp + 3 * STEP, (0.0, 0.0, 0.0), order='p')   # at rest again
    client.send(stamp + 4 * STEP, Q, QD, QDD, order='tap')
    assert client.wait_actuator(n + 3, timeout=3.0)
    stamps = [stamp_ns(m) for _, m in client.actuator[n:n + 3]]
    assert stamps == [stamp, stamp + 3 * STEP, stamp + 4 * STEP]
    # the rejected pose left no trace: the estimate is from the two poses at rest
    rest = fsd.solve(model, (0.0, 0.0, 0.0), (0.0,) * 3, (0.0,) * 3)
    np.testing.assert_allclose(client.actuator[n + 1][1].effort, rest.force, rtol=0, atol=1e-9)
    diag = client.wait_diagnostics(
        lambda v: int(v['rejected absurd_acceleration'])
        > int(before['rejected absurd_acceleration']), 3.0)
    assert int(diag['rejected warming_up']) - int(before['rejected warming_up']) == 1


def test_node_reports_error_and_recovers(client, node):
    """The diagnostics level says ERROR after rejections, then OK again once
    valid setpoints flow; rejections are logged and throttled."""
    stamp = BASE + 20_000_000_000
    for k in range(20):                                         # a burst of bad poses
        client.send(stamp + k * STEP, Q, QD, QDD, raw={'pose.position.x': NAN})
    diag = client.wait_diagnostics(lambda v: v['level'] == '2', timeout=3.0)
    assert 'non_finite' in diag['message']
    assert node.alive()
    stamp += 20 * STEP
    n = len(client.actuator)
    client.send(stamp, Q, QD, QDD, order='tap')
    assert client.wait_actuator(n + 1)
    # the next full period without bad input is OK again
    k = 1

    def feed_and_check(v: dict) -> bool:
        return v['level'] == '0'
    ok = None
    for _ in range(60):
        client.send(stamp + k * STEP, Q, QD, QDD, order='tap')
        k += 1
        try:
            ok = client.wait_diagnostics(feed_and_check, timeout=0.1)
            break
        except AssertionError:
            continue
    assert ok is not None, 'diagnostics never went back to OK'
    log = node.output()
    lines = [line for line in log.splitlines() if 'pose rejected' in line and 'non-finite' in line]
    assert 1 <= len(lines) <= 8, f'{len(lines)} log lines for non-finite poses (not throttled?)'
    assert re.search(r'more since the last such message|pose rejected', log)


def truncated_platform_setpoint(client: Client, stamp: int, last: int) -> None:
    """A JointTrajectory cut short (published as serialized bytes)."""
    from rclpy.serialization import serialize_message
    from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint
    msg = JointTrajectory()
    msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(stamp, 1_000_000_000)
    msg.joint_names = ['surge', 'heave', 'roll']
    msg.points = [JointTrajectoryPoint(positions=list(Q), velocities=list(QD))]
    client.platform_pub.publish(serialize_message(msg)[:70])


PLATFORM = [(Q, QD, QDD)]
# (name, reason counter, how to send it at stamp s: f(client, s, last_valid_stamp)),
# all on platform_setpoint (trajectory_msgs/JointTrajectory). These tests come
# last: their stamps follow those of the tests above (one node for the module).
PLATFORM_BAD_INPUTS = [
    ('joint_names with pitch', 'bad_setpoint',
     lambda c, s, last: c.send_platform(s, PLATFORM, names=('surge', 'heave', 'pitch'))),
    ('joint_names missing roll', 'bad_setpoint',
     lambda c, s, last: c.send_platform(s, [(Q[:2], QD[:2], QDD[:2])], names=('surge', 'heave'))),
    ('no points', 'bad_setpoint', lambda c, s, last: c.send_platform(s, [])),
    ('2 positions', 'bad_setpoint', lambda c, s, last: c.send_platform(s, [(Q[:2], QD, QDD)])),
    ('2 velocities', 'bad_setpoint',
     lambda c, s, last: c.send_platform(s, [(Q, QD[:2], QDD)])),
    ('4 accelerations', 'bad_setpoint',
     lambda c, s, last: c.send_platform(s, [(Q, QD, [*QDD, 0.0])])),
    ('effort given', 'bad_setpoint',
     lambda c, s, last: c.send_platform(s, PLATFORM, effort=[[30.0, 30.0, 30.0]])),
    ('negative time_from_start', 'bad_setpoint',
     lambda c, s, last: c.send_platform(s + STEP // 2, PLATFORM, offsets_ns=[-STEP // 2])),
    ('truncated message', 'bad_setpoint', truncated_platform_setpoint),
    ('nan position', 'non_finite',
     lambda c, s, last: c.send_platform(s, [((NAN, Q[1], Q[2]), QD, QDD)])),
    ('inf velocity', 'non_finite',
     lambda c, s, last: c.send_platform(s, [(Q, (QD[0], INF, QD[2]), QDD)])),
    ('nan acceleration', 'non_finite',
     lambda c, s, last: c.send_platform(s, [(Q, QD, (QDD[0], QDD[1], NAN))])),
    ('absurd acceleration (1000 m/s^2)', 'absurd_acceleration',
     lambda c, s, last: c.send_platform(s, [(Q, QD, (1000.0, 0.0, 0.0))])),
    ('heave jump, no accelerations (estimated one absurd)', 'absurd_acceleration',
     lambda c, s, last: c.send_platform(s, [((Q[0], Q[1] + 0.1, Q[2]), None, None)])),
    ('unreachable pose (heave -0.5 m)', 'unreachable',
     lambda c, s, last: c.send_platform(s, [((0.0, -0.5, 0.0), (0, 0, 0), (0, 0, 0))])),
    ('repeated stamp', 'stamp_repeated', lambda c, s, last: c.send_platform(last, PLATFORM)),
    ('stamp going backwards', 'stamp_backwards',
     lambda c, s, last: c.send_platform(last - 10 * STEP, PLATFORM)),
    ('a rate so large that the results overflow (1e150)', 'bad_setpoint',
     lambda c, s, last: c.send_platform(s, [(Q, (0.0, 1e150, 0.0), QDD)])),
]


def test_each_bad_platform_setpoint_is_rejected_and_the_next_answered(client, model, node):
    """Each bad platform_setpoint is rejected with its counter (one rejection
    each, nothing published) and the next one, valid, is answered exactly."""
    before, after = reject_each_then_answer(
        client, model, PLATFORM_BAD_INPUTS, lambda c, s: c.send_platform(s, PLATFORM),
        BASE + 30_000_000_000)
    assert int(after['rejected total']) - int(before['rejected total']) \
        == len(PLATFORM_BAD_INPUTS)
    # every message counted as received, the malformed ones too
    assert int(after['received platform_setpoint']) - int(before['received platform_setpoint']) \
        == 2 * len(PLATFORM_BAD_INPUTS) + 1
    assert all(all_finite(m) for _, m in client.actuator)
    log = node.output()
    assert ("platform_setpoint rejected: joint_names must be surge, heave, roll (each once, in "
            "any order), got ['surge', 'heave', 'pitch']") in log


def test_one_bad_point_rejects_that_point_only(client, model):
    """A message of three points whose middle one is bad: the other two are
    answered (stamps header + time_from_start), the bad one counted."""
    expected = fsd.solve(model, Q, QD, QDD)
    before = client.wait_diagnostics(lambda v: 'rejected non_finite' in v, timeout=3.0)
    stamp = BASE + 40_000_000_000
    n = len(client.actuator)
    client.send_platform(stamp, [(Q, QD, QDD), ((Q[0], NAN, Q[2]), QD, QDD), (Q, QD, QDD)],
                         offsets_ns=[0, STEP, 2 * STEP])
    assert client.wait_actuator(n + 2)
    client.spin_until(lambda: False, 0.05)
    answered = [m for _, m in client.actuator[n:]]
    assert [stamp_ns(m) for m in answered] == [stamp, stamp + 2 * STEP]
    for msg in answered:
        np.testing.assert_allclose(msg.effort, expected.force, rtol=0, atol=1e-9)
    after = client.wait_diagnostics(
        lambda v: int(v['rejected non_finite']) > int(before['rejected non_finite']), 3.0)
    assert int(after['rejected total']) - int(before['rejected total']) == 1
    assert 'point 1' in after['last rejection'] and 'positions' in after['last rejection']


def test_malformed_serialized_samples_never_reach_the_node(client, model, node):
    """A truncated pose, twist or accel (published as serialized bytes) is
    dropped by the middleware before the node's callback: it is not
    answered, does not count as received, and the node keeps answering."""
    from geometry_msgs.msg import AccelStamped, PoseStamped, TwistStamped
    from rclpy.serialization import serialize_message
    expected = fsd.solve(model, Q, QD, QDD)
    before = client.wait_diagnostics(lambda v: 'received pose' in v, timeout=3.0)
    stamp = BASE + 60_000_000_000
    n = len(client.actuator)
    for msg_type, publisher, cut in ((PoseStamped, client.pose_pub, 30),
                                     (TwistStamped, client.twist_pub, 20),
                                     (AccelStamped, client.accel_pub, 10)):
        msg = msg_type()
        msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(stamp, 1_000_000_000)
        publisher.publish(serialize_message(msg)[:cut])
    client.send(stamp + STEP, Q, QD, QDD, order='tap')
    assert client.wait_actuator(n + 1, timeout=3.0)
    assert [stamp_ns(m) for _, m in client.actuator[n:]] == [stamp + STEP]
    np.testing.assert_allclose(client.actuator[n][1].effort, expected.force, rtol=0, atol=1e-9)
    after = client.wait_diagnostics(
        lambda v: int(v['received accel']) > int(before['received accel']), timeout=3.0)
    for kind in ('pose', 'twist', 'accel'):          # the valid one only
        assert int(after[f'received {kind}']) - int(before[f'received {kind}']) == 1
    assert after['rejected solver_error'] == before['rejected solver_error']
    assert 'internal error' not in node.output()
