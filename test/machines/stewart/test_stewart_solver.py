"""The hexapod's solve and solve_batch: fields, statuses and hard cases
(stroke edges, near-singular poses, large yaw, bad numbers): a status, never
a NaN, never an exception for a bad pose."""
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from flight_sim_dynamics.core.status import SINGULAR, Status
from flight_sim_dynamics.machines.stewart import kinematics as kin
from flight_sim_dynamics.machines.stewart import model as sm
from flight_sim_dynamics.machines.stewart import solver

from stewart_cases import MACHINES, model_of, random_motion

MODEL = model_of('stewart_6dof')
Z = np.zeros(6)
FIELDS = ('length', 'stroke', 'rate', 'acceleration', 'force', 'power', 'joints', 'joint_rates',
          'joint_accelerations', 'spherical_angles', 'jacobian', 'twist_jacobian')


def _all_finite(sol):
    return all(np.all(np.isfinite(getattr(sol, name))) for name in FIELDS) and \
        np.all(np.isfinite(sol.jacobian_condition))


def _void(sol):
    return all(np.all(getattr(sol, name) == 0.0) for name in FIELDS)


def test_one_sample_is_the_batch_of_one():
    q, qd, qdd = random_motion(1, 'violent', n=5)
    batch = solver.solve_batch(MODEL, q, qd, qdd)
    for i in range(5):
        one = solver.solve(MODEL, list(q[i]), tuple(qd[i]), qdd[i])
        for name in FIELDS:
            np.testing.assert_array_equal(getattr(one, name), getattr(batch, name)[i])
        assert one.status == batch.status[i] and one.detail == batch.detail[i]
        assert one.jacobian_condition == batch.jacobian_condition[i]


def test_fields_are_consistent():
    q, qd, qdd = random_motion(2, 'gentle', n=10)
    sol = solver.solve_batch(MODEL, q, qd, qdd)
    np.testing.assert_allclose(sol.stroke, sol.length - MODEL.home_lengths, atol=1e-15)
    np.testing.assert_array_equal(sol.power, sol.force * sol.rate)
    np.testing.assert_allclose(np.einsum('nij,nj->ni', sol.jacobian, qd), sol.rate, atol=1e-12)
    np.testing.assert_array_equal(sol.joints[..., 2], sol.length)
    np.testing.assert_array_equal(sol.joint_rates[..., 2], sol.rate)
    np.testing.assert_array_equal(sol.joint_accelerations[..., 2], sol.acceleration)
    np.testing.assert_allclose(sol.jacobian_condition,
                               np.linalg.cond(sol.twist_jacobian), rtol=1e-12)
    assert all((s is Status.OK) == (d == '') for s, d in zip(sol.status, sol.detail))


# ---------------------------------------------------------------------------
# limits
# ---------------------------------------------------------------------------

def _heave_for_length(length):
    """Pure heave at which every leg of the default machine has ``length``."""
    d = MODEL.home + MODEL.platform_joints[0] - MODEL.base_joints[0]
    return math.sqrt(length ** 2 - d[0] ** 2 - d[1] ** 2) - d[2]


@pytest.mark.parametrize('edge', ['length_min', 'length_max'])
def test_stroke_edges(edge):
    lim = getattr(MODEL.limits, edge)
    inside = -1e-9 if edge == 'length_max' else 1e-9
    for delta, status in ((inside, Status.OK), (-inside, Status.LIMIT)):
        q = np.array([0, 0, _heave_for_length(lim + delta), 0, 0, 0])
        sol = solver.solve(MODEL, q, Z, Z)
        assert sol.status is status, sol.detail
        if status is Status.LIMIT:
            assert 'length' in sol.detail and 'leg 1' in sol.detail
        np.testing.assert_allclose(sol.length, lim + delta, atol=1e-12)


def test_speed_and_force_limits():
    slow = solver.solve(MODEL, Z, [0, 0, 1.0, 0, 0, 0], Z)
    assert slow.status is Status.OK
    fast = solver.solve(MODEL, Z, [0, 0, 2.5, 0, 0, 0], Z)
    assert fast.status is Status.LIMIT and 'speed' in fast.detail
    hard = solver.solve(MODEL, Z, Z, [0, 0, 300.0, 0, 0, 0])
    assert hard.status is Status.LIMIT and 'force' in hard.detail
    assert np.abs(hard.force).max() > MODEL.limits.max_force


def test_joint_angle_limits_are_off_by_default_and_act_when_given():
    q = np.array([0.1, 0.0, 0.0, 0.0, 0.0, 0.0])
    assert solver.solve(MODEL, q, Z, Z).status is Status.OK
    params = MACHINES['stewart_6dof']
    u_limit = sm.from_dict({**params, 'limits': {**params['limits'],
                                                 'u_joint_max_angle': math.radians(30.0)}})
    sol = solver.solve(u_limit, q, Z, Z)
    assert np.degrees(np.abs(sol.joints[:, :2]).max()) > 30.0
    assert sol.status is Status.LIMIT and 'U-joint angle' in sol.detail
    assert solver.solve(u_limit, Z, Z, Z).status is Status.OK      # 28.6 deg at home
    ball = sm.from_dict({**params, 'limits': {**params['limits'],
                                              'spherical_joint_max_angle': 0.7}})
    angles = solver.solve(ball, Z, Z, Z).spherical_angles
    assert angles.max() < 0.7
    tilted = solver.solve(ball, [0, 0, 0, 0.3, 0, 0], Z, Z)
    assert tilted.spherical_angles.max() > 0.7
    assert tilted.status is Status.LIMIT and 'spherical joint angle' in tilted.detail


# ---------------------------------------------------------------------------
# singular and unreachable poses
# ---------------------------------------------------------------------------

def test_near_singular_poses_are_reported_with_finite_numbers():
    """Heave towards the base plane: the legs turn horizontal, J degenerates."""
    heaves = -np.linspace(0.9, 0.999, 12)
    q = np.zeros((12, 6))
    q[:, 2] = heaves
    sol = solver.solve_batch(MODEL, q, np.ones((12, 6)), np.ones((12, 6)))
    assert _all_finite(sol)
    cond = sol.jacobian_condition
    assert np.all(np.diff(cond) > 0)            # worse and worse
    near = cond > MODEL.limits.max_jacobian_condition
    assert near.any() and not near.all()
    assert all(s is Status.NEAR_SINGULAR for s in sol.status[near])
    assert all('condition' in d for d in np.array(sol.detail)[near])
    assert np.abs(sol.force[near]).max() > 10 * np.abs(sol.force[~near]).max()


def test_an_exact_singularity_is_near_singular_with_zero_forces():
    sol = solver.solve(MODEL, [0, 0, -1.0, 0, 0, 0], np.ones(6), np.ones(6))  # flat
    assert sol.status is Status.NEAR_SINGULAR and 'exact singularity' in sol.detail
    assert np.all(sol.force == 0.0) and sol.jacobian_condition == SINGULAR
    assert _all_finite(sol)
    np.testing.assert_allclose(sol.length, np.linalg.norm(
        MODEL.platform_joints + MODEL.home - [0, 0, 1.0] - MODEL.base_joints, axis=1))


def test_a_leg_along_its_u_joint_axis_is_unreachable():
    """Put P_1 on the line of a_1,1 through B_1: theta_2 = 90 deg (S5)."""
    target = MODEL.base_joints[0] + 1.2 * MODEL.base_axes[0]
    q = np.zeros(6)
    q[:3] = target - MODEL.home - MODEL.platform_joints[0]
    sol = solver.solve(MODEL, q, np.ones(6), np.ones(6))
    assert sol.status is Status.UNREACHABLE and 'leg 1' in sol.detail
    assert _void(sol) and sol.jacobian_condition == 0.0


def test_a_leg_of_zero_length_is_unreachable():
    q = np.zeros(6)
    q[:3] = MODEL.base_joints[3] - MODEL.home - MODEL.platform_joints[3]
    sol = solver.solve(MODEL, q, Z, Z)
    assert sol.status is Status.UNREACHABLE and 'leg 4' in sol.detail and 'length' in sol.detail
    assert _void(sol)


@pytest.mark.parametrize('name', sorted(MACHINES))
def test_large_yaw(name):
    """Yaw is periodic: a turn more or less changes nothing; half a turn is
    still a finite solve with a status."""
    model = model_of(name)
    q, qd, qdd = random_motion(3, 'gentle', n=8)
    turned = q.copy()
    turned[:, 5] += np.array([2, -2, 4, -4, 2, -2, 6, -6]) * np.pi
    a = solver.solve_batch(model, q, qd, qdd)
    b = solver.solve_batch(model, turned, qd, qdd)
    np.testing.assert_allclose(b.force, a.force, rtol=1e-9, atol=1e-9 * np.abs(a.force).max())
    q[:, 5] = np.linspace(-np.pi, np.pi, 8)
    sol = solver.solve_batch(model, q, qd, qdd)
    assert _all_finite(sol)
    assert all(s in (Status.OK, Status.LIMIT, Status.NEAR_SINGULAR, Status.UNREACHABLE)
               for s in sol.status)


def test_pitch_at_ninety_degrees_solves_the_twist():
    """det E = cos(pitch) = 0: the Euler rates lose a direction, the forces do not."""
    q = np.array([0, 0, 0.2, 0, np.pi / 2, 0])
    sol = solver.solve(MODEL, q, np.full(6, 0.1), np.full(6, 0.1))
    assert _all_finite(sol)
    assert abs(np.linalg.det(sol.jacobian)) < 1e-12 < abs(np.linalg.det(sol.twist_jacobian))


# ---------------------------------------------------------------------------
# bad numbers
# ---------------------------------------------------------------------------

@pytest.mark.parametrize('index', range(18))
@pytest.mark.parametrize('value', [math.nan, math.inf, -math.inf])
def test_a_non_finite_input_is_invalid_input_naming_it(index, value):
    rows = [np.zeros(6), np.zeros(6), np.zeros(6)]
    rows[index // 6][index % 6] = value
    sol = solver.solve(MODEL, *rows)
    assert sol.status is Status.INVALID_INPUT and _void(sol)
    assert sol.detail.startswith(f"{('q', 'qd', 'qdd')[index // 6]}[{index % 6}] "
                                 f"({solver.COORDINATES[index % 6]})")


def test_bad_samples_do_not_spoil_a_batch():
    q, qd, qdd = random_motion(4, 'gentle', n=6)
    good = solver.solve_batch(MODEL, q, qd, qdd)
    q[1, 0], qdd[3, 4] = math.nan, math.inf
    q[4] = [0.0, 0.0, -1.0, 0.0, 0.0, 0.0]      # flat: J singular
    mixed = solver.solve_batch(MODEL, q, qd, qdd)
    assert [str(s) for s in mixed.status] == ['ok', 'invalid_input', 'ok', 'invalid_input',
                                              'near_singular', 'ok']
    for i in (0, 2, 5):
        np.testing.assert_array_equal(mixed.force[i], good.force[i])
    assert _all_finite(mixed)


def test_results_that_overflow_are_invalid_input():
    sol = solver.solve(MODEL, Z, np.full(6, 1e200), Z)
    assert sol.status is Status.INVALID_INPUT and 'not finite' in sol.detail
    assert _all_finite(sol)


_ANY = st.floats(allow_nan=True, allow_infinity=True)
_WILD = st.one_of(_ANY, st.floats(-1e3, 1e3), st.floats(-2.0, 2.0))


def test_any_numbers_give_a_status_and_finite_results(sweep):
    @settings(max_examples=sweep(300), deadline=None)
    @given(values=st.lists(_WILD, min_size=18, max_size=18))
    def check(values):
        v = np.array(values).reshape(3, 6)
        sol = solver.solve(MODEL, v[0], v[1], v[2])
        assert isinstance(sol.status, Status) and sol.status is not Status.NOT_CONVERGED
        assert _all_finite(sol)
        assert (sol.status is Status.OK) == (sol.detail == '')
        if not np.all(np.isfinite(v)):
            assert sol.status is Status.INVALID_INPUT and _void(sol)

    check()


@pytest.mark.parametrize('value', [[0.0] * 5, 'abcdef', [[0.0] * 6], [True] * 6, None,
                                   [0.0] * 5 + ['x'], [10 ** 400] + [0] * 5,
                                   [True] + [0.0] * 5])
def test_solve_refuses_what_is_not_six_numbers(value):
    with pytest.raises(ValueError, match='qd'):
        solver.solve(MODEL, Z, value, Z)


@pytest.mark.parametrize('q, match', [
    (np.zeros((3, 5)), r'shape \(N, 6\)'), (np.zeros(6), r'shape \(N, 6\)'),
    (np.zeros((3, 6), dtype=bool), 'numbers'), ([['a'] * 6], 'numbers'),
    ([[0.0] * 6, [0.0] * 5 + [False], [0.0] * 6], 'bool'),
    (np.ma.masked_array(np.zeros((2, 6)), mask=[[1] + [0] * 5, [0] * 6]), 'masked')])
def test_solve_batch_refuses_what_is_not_n_by_six_numbers(q, match):
    with pytest.raises(ValueError, match=match):
        solver.solve_batch(MODEL, q, np.zeros((3, 6)), np.zeros((3, 6)))


def test_solve_batch_refuses_rows_that_do_not_match():
    with pytest.raises(ValueError, match='qdd has 2 rows'):
        solver.solve_batch(MODEL, np.zeros((3, 6)), np.zeros((3, 6)), np.zeros((2, 6)))


def test_degenerate_legs_flag_what_the_solver_cannot_solve():
    legs = kin.leg_positions(MODEL, np.array([[0.0, 0.0, 1.0]]), np.eye(3)[None])
    assert not kin.degenerate_legs(legs).any()
