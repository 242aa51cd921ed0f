"""The hexapod's kinematics (S1)-(S14), (S21)-(S22) against finite
differences of its positions, the check values of stewart.md, and forward
kinematics (pose from six lengths) round trips."""
import warnings

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from flight_sim_dynamics.core.status import Status
from flight_sim_dynamics.machines.stewart import kinematics as kin

from stewart_cases import MACHINES, doc_number, model_of, random_motion

NAMES = sorted(MACHINES)


def _state(model, q, qd, qdd):
    platform = kin.platform_motion(model, q, qd, qdd)
    legs = kin.leg_positions(model, platform.p, platform.R)
    rates = kin.leg_velocities(model, legs, platform)
    return platform, legs, rates, kin.leg_accelerations(model, legs, rates, platform)


def _along(q, qd, qdd, t):
    """Poses q(t) = q + qd t + qdd t^2 / 2 (N samples at time t)."""
    return q + qd * t + 0.5 * qdd * t * t


# fourth-order central stencils
_H = 2e-4
#: relative tolerances of the stencils' first and second derivatives (truncation + rounding)
D1, D2 = 1e-8, 1e-5


def _d1(f):
    return (f(-2 * _H) - 8 * f(-_H) + 8 * f(_H) - f(2 * _H)) / (12 * _H)


def _d2(f):
    return (-f(-2 * _H) + 16 * f(-_H) - 30 * f(0.0) + 16 * f(_H) - f(2 * _H)) / (12 * _H * _H)


def _close(actual, numeric, tol):
    """max |actual - numeric| <= tol x max(1, max |numeric|)."""
    scale = max(1.0, float(np.abs(numeric).max()))
    assert np.abs(actual - numeric).max() <= tol * scale, np.abs(actual - numeric).max() / scale


def _vee(S):
    return np.stack([S[..., 2, 1], S[..., 0, 2], S[..., 1, 0]], axis=-1)


def _leg_frame(model, q):
    """The cylinder's orientation [a_2 x u, a_2, u] from the geometry alone,
    a_2 = -(a_1 x u) / |a_1 x u| (S5), (N, 6, 3, 3)."""
    u = kin.leg_positions(model, model.home + q[:, :3], kin.rotation(q)).u
    a2 = -np.cross(model.base_axes, u)
    a2 /= np.linalg.norm(a2, axis=-1, keepdims=True)
    return np.stack([np.cross(a2, u), a2, u], axis=-1)


@pytest.mark.parametrize('name', NAMES)
def test_pose_jacobian_is_the_derivative_of_the_lengths(name):
    model = model_of(name)
    q = random_motion(1, 'violent', 10)[0]
    platform, legs, _, _ = _state(model, q, q * 0, q * 0)
    J_L = kin.pose_jacobian(kin.actuator_jacobian(legs), platform.E)
    numeric = np.stack([_d1(lambda h, j=j: kin.leg_lengths(model, q + h * np.eye(6)[j]))
                        for j in range(6)], axis=-1)
    _close(J_L, numeric, D1)


@pytest.mark.parametrize('name', NAMES)
def test_rates_and_accelerations_are_the_derivatives_along_the_motion(name):
    model = model_of(name)
    q, qd, qdd = random_motion(2, 'violent', 10)
    _, legs, rates, acc = _state(model, q, qd, qdd)

    def lengths(t):
        return kin.leg_lengths(model, _along(q, qd, qdd, t))

    def joint(t, key):
        x = _along(q, qd, qdd, t)
        return getattr(kin.leg_positions(model, model.home + x[:, :3], kin.rotation(x)), key)

    _close(rates.Ld, _d1(lengths), D1)
    _close(acc.Ldd, _d2(lengths), D2)
    for key, first, second in (('theta1', rates.theta1d, acc.theta1dd),
                               ('theta2', rates.theta2d, acc.theta2dd)):
        _close(first, _d1(lambda t: joint(t, key)), D1)
        _close(second, _d2(lambda t: joint(t, key)), D2)
    _close(rates.ud, _d1(lambda t: joint(t, 'u')), D1)
    _close(acc.udd, _d2(lambda t: joint(t, 'u')), D2)


@pytest.mark.parametrize('name', NAMES)
def test_platform_angular_velocity_and_acceleration(name):
    """omega = E rates (S2) and eps = E rates' + E' rates (S3) are the motion of R(t)."""
    model = model_of(name)
    q, qd, qdd = random_motion(3, 'violent', 10)
    platform = kin.platform_motion(model, q, qd, qdd)
    R = kin.rotation(q)
    Rd = _d1(lambda t: kin.rotation(_along(q, qd, qdd, t)))
    _close(platform.omega, _vee(Rd @ np.swapaxes(R, 1, 2)), D1)

    def omega(t):
        x = _along(q, qd, qdd, t)
        return kin.platform_motion(model, x, qd + qdd * t, qdd).omega

    _close(platform.eps, _d1(omega), D1)
    Ed = _d1(lambda t: kin.euler_rate_matrix(_along(q, qd, qdd, t)))
    _close(kin.euler_rate_matrix_derivative(q, qd), Ed, D1)


@pytest.mark.parametrize('name', NAMES)
def test_leg_angular_velocity_includes_the_spin_the_u_joint_imposes(name):
    """omega_i (S9) and eps_i (S13) are the motion of the cylinder's frame,
    whose spin about the leg is sigma_i = sin(theta_2) theta_1' (not zero)."""
    model = model_of(name)
    q, qd, qdd = random_motion(4, 'violent', 10)
    _, legs, rates, acc = _state(model, q, qd, qdd)
    C = _leg_frame(model, q)
    Cd = _d1(lambda t: _leg_frame(model, _along(q, qd, qdd, t)))
    _close(rates.omega, _vee(Cd @ np.swapaxes(C, -1, -2)), D1)
    spin = np.sum(rates.omega * legs.u, axis=-1)
    np.testing.assert_allclose(spin, rates.sigma, atol=1e-12)
    assert np.abs(spin).max() > 0.1

    def omega(t):
        x = _along(q, qd, qdd, t)
        return _state(model, x, qd + qdd * t, qdd)[2].omega

    _close(acc.eps, _d1(omega), D1)


@pytest.mark.parametrize('name', NAMES)
def test_actuator_jacobian_maps_the_twist_to_the_leg_rates(name):
    model = model_of(name)
    q, qd, qdd = random_motion(5, 'violent', 10)
    platform, legs, rates, _ = _state(model, q, qd, qdd)
    J = kin.actuator_jacobian(legs)
    twist = np.concatenate([platform.v, platform.omega], axis=-1)
    np.testing.assert_allclose(np.einsum('nij,nj->ni', J, twist), rates.Ld, atol=1e-12)
    J_L = kin.pose_jacobian(J, platform.E)
    np.testing.assert_allclose(np.einsum('nij,nj->ni', J_L, qd), rates.Ld, atol=1e-12)


def test_spherical_joint_angle_is_the_legs_tilt_from_the_platform_normal():
    """The default machine's platform joints lie in the platform's z = 0 plane:
    its normal is (P_2 - P_1) x (P_3 - P_1), up at home."""
    model = model_of('stewart_6dof')
    q = random_motion(6, 'violent', 10)[0]
    platform, legs, _, _ = _state(model, q, q * 0, q * 0)
    n = np.cross(legs.P[:, 1] - legs.P[:, 0], legs.P[:, 2] - legs.P[:, 0])
    n /= np.linalg.norm(n, axis=-1, keepdims=True)
    expected = np.arccos(np.einsum('nkj,nj->nk', legs.u, n))
    np.testing.assert_allclose(kin.spherical_joint_angles(platform.R, legs.u), expected,
                               atol=1e-12)


def test_home_u_joint_angles_and_conditions_are_the_documented_ones():
    model = model_of('stewart_6dof')
    zero = np.zeros((1, 6))
    _, legs, _, _ = _state(model, zero, zero, zero)
    # the doc writes the minus sign as U+2212
    theta1 = -doc_number(r'sit at `θ₁ = −([\d.]+)°`')
    theta2 = doc_number(r'`θ₂ = ±([\d.]+)°` at home')
    np.testing.assert_allclose(np.degrees(legs.theta1), theta1, atol=5e-4)
    np.testing.assert_allclose(np.degrees(np.abs(legs.theta2)), theta2, atol=5e-4)
    for name, pattern in (('stewart_6dof', r'\(([\d.]+) at home for the default'),
                          ('stewart_tsai2000', r'([\d.]+) for Tsai\'s')):
        m = model_of(name)
        legs = kin.leg_positions(m, m.home[None, :], np.eye(3)[None])
        cond = kin.jacobian_condition(kin.actuator_jacobian(legs))[0]
        assert cond == pytest.approx(doc_number(pattern), abs=5e-3)


# ---------------------------------------------------------------------------
# forward kinematics
# ---------------------------------------------------------------------------

_POSES = st.tuples(*[st.floats(-0.15, 0.15)] * 3, *[st.floats(-0.3, 0.3)] * 2,
                   st.floats(-0.8, 0.8))


@pytest.mark.parametrize('name', NAMES)
@settings(max_examples=40, deadline=None)
@given(pose=_POSES)
def test_forward_kinematics_round_trip(name, pose):
    """Lengths of a pose -> that pose. Near a parallel singularity two
    assembly modes of the same lengths lie close together (Tsai's machine
    meets one in this box), so the pose itself is compared where J is well
    conditioned, the lengths everywhere."""
    model = model_of(name)
    q = np.array(pose)
    L = kin.leg_lengths(model, q)[0]
    fk = kin.forward_kinematics(model, L)
    assert fk.status is Status.OK, fk.detail
    np.testing.assert_allclose(kin.leg_lengths(model, fk.pose)[0], L, rtol=0, atol=1e-12)
    legs = kin.leg_positions(model, model.home[None, :] + q[:3], kin.rotation(q[None, :]))
    if kin.jacobian_condition(kin.actuator_jacobian(legs))[0] <= 100.0:
        np.testing.assert_allclose(fk.pose, q, rtol=0, atol=1e-9)


@pytest.mark.parametrize('name', NAMES)
def test_forward_kinematics_from_the_answer_is_the_answer(name):
    model = model_of(name)
    fk = kin.forward_kinematics(model, model.home_lengths)
    assert fk.status is Status.OK and fk.iterations == 0
    np.testing.assert_array_equal(fk.pose, np.zeros(6))


def test_forward_kinematics_from_a_far_start():
    """Full Newton steps from here overshoot and wander (not converged in 50
    iterations); the halved steps that must reduce the residual arrive."""
    model = model_of('stewart_6dof')
    fk = kin.forward_kinematics(model, model.home_lengths, [0.5] * 6)
    assert fk.status is Status.OK
    np.testing.assert_allclose(fk.pose, 0.0, atol=1e-9)


def test_forward_kinematics_from_a_start_near_the_answer():
    model = model_of('stewart_6dof')
    q = np.array([0.1, -0.05, 0.2, 0.1, -0.2, 1.2])
    fk = kin.forward_kinematics(model, kin.leg_lengths(model, q)[0], q + 0.01)
    assert fk.status is Status.OK and fk.iterations <= 6
    np.testing.assert_allclose(fk.pose, q, rtol=0, atol=1e-9)


def test_forward_kinematics_from_a_degenerate_start_is_invalid_input():
    """An initial pose with a leg of zero length (platform joint 1 on base
    joint 1): invalid_input, no pose, no warning."""
    model = model_of('stewart_6dof')
    t = model.base_joints[0] - np.asarray(model.home) - model.platform_joints[0]
    with warnings.catch_warnings():
        warnings.simplefilter('error')
        fk = kin.forward_kinematics(model, model.home_lengths, [*t, 0.0, 0.0, 0.0])
    assert fk.status is Status.INVALID_INPUT and fk.iterations == 0
    assert np.all(fk.pose == 0.0) and 'initial' in fk.detail


@pytest.mark.parametrize('lengths', [[0.05] * 6, [1.0] * 5 + [3.0], [1.0] * 5 + [9.0]])
def test_forward_kinematics_of_impossible_lengths_is_a_status(lengths):
    fk = kin.forward_kinematics(model_of('stewart_6dof'), lengths)
    assert fk.status in (Status.UNREACHABLE, Status.NOT_CONVERGED)
    assert np.all(fk.pose == 0.0) and fk.detail


@pytest.mark.parametrize('lengths, initial', [
    ([np.nan] + [1.2] * 5, [0.0] * 6), ([1.2] * 5 + [np.inf], [0.0] * 6),
    ([1.2] * 5 + [-1.0], [0.0] * 6), ([1.2] * 6, [0.0] * 5 + [np.nan])])
def test_forward_kinematics_of_bad_numbers_is_invalid_input(lengths, initial):
    fk = kin.forward_kinematics(model_of('stewart_6dof'), lengths, initial)
    assert fk.status is Status.INVALID_INPUT
    assert np.all(fk.pose == 0.0)


@pytest.mark.parametrize('value', [[1.0] * 5, 'abcdef', [[1.0] * 6], [True] * 6, None])
def test_forward_kinematics_refuses_what_is_not_six_numbers(value):
    with pytest.raises(ValueError, match='lengths'):
        kin.forward_kinematics(model_of('stewart_6dof'), value)
