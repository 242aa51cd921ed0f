"""core/pose.py: a machine's pose as ROS messages carry it. The angular
velocity and acceleration of Euler-angle rates, (S2) and (S3) of
docs/design/stewart.md, against the hexapod kinematics' own matrices and a
finite difference of the rotation; the inverse conversions; the 3-DOF
machine's roll rate carried exactly as angular.x.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from flight_sim_dynamics.core import pose
from flight_sim_dynamics.core.motion import PlannerSequence
from flight_sim_dynamics.machines import MACHINES
from flight_sim_dynamics.machines.stewart.kinematics import (euler_rate_matrix,
                                                             euler_rate_matrix_derivative,
                                                             rotation)

RNG = np.random.default_rng(23)
SAMPLES = [(RNG.uniform(-1.2, 1.2, 6), RNG.normal(size=6), RNG.normal(size=6))
           for _ in range(50)]


@pytest.mark.parametrize('q, qd, qdd', SAMPLES[:10])
def test_angular_velocity_and_acceleration_are_s2_and_s3(q, qd, qdd):
    E = euler_rate_matrix(q[None])[0]
    E_dot = euler_rate_matrix_derivative(q[None], qd[None])[0]
    np.testing.assert_allclose(pose.angular_velocity(q[3:], qd[3:]), E @ qd[3:], atol=1e-14)
    np.testing.assert_allclose(pose.angular_acceleration(q[3:], qd[3:], qdd[3:]),
                               E @ qdd[3:] + E_dot @ qd[3:], atol=1e-13)


def test_angular_velocity_is_that_of_the_rotation():
    """omega~ = R' R^T: a central difference of R = Rz Ry Rx along the rates."""
    for q, qd, qdd in SAMPLES[:10]:
        h = 1e-6
        R_dot = (rotation((q + h * qd)[None])[0] - rotation((q - h * qd)[None])[0]) / (2 * h)
        W = R_dot @ rotation(q[None])[0].T
        np.testing.assert_allclose(pose.angular_velocity(q[3:], qd[3:]),
                                   (W[2, 1], W[0, 2], W[1, 0]), atol=1e-8)
        w = np.array(pose.angular_velocity(q[3:], qd[3:]))
        w_next = np.array(pose.angular_velocity((q + h * qd)[3:], (qd + h * qdd)[3:]))
        w_prev = np.array(pose.angular_velocity((q - h * qd)[3:], (qd - h * qdd)[3:]))
        np.testing.assert_allclose(pose.angular_acceleration(q[3:], qd[3:], qdd[3:]),
                                   (w_next - w_prev) / (2 * h), atol=1e-6)
        assert np.all(np.isfinite(w))


@pytest.mark.parametrize('q, qd, qdd', SAMPLES)
def test_euler_rates_and_accelerations_invert_them(q, qd, qdd):
    omega = pose.angular_velocity(q[3:], qd[3:])
    epsilon = pose.angular_acceleration(q[3:], qd[3:], qdd[3:])
    scale = 1.0 / abs(math.cos(q[4]))
    np.testing.assert_allclose(pose.euler_rates(q[3:], omega), qd[3:], atol=1e-13 * scale)
    np.testing.assert_allclose(pose.euler_accelerations(q[3:], qd[3:], epsilon), qdd[3:],
                               atol=1e-12 * scale ** 2)


def test_a_roll_alone_is_its_rate_about_x_exactly():
    """The 3-DOF machine (pitch = yaw = 0): angular = (roll rate, 0, 0), bit for bit."""
    for roll, rate, acc in ((0.3, -0.7, 2.5), (-0.52, 1e-3, -40.0)):
        assert pose.angular_velocity((roll, 0.0, 0.0), (rate, 0.0, 0.0)) == (rate, 0.0, 0.0)
        assert pose.angular_acceleration((roll, 0.0, 0.0), (rate, 0.0, 0.0),
                                         (acc, 0.0, 0.0)) == (acc, 0.0, 0.0)


def test_six_and_coordinates_place_each_machines_coordinates():
    three, six = MACHINES
    assert pose.six(three.pose_components, (0.1, 0.2, 0.3)) == [0.1, 0.0, 0.2, 0.3, 0.0, 0.0]
    assert pose.coordinates(three.pose_components, (0.1, 9.0, 0.2, 0.3, 9.0, 9.0)) == \
        [0.1, 0.2, 0.3]
    values = [0.1, 0.2, 0.3, 0.4, 0.5, 0.6]
    assert pose.six(six.pose_components, values) == values
    assert pose.coordinates(six.pose_components, values) == values


@pytest.mark.parametrize('machine', MACHINES, ids=lambda m: m.name)
def test_every_machine_names_its_pose_and_planner_motions(machine):
    assert len(machine.pose_components) == machine.dof
    assert len(set(machine.pose_components)) == machine.dof
    assert set(machine.pose_components) <= set(pose.COMPONENTS)
    assert machine.planner_example in machine.planner_motions
    assert set(machine.planner_motions) <= set(machine.motions)
    sequence = PlannerSequence(machine.motions, list(machine.planner_motions))
    q, qd, qdd, label = sequence.sample(0.5 * sequence.period)
    assert q.shape == qd.shape == qdd.shape == (machine.dof,)
    assert label in (*machine.planner_motions, 'return')
