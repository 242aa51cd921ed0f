"""The hexapod's model from the parameter-file layout: the machines of
stewart.md, and a clear ValueError naming the field for every bad number."""
import copy
import math

import numpy as np
import pytest

from flight_sim_dynamics.core.effects import Effects
from flight_sim_dynamics.machines.stewart import model as sm

from stewart_cases import MACHINES, doc_number, model_of


def _params(name='stewart_6dof'):
    return copy.deepcopy(MACHINES[name])


@pytest.mark.parametrize('name', sorted(MACHINES))
def test_the_documented_machines_load_with_their_numbers(name):
    params = _params(name)
    m = sm.from_dict(MACHINES[name])
    geo = params['geometry']
    np.testing.assert_array_equal(m.base_joints, np.reshape(geo['base_joints'], (6, 3)))
    np.testing.assert_array_equal(m.platform_joints, np.reshape(geo['platform_joints'], (6, 3)))
    np.testing.assert_allclose(m.base_axes, np.reshape(geo['base_axes'], (6, 3)), rtol=1e-15)
    np.testing.assert_array_equal(m.home, geo['home'])
    assert m.gravity == params['gravity'] and m.name == name and m.scene == params['scene']
    assert m.platform.mass == params['bodies']['platform']['mass']
    np.testing.assert_array_equal(m.platform.inertia.ravel(),
                                  params['bodies']['platform']['inertia'])
    assert m.cylinder == sm.LegBody(**params['bodies']['cylinder'])
    assert m.rod == sm.LegBody(**params['bodies']['rod'])
    assert m.limits.length_min == params['limits']['length_min']
    assert m.limits.u_joint_max_angle is None and m.limits.spherical_joint_max_angle is None


def test_default_machine_is_the_table_of_the_design_doc():
    """The joints of the file are the table's circles (r_b, theta_b; r_p, theta_p)."""
    m = model_of('stewart_6dof')
    r_b = doc_number(r'\| `r_b` \| ([\d.]+) \|')
    r_p = doc_number(r'\| `r_p` \| ([\d.]+) \|')
    np.testing.assert_allclose(np.linalg.norm(m.base_joints, axis=1), r_b, rtol=1e-15)
    np.testing.assert_allclose(np.linalg.norm(m.platform_joints, axis=1), r_p, rtol=1e-15)
    np.testing.assert_allclose(m.home_lengths, doc_number(r'At home every leg is `([\d.]+) m`'),
                               rtol=0, atol=1e-15)
    # first U axes tangent to the base circle, horizontal
    np.testing.assert_allclose(np.sum(m.base_axes * m.base_joints, axis=1), 0.0, atol=1e-15)
    np.testing.assert_allclose(m.base_axes[:, 2], 0.0)


def test_u_joint_frames_are_rotations_with_the_first_axis_first():
    for axes in (model_of('stewart_6dof').base_axes,
                 np.array([[0.0, 0.0, 1.0], [0.6, 0.0, 0.8]] * 3)):
        C = sm.u_joint_frames(axes)
        np.testing.assert_allclose(C @ np.swapaxes(C, 1, 2), np.broadcast_to(np.eye(3), C.shape),
                                   atol=1e-15)
        np.testing.assert_allclose(np.linalg.det(C), 1.0)
        np.testing.assert_allclose(C[:, :, 0], axes)


def test_payload_and_friction_may_be_left_out():
    params = _params()
    del params['payload'], params['friction']
    m = sm.from_dict(params)
    assert m.payload.mass == 0.0
    np.testing.assert_array_equal(m.friction.viscous, np.zeros(6))


def test_effects_scene_and_payload_are_replaced_not_mutated():
    m = model_of('stewart_6dof')
    heavy = m.with_payload(80.0, (0.0, 0.0, 0.5)).with_effects(Effects(payload=True), 'payload')
    assert heavy.payload.mass == 80.0 and heavy.effects.payload and heavy.scene == 'payload'
    assert m.payload.mass == 0.0 and not m.effects.payload and m.scene == 'full'
    with pytest.raises(ValueError, match='payload.mass'):
        m.with_payload(-1.0)


def test_optional_limits_are_read():
    params = _params()
    params['limits'].update(u_joint_max_angle=0.6, spherical_joint_max_angle=0.8,
                            max_jacobian_condition=50.0)
    lim = sm.from_dict(params).limits
    assert (lim.u_joint_max_angle, lim.spherical_joint_max_angle,
            lim.max_jacobian_condition) == (0.6, 0.8, 50.0)


def _set(params, path, value):
    *keys, last = path.split('.')
    target = params
    for key in keys:
        target = target[key]
    if value is KeyError:
        del target[last]
    else:
        target[last] = value


BAD = [
    ('gravity', -9.81, 'gravity'),
    ('gravity', math.nan, 'gravity'),
    ('gravity', '9.81', 'gravity'),
    ('gravity', True, 'gravity'),
    ('geometry.base_joints', [0.0] * 17, 'geometry.base_joints'),
    ('geometry.platform_joints', [0.0] * 17 + [math.inf], r'geometry.platform_joints.*element 17'),
    ('geometry.base_axes', [0.0] * 18, 'geometry.base_axes'),
    ('geometry.home', [0.0, 0.0], 'geometry.home'),
    ('geometry.home', KeyError, 'geometry: missing key'),
    ('geometry.extra', 1.0, 'geometry: unknown key'),
    ('bodies.platform.mass', 0.0, 'bodies.platform.mass'),
    ('bodies.platform.inertia', [40.0, 1.0, 0, 0, 45.0, 0, 0, 0, 60.0], 'bodies.platform.inertia'),
    ('bodies.platform.inertia', [1.0, 0, 0, 0, 1.0, 0, 0, 0, 5.0], 'bodies.platform.inertia'),
    ('bodies.platform.com', [0.0, 0.0], 'bodies.platform.com'),
    ('bodies.cylinder.com_distance', -0.1, 'bodies.cylinder.com_distance'),
    ('bodies.rod.inertia_along', math.inf, 'bodies.rod.inertia_along'),
    ('bodies.rod', KeyError, 'bodies: missing key'),
    ('payload.mass', -1.0, 'payload.mass'),
    ('payload.inertia', [1.0, 0, 0, 0, 1.0, 0, 0, 0, 1.0], 'payload.inertia'),
    ('friction.viscous', [1.0] * 5, 'friction.viscous'),
    ('friction.coulomb', [-1.0] * 6, r'friction.coulomb.*element 0'),
    ('friction.smoothing_velocity', 0.0, 'friction.smoothing_velocity'),
    ('limits.length_min', 0.0, 'limits.length_min'),
    ('limits.length_max', 0.9, 'limits.length_max'),
    ('limits.max_speed', 0.0, 'limits.max_speed'),
    ('limits.max_force', KeyError, 'limits: missing key'),
    ('limits.u_joint_max_angle', 4.0, 'limits.u_joint_max_angle'),
    ('limits.stroke_min', 0.1, 'limits: unknown key'),
    ('machine', '', 'machine'),
    ('scene', 3, 'scene'),
    ('rate', 100, 'parameters: unknown key'),
    # the declared bounds (machines/stewart/parameters.py), the builder's too
    ('gravity', 1000.0, 'gravity: must be <= 100'),
    ('bodies.platform.mass', 1.0e6, 'bodies.platform.mass: must be <= 100000 kg'),
    ('geometry.home', [0.0, 0.0, 1.0e3], r'geometry.home: must be <= 100 m \(element 2\)'),
]


@pytest.mark.parametrize('path, value, field', BAD, ids=[f'{p}={v!r}' for p, v, _ in BAD])
def test_a_bad_number_is_refused_naming_its_field(path, value, field):
    params = _params()
    _set(params, path, value)
    with pytest.raises(ValueError, match=field):
        sm.from_dict(params)


def test_a_home_on_a_singular_u_joint_is_refused():
    params = _params()
    m = sm.from_dict(params)
    leg = m.home + m.platform_joints[2] - m.base_joints[2]
    axes = np.reshape(params['geometry']['base_axes'], (6, 3))
    axes[2] = leg / np.linalg.norm(leg)
    params['geometry']['base_axes'] = axes.ravel().tolist()
    with pytest.raises(ValueError, match='leg 3'):
        sm.from_dict(params)



def test_a_scene_other_than_full_needs_its_effects():
    params = _params()
    params['scene'] = 'payload'
    with pytest.raises(ValueError, match="scene 'payload'"):
        sm.from_dict(params)
    m = sm.from_dict(params, Effects(payload=True))
    assert m.scene == 'payload' and m.effects.payload


def test_the_model_cannot_be_changed_in_place():
    m = model_of('stewart_6dof')
    for array in (m.base_joints, m.platform_joints, m.base_axes, m.home, m.platform.com,
                  m.platform.inertia, m.payload.inertia, m.friction.viscous, m.home_lengths):
        with pytest.raises(ValueError, match='read-only'):
            array[0] = 1.0
