"""Euler-angle rates and accelerations of an angular velocity and acceleration
(core/euler.py) against the solver's own E and dE/dt ((S2), (S3) of
docs/design/stewart.md), for any pose away from pitch +-90 deg; and what the
node takes of the messages (ros/messages.PoseMap) on both machines: the
hexapod's answers are the solver's at the converted rates, the 3-DOF
machine's take linear.x, linear.z, angular.x exactly, as they always did.
The other way (the twin's platform_twist, the planner's setpoints): the
angular velocity and acceleration of Euler-angle rates, E and E + dE/dt of
the solver and a central difference of the rotation.
"""
from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from flight_sim_dynamics.core.euler import (EulerSingularity, angular_acceleration,
                                            angular_velocity, euler_accelerations, euler_rates)
from flight_sim_dynamics.machines import FLIGHT_SIMULATOR, STEWART
from flight_sim_dynamics.machines.stewart.kinematics import (euler_rate_matrix,
                                                             euler_rate_matrix_derivative,
                                                             rotation)
from flight_sim_dynamics.ros.messages import pose_map

angle = st.floats(-math.pi, math.pi)
pitch = st.floats(-1.5, 1.5)                       # |pitch| <= 86 deg
rate = st.floats(-10.0, 10.0)
number = st.floats(-1e3, 1e3)
finite = st.floats(allow_nan=False, allow_infinity=False, width=64)


def omega_eps(q6: np.ndarray, qd6: np.ndarray, qdd6: np.ndarray):
    """The solver's angular velocity and acceleration of an Euler-angle motion."""
    E = euler_rate_matrix(q6[None])[0]
    Ed = euler_rate_matrix_derivative(q6[None], qd6[None])[0]
    return E @ qd6[3:], E @ qdd6[3:] + Ed @ qd6[3:]


@settings(max_examples=400, deadline=None)
@given(angle, pitch, angle, st.lists(rate, min_size=6, max_size=6))
def test_rates_and_accelerations_invert_the_solvers_E(roll, pitch_, yaw, derivatives):
    q6 = np.array([0.0, 0.0, 0.0, roll, pitch_, yaw])
    qd6 = np.array([0.0, 0.0, 0.0, *derivatives[:3]])
    qdd6 = np.array([0.0, 0.0, 0.0, *derivatives[3:]])
    omega, eps = omega_eps(q6, qd6, qdd6)
    # E^-1 grows as 1 / cos(pitch): the tolerance with it
    scale = 1e-12 * (1.0 + 10.0 / math.cos(pitch_) ** 2)
    rates = euler_rates((roll, pitch_, yaw), tuple(omega))
    np.testing.assert_allclose(rates, qd6[3:], atol=scale * 10)
    accelerations = euler_accelerations((roll, pitch_, yaw), rates, tuple(eps))
    np.testing.assert_allclose(accelerations, qdd6[3:], atol=scale * 1e3)


@settings(max_examples=300, deadline=None)
@given(angle, finite, finite, finite)
def test_at_zero_pitch_and_yaw_the_conversion_is_the_identity(roll, x, y, z):
    assert euler_rates((roll, 0.0, 0.0), (x, y, z)) == (x, y, z)
    assert euler_accelerations((roll, 0.0, 0.0), (x, 0.0, 0.0), (x, y, z)) == (x, y, z)


def test_pitch_of_90_degrees_is_refused():
    with pytest.raises(EulerSingularity):
        euler_rates((0.0, math.pi / 2, 0.0), (1.0, 0.0, 0.0))


@settings(max_examples=300, deadline=None)
@given(st.lists(number, min_size=6, max_size=6), st.lists(number, min_size=6, max_size=6),
       st.lists(number, min_size=6, max_size=6), angle, pitch, angle)
def test_the_three_dof_machine_takes_what_it_always_took(pose, twist, accel, roll, p, yaw):
    """q = (x, z, roll), qd = (linear.x, linear.z, angular.x), qdd the same of
    the acceleration, bit for bit, whatever pitch and yaw the pose carries (the
    machine follows neither: its conversion is at zero pitch and yaw)."""
    poses = pose_map(FLIGHT_SIMULATOR)
    msg = (pose[0], pose[1], pose[2], roll, p, yaw)
    q = poses.coordinates(msg)
    assert q == (pose[0], pose[2], roll)
    qd = poses.rates(q, tuple(twist))
    assert qd == (twist[0], twist[2], twist[3])
    assert poses.accelerations(q, qd, tuple(accel)) == (accel[0], accel[2], accel[3])
    assert poses.ignored == ('sway', 'yaw', 'pitch')


@settings(max_examples=200, deadline=None)
@given(st.lists(st.floats(-0.1, 0.1), min_size=6, max_size=6),
       st.lists(rate, min_size=6, max_size=6), st.lists(rate, min_size=6, max_size=6))
def test_the_hexapod_takes_the_euler_rates_of_the_twist(q, qd, qdd):
    """Any pose near home with any rates: the PoseMap of the hexapod gives back
    the coordinates, rates and accelerations whose twist and acceleration the
    messages carry."""
    q, qd, qdd = (np.array(v) for v in (q, qd, qdd))
    omega, eps = omega_eps(q, qd, qdd)
    poses = pose_map(STEWART)
    coordinates = poses.coordinates(tuple(q))
    rates = poses.rates(coordinates, (*qd[:3], *omega))
    accelerations = poses.accelerations(coordinates, rates, (*qdd[:3], *eps))
    assert coordinates == tuple(q)
    np.testing.assert_allclose(rates, qd, atol=1e-12)
    np.testing.assert_allclose(accelerations, qdd, atol=1e-10)
    assert poses.ignored == () and poses.angles == (3, 4, 5)


# -- the other way: the angular velocity and acceleration of Euler-angle rates (the
# -- twin's platform_twist, the planner's setpoints)
SAMPLES = [(np.random.default_rng(seed).uniform(-1.2, 1.2, 6),
            np.random.default_rng(seed + 100).normal(size=6),
            np.random.default_rng(seed + 200).normal(size=6)) for seed in range(20)]


@pytest.mark.parametrize('q, qd, qdd', SAMPLES)
def test_angular_velocity_and_acceleration_are_the_solvers_E(q, qd, qdd):
    omega, eps = omega_eps(q, qd, qdd)
    np.testing.assert_allclose(angular_velocity(q[3:], qd[3:]), omega, atol=1e-14)
    np.testing.assert_allclose(angular_acceleration(q[3:], qd[3:], qdd[3:]), eps, atol=1e-13)
    # and back (the node's side)
    rates = euler_rates(tuple(q[3:]), angular_velocity(q[3:], qd[3:]))
    np.testing.assert_allclose(rates, qd[3:], atol=1e-13 / abs(math.cos(q[4])))


def test_angular_velocity_is_that_of_the_rotation():
    """omega~ = R' R^T, R = Rz Ry Rx differenced along the rates; epsilon the
    difference of omega along the rates and accelerations."""
    h = 1e-6
    for q, qd, qdd in SAMPLES:
        R_dot = (rotation((q + h * qd)[None])[0] - rotation((q - h * qd)[None])[0]) / (2 * h)
        W = R_dot @ rotation(q[None])[0].T
        np.testing.assert_allclose(angular_velocity(q[3:], qd[3:]),
                                   (W[2, 1], W[0, 2], W[1, 0]), atol=1e-8)
        w_next = np.array(angular_velocity((q + h * qd)[3:], (qd + h * qdd)[3:]))
        w_prev = np.array(angular_velocity((q - h * qd)[3:], (qd - h * qdd)[3:]))
        np.testing.assert_allclose(angular_acceleration(q[3:], qd[3:], qdd[3:]),
                                   (w_next - w_prev) / (2 * h), atol=1e-6)


@settings(max_examples=300, deadline=None)
@given(angle, finite, finite)
def test_a_roll_alone_is_its_rate_about_x_as_it_is(roll, rate_, acc):
    """The 3-DOF machine (pitch = yaw = 0): angular = (roll rate, 0, 0), bit for bit."""
    assert angular_velocity((roll, 0.0, 0.0), (rate_, 0.0, 0.0)) == (rate_, 0.0, 0.0)
    assert angular_acceleration((roll, 0.0, 0.0), (rate_, 0.0, 0.0),
                                (acc, 0.0, 0.0)) == (acc, 0.0, 0.0)
