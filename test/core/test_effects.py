"""Effects and scenes: superposition, per-scene power balance, skipped work,
scene files (issue 4)."""
import itertools

import numpy as np
import pytest
import yaml

import flight_sim_dynamics as fsd
import reference_model as ref
from flight_sim_dynamics.config.scenes import SceneError, load_scene
from flight_sim_dynamics.core.effects import EFFECT_NAMES, Effects
from flight_sim_dynamics.machines.staicu import dynamics
from flight_sim_dynamics.machines.staicu.trajectories import paper_example

FULL = fsd.load_model()
GROUPS = ('gravity', 'platform_inertia', 'leg_inertia', 'crank_inertia')


def _violent(n=40, seed=3):
    """Random states with large rates and accelerations (motion-cueing-like)."""
    rng = np.random.default_rng(seed)
    q = rng.uniform([-0.05, -0.08, -0.25], [0.05, 0.08, 0.25], size=(n, 3))
    qd = rng.normal(scale=[0.5, 0.5, 1.5], size=(n, 3))
    qdd = rng.normal(scale=[20.0, 20.0, 20.0], size=(n, 3))
    return q, qd, qdd


def _force(effects, q, qd, qdd, model=FULL):
    return fsd.solve_batch(model.with_effects(effects), q, qd, qdd).force


@pytest.mark.parametrize('vp', [True, False])
def test_single_effects_sum_to_the_full_model(vp):
    """f = g(q) + M_platform qdd + M_legs qdd + M_cranks qdd (+ C qd with velocity
    products): each effect alone, summed, gives the model with all of them."""
    q, qd, qdd = _violent()
    extra = ('velocity_products',) if vp else ()
    total = sum(_force(Effects().only(name, *extra), q, qd, qdd) for name in GROUPS)
    full = _force(Effects().only(*GROUPS, *extra), q, qd, qdd)
    np.testing.assert_allclose(total, full, rtol=1e-12, atol=1e-9 * np.abs(full).max())


@pytest.mark.parametrize('a, b', list(itertools.combinations(GROUPS, 2)))
def test_pairs_superpose(a, b):
    q, qd, qdd = _violent(12)
    for extra in ((), ('velocity_products',)):
        pair = _force(Effects().only(a, b, *extra), q, qd, qdd)
        alone = _force(Effects().only(a, *extra), q, qd, qdd) + \
            _force(Effects().only(b, *extra), q, qd, qdd)
        np.testing.assert_allclose(pair, alone, rtol=1e-12, atol=1e-9 * np.abs(pair).max())


def test_velocity_products_superpose_across_bodies_but_not_alone():
    """The centrifugal/Coriolis part is C(q, qd) qd of the bodies with inertia: it
    adds up across body groups, and alone (no inertia) it is nothing."""
    q, qd, qdd = _violent(12)
    part = [(_force(Effects().only(g, 'velocity_products'), q, qd, qdd)
             - _force(Effects().only(g), q, qd, qdd)) for g in GROUPS[1:]]
    full_part = (_force(Effects(), q, qd, qdd)
                 - _force(Effects().without('velocity_products'), q, qd, qdd))
    np.testing.assert_allclose(sum(part), full_part, rtol=1e-11,
                               atol=1e-9 * np.abs(full_part).max())
    assert np.abs(full_part).max() > 1.0       # it is not negligible in a violent motion
    np.testing.assert_array_equal(_force(Effects().only('velocity_products'), q, qd, qdd), 0.0)


def test_friction_adds_its_own_law():
    q, qd, qdd = _violent(12)
    model = FULL.with_effects(Effects(friction=True))
    sol = fsd.solve_batch(model, q, qd, qdd)
    fr = FULL.friction
    expected = (np.array(fr.viscous) * sol.rate
                + np.array(fr.coulomb) * np.tanh(sol.rate / fr.smoothing_velocity))
    np.testing.assert_allclose(sol.force - _force(Effects(), q, qd, qdd), expected,
                               rtol=1e-12, atol=1e-9)


def test_payload_scene_adds_the_payload_weight_and_inertia():
    q, qd, qdd = _violent(12)
    payload = fsd.load_model(scene='payload')
    assert payload.effects.payload and payload.scene == 'payload'
    added = fsd.solve_batch(payload, q, qd, qdd).force - _force(Effects(), q, qd, qdd)
    # the payload's part: (payload + gravity) minus gravity, both with velocity products
    part = (_force(Effects().only('payload', 'gravity', 'velocity_products'), q, qd, qdd)
            - _force(Effects().only('gravity'), q, qd, qdd))
    np.testing.assert_allclose(added, part, rtol=1e-11, atol=1e-9 * np.abs(part).max())
    # at rest it is the static weight of 140 kg: far above the bare machine's 100 N
    rest = fsd.solve(payload, [0, 0, 0], [0, 0, 0], [0, 0, 0]).force
    assert rest.sum() > 1000.0


# --- power balance inside each scene -------------------------------------------------
def _scene_energy_rate(params, effects, q, qd, qdd):
    """d/dt (kinetic energy of the bodies whose inertia the scene simulates +
    potential energy of every body, if gravity), from the independent reference."""
    geo = ref._geometry(params, ref._pose_jet(q, qd, qdd, order=2))
    bodies = list(geo['bodies'])
    if effects.payload:
        platform = next(b for b in bodies if b[0] == 'platform')
        bodies.append(('payload', platform[1], platform[2]))
    geo = dict(geo, bodies=bodies)
    inertial = dynamics.inertial_bodies(effects)
    rate = 0.0
    for name, m, com, omega, Iw in ref._body_motion(params, geo):
        v = com.d(1)
        if name in inertial:
            eps = omega.d(1)
            w = omega.d(0)
            rate = rate + m * np.sum(v * com.d(2), axis=-1) + np.einsum(
                '...i,...ij,...j->...', w, Iw.d(0), eps)
        if effects.gravity:
            rate = rate + m * params['gravity'] * v[..., 1]
    return rate


@pytest.mark.parametrize('scene', ['full', 'quasi_static', 'platform_only', 'payload'])
def test_power_balance_inside_each_scene(scene):
    model = fsd.load_model(scene=scene)
    params = ref.load_reference_params()
    params['bodies']['payload'] = {'mass': model.payload.mass, 'com': model.payload.com,
                                   'inertia': model.payload.inertia}
    q, qd, qdd = paper_example('general', np.linspace(0.0, 3.0, 61))
    vq, vqd, vqdd = _violent(30)
    q, qd, qdd = (np.vstack(p) for p in ((q, vq), (qd, vqd), (qdd, vqdd)))
    power = fsd.solve_batch(model, q, qd, qdd).power.sum(axis=1)
    effects = model.effects
    if not effects.velocity_products:
        # forces of the same accelerations from rest: the balance holds for the
        # potential energy alone when no inertia is simulated (quasi-static)
        assert not effects.any_inertia
    expected = _scene_energy_rate(params, effects, q, qd, qdd)
    scale = np.maximum(np.abs(expected), 1.0)
    np.testing.assert_array_less(np.abs(power - expected) / scale, 1e-9, err_msg=scene)


# --- skipped work ----------------------------------------------------------------------
def test_disabled_effects_are_not_computed():
    """Structural check that skipped effects are skipped: no motion is computed
    for a body without inertia, no body at all without weight or inertia."""
    from flight_sim_dynamics.machines.staicu.kinematics import (factorize, inverse_geometry,
                                                                pose_rate_columns)
    from flight_sim_dynamics.machines.staicu.kinematics import solve_connectivity
    from flight_sim_dynamics.core.vectors import backend

    def states(effects):
        model = FULL.with_effects(effects)
        g = inverse_geometry(model, (0.01, 0.02, 0.1), backend(False))
        V = solve_connectivity(g, factorize(model, g), pose_rate_columns(g)[0])
        return dynamics.body_states(model, g, V, V, (1.0, 0.0, 0.0), (0.0, 0.0, 0.0))

    quasi = states(Effects().only('gravity'))
    assert set(quasi) == set(FULL.bodies) and all(s.acc is None for s in quasi.values())
    platform = states(Effects().only('platform_inertia'))
    assert set(platform) == {'platform'} and platform['platform'].acc is not None
    assert states(Effects().only('velocity_products')) == {}


# --- scene files ---------------------------------------------------------------------
def test_packaged_scenes():
    from flight_sim_dynamics.config.scenes import available_scenes
    assert {'full', 'quasi_static', 'platform_only', 'payload'} <= set(available_scenes())
    assert load_scene('full').effects == Effects()
    assert load_scene('quasi_static').effects == Effects().only('gravity')
    assert fsd.load_model(scene=None).scene == 'full'


def _scene_file(tmp_path, doc):
    path = tmp_path / 'my_scene.yaml'
    path.write_text(yaml.safe_dump(doc))
    return path


def _effects(**changes):
    effects = {name: True for name in EFFECT_NAMES}
    effects.update(changes)
    return effects


@pytest.mark.parametrize('doc, words', [
    ({'effects': _effects(turbulence=True)}, ('my_scene', 'turbulence')),
    ({'effects': {'gravity': True}}, ('my_scene', 'platform_inertia', 'friction')),
    ({'effects': _effects(gravity='yes')}, ('my_scene', 'gravity', 'yes')),
    ({'description': 'x'}, ('my_scene', 'effects')),
    ({'effects': _effects(), 'colour': 'red'}, ('my_scene', 'colour')),
    ({'effects': _effects(), 'parameters': {'payload': {'mass': -3.0}}},
     ('payload.mass', '-3')),
    ({'effects': _effects(), 'parameters': {'qos': {'depth': 5}}}, ('my_scene', 'qos.depth')),
    ([1, 2], ('my_scene', 'effects')),
])
def test_bad_scene_is_an_error_that_names_it(tmp_path, doc, words):
    """The error names the scene and what is wrong in it (key or value)."""
    with pytest.raises((SceneError, fsd.ParameterError)) as info:
        fsd.load_model(scene=_scene_file(tmp_path, doc))
    assert all(w in str(info.value) for w in words), (words, str(info.value))


def test_unknown_scene_name_lists_the_available_ones():
    from flight_sim_dynamics.config.scenes import available_scenes
    with pytest.raises(SceneError) as info:
        fsd.load_model(scene='turbulence')
    assert all(w in str(info.value) for w in ('turbulence', *available_scenes())), info.value


def test_user_scene_file_with_parameter_overrides(tmp_path):
    path = _scene_file(tmp_path, {'description': 'heavy cab',
                                  'effects': _effects(friction=False),
                                  'parameters': {'payload': {'mass': 200.0}}})
    model = fsd.load_model(scene=path)
    assert model.scene == 'my_scene' and model.payload.mass == 200.0
