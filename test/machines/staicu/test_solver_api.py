"""The public Python API: shapes, batch vs single, input checking, statics."""
import numpy as np
import pytest

import flight_sim_dynamics as fsd
from flight_sim_dynamics.machines.staicu.trajectories import paper_example

MODEL = fsd.load_model()


def test_check_values_at_rest():
    sol = fsd.solve(MODEL, [0, 0, 0], [0, 0, 0], [0, 0, 0])
    np.testing.assert_allclose(sol.force, [38.6066, 33.2041, 33.2041], atol=5e-5)
    assert np.all(sol.power == 0.0) and np.all(sol.rate == 0.0)
    assert isinstance(sol.cond, float) and sol.cond > 1
    assert sol.length.shape == sol.stroke.shape == sol.force.shape == (3,)
    assert sol.joints.shape == sol.joint_rates.shape == (12,)


def test_single_equals_batch():
    q, qd, qdd = paper_example('general', np.linspace(0, 3, 13))
    batch = fsd.solve_batch(MODEL, q, qd, qdd)
    for i in range(len(q)):
        one = fsd.solve(MODEL, q[i], qd[i], qdd[i])
        for field in ('length', 'stroke', 'rate', 'acceleration', 'force', 'power', 'joints'):
            np.testing.assert_allclose(getattr(one, field), getattr(batch, field)[i],
                                       rtol=1e-13, atol=1e-13)


def test_heave_up_needs_more_force_than_down():
    up = fsd.solve(MODEL, [0, 0, 0], [0, 0, 0], [0, 2.0, 0]).force
    down = fsd.solve(MODEL, [0, 0, 0], [0, 0, 0], [0, -2.0, 0]).force
    assert np.all(up > down)


@pytest.mark.parametrize('args, words', [
    (([0, 0], [0, 0, 0], [0, 0, 0]), 'q must be 3 numbers'),
    (([0, 0, 0], [0, 0, 0, 0], [0, 0, 0]), 'qd must be 3 numbers'),
    (([0, 0, 0], [0, 0, 0], 'abc'), 'qdd must be 3 numbers'),
    (([0, 'x', 0], [0, 0, 0], [0, 0, 0]), 'q must be 3 numbers'),
])
def test_bad_input_is_a_clear_error(args, words):
    with pytest.raises(ValueError, match=words):
        fsd.solve(MODEL, *args)


@pytest.mark.parametrize('args, words', [
    (([0, float('nan'), 0], [0, 0, 0], [0, 0, 0]), 'q[1] (heave) is not finite'),
    (([0, 0, 0], [0, 0, float('inf')], [0, 0, 0]), 'qd[2] (roll) is not finite'),
    (([0, 0, 0], [0, 0, 0], [-float('inf'), 0, 0]), 'qdd[0] (surge) is not finite'),
])
def test_non_finite_numbers_give_invalid_input(args, words):
    sol = fsd.solve(MODEL, *args)
    assert sol.status == fsd.Status.INVALID_INPUT and words in sol.detail
    assert np.all(sol.force == 0.0) and np.all(sol.length == 0.0)


def test_batch_shape_mismatch():
    with pytest.raises(ValueError, match='rows'):
        fsd.solve_batch(MODEL, np.zeros((3, 3)), np.zeros((2, 3)), np.zeros((3, 3)))
    with pytest.raises(ValueError, match=r'shape \(N, 3\)'):
        fsd.solve_batch(MODEL, np.zeros((3, 4)), np.zeros((3, 4)), np.zeros((3, 4)))


# ---------------------------------------------------------------------------
# One input rule for solve, solve_batch and forward_kinematics (issue 12 #11)
# ---------------------------------------------------------------------------
_NOT_THREE_NUMBERS = [[10**400, 0.0, 0.0], [True, 0.0, 0.0], ['0', 0.0, 0.0],
                      [0.0, 0.0], None, 'abc', [[0.0, 0.0, 0.0]]]


@pytest.mark.parametrize('bad', _NOT_THREE_NUMBERS)
def test_one_input_rule_solve(bad):
    with pytest.raises(ValueError, match='q must be 3 numbers'):
        fsd.solve(MODEL, bad, [0.0] * 3, [0.0] * 3)


@pytest.mark.parametrize('bad', _NOT_THREE_NUMBERS)
def test_one_input_rule_solve_batch(bad):
    with pytest.raises(ValueError, match='q'):
        fsd.solve_batch(MODEL, [bad], np.zeros((1, 3)), np.zeros((1, 3)))


@pytest.mark.parametrize('bad', _NOT_THREE_NUMBERS)
def test_one_input_rule_forward_kinematics(bad):
    with pytest.raises(ValueError, match='lengths must be 3 numbers'):
        fsd.forward_kinematics(MODEL, bad)


def test_masked_entries_are_refused_not_solved():
    q = np.ma.masked_array(np.zeros((2, 3)), mask=[[False] * 3, [True, False, False]])
    with pytest.raises(ValueError, match='masked'):
        fsd.solve_batch(MODEL, q, np.zeros((2, 3)), np.zeros((2, 3)))
    with pytest.raises(ValueError, match='3 numbers'):
        fsd.solve(MODEL, q[1], [0.0] * 3, [0.0] * 3)
    unmasked = np.ma.masked_array(np.zeros((2, 3)), mask=False)
    solved = fsd.solve_batch(MODEL, unmasked, np.zeros((2, 3)), np.zeros((2, 3)))
    assert solved.force.shape == (2, 3)


def test_non_finite_numbers_are_a_status_not_an_exception():
    invalid = fsd.Status.INVALID_INPUT
    assert fsd.solve(MODEL, [float('inf'), 0.0, 0.0], [0.0] * 3, [0.0] * 3).status == invalid
    assert fsd.forward_kinematics(MODEL, [float('nan'), 1.3, 1.3]).status == invalid
