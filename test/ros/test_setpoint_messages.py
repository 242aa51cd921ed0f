"""Unit tests of the setpoint messages' rules (flight_sim_dynamics.ros.messages):
quaternions, pose and rate inputs, what the 3-DOF machine cannot follow."""
from __future__ import annotations

import math
from types import SimpleNamespace

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from flight_sim_dynamics.core.estimator import wrap_angle
from flight_sim_dynamics.ros.messages import (ABSURD_ACCELERATION, BAD_QUATERNION, NON_FINITE,
                                              PITCH, SWAY, YAW, SetpointError, pose_input, pose_map,
                                              quaternion_to_rpy, rate_input, rpy_to_quaternion)
from flight_sim_dynamics.machines import FLIGHT_SIMULATOR

#: What the 3-DOF machine takes of the messages; a solution of parasitic pitch -0.04 rad.
POSES = pose_map(FLIGHT_SIMULATOR)
BETA = SimpleNamespace(beta=0.04)
unfollowable = POSES.unfollowable

angles = st.floats(-math.pi + 1e-6, math.pi - 1e-6)


# ----------------------------------------------------------------------------
# Quaternions
# ----------------------------------------------------------------------------
@settings(max_examples=300, deadline=None)
@given(angles, st.floats(-1.5, 1.5), angles)
def test_rpy_round_trip(roll, pitch, yaw):
    r, p, y = quaternion_to_rpy(*rpy_to_quaternion(roll, pitch, yaw))
    assert abs(wrap_angle(r - roll)) < 1e-9
    assert abs(p - pitch) < 1e-9
    assert abs(wrap_angle(y - yaw)) < 1e-9


@settings(max_examples=200, deadline=None)
@given(st.floats(-1.4, 1.4), st.floats(-0.3, 0.3))
def test_parasitic_pitch_does_not_change_roll(roll, pitch):
    """Ry(pitch) Rx(roll): the ZYX roll is the roll of the roll-only quaternion."""
    with_pitch = quaternion_to_rpy(*rpy_to_quaternion(roll, pitch, 0.0))
    roll_only = quaternion_to_rpy(*rpy_to_quaternion(roll, 0.0, 0.0))
    assert with_pitch[0] == pytest.approx(roll_only[0], abs=1e-12)
    assert with_pitch[1] == pytest.approx(pitch, abs=1e-12)


def test_roll_sign_rep103():
    """Positive roll about +X (forward) lowers the right (-Y) side."""
    x, y, z, w = rpy_to_quaternion(0.2)
    # rotate the left unit vector (0, 1, 0): its z becomes +sin(roll) (left side up)
    z_of_left = 2 * (y * z + w * x)
    assert z_of_left == pytest.approx(math.sin(0.2))
    assert quaternion_to_rpy(x, y, z, w)[0] == pytest.approx(0.2)


@pytest.mark.parametrize('q, reason', [
    ((0.0, 0.0, 0.0, 0.0), BAD_QUATERNION),
    ((0.0, 0.0, 0.0, 2.0), BAD_QUATERNION),
    ((0.0, 0.0, 0.0, 0.99), BAD_QUATERNION),
    ((math.nan, 0.0, 0.0, 1.0), NON_FINITE),
    ((0.0, math.inf, 0.0, 1.0), NON_FINITE),
])
def test_bad_quaternions_rejected(q, reason):
    with pytest.raises(SetpointError) as info:
        quaternion_to_rpy(*q, tolerance=1e-3)
    assert info.value.reason == reason


def test_slightly_non_unit_quaternion_normalised():
    x, y, z, w = rpy_to_quaternion(0.3)
    assert quaternion_to_rpy(x * 1.0005, y, z, w * 1.0005, 1e-3)[0] == pytest.approx(0.3)


def test_pose_and_rate_inputs():
    pose = pose_input(0.05, 0.01, 0.1, *rpy_to_quaternion(0.2, 0.03, 0.04))
    assert pose == pytest.approx((0.05, 0.01, 0.1, 0.2, 0.03, 0.04))
    assert POSES.coordinates(pose) == pytest.approx((0.05, 0.1, 0.2))
    rates = rate_input(1.0, 2.0, 3.0, 4.0, 5.0, 6.0)
    assert rates == (1.0, 2.0, 3.0, 4.0, 5.0, 6.0)
    assert POSES.coordinates(rates) == (1.0, 3.0, 4.0)
    with pytest.raises(SetpointError):
        pose_input(math.nan, 0, 0, 0, 0, 0, 1)
    with pytest.raises(SetpointError):
        rate_input(0, 0, 0, 0, 0, math.inf)


def test_unfollowable_components():
    clean = pose_input(0, 0, 0, *rpy_to_quaternion(0.1))
    assert unfollowable(clean, None, None, BETA, 1e-3, 1e-3) == ()
    parasitic = pose_input(0, 0, 0, *rpy_to_quaternion(0.1, -0.04))
    assert unfollowable(parasitic, None, None, BETA, 1e-3, 1e-3) == ()
    other = pose_input(0, 0.1, 0, *rpy_to_quaternion(0.1, 0.2, 0.3))
    assert unfollowable(other, None, None, BETA, 1e-3, 1e-3) == (SWAY, YAW, PITCH)
    twist = rate_input(0, 0.5, 0, 0, 0, 0)
    assert unfollowable(clean, twist, None, BETA, 1e-3, 1e-3) == (SWAY,)


def test_absurd_acceleration():
    POSES.check_acceleration((1.0, -2.0, 3.0), 50.0, 100.0)
    for qdd in ((51.0, 0.0, 0.0), (0.0, -51.0, 0.0), (0.0, 0.0, 101.0)):
        with pytest.raises(SetpointError) as info:
            POSES.check_acceleration(qdd, 50.0, 100.0)
        assert info.value.reason == ABSURD_ACCELERATION
