"""The demo planner (``flight-sim-dynamics demo-planner``) as a process over
DDS, on the hexapod (``--params config/stewart_6dof.yaml``): it streams the
machine's motion-cueing sequence, every sample, as the setpoints the node
reads: position = surge, sway, heave, the orientation's ZYX angles = roll,
pitch, yaw, twist/accel linear = their rates and accelerations, angular = the
platform's angular velocity and acceleration in the base frame (checked with
the hexapod kinematics' own E and dE/dt, (S2) and (S3)).
"""
from __future__ import annotations

import numpy as np
import pytest
from geometry_msgs.msg import AccelStamped, PoseStamped, TwistStamped

import flight_sim_dynamics as fsd
from flight_sim_dynamics.core.motion import PlannerSequence
from flight_sim_dynamics.machines.stewart.kinematics import (euler_rate_matrix,
                                                             euler_rate_matrix_derivative)
from flight_sim_dynamics.ros.messages import quaternion_to_rpy
from node_harness import QOS, ROOT, Client, PlannerProcess, stamp_ns

pytestmark = pytest.mark.ros

STEWART_FILE = ROOT / 'config' / 'stewart_6dof.yaml'
RATE = 50.0


def test_planner_streams_the_hexapods_cueing_sequence():
    machine = fsd.machine_of(fsd.load_model(STEWART_FILE))
    client = Client('planner_test_client', namespace='/plan')
    received = {kind: [] for kind in ('pose', 'twist', 'accel')}
    for kind, msg_type in (('pose', PoseStamped), ('twist', TwistStamped),
                           ('accel', AccelStamped)):
        client.node.create_subscription(msg_type, f'/plan/{kind}_setpoint',
                                        received[kind].append, QOS)
    planner = PlannerProcess('--params', str(STEWART_FILE), '--example', 'cueing', '--rate',
                             str(RATE), '--ros-args', '-r', '__ns:=/plan')
    sequence = PlannerSequence(machine.motions, ['cueing'])
    n = int(sequence.period * RATE) + 1
    try:
        assert client.spin_until(lambda: all(len(v) >= n for v in received.values())
                                 or not planner.alive(), 60.0), planner.output()
        client.spin_until(lambda: all(len(v) >= n for v in received.values()), 5.0)
        assert planner.proc.wait(10) == 0, planner.output()
    finally:
        planner.stop()
        client.close()
    assert [len(v) for v in received.values()] == [n, n, n], planner.output()
    t0 = stamp_ns(received['pose'][0])
    for pose, twist, accel in zip(*received.values()):
        k = round((stamp_ns(pose) - t0) * 1e-9 * RATE)
        assert stamp_ns(twist) == stamp_ns(accel) == stamp_ns(pose)
        q, qd, qdd, _ = sequence.sample(k / RATE)
        p, o = pose.pose.position, pose.pose.orientation
        np.testing.assert_allclose([p.x, p.y, p.z, *quaternion_to_rpy(o.x, o.y, o.z, o.w)], q,
                                   atol=1e-12)
        E = euler_rate_matrix(q[None])[0]
        E_dot = euler_rate_matrix_derivative(q[None], qd[None])[0]
        v, w = twist.twist.linear, twist.twist.angular
        np.testing.assert_allclose([v.x, v.y, v.z, w.x, w.y, w.z],
                                   [*qd[:3], *(E @ qd[3:])], atol=1e-12)
        a, e = accel.accel.linear, accel.accel.angular
        np.testing.assert_allclose([a.x, a.y, a.z, e.x, e.y, e.z],
                                   [*qdd[:3], *(E @ qdd[3:] + E_dot @ qd[3:])], atol=1e-12)
    # it moved every coordinate
    poses = np.array([[m.pose.position.x, m.pose.position.y, m.pose.position.z]
                      for m in received['pose']])
    assert np.abs(poses).max(axis=0).min() > 0.04


def test_planner_refuses_a_motion_of_another_machine():
    planner = PlannerProcess('--params', str(STEWART_FILE), '--example', 'general')
    try:
        assert planner.proc.wait(30) == 2
        assert 'cueing' in planner.output()            # names the hexapod's motions
    finally:
        planner.stop()
