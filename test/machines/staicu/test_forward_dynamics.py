"""Forward dynamics (flight_sim_dynamics.machines.staicu.forward_dynamics): the
accelerations that given forces produce, from the inverse dynamics being
affine in the accelerations (f = M qdd + b).

* property over the workspace (the samples of test_workspace_properties.py,
  forces drawn up to the actuators' limit): for every sample whose status is
  ok or limit, ``solve(q, qd, forward_dynamics(q, qd, f).acceleration).force``
  is f to 1e-9 relative (to max(|f|, |b|, 1 N)), and the independent
  reference model (test/reference/reference_model.py) agrees on those forces too;
  every status is solve's, no NaN ever, zeros where the status is void;
* the statuses of bad input, unreachable poses and singularities;
* a scene without inertia is a clear error naming the scene.
(The energy test is in test_simulation.py: it needs the integrator.)
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import flight_sim_dynamics as fsd
import reference_model as rm
from flight_sim_dynamics import Status
from flight_sim_dynamics.machines.staicu import forward_dynamics as fd_module
from flight_sim_dynamics.machines.staicu.model import Friction
from test_workspace_properties import batches, examples, tolerance_factor

MODEL = fsd.load_model()
PARAMS = rm.load_reference_params()
RTOL = 1e-9
VOID = (Status.UNREACHABLE, Status.INVALID_INPUT, Status.NEAR_SINGULAR)


def assert_finite(result) -> None:
    for name in ('acceleration', 'M', 'b'):
        assert np.all(np.isfinite(getattr(result, name))), (name, result)


@settings(max_examples=examples(0.5), report_multiple_bugs=False)
@given(batches(), st.integers(0, 2**32 - 1))
def test_forward_dynamics_inverts_solve_over_the_workspace(batch, seed):
    q, qd, _ = batch
    force = np.random.default_rng(seed).uniform(-1.0, 1.0, q.shape) * MODEL.limits.max_force
    checked = []
    for i in range(len(q)):
        result = fsd.forward_dynamics(MODEL, q[i], qd[i], force[i])
        base = fsd.solve(MODEL, q[i], qd[i], (0.0, 0.0, 0.0))
        where = f'q={q[i].tolist()} qd={qd[i].tolist()} f={force[i].tolist()}'
        assert_finite(result)
        if base.status in (Status.UNREACHABLE, Status.NEAR_SINGULAR):
            assert result.status == base.status and result.detail == base.detail, where
        if result.status in VOID:
            assert np.all(result.acceleration == 0.0), where
            continue
        assert result.status in (Status.OK, Status.LIMIT), where
        sol = fsd.solve(MODEL, q[i], qd[i], result.acceleration)
        assert result.status == sol.status and result.detail == sol.detail, where
        scale = max(np.abs(force[i]).max(), np.abs(result.b).max(), 1.0)
        allowed = RTOL * tolerance_factor(max(sol.kinematic_condition, sol.jacobian_condition))
        assert np.abs(sol.force - force[i]).max() <= allowed * scale, (where, sol.force)
        checked.append(i)
    if checked:     # an independent method (virtual power, test/reference/reference_model.py)
        results = [fsd.forward_dynamics(MODEL, q[i], qd[i], force[i]) for i in checked]
        acc = np.array([r.acceleration for r in results])
        with np.errstate(all='ignore'):
            ref = rm.reference_solve(PARAMS, q[checked], qd[checked], acc)
        # relative to max(|f|, |b|, 1 N), as above: f = M qdd + b cancels
        # terms of up to 1e7 N at the fastest rates drawn
        scale = np.maximum(np.maximum(np.abs(force[checked]).max(axis=1),
                                      np.array([np.abs(r.b).max() for r in results])), 1.0)
        error = np.abs(ref['force'] - force[checked]).max(axis=1) / scale
        assert np.all(error <= 1e-8), (error.max(), q[checked][np.argmax(error)])


def test_m_and_b_are_the_affine_terms_and_the_leg_space_mass_is_symmetric():
    q, qd = (0.02, 0.1, 0.2), (0.1, -0.2, 0.3)
    M, b, base = fd_module.affine_terms(MODEL, q, qd)
    np.testing.assert_array_equal(b, base.force)
    qdd = np.array([1.5, -2.0, 3.0])
    np.testing.assert_allclose(M @ qdd + b, fsd.solve(MODEL, q, qd, qdd).force, rtol=1e-12)
    # M J^-1 = J^-T M_q J^-1 is the leg-space mass matrix: symmetric positive definite
    mass = np.linalg.solve(base.jacobian.T, M.T).T
    np.testing.assert_allclose(mass, mass.T, rtol=1e-10, atol=1e-12)
    assert np.all(np.linalg.eigvalsh(0.5 * (mass + mass.T)) > 0)


def test_gravity_only_scene_cannot_be_simulated():
    model = fsd.load_model(scene='quasi_static')
    with pytest.raises(ValueError, match="scene 'quasi_static' computes no inertia"):
        fsd.forward_dynamics(model, (0, 0, 0), (0, 0, 0), (0, 0, 0))


def test_bad_input_gives_invalid_input_and_zeros():
    result = fsd.forward_dynamics(MODEL, (0, float('nan'), 0), (0, 0, 0), (1, 2, 3))
    assert result.status == Status.INVALID_INPUT and 'q[1] (heave)' in result.detail
    assert np.all(result.acceleration == 0.0)
    assert_finite(result)
    result = fsd.forward_dynamics(MODEL, (0, 0, 0), (0, 0, 0), (1, float('inf'), 3))
    assert result.status == Status.INVALID_INPUT and result.detail.startswith('force[1] (leg B)')
    assert np.all(result.acceleration == 0.0)
    result = fsd.forward_dynamics(MODEL, (0, 0, 0), (0, 0, 0), (1e308, -1e308, 1e308))
    assert result.status == Status.INVALID_INPUT, result
    assert_finite(result)


@pytest.mark.parametrize('force', ['abc', (1, 2), None, ((1, 2, 3),), (1, 2, 3, 4)])
def test_force_that_is_not_three_numbers_raises(force):
    with pytest.raises(ValueError, match='force must be 3 numbers'):
        fsd.forward_dynamics(MODEL, (0, 0, 0), (0, 0, 0), force)


def test_q_that_is_not_three_numbers_raises_as_in_solve():
    with pytest.raises(ValueError, match='q must be 3 numbers'):
        fsd.forward_dynamics(MODEL, (0, 0), (0, 0, 0), (0, 0, 0))


def test_unreachable_pose_gives_unreachable_and_zeros():
    result = fsd.forward_dynamics(MODEL, (0, -0.8, 0), (0, 0, 0), (100, 100, 100))
    assert result.status == Status.UNREACHABLE and result.detail.startswith('loop ')
    for name in ('acceleration', 'M', 'b'):
        assert np.all(getattr(result, name) == 0.0)


def test_near_singular_pose_gives_near_singular_and_zero_accelerations():
    q = (0.0, 0.0, 1.06)        # the roll singularity of the actuator Jacobian
    assert fsd.solve(MODEL, q, (0, 0, 0), (0, 0, 0)).status == Status.NEAR_SINGULAR
    result = fsd.forward_dynamics(MODEL, q, (0, 0, 0), (10, 20, 30))
    assert result.status == Status.NEAR_SINGULAR and 'condition' in result.detail
    assert np.all(result.acceleration == 0.0)
    assert_finite(result)


def test_ill_conditioned_m_is_refused_not_solved():
    M = np.diag([1.0, 1.0, 1e-9])
    qdd, status, detail = fd_module.solve_accelerations(M, np.zeros(3), np.ones(3))
    assert status == Status.NEAR_SINGULAR and np.all(qdd == 0.0)
    assert detail.startswith('condition of M 1e+09 >')
    qdd, status, detail = fd_module.solve_accelerations(np.zeros((3, 3)), np.zeros(3), np.ones(3))
    assert status == Status.NEAR_SINGULAR and 'condition of M inf' in detail
    assert np.all(qdd == 0.0)
    qdd, status, detail = fd_module.solve_accelerations(np.eye(3), np.zeros(3), np.ones(3) * 1e308)
    assert status == Status.OK and qdd.tolist() == [1e308] * 3     # finite: solved
    qdd, status, detail = fd_module.solve_accelerations(np.eye(3) * 1e-300, np.zeros(3),
                                                        np.ones(3) * 1e300)
    assert status == Status.INVALID_INPUT and np.all(qdd == 0.0)
    qdd, status, detail = fd_module.solve_accelerations(np.eye(3), np.zeros(3),
                                                        np.array([1., 2., 3.]))
    assert status == Status.OK and detail == '' and qdd.tolist() == [1.0, 2.0, 3.0]


def test_limit_status_names_the_force_given():
    rest = fsd.solve(MODEL, (0, 0, 0), (0, 0, 0), (0, 0, 0)).force
    force = rest + np.array([3000.0, 0.0, 0.0])
    result = fsd.forward_dynamics(MODEL, (0, 0, 0), (0, 0, 0), force)
    assert result.status == Status.LIMIT and 'force A' in result.detail
    assert np.abs(result.acceleration).max() > 100.0


def test_friction_is_in_b_when_the_scene_has_it():
    friction = Friction(viscous=(100.0, 120.0, 140.0), coulomb=(20.0, 30.0, 40.0))
    model = replace(MODEL.with_effects(replace(MODEL.effects, friction=True)), friction=friction)
    q, qd = (0.0, 0.1, 0.0), (0.05, 0.2, -0.1)
    M, b, _ = fd_module.affine_terms(model, q, qd)
    M0, b0, _ = fd_module.affine_terms(MODEL, q, qd)
    np.testing.assert_allclose(M, M0, rtol=1e-12, atol=1e-12)   # friction: rates only
    assert np.abs(b - b0).min() > 10.0
    force = b + np.array([5.0, -5.0, 5.0])
    result = fsd.forward_dynamics(model, q, qd, force)
    np.testing.assert_allclose(fsd.solve(model, q, qd, result.acceleration).force, force,
                               rtol=1e-12)
