"""Forward kinematics: round trip through the inverse geometry, lengths outside
the workspace (bad input: test_hard_cases.py)."""
import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

import flight_sim_dynamics as fsd
from flight_sim_dynamics import forward_kinematics
from flight_sim_dynamics import Status
from flight_sim_dynamics.core import kernel as core_kernel
from flight_sim_dynamics.machines.staicu import kernel

MODEL = fsd.load_model()

poses = st.tuples(st.floats(-0.12, 0.12), st.floats(-0.15, 0.15), st.floats(-0.5, 0.5))


@settings(max_examples=150, deadline=None)
@given(poses)
def test_round_trip_through_inverse_geometry(q):
    sol = fsd.solve(MODEL, q, (0, 0, 0), (0, 0, 0))
    assert sol.status == Status.OK, sol.detail          # the box is inside the workspace
    result = forward_kinematics(MODEL, sol.length)
    assert result.status == Status.OK, result.detail
    np.testing.assert_allclose(result.pose, q, atol=1e-9)
    assert result.residual <= 1e-12


def test_central_configuration_needs_no_iteration():
    result = forward_kinematics(MODEL, MODEL.central.length)
    assert result.status == 'ok' and result.iterations == 0
    np.testing.assert_array_equal(result.pose, 0.0)


@pytest.mark.parametrize('lengths', [[3.0, 3.0, 3.0], [1.0, 1.0, 1.0], [1.14, 2.5, 0.6]])
def test_lengths_outside_the_workspace_are_unreachable(lengths):
    result = forward_kinematics(MODEL, lengths)
    assert result.status == Status.UNREACHABLE, result
    assert 'loop' in result.detail and np.all(result.pose == 0.0)


def test_status_string_form_is_its_name():
    assert str(Status.NEAR_SINGULAR) == 'near_singular' and Status('limit') is Status.LIMIT


@pytest.mark.skipif(not kernel.available(), reason='kernel not built (FSD_REQUIRE_KERNEL=0)')
def test_the_kernels_lengths_find_the_python_codes_pose():
    """L(q) and J_L by the solver's kernel (when enabled) or by the Python code:
    the same status and pose, on lengths of poses across the workspace (one
    that needs the continuation) and on lengths no pose has (after the seeds)."""
    rng = np.random.default_rng(7)
    q = np.column_stack([rng.uniform(-0.3, 0.3, 8), rng.uniform(-0.3, 0.8, 8),
                         rng.uniform(-1.0, 1.0, 8)])
    q = np.vstack([q, [(0.2, -0.2, 0.8)]])        # found by the continuation
    sol = fsd.solve_batch(MODEL, q, np.zeros_like(q), np.zeros_like(q))
    cases = [list(L) for L in sol.length[sol.status != Status.UNREACHABLE]]
    cases.append([3.0, 3.0, 3.0])
    statuses = set()
    for lengths in cases:
        with core_kernel.use_kernel(True):
            fast = forward_kinematics(MODEL, lengths)
        with core_kernel.use_kernel(False):
            slow = forward_kinematics(MODEL, lengths)
        assert fast.status == slow.status, (lengths, fast, slow)
        np.testing.assert_allclose(fast.pose, slow.pose, atol=1e-10)
        statuses.add(fast.status)
    assert {Status.OK, Status.UNREACHABLE} <= statuses
