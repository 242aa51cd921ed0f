"""The hexapod's forward dynamics: f = M qdd + b, solve(forward_dynamics(f))
gives f back, the mass matrix is the kinetic energy's, and bad inputs get a
status."""
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import stewart_reference as sr
from flight_sim_dynamics.core.effects import Effects
from flight_sim_dynamics.core.status import Status
from flight_sim_dynamics.machines.stewart import forward_dynamics as fdyn
from flight_sim_dynamics.machines.stewart import solver

from stewart_cases import MACHINES, model_of, random_motion

NAMES = sorted(MACHINES)


@pytest.mark.parametrize('name', NAMES)
@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2 ** 32 - 1), kind=st.sampled_from(['gentle', 'violent']),
       friction=st.booleans())
def test_solve_of_forward_dynamics_gives_the_forces_back(name, seed, kind, friction):
    model = model_of(name).with_effects(Effects(friction=friction))
    q, qd, qdd = (a[0] for a in random_motion(seed, kind, n=1))
    f = solver.solve(model, q, qd, qdd).force
    fd = fdyn.forward_dynamics(model, q, qd, f)
    assert fd.status in (Status.OK, Status.LIMIT), fd.detail
    np.testing.assert_allclose(fd.acceleration, qdd, rtol=1e-8, atol=1e-8 * np.abs(qdd).max())
    np.testing.assert_allclose(solver.solve(model, q, qd, fd.acceleration).force, f, rtol=0,
                               atol=1e-9 * np.abs(f).max())


@pytest.mark.parametrize('name', NAMES)
def test_the_forces_are_affine_in_the_accelerations(name):
    model = model_of(name)
    q, qd, qdd = (a[0] for a in random_motion(3, 'violent', n=1))
    terms = fdyn.affine_terms(model, q, qd)
    f = solver.solve(model, q, qd, qdd).force
    np.testing.assert_allclose(terms.M @ qdd + terms.b, f, rtol=0, atol=1e-9 * np.abs(f).max())
    np.testing.assert_allclose(terms.b, solver.solve(model, q, qd, np.zeros(6)).force)


@pytest.mark.parametrize('name', NAMES)
def test_the_mass_matrix_is_the_kinetic_energys(name):
    """J_L^T M (S22) is symmetric, positive definite, and qd^T (J_L^T M) qd / 2 = T."""
    model = model_of(name)
    reference = sr.machine_from_dict(MACHINES[name])
    q, qd, _ = random_motion(4, 'violent', n=8)
    for qi, qdi in zip(q, qd):
        mass = fdyn.affine_terms(model, qi, qdi).mass_matrix
        np.testing.assert_allclose(mass, mass.T, rtol=0, atol=1e-10 * np.abs(mass).max())
        assert np.linalg.eigvalsh(mass)[0] > 0.0
        T = sr.energy(reference, qi, qdi)[0]
        assert 0.5 * qdi @ mass @ qdi == pytest.approx(T, rel=1e-10)


def test_rest_forces_hold_the_platform_still():
    model = model_of('stewart_6dof')
    zero = np.zeros(6)
    fd = fdyn.forward_dynamics(model, zero, zero, solver.solve(model, zero, zero, zero).force)
    assert fd.status is Status.OK
    np.testing.assert_allclose(fd.acceleration, 0.0, atol=1e-12)


@pytest.mark.parametrize('force, match', [([math.nan] + [0.0] * 5, r'force\[0\]'),
                                          ([0.0] * 5 + [math.inf], r'force\[5\]')])
def test_non_finite_forces_are_invalid_input(force, match):
    fd = fdyn.forward_dynamics(model_of('stewart_6dof'), np.zeros(6), np.zeros(6), force)
    assert fd.status is Status.INVALID_INPUT and np.all(fd.acceleration == 0.0)
    assert fd.detail.startswith(match.replace('\\', ''))


def test_unreachable_and_singular_poses_give_no_accelerations():
    model = model_of('stewart_6dof')
    q = np.zeros(6)
    q[:3] = model.base_joints[3] - model.home - model.platform_joints[3]   # leg 4 of length 0
    fd = fdyn.forward_dynamics(model, q, np.zeros(6), np.full(6, 100.0))
    assert fd.status is Status.UNREACHABLE and np.all(fd.acceleration == 0.0)
    flat = fdyn.forward_dynamics(model, [0, 0, -1.0, 0, 0, 0], np.zeros(6), np.full(6, 100.0))
    assert flat.status is Status.NEAR_SINGULAR and np.all(flat.acceleration == 0.0)
    nan_pose = fdyn.forward_dynamics(model, [math.nan] * 6, np.zeros(6), np.full(6, 100.0))
    assert nan_pose.status is Status.INVALID_INPUT and np.all(nan_pose.acceleration == 0.0)


def test_pitch_at_ninety_degrees_cannot_resolve_euler_accelerations():
    fd = fdyn.forward_dynamics(model_of('stewart_6dof'), [0, 0, 0.2, 0, np.pi / 2, 0],
                               np.zeros(6), np.full(6, 300.0))
    assert fd.status is Status.NEAR_SINGULAR and np.all(fd.acceleration == 0.0)


@pytest.mark.parametrize('effects', [Effects().only('gravity'),
                                     Effects().only('gravity', 'crank_inertia', 'payload')],
                         ids=['gravity', 'no_hexapod_body_moves'])
def test_a_scene_without_inertia_is_refused(effects):
    """A hexapod has no cranks, and the default payload has no mass."""
    model = model_of('stewart_6dof').with_effects(effects, 'quasi_static')
    with pytest.raises(ValueError, match='quasi_static'):
        fdyn.forward_dynamics(model, np.zeros(6), np.zeros(6), np.zeros(6))


def test_arguments_that_are_not_six_numbers_are_refused():
    with pytest.raises(ValueError, match='force'):
        fdyn.forward_dynamics(model_of('stewart_6dof'), np.zeros(6), np.zeros(6), [1.0] * 5)
