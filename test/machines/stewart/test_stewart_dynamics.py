"""The hexapod's inverse dynamics (S14)-(S23): the check values of
stewart.md, agreement with the independent reference
(test/reference/stewart_reference.py: pinocchio's rnea on the open tree,
Lagrange's equations), the power balance, and the effects of a scene."""
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import stewart_reference as sr
from flight_sim_dynamics.core.effects import Effects
from flight_sim_dynamics.core.kernel import use_kernel
from flight_sim_dynamics.machines.stewart import dynamics, solver
from flight_sim_dynamics.machines.stewart import model as sm

from stewart_cases import (FULL, MACHINES, doc_static_forces, doc_tsai_peaks, model_of,
                           random_motion)

NAMES = sorted(MACHINES)
RTOL = 1e-9                         # agreement with the reference, relative to the sample
REFERENCE = {name: sr.PinocchioHexapod(sr.machine_from_dict(MACHINES[name])) for name in NAMES}
ZERO = np.zeros((1, 6))


def relative(a, b):
    """Per sample max |a - b| over the legs, relative to the sample's largest |b|."""
    return np.abs(a - b).max(axis=-1) / np.maximum(np.abs(b).max(axis=-1), 1e-300)


def _forces(model, q, qd, qdd):
    sol = solver.solve_batch(model, q, qd, qdd)
    assert all(str(s) in ('ok', 'limit') for s in sol.status), sol.detail
    return sol.force


# ---------------------------------------------------------------------------
# check values
# ---------------------------------------------------------------------------

def test_static_forces_at_home_are_the_check_values():
    doc = doc_static_forces()
    model = model_of('stewart_6dof')
    np.testing.assert_allclose(_forces(model, ZERO, ZERO, ZERO)[0], doc['full'], rtol=0,
                               atol=1e-6)
    heavy = model.with_payload(doc['payload_mass'], doc['payload_com']).with_effects(
        Effects(payload=True), 'payload')
    np.testing.assert_allclose(_forces(heavy, ZERO, ZERO, ZERO)[0], doc['payload'], rtol=0,
                               atol=1e-6)
    # a payload's inertia tensor does not act at rest
    spinning = model.with_payload(doc['payload_mass'], doc['payload_com'],
                                  [5, 0, 1, 0, 7, 0, 1, 0, 9]).with_effects(Effects(payload=True))
    np.testing.assert_allclose(_forces(spinning, ZERO, ZERO, ZERO)[0], doc['payload'], rtol=0,
                               atol=1e-6)
    # the payload is the payload effect's: off, the same model needs the forces of scene full
    np.testing.assert_allclose(_forces(heavy.with_effects(FULL), ZERO, ZERO, ZERO)[0],
                               doc['full'], rtol=0, atol=1e-6)


def _tsai_motion(k, t, omega=3.0):
    """Tsai's motion k of stewart.md (1: surge = sway = heave = 0.2 sin wt,
    2: yaw = pi/6 sin wt, 3: surge = 0.2 sin wt, 4: at rest)."""
    q, qd, qdd = (np.zeros((t.size, 6)) for _ in range(3))
    cols, amp = {1: ([0, 1, 2], 0.2), 2: ([5], np.pi / 6), 3: ([0], 0.2), 4: ([], 0.0)}[k]
    for j in cols:
        q[:, j] = amp * np.sin(omega * t)
        qd[:, j] = amp * omega * np.cos(omega * t)
        qdd[:, j] = -amp * omega ** 2 * np.sin(omega * t)
    return q, qd, qdd


@pytest.mark.parametrize('k, peaks', sorted(doc_tsai_peaks().items()))
def test_tsai_motions_peak_forces_are_the_documented_ones(k, peaks):
    model = model_of('stewart_tsai2000')
    t = np.linspace(0.0, 2.0 * np.pi / 3.0, 121)
    f = _forces(model, *_tsai_motion(k, t))
    np.testing.assert_allclose(np.abs(f).max(axis=0), peaks, rtol=0, atol=1e-6)


# ---------------------------------------------------------------------------
# agreement with the independent reference, power balance
# ---------------------------------------------------------------------------

def _payload_model(name):
    """The machine with an off-centre payload of full inertia, and its reference dict."""
    com, inertia = (0.1, -0.05, 0.4), (6.0, 0.5, -0.3, 0.5, 8.0, 0.2, -0.3, 0.2, 9.0)
    mass = 80.0 if name == 'stewart_6dof' else 0.7
    model = model_of(name).with_payload(mass, com, inertia).with_effects(Effects(payload=True))
    return model, sr.with_payload(MACHINES[name], mass, com, inertia)


@pytest.mark.parametrize('name', NAMES)
@pytest.mark.parametrize('payload', [False, True], ids=['full', 'payload'])
@settings(max_examples=15, deadline=None)
@given(seed=st.integers(0, 2 ** 32 - 1), kind=st.sampled_from(['gentle', 'violent']))
def test_forces_agree_with_the_reference(name, payload, seed, kind):
    q, qd, qdd = random_motion(seed, kind, n=6)
    if payload:
        model, d = _payload_model(name)
        reference = sr.forces_pinocchio(sr.machine_from_dict(d), q, qd, qdd)
    else:
        model = model_of(name)
        reference = sr.forces_pinocchio(REFERENCE[name], q, qd, qdd)
    assert relative(_forces(model, q, qd, qdd), reference).max() < RTOL


@pytest.mark.parametrize('name', NAMES)
def test_forces_agree_with_lagrange_on_a_long_violent_batch(name):
    q, qd, qdd = random_motion(11, 'violent', n=200)
    f = _forces(model_of(name), q, qd, qdd)
    err = relative(f, sr.forces_lagrange(sr.machine_from_dict(MACHINES[name]), q, qd, qdd))
    print(f'\n{name}: max relative error vs Lagrange {err.max():.2e}')
    assert err.max() < RTOL


@pytest.mark.parametrize('name', NAMES)
@settings(max_examples=15, deadline=None)
@given(seed=st.integers(0, 2 ** 32 - 1), kind=st.sampled_from(['gentle', 'violent']))
def test_power_balance(name, seed, kind):
    """sum f_i dL_i/dt = d(T + V)/dt (S23), friction off."""
    q, qd, qdd = random_motion(seed, kind, n=6)
    sol = solver.solve_batch(model_of(name), q, qd, qdd)
    power = sol.power.sum(axis=-1)
    dE = sr.energy_rate(sr.machine_from_dict(MACHINES[name]), q, qd, qdd)
    scale = np.maximum(np.maximum(np.abs(sol.power).sum(axis=-1), np.abs(dE)), 1.0)
    assert (np.abs(power - dE) / scale).max() < RTOL


def test_the_legs_spin_about_their_axis_matters():
    """Dropping sigma_i (S9) changes the forces by inertia_along's share; the
    reference, with the spin, agrees with the model that has it."""
    q, qd, qdd = random_motion(5, 'violent', n=10)
    params = MACHINES['stewart_6dof']
    no_spin = {**params, 'bodies': {**params['bodies'],
                                    'cylinder': {**params['bodies']['cylinder'],
                                                 'inertia_along': 0.0},
                                    'rod': {**params['bodies']['rod'], 'inertia_along': 0.0}}}
    f = _forces(model_of('stewart_6dof'), q, qd, qdd)
    f_no_spin = _forces(sm.from_dict(no_spin), q, qd, qdd)
    assert relative(f_no_spin, f).max() > 1e-6
    assert relative(f, sr.forces_pinocchio(REFERENCE['stewart_6dof'], q, qd, qdd)).max() < RTOL


def test_base_axes_do_not_act_on_legs_without_axial_inertia():
    """With inertia_along = 0 (Tsai's legs) the U-joints' first axes drop out (S20)."""
    q, qd, qdd = random_motion(6, 'violent', n=10)
    params = MACHINES['stewart_tsai2000']
    tilted = {**params, 'geometry': {**params['geometry'], 'base_axes': [0.6, 0.0, 0.8] * 6}}
    f = _forces(model_of('stewart_tsai2000'), q, qd, qdd)
    np.testing.assert_allclose(_forces(sm.from_dict(tilted), q, qd, qdd), f, rtol=0,
                               atol=1e-12 * np.abs(f).max())


# ---------------------------------------------------------------------------
# effects
# ---------------------------------------------------------------------------

#: Effects that superpose (the payload's weight needs both payload and gravity).
GROUPS = ('gravity', 'platform_inertia', 'leg_inertia')


@pytest.mark.parametrize('name', NAMES)
@pytest.mark.parametrize('vp', [True, False], ids=['velocity_products', 'from_rest'])
def test_single_effects_sum_to_the_full_model(name, vp):
    model = model_of(name)
    q, qd, qdd = random_motion(7, 'violent', n=20)
    extra = ('velocity_products',) if vp else ()

    def force(*names):
        return solver.solve_batch(model.with_effects(Effects().only(*names, *extra)),
                                  q, qd, qdd).force

    total = sum(force(g) for g in GROUPS)
    full = force(*GROUPS)
    np.testing.assert_allclose(total, full, rtol=0, atol=1e-12 * np.abs(full).max())
    assert all(np.abs(force(g)).max() > 1e-3 * np.abs(full).max() for g in GROUPS)


@pytest.mark.parametrize('name', NAMES)
def test_without_velocity_products_the_forces_are_those_from_rest(name):
    model = model_of(name)
    q, qd, qdd = random_motion(8, 'violent', n=20)
    off = solver.solve_batch(model.with_effects(Effects(velocity_products=False)), q, qd, qdd)
    rest = solver.solve_batch(model, q, np.zeros_like(qd), qdd)
    np.testing.assert_allclose(off.force, rest.force, rtol=1e-12, atol=1e-9)
    on = solver.solve_batch(model, q, qd, qdd)
    assert relative(off.force, on.force).max() > 1e-3
    np.testing.assert_array_equal(off.rate, on.rate)    # the kinematics are the motion's


def test_friction_adds_viscous_and_smoothed_coulomb_terms():
    params = MACHINES['stewart_6dof']
    friction = {'viscous': [10.0, 20.0, 30.0, 40.0, 50.0, 60.0],
                'coulomb': [1.0, 2.0, 3.0, 4.0, 5.0, 6.0], 'smoothing_velocity': 0.01}
    model = sm.from_dict({**params, 'friction': friction})
    q, qd, qdd = random_motion(9, 'gentle', n=20)
    plain = solver.solve_batch(model, q, qd, qdd)
    rubbing = solver.solve_batch(model.with_effects(Effects(friction=True)), q, qd, qdd)
    expected = (np.array(friction['viscous']) * plain.rate
                + np.array(friction['coulomb']) * np.tanh(plain.rate / 0.01))
    np.testing.assert_allclose(rubbing.force - plain.force, expected, rtol=1e-12, atol=1e-9)


def _refuse(name):
    def fail(*args, **kwargs):
        raise AssertionError(f'{name} computed for a disabled effect')
    return fail


@pytest.mark.parametrize('effects, skipped', [
    (Effects(leg_inertia=False), ('leg_moment',)),
    (Effects(leg_inertia=False, gravity=False), ('leg_moment', 'leg_forces', 'carried_force')),
    (Effects(leg_inertia=False, gravity=False, platform_inertia=False),
     ('leg_moment', 'carried_force', 'rigid_body_wrench')),
    (Effects(payload=False), ()),
], ids=['no_leg_inertia', 'no_leg_terms', 'nothing', 'no_payload'])
def test_a_disabled_effect_is_skipped_not_multiplied_by_zero(monkeypatch, effects, skipped):
    """The numpy code (the kernel's: test_stewart_kernel.py)."""
    model = _payload_model('stewart_6dof')[0].with_effects(effects)
    for name in skipped:
        monkeypatch.setattr(dynamics, name, _refuse(name))
    monkeypatch.setattr(solver, 'friction_forces', _refuse('friction_forces'))
    q, qd, qdd = random_motion(10, 'gentle', n=4)
    with use_kernel(False):
        sol = solver.solve_batch(model, q, qd, qdd)
    assert np.all(np.isfinite(sol.force))


def test_the_payload_is_computed_only_when_its_effect_is_on(monkeypatch):
    """The numpy code (the kernel's: test_stewart_kernel.py)."""
    model = _payload_model('stewart_6dof')[0]
    bodies = []
    original = dynamics.rigid_body_wrench
    monkeypatch.setattr(dynamics, 'rigid_body_wrench',
                        lambda body, *a: bodies.append(body) or original(body, *a))
    q, qd, qdd = random_motion(10, 'gentle', n=4)
    with use_kernel(False):
        solver.solve_batch(model.with_effects(Effects(payload=False)), q, qd, qdd)
        assert bodies == [model.platform]
        bodies.clear()
        solver.solve_batch(model, q, qd, qdd)
    assert bodies == [model.platform, model.payload]


def test_one_singular_jacobian_does_not_fail_the_batch():
    J = np.stack([np.eye(6), np.zeros((6, 6)), 2.0 * np.eye(6)])
    f = dynamics.actuator_forces(J, np.ones((3, 6)))
    np.testing.assert_array_equal(f[0], 1.0)
    assert np.all(np.isnan(f[1]))
    np.testing.assert_array_equal(f[2], 0.5)
