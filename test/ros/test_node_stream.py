"""The node as a user runs it: a separate process with the params file, fed the
paper's three motions at 200 Hz by a test publisher.

Checks: every setpoint answered (no loss at 200 Hz), in order, with the
setpoint's stamp, values equal to the solver's to 1e-9; the synchroniser
whatever the delivery order; pose-only and pose+twist streams (estimation);
motion the mechanism cannot follow reported and ignored; the same through
platform_setpoint (one JointTrajectory per setpoint, or several points per
message), alone and mixed with the three topics.
"""
from __future__ import annotations

import time

import numpy as np
import pytest

import flight_sim_dynamics as fsd
from flight_sim_dynamics.machines.staicu.model import JOINT_NAMES, LEG_NAMES
from flight_sim_dynamics.machines.staicu.trajectories import paper_example
from node_harness import Client, all_finite, stamp_ns

pytestmark = pytest.mark.ros

RATE = 200.0
T0_NS = 1_700_000_000 * 1_000_000_000   # stamps: a fixed epoch, 5 ms apart


class Stamps:
    """Increasing stamps shared by the tests of this module (one node)."""

    next_ns = T0_NS

    @classmethod
    def take(cls, n: int) -> np.ndarray:
        stamps = cls.next_ns + np.arange(n, dtype=np.int64) * int(1e9 / RATE)
        cls.next_ns = int(stamps[-1]) + 1_000_000_000   # a gap > estimator.max_gap
        return stamps


def stream(client: Client, stamps, q, qd, qdd, rate: float = RATE, order: str = 'pta') -> float:
    """Publish setpoints paced at ``rate`` (spinning in between); returns the
    time taken."""
    start = time.monotonic()
    for k, stamp in enumerate(stamps):
        target = start + k / rate
        client.spin_until(lambda: time.monotonic() >= target, max(0.0, target - time.monotonic()))
        client.send(int(stamp), q[k], None if qd is None else qd[k],
                    None if qdd is None else qdd[k], order=order)
    return time.monotonic() - start


def received_since(client: Client, first: int):
    return [m for _, m in client.actuator[first:]]


def answered_exactly(client: Client, model, first: int, stamps, q, qd, qdd):
    """Wait for one actuator_states per stamp after the first ``first``; check
    that nothing more arrives, the stamps and the forces (== solve_batch to
    1e-9). Returns (messages, the batch solution)."""
    assert client.wait_actuator(first + len(q))
    client.spin_until(lambda: False, 0.1)   # nothing more may arrive
    got = received_since(client, first)
    assert [stamp_ns(m) for m in got] == [int(s) for s in stamps]
    expected = fsd.solve_batch(model, q, qd, qdd)
    np.testing.assert_allclose([list(m.effort) for m in got], expected.force, rtol=0, atol=1e-9)
    return got, expected


def test_paper_motions_at_200hz_match_solver(client, model):
    """Three paper motions, pose + twist + accel at 200 Hz: no loss, order,
    stamps, values == solver to 1e-9, joint states too."""
    t = np.arange(0.0, 3.0 + 1e-9, 1.0 / RATE)
    q, qd, qdd = (np.concatenate(parts) for parts in zip(
        *(paper_example(name, t) for name in ('vertical', 'rectilinear', 'general'))))
    stamps = Stamps.take(len(q))
    first, first_joint = len(client.actuator), len(client.joints)
    stream(client, stamps, q, qd, qdd)
    assert client.wait_actuator(first + len(q), timeout=10.0), \
        f'lost {first + len(q) - len(client.actuator)} of {len(q)} setpoints at 200 Hz' \
        + client.explain()
    got = received_since(client, first)
    assert len(got) == len(q)
    assert [stamp_ns(m) for m in got] == [int(s) for s in stamps], 'order or stamps differ'
    expected = fsd.solve_batch(model, q, qd, qdd)
    for k, msg in enumerate(got):
        assert list(msg.name) == list(LEG_NAMES)
        assert msg.header.frame_id == 'simulator_base'
        np.testing.assert_allclose(msg.position, expected.length[k], rtol=0, atol=1e-9)
        np.testing.assert_allclose(msg.velocity, expected.rate[k], rtol=0, atol=1e-9)
        np.testing.assert_allclose(msg.effort, expected.force[k], rtol=0, atol=1e-9)
    assert client.spin_until(lambda: len(client.joints) >= first_joint + len(q), 5.0)
    joints = client.joints[first_joint:first_joint + len(q)]
    assert [stamp_ns(m) for m in joints] == [int(s) for s in stamps]
    assert list(joints[0].name) == list(JOINT_NAMES)
    np.testing.assert_allclose([list(m.position) for m in joints], expected.joints,
                               rtol=0, atol=1e-9)
    np.testing.assert_allclose([list(m.velocity) for m in joints], expected.joint_rates,
                               rtol=0, atol=1e-9)


@pytest.mark.parametrize('order', ['atp', 'tap', 'pat'])
def test_any_delivery_order_gives_one_exact_solve_per_stamp(client, model, order):
    t = np.arange(0.0, 0.5, 1.0 / RATE) + 1.0
    q, qd, qdd = paper_example('general', t)
    stamps = Stamps.take(len(q))
    first = len(client.actuator)
    stream(client, stamps, q, qd, qdd, order=order)
    answered_exactly(client, model, first, stamps, q, qd, qdd)


@pytest.mark.parametrize('kinds, tolerance', [('pt', 0.05), ('p', 0.5)])
def test_pose_only_and_pose_twist_streams_are_estimated(client, model, kinds, tolerance):
    """Missing accelerations (and rates) are estimated from the stream: every
    setpoint answered but, pose only, the second (warming up: its
    acceleration would difference the first one's assumed rest); forces
    within ``tolerance`` N of the exact ones after the first three samples
    (see docs/node.md for the measured accuracy)."""
    t = np.arange(0.0, 1.5, 1.0 / RATE)
    q, qd, qdd = paper_example('general', t)
    stamps = Stamps.take(len(q))
    before = counters(client)
    first = len(client.actuator)
    stream(client, stamps, q, qd if 't' in kinds else None, None, order=kinds)
    kept = [k for k in range(len(q)) if k != 1 or 't' in kinds]
    assert client.wait_actuator(first + len(kept), timeout=5.0)
    got = received_since(client, first)
    assert [stamp_ns(m) for m in got] == [int(stamps[k]) for k in kept]
    after = client.wait_diagnostics(lambda v: int(v['setpoints answered'])
                                    >= int(before['setpoints answered']) + len(kept))
    assert (int(after['rejected warming_up']) - int(before['rejected warming_up'])
            == len(q) - len(kept))
    q, qd, qdd = q[kept], qd[kept], qdd[kept]
    expected = fsd.solve_batch(model, q, qd, qdd)
    forces = np.array([list(m.effort) for m in got])
    assert all(all_finite(m) for m in got)
    np.testing.assert_allclose([list(m.position) for m in got], expected.length,
                               rtol=0, atol=1e-9)   # positions are exact
    error = np.abs(forces[3:] - expected.force[3:]).max()
    assert error < tolerance, f'estimation error {error:.3g} N'


def test_unfollowable_motion_reported_parasitic_pitch_accepted(client, model):
    """Sway, yaw and a non-parasitic pitch are reported (diagnostics counters)
    and ignored; the parasitic pitch (or none) is not reported; all answered."""
    q, qd, qdd = (v[0] for v in paper_example('general', np.array([1.0])))
    sol = fsd.solve(model, q, qd, qdd)
    before = client.wait_diagnostics(lambda v: 'ignored sway' in v, timeout=3.0)
    cases = [dict(pitch=-sol.beta), dict(), dict(sway=0.05), dict(yaw=0.1), dict(pitch=0.3)]
    stamps = Stamps.take(len(cases))
    first = len(client.actuator)
    for stamp, case in zip(stamps, cases):
        # twist and accel first: complete whatever streams the previous test left
        client.send(int(stamp), q, qd, qdd, order='tap', **case)
        assert client.wait_actuator(len(client.actuator) + 1)
    got = received_since(client, first)
    for msg in got:
        np.testing.assert_allclose(msg.effort, sol.force, rtol=0, atol=1e-9)
    after = client.wait_diagnostics(
        lambda v: int(v['ignored pitch']) > int(before['ignored pitch']), timeout=3.0)
    for key in ('ignored sway', 'ignored yaw', 'ignored pitch'):
        assert int(after[key]) == int(before[key]) + 1, key


# ----------------------------------------------------------------------------
# One message per setpoint: platform_setpoint (trajectory_msgs/JointTrajectory)
# ----------------------------------------------------------------------------
def stream_platform(client: Client, stamps, q, qd, qdd, names=('surge', 'heave', 'roll'),
                    rate: float = RATE) -> None:
    """One JointTrajectory per setpoint (one point, time_from_start 0), paced
    at ``rate``; ``qd``/``qdd`` None: not sent (the node estimates them)."""
    start = time.monotonic()
    for k, stamp in enumerate(stamps):
        target = start + k / rate
        client.spin_until(lambda: time.monotonic() >= target, max(0.0, target - time.monotonic()))
        client.send_platform(int(stamp), [(q[k], None if qd is None else qd[k],
                                           None if qdd is None else qdd[k])], names=names)


def counters(client: Client) -> dict:
    return client.wait_diagnostics(lambda v: 'received platform_setpoint' in v, timeout=3.0)


def test_platform_setpoint_stream_matches_solver(client, model):
    """The paper's general motion as one JointTrajectory per setpoint (names in
    another order than surge, heave, roll) at 200 Hz: every setpoint answered
    in order with its stamp, actuator_states and joint_states equal to the
    solver's to 1e-9, nothing estimated, the messages counted."""
    t = np.arange(0.0, 3.0 + 1e-9, 1.0 / RATE)
    q, qd, qdd = paper_example('general', t)
    stamps = Stamps.take(len(q))
    before = counters(client)
    first, first_joint = len(client.actuator), len(client.joints)
    stream_platform(client, stamps, q, qd, qdd, names=('roll', 'surge', 'heave'))
    assert client.wait_actuator(first + len(q), timeout=10.0), \
        f'lost {first + len(q) - len(client.actuator)} of {len(q)} setpoints'
    got = received_since(client, first)
    assert [stamp_ns(m) for m in got] == [int(s) for s in stamps], 'order or stamps differ'
    expected = fsd.solve_batch(model, q, qd, qdd)
    np.testing.assert_allclose([list(m.position) for m in got], expected.length, rtol=0, atol=1e-9)
    np.testing.assert_allclose([list(m.velocity) for m in got], expected.rate, rtol=0, atol=1e-9)
    np.testing.assert_allclose([list(m.effort) for m in got], expected.force, rtol=0, atol=1e-9)
    assert client.spin_until(lambda: len(client.joints) >= first_joint + len(q), 5.0)
    joints = client.joints[first_joint:first_joint + len(q)]
    assert [stamp_ns(m) for m in joints] == [int(s) for s in stamps]
    np.testing.assert_allclose([list(m.position) for m in joints], expected.joints,
                               rtol=0, atol=1e-9)
    np.testing.assert_allclose([list(m.velocity) for m in joints], expected.joint_rates,
                               rtol=0, atol=1e-9)
    after = client.wait_diagnostics(lambda v: int(v['received platform_setpoint'])
                                    >= int(before['received platform_setpoint']) + len(q))
    assert int(after['received platform_setpoint']) - int(before['received platform_setpoint']) \
        == len(q)
    for key in ('received pose', 'estimated twist', 'estimated accel', 'rejected total'):
        assert after[key] == before[key], key


def test_platform_and_three_topic_setpoints_mixed(client, model):
    """Setpoints alternately as one JointTrajectory and as pose + twist + accel:
    one stamp order, every one answered, the same numbers either way."""
    t = np.arange(0.0, 0.5, 1.0 / RATE) + 1.0
    q, qd, qdd = paper_example('general', t)
    stamps = Stamps.take(len(q))
    first = len(client.actuator)
    start = time.monotonic()
    for k, stamp in enumerate(stamps):
        target = start + k / RATE
        client.spin_until(lambda: time.monotonic() >= target, max(0.0, target - time.monotonic()))
        if k % 2:
            client.send(int(stamp), q[k], qd[k], qdd[k], order='tap')
        else:
            client.send_platform(int(stamp), [(q[k], qd[k], qdd[k])])
    got, expected = answered_exactly(client, model, first, stamps, q, qd, qdd)
    np.testing.assert_allclose([list(m.position) for m in got], expected.length,
                               rtol=0, atol=1e-9)


@pytest.mark.parametrize('kinds, tolerance', [('pv', 0.05), ('p', 0.5)])
def test_platform_positions_only_points_are_estimated(client, model, kinds, tolerance):
    """Points without accelerations (and velocities) are estimated like a
    pose-only (pose + twist) stream, and counted as estimated."""
    t = np.arange(0.0, 0.75, 1.0 / RATE)
    q, qd, qdd = paper_example('general', t)
    stamps = Stamps.take(len(q))
    before = counters(client)
    first = len(client.actuator)
    stream_platform(client, stamps, q, qd if 'v' in kinds else None, None)
    kept = [k for k in range(len(q)) if k != 1 or 'v' in kinds]   # 1: warming up
    assert client.wait_actuator(first + len(kept), timeout=5.0)
    got = received_since(client, first)
    assert [stamp_ns(m) for m in got] == [int(stamps[k]) for k in kept]
    expected = fsd.solve_batch(model, q[kept], qd[kept], qdd[kept])
    np.testing.assert_allclose([list(m.position) for m in got], expected.length,
                               rtol=0, atol=1e-9)   # positions are exact
    error = np.abs(np.array([list(m.effort) for m in got])[3:] - expected.force[3:]).max()
    assert error < tolerance, f'estimation error {error:.3g} N'
    after = client.wait_diagnostics(lambda v: int(v['estimated accel'])
                                    >= int(before['estimated accel']) + len(kept))
    assert int(after['estimated accel']) - int(before['estimated accel']) == len(kept)
    assert int(after['estimated twist']) - int(before['estimated twist']) == \
        (0 if 'v' in kinds else len(q))


def test_platform_multi_point_messages(client, model):
    """A message of several points: one answer per point, in order, stamped
    header.stamp + time_from_start, each equal to the solver's."""
    t = 1.0 + np.array([0.0, 0.005, 0.01, 0.015, 0.02, 0.0215, 0.03, 1.03])
    q, qd, qdd = paper_example('general', t)
    header = Stamps.take(1)[0]
    offsets = [int(round((x - t[0]) * 1e9)) for x in t]
    offsets[-1] += 3                                      # a second and some nanoseconds
    first = len(client.actuator)
    client.send_platform(int(header), [(q[k], qd[k], qdd[k]) for k in range(5)],
                         offsets_ns=offsets[:5])
    client.send_platform(int(header) + offsets[5], [(q[k], qd[k], qdd[k]) for k in range(5, 8)],
                         offsets_ns=[o - offsets[5] for o in offsets[5:]])
    assert client.wait_actuator(first + len(t))
    client.spin_until(lambda: False, 0.1)
    got = received_since(client, first)
    assert [stamp_ns(m) for m in got] == [int(header) + o for o in offsets]
    assert got[-1].header.stamp.nanosec == (int(header) + offsets[-1]) % 1_000_000_000
    expected = fsd.solve_batch(model, q, qd, qdd)
    np.testing.assert_allclose([list(m.effort) for m in got], expected.force, rtol=0, atol=1e-9)


def test_demo_planner_process_drives_the_node(client):
    """`python -m flight_sim_dynamics.planner` (= flight-sim-dynamics demo-planner)
    as its own process: every sample answered (accelerations estimated)."""
    import subprocess
    import sys

    from node_harness import ROOT
    first = len(client.actuator)
    proc = subprocess.Popen([sys.executable, '-m', 'flight_sim_dynamics.ros.planner',
                             '--example', 'vertical', '--rate', '200', '--no-accel'],
                            cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                            text=True)
    try:
        assert client.spin_until(lambda: proc.poll() is not None, 60.0), 'planner did not end'
        output = proc.stdout.read()
        assert proc.returncode == 0, output
        assert 'sent 601 setpoints' in output, output
        assert client.wait_actuator(first + 601, timeout=30.0), \
            f'{len(client.actuator) - first} of 601 answered'
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    got = [m for _, m in client.actuator[first:]]
    assert all(all_finite(m) for m in got)
    heave_leg_b = [m.position[1] for m in got]
    assert heave_leg_b[-1] > heave_leg_b[0] + 0.1              # the platform went up
