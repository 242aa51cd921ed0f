"""core/euler.py: the angular velocity and acceleration in the base frame of
Euler-angle rates, (S2) and (S3) of docs/design/stewart.md, against the
hexapod kinematics' own matrices and a central difference of the rotation,
and their inverses; the 3-DOF machine's roll rate carried as it is.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from flight_sim_dynamics.core import euler
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
    np.testing.assert_allclose(euler.angular_velocity(q[3:], qd[3:]), E @ qd[3:], atol=1e-14)
    np.testing.assert_allclose(euler.angular_acceleration(q[3:], qd[3:], qdd[3:]),
                               E @ qdd[3:] + E_dot @ qd[3:], atol=1e-13)


def test_angular_velocity_is_that_of_the_rotation():
    """omega~ = R' R^T, R = Rz Ry Rx differenced along the rates; epsilon the
    difference of omega along the rates and accelerations."""
    h = 1e-6
    for q, qd, qdd in SAMPLES[:10]:
        R_dot = (rotation((q + h * qd)[None])[0] - rotation((q - h * qd)[None])[0]) / (2 * h)
        W = R_dot @ rotation(q[None])[0].T
        np.testing.assert_allclose(euler.angular_velocity(q[3:], qd[3:]),
                                   (W[2, 1], W[0, 2], W[1, 0]), atol=1e-8)
        w_next = np.array(euler.angular_velocity((q + h * qd)[3:], (qd + h * qdd)[3:]))
        w_prev = np.array(euler.angular_velocity((q - h * qd)[3:], (qd - h * qdd)[3:]))
        np.testing.assert_allclose(euler.angular_acceleration(q[3:], qd[3:], qdd[3:]),
                                   (w_next - w_prev) / (2 * h), atol=1e-6)


@pytest.mark.parametrize('q, qd, qdd', SAMPLES)
def test_euler_rates_and_accelerations_invert_them(q, qd, qdd):
    omega = euler.angular_velocity(q[3:], qd[3:])
    epsilon = euler.angular_acceleration(q[3:], qd[3:], qdd[3:])
    scale = 1.0 / abs(math.cos(q[4]))
    np.testing.assert_allclose(euler.euler_rates(q[3:], omega), qd[3:], atol=1e-13 * scale)
    np.testing.assert_allclose(euler.euler_accelerations(q[3:], qd[3:], epsilon), qdd[3:],
                               atol=1e-12 * scale ** 2)


def test_a_roll_alone_is_its_rate_about_x_as_it_is():
    """The 3-DOF machine (pitch = yaw = 0): angular = (roll rate, 0, 0), bit for bit."""
    for roll, rate, acc in ((0.3, -0.7, 2.5), (-0.52, 1e-3, -40.0)):
        assert euler.angular_velocity((roll, 0.0, 0.0), (rate, 0.0, 0.0)) == (rate, 0.0, 0.0)
        assert euler.angular_acceleration((roll, 0.0, 0.0), (rate, 0.0, 0.0),
                                          (acc, 0.0, 0.0)) == (acc, 0.0, 0.0)


@pytest.mark.parametrize('machine', MACHINES, ids=lambda m: m.name)
def test_every_machine_names_its_planner_motions(machine):
    assert machine.planner_example in machine.planner_motions
    assert set(machine.planner_motions) <= set(machine.motions)
    sequence = PlannerSequence(machine.motions, list(machine.planner_motions))
    q, qd, qdd, label = sequence.sample(0.5 * sequence.period)
    assert q.shape == qd.shape == qdd.shape == (machine.dof,)
    assert label in (*machine.planner_motions, 'return')
