"""Parameter files that name their machine (a hexapod): the packaged file of
that name gives the defaults a partial file overrides, a machine of one's own
is given whole, scenes apply as for the 3-DOF machine, and every bad file is
one ParameterError naming the file and the key."""
from __future__ import annotations

import dataclasses
import re
from pathlib import Path

import numpy as np
import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st

import flight_sim_dynamics as fsd
from flight_sim_dynamics.config.node_schema import check_node_params_files
from flight_sim_dynamics.config.errors import ParameterError
from flight_sim_dynamics.config.files import PACKAGED_SECTION
from flight_sim_dynamics.config.scenes import SceneError, load_scene
from flight_sim_dynamics.core.effects import Effects
from flight_sim_dynamics.machines import default_machine
from flight_sim_dynamics.machines.staicu.model import Model
from flight_sim_dynamics.machines.stewart.model import PARAMETER_NAMES, StewartModel
from test_param_files_fuzz import ODD_VALUES, mutated

ROOT = Path(__file__).resolve().parents[2]
CONFIG = ROOT / 'config'
HEADER = 'flight_sim_dynamics:\n  ros__parameters:\n'
DOC = (ROOT / 'docs' / 'design' / 'stewart.md').read_text(encoding='utf-8')


def _file(tmp_path, body: str, name: str = 'p.yaml') -> Path:
    path = tmp_path / name
    path.write_text(HEADER + ''.join(f'    {line}\n' for line in body.splitlines()))
    return path


def _tree(name: str) -> dict:
    return yaml.safe_load((CONFIG / f'{name}.yaml').read_text(encoding='utf-8'))


def _params(tree: dict) -> dict:
    return tree[PACKAGED_SECTION]['ros__parameters']


def _dump(tmp_path, tree: dict, name: str = 'mine.yaml') -> Path:
    path = tmp_path / name
    path.write_text(yaml.safe_dump(tree))
    return path


def _raises(path, key, *words, scene=None, error=ParameterError) -> ParameterError:
    """load_model(path) raises one ``error`` with ``key``, the file and ``words``."""
    with pytest.raises(error) as info:
        fsd.load_model(path, scene=scene)
    assert type(info.value) is error
    assert info.value.key == key, str(info.value)
    for word in (str(path),) + words:
        assert word in str(info.value), (word, str(info.value))
    return info.value


def fields(model) -> dict:
    """A model's fields, nested dataclasses as dicts, arrays as lists."""
    def plain(value):
        if dataclasses.is_dataclass(value):
            return {f.name: plain(getattr(value, f.name)) for f in dataclasses.fields(value)}
        return value.tolist() if isinstance(value, np.ndarray) else value
    return plain(model)


PACKAGED = {name: fsd.load_model(CONFIG / f'{name}.yaml')
            for name in ('stewart_6dof', 'stewart_tsai2000')}


# -- the packaged files and partial files ---------------------------------------------
@pytest.mark.parametrize('name', sorted(PACKAGED))
def test_a_file_naming_only_a_packaged_machine_is_that_machine(tmp_path, name):
    model = fsd.load_model(_file(tmp_path, f'machine: {name}'))
    assert isinstance(model, StewartModel)
    assert fields(model) == fields(PACKAGED[name])


@pytest.mark.parametrize('name', sorted(PACKAGED))
def test_a_packaged_file_by_its_name_from_any_folder(tmp_path, monkeypatch, name):
    monkeypatch.chdir(tmp_path)
    assert fields(fsd.load_model(name)) == fields(PACKAGED[name])


def test_the_3dof_file_by_its_name():
    q = ([0.02, 0.05, 0.1], [0.1, 0.0, 0.2], [1.0, 2.0, 3.0])
    np.testing.assert_array_equal(fsd.solve(fsd.load_model('flight_sim_dynamics'), *q).force,
                                  fsd.solve(fsd.load_model(), *q).force)


def test_an_unknown_name_lists_the_packaged_ones(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    with pytest.raises(ParameterError) as info:
        fsd.load_model('stewart_6dog')
    assert info.value.key == 'params_file'
    for name in ('flight_sim_dynamics', *sorted(PACKAGED)):
        assert name in str(info.value)


def test_a_file_without_a_suffix_is_still_read_as_a_file(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    _file(tmp_path, 'machine: stewart_6dof\nbodies:\n  platform:\n    mass: 200.0', 'mine')
    assert fsd.load_model('mine').platform.mass == 200.0


def test_a_partial_file_overrides_the_packaged_machine_of_its_name(tmp_path):
    path = _file(tmp_path, 'machine: stewart_6dof\nbodies:\n  platform:\n    mass: 200.0\n'
                           'limits:\n  max_force: 5000.0\n  u_joint_max_angle: 0.7')
    model = fsd.load_model(path)
    base = PACKAGED['stewart_6dof']
    assert model.platform.mass == 200.0 and model.limits.max_force == 5000.0
    assert model.limits.u_joint_max_angle == 0.7
    expected = fields(dataclasses.replace(
        base, platform=dataclasses.replace(base.platform, mass=200.0),
        limits=dataclasses.replace(base.limits, max_force=5000.0, u_joint_max_angle=0.7)))
    assert fields(model) == expected
    heavier = fsd.solve(model, [0.0] * 6, [0.0] * 6, [0.0] * 6).force
    assert np.all(heavier > fsd.solve(base, [0.0] * 6, [0.0] * 6, [0.0] * 6).force)


def test_a_partial_payload_with_the_payload_scene_gives_the_check_values(tmp_path):
    """stewart.md: 80 kg at (0, 0, 0.5), scene payload, at rest at home."""
    text = DOC.split('## Check values', 1)[1]
    forces = [float(x) for x in re.findall(r'`\(([-\d., ]+)\) N`', text)[0].split(',')]
    mass, com = re.search(r'With an ([\d.]+) kg payload at \(([-\d., ]+)\)', text).groups()
    path = _file(tmp_path, f'machine: stewart_6dof\nscene: payload\npayload:\n  mass: {mass}\n'
                           f'  com: [{com}]')
    model = fsd.load_model(path)
    assert model.scene == 'payload' and model.effects == load_scene('payload').effects
    sol = fsd.solve(model, [0.0] * 6, [0.0] * 6, [0.0] * 6)
    np.testing.assert_allclose(sol.force, forces, atol=1e-6)


def test_node_and_ros_parameters_are_ignored_as_for_the_3dof_files(tmp_path):
    path = _file(tmp_path, 'machine: stewart_tsai2000\nuse_sim_time: true\nqos_overrides:\n'
                           '  /pose_setpoint:\n    subscription:\n      depth: 5')
    assert fields(fsd.load_model(path)) == fields(PACKAGED['stewart_tsai2000'])


# -- a machine of one's own: named by its kind ('stewart'), given whole ---------------------
def test_a_whole_file_of_a_machine_of_ones_own(tmp_path):
    tree = _tree('stewart_tsai2000')
    _params(tree)['machine'] = 'stewart'
    model = fsd.load_model(_dump(tmp_path, tree))
    assert model.name == 'stewart'
    assert fields(model) == {**fields(PACKAGED['stewart_tsai2000']), 'name': 'stewart'}
    q = [0.01, -0.02, 0.03, 0.04, -0.05, 0.06]
    np.testing.assert_array_equal(fsd.solve(model, q, q, q).force,
                                  fsd.solve(PACKAGED['stewart_tsai2000'], q, q, q).force)


def test_a_machine_of_ones_own_may_leave_payload_and_friction_out(tmp_path):
    tree = _tree('stewart_6dof')
    params = _params(tree)
    params['machine'] = 'stewart'
    del params['payload'], params['friction']
    model = fsd.load_model(_dump(tmp_path, tree))
    assert model.payload.mass == 0.0 and np.all(model.friction.viscous == 0.0)


@pytest.mark.parametrize('section', ['geometry', 'bodies', 'limits', 'gravity'])
def test_an_incomplete_file_of_ones_own_names_what_is_missing(tmp_path, section):
    tree = _tree('stewart_6dof')
    params = _params(tree)
    params['machine'] = 'stewart'
    del params[section]
    error = _raises(_dump(tmp_path, tree), section, 'missing', 'machine of your own',
                    'stewart_6dof, stewart_tsai2000')
    assert error.value is None


def test_a_missing_key_of_a_section_of_ones_own_is_named(tmp_path):
    tree = _tree('stewart_6dof')
    params = _params(tree)
    params['machine'] = 'stewart'
    del params['bodies']['rod']['com_distance']
    _raises(_dump(tmp_path, tree), 'bodies.rod.com_distance', 'missing')


@pytest.mark.parametrize('name, close', [('my_hexapod', None), ('stewart_6dfo', 'stewart_6dof'),
                                         ('stewrat', 'stewart')])
def test_an_unknown_machine_name_is_an_error_listing_the_known_ones(tmp_path, name, close):
    """No name is taken for a hexapod of one's own any more: one error, of the
    key 'machine', with every name a file may give."""
    tree = _tree('stewart_6dof')
    _params(tree)['machine'] = name
    error = _raises(_dump(tmp_path, tree), 'machine', 'no machine is named', 'stewart_6dof',
                    'stewart_tsai2000', 'stewart')
    assert error.value == name
    assert (f"did you mean '{close}'?" in str(error)) == (close is not None)


def test_a_hexapod_file_without_its_machine_line_says_whose_keys_they_are(tmp_path):
    """Without 'machine:' a file is the 3-DOF machine's; a hexapod's keys there
    are named as the hexapod's (not 'friction.coulomb expected 3 numbers')."""
    tree = _tree('stewart_6dof')
    del _params(tree)['machine']
    error = _raises(_dump(tmp_path, tree), 'machine', "machine 'stewart'",
                    "add the line 'machine: stewart'")
    assert 'expected 3 numbers' not in str(error)
    partial = _file(tmp_path, 'geometry:\n  base_joints: [' + ', '.join(['0.1'] * 18) + ']',
                    'partial.yaml')
    _raises(partial, 'machine', 'geometry.base_joints', "'machine: stewart'",
            "'machine: stewart_6dof'")


# -- bad files -------------------------------------------------------------------------
@pytest.mark.parametrize('body, key, words', [
    ('geometry:\n  hom: [0.0, 0.0, 1.0]', 'geometry.hom', ["did you mean 'geometry.home'?"]),
    ('bodies:\n  rod:\n    mas: 5.0', 'bodies.rod.mas', ["did you mean 'bodies.rod.mass'?"]),
    ('gravty: 9.81', 'gravty', ["did you mean 'gravity'?"]),
    # a 3-DOF key in a hexapod file: named as the default machine's, by its title
    ('geometry:\n  d1: 0.4', 'geometry.d1', [default_machine().title]),
    ('limits:\n  stroke_max: 0.5', 'limits.stroke_max', [default_machine().title]),
    ('bodies:\n  crank_d:\n    mass: 1.0', 'bodies.crank_d.mass', [default_machine().title]),
])
def test_an_unknown_name_in_a_hexapod_file(tmp_path, body, key, words):
    path = _file(tmp_path, 'machine: stewart_6dof\n' + body)
    _raises(path, key, 'unknown parameter', *words)


def test_a_hexapod_file_may_give_the_node_parameters(tmp_path):
    """One file serves the model and the node, as for the 3-DOF machine: the
    node's parameters are checked, and leave the model as it is."""
    given = _file(tmp_path, 'machine: stewart_6dof\ninput:\n  max_points: 10\n'
                            'limits:\n  warn_fraction: 0.8\n')
    model = fsd.load_model(given)
    packaged = fsd.load_model(ROOT / 'config' / 'stewart_6dof.yaml')
    assert model.limits == packaged.limits
    bad = _file(tmp_path, 'machine: stewart_6dof\ninput:\n  max_points: 0\n')
    _raises(bad, 'input.max_points', '>= 1')


@pytest.mark.parametrize('body, key, words', [
    ('geometry:\n  home: [0.0, 1.0]', 'geometry.home', ['3 numbers', 'got 2']),
    ('geometry:\n  base_joints: [0.0, 1.0, 2.0]', 'geometry.base_joints', ['18 numbers']),
    ('friction:\n  viscous: [1.0, 1.0, 1.0]', 'friction.viscous', ['6 numbers', 'got 3']),
    ('bodies:\n  platform:\n    inertia: [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0]',
     'bodies.platform.inertia', ['9 numbers']),
    ('payload:\n  com: 0.5', 'payload.com', ['3 numbers']),
    ('geometry:\n  home: [0.0, 0.0, .nan]', 'geometry.home', ['finite']),
    ('gravity: -9.81', 'gravity', ['>= 0']),
    ('gravity: "9.81"', 'gravity', ['number']),
    ('bodies:\n  rod:\n    mass: true', 'bodies.rod.mass', ['number']),
    ('bodies:\n  platform:\n    inertia: [1.0, 2.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0]',
     'bodies.platform.inertia', ['symmetric']),
    ('bodies:\n  platform:\n    mass: 0.0', 'bodies.platform.mass', ['> 0']),
    ('limits:\n  length_min: 2.0', 'limits.length_max', ['> 2', 'stewart_6dof.yaml']),
    ('limits:\n  u_joint_max_angle: 4.0', 'limits.u_joint_max_angle', ['<= 3.14159 rad']),
    ('geometry:\n  home: [0.0, 0.0, 0.0]\n  platform_joints: [' + ', '.join(['0.0'] * 18) + ']\n'
     '  base_joints: [' + ', '.join(['0.0'] * 18) + ']', 'geometry.home', ['zero length']),
    ('machine: 5', 'machine', ['name of a machine']),
    ('machine: flight_simulator_3dof', 'machine', ['name no machine']),
    ('scene: 5', 'scene', ['scene name']),
])
def test_a_bad_value_in_a_hexapod_file(tmp_path, body, key, words):
    lines = body if body.startswith('machine') else 'machine: stewart_6dof\n' + body
    _raises(_file(tmp_path, lines), key, *words)


@pytest.mark.parametrize('body, key', [
    ('machine: stewart_6dof\ngeometry:\n  home: !!set {1.0, 0.0, 0.5}', 'geometry.home'),
    ('machine: stewart_6dof\npayload:\n  com: !!set {0.0, 0.1, 0.2}', 'payload.com'),
    ('limits:\n  stroke_min: !!set {0.1}', 'limits.stroke_min'),
    ('payload:\n  inertia: !!set {1.0, 0.0}', 'payload.inertia'),
])
def test_a_set_is_refused_in_either_machines_file(tmp_path, body, key):
    """A set has no order: read as a vector it would come in hash order (issue 29)."""
    _raises(_file(tmp_path, body), key)


def test_a_hexapod_key_in_a_3dof_file_is_named_as_the_hexapods(tmp_path):
    """fsd.load_model says whose key it is and which line to add; so does the
    node's --params-file check (one loader: it once called it an unknown
    parameter)."""
    for body, key in (('geometry:\n  home: [0.0, 0.0, 1.0]', 'geometry.home'),
                      ('limits:\n  length_min: 0.9', 'limits.length_min'),
                      ('bodies:\n  cylinder:\n    com_distance: 0.3',
                       'bodies.cylinder.com_distance')):
        path = _file(tmp_path, body)
        _raises(path, 'machine', key, "machine 'stewart'", "'machine: stewart'")
        with pytest.raises(ParameterError, match="'machine: stewart'") as info:
            check_node_params_files(['n', '--ros-args', '--params-file', str(path)])
        assert info.value.key == 'machine' and key in str(info.value)


def test_the_3dof_files_are_read_as_before(tmp_path):
    model = fsd.load_model(_file(tmp_path, 'bodies:\n  rod:\n    mass: 2.0'))
    assert isinstance(model, Model) and model.bodies['rod'].mass == 2.0
    _raises(_file(tmp_path, 'gravity: -1.0'), 'gravity', 'must be >= 0')


# -- scenes ----------------------------------------------------------------------------
@pytest.mark.parametrize('scene', ['quasi_static', 'platform_only', 'payload', 'full'])
def test_the_files_scene_and_the_callers_scene(tmp_path, scene):
    path = _file(tmp_path, f'machine: stewart_6dof\nscene: {scene}')
    model = fsd.load_model(path)
    assert model.scene == scene and model.effects == load_scene(scene).effects
    other = fsd.load_model(path, scene='quasi_static')
    assert other.scene == 'quasi_static' and other.effects == load_scene('quasi_static').effects


def test_a_scene_switches_the_hexapods_effects_off(tmp_path):
    """Gravity only: at rest the forces of the full model; moving, the inertia is skipped."""
    full = PACKAGED['stewart_6dof']
    static = fsd.load_model(CONFIG / 'stewart_6dof.yaml', scene='quasi_static')
    zero, q, qdd = [0.0] * 6, [0.02] * 6, [3.0] * 6
    np.testing.assert_allclose(fsd.solve(static, zero, zero, zero).force,
                               fsd.solve(full, zero, zero, zero).force, rtol=1e-12)
    np.testing.assert_array_equal(fsd.solve(static, q, zero, qdd).force,
                                  fsd.solve(static, q, zero, zero).force)
    assert not np.allclose(fsd.solve(full, q, zero, qdd).force,
                           fsd.solve(full, q, zero, zero).force)


def test_a_scene_files_overrides_apply_to_a_hexapod(tmp_path):
    scene = tmp_path / 'cab.yaml'
    scene.write_text('effects: {gravity: true, platform_inertia: true, payload: true, '
                     'leg_inertia: true, crank_inertia: false, velocity_products: true, '
                     'friction: true}\nparameters:\n  payload:\n    mass: 80.0\n'
                     '  friction:\n    viscous: [10.0, 10.0, 10.0, 10.0, 10.0, 10.0]\n')
    model = fsd.load_model(CONFIG / 'stewart_6dof.yaml', scene=scene)
    assert model.payload.mass == 80.0 and np.all(model.friction.viscous == 10.0)
    assert model.effects == Effects(payload=True, crank_inertia=False, friction=True)
    path = _file(tmp_path, f'machine: stewart_6dof\nscene: {scene}\npayload:\n  mass: 5.0')
    assert fsd.load_model(path).payload.mass == 80.0      # the scene's override wins


@pytest.mark.parametrize('parameters, words', [
    ('payload:\n    mass: -1.0', ['payload.mass', '>= 0']),
    ('friction:\n    viscous: [1.0, 2.0, 3.0]', ['friction.viscous', '6 numbers']),
    ('geometry:\n    d1: 0.4', ["'geometry.d1' is not a model parameter"]),
    ('machine: stewart_tsai2000', ["'machine' is not a model parameter"]),
])
def test_a_bad_scene_override_for_a_hexapod_names_the_scene_file(tmp_path, parameters, words):
    scene = tmp_path / 'bad_scene.yaml'
    scene.write_text('effects: {gravity: true, platform_inertia: true, payload: true, '
                     'leg_inertia: true, crank_inertia: true, velocity_products: true, '
                     f'friction: false}}\nparameters:\n  {parameters}\n')
    with pytest.raises(SceneError) as info:
        fsd.load_model(CONFIG / 'stewart_6dof.yaml', scene=scene)
    for word in ['bad_scene'] + words:
        assert word in str(info.value), (word, str(info.value))


def test_an_unknown_scene_for_a_hexapod(tmp_path):
    with pytest.raises(SceneError, match="did you mean 'quasi_static'"):
        fsd.load_model(_file(tmp_path, 'machine: stewart_6dof\nscene: quasi_statc'))


# -- any file: a model or one ParameterError -------------------------------------------------
HEXAPOD_TEXT = (CONFIG / 'stewart_6dof.yaml').read_text(encoding='utf-8')


def _model_or_parameter_error(path: Path) -> None:
    try:
        model = fsd.load_model(path)
    except ParameterError as exc:
        assert str(path) in str(exc) or isinstance(exc, SceneError) or exc.key in {
            'params_file', 'scene'}, str(exc)
        return
    assert isinstance(model, (Model, StewartModel))


@settings(max_examples=150, deadline=None)
@given(content=mutated(HEXAPOD_TEXT))
def test_a_mutated_hexapod_file_is_a_model_or_a_parameter_error(tmp_path_factory, content):
    path = tmp_path_factory.mktemp('fuzz') / 'hexapod.yaml'
    path.write_bytes(content)
    _model_or_parameter_error(path)


@settings(max_examples=150, deadline=None)
@given(key=st.sampled_from(sorted(PARAMETER_NAMES)),
       value=st.sampled_from(ODD_VALUES) | st.builds(
           lambda xs: '[' + ', '.join(map(repr, xs)) + ']',
           st.lists(st.floats(allow_nan=True, allow_infinity=True), max_size=20)),
       packaged=st.booleans())
def test_any_value_of_any_hexapod_parameter_is_a_model_or_a_parameter_error(
        tmp_path_factory, key, value, packaged):
    *groups, leaf = key.split('.')
    body = 'machine: stewart_6dof\n' if packaged or key == 'machine' else ''
    for depth, group in enumerate(groups):
        body += '  ' * depth + group + ':\n'
    body += '  ' * len(groups) + f'{leaf}: {value.replace("nan", ".nan").replace("inf", ".inf")}'
    path = tmp_path_factory.mktemp('fuzz') / 'value.yaml'
    path.write_text(HEADER + ''.join(f'    {line}\n' for line in body.splitlines()))
    _model_or_parameter_error(path)


@pytest.mark.parametrize('first', ['machine: stewart_6dof\n', ''])
def test_an_empty_group_names_the_file(tmp_path, first):
    _raises(_file(tmp_path, first + 'bodies:\n  rod: {}'), 'bodies.rod', 'empty group')


# -- the node's --params-file check ------------------------------------------------------
@pytest.mark.parametrize('name', sorted(PACKAGED))
def test_the_nodes_check_refuses_a_file_naming_another_machine(tmp_path, name):
    """A node not started for the machine a file names: one ParameterError of
    'machine' naming the file; started for it, the file is read as load_model
    reads it."""
    path = CONFIG / f'{name}.yaml'
    with pytest.raises(ParameterError) as info:
        check_node_params_files(['n', '--ros-args', '--params-file', str(path)])
    assert info.value.key == 'machine' and str(path) in str(info.value)
    check_node_params_files(['n', '--ros-args', '--params-file', str(path)], machine=name)


# -- values the scene does not use ------------------------------------------------------
def test_a_payload_the_scene_leaves_out_is_warned_about(tmp_path):
    """A file's payload (or friction) under a scene without the effect changes
    nothing: load_model says so; with the effect, or as the packaged files give
    it, nothing is said."""
    from flight_sim_dynamics.config.errors import IgnoredParameterWarning
    path = _file(tmp_path, 'machine: stewart_6dof\npayload:\n  mass: 80.0\nfriction:\n'
                           '  viscous: [1.0, 1.0, 1.0, 1.0, 1.0, 1.0]')
    with pytest.warns(IgnoredParameterWarning) as caught:
        fsd.load_model(path)
    text = str(caught[0].message)
    assert 'payload.mass' in text and 'friction.viscous' in text and str(path) in text
    with pytest.warns(IgnoredParameterWarning) as caught:      # friction still left out
        assert fsd.load_model(path, scene='payload').payload.mass == 80.0
    text = str(caught[0].message)
    assert 'friction.viscous' in text and 'payload.mass' not in text


def test_what_is_warned_about_is_what_the_scene_leaves_out(tmp_path):
    import warnings

    from flight_sim_dynamics.config.errors import IgnoredParameterWarning
    payload_only = _file(tmp_path, 'machine: stewart_6dof\npayload:\n  mass: 80.0')
    with warnings.catch_warnings():
        warnings.simplefilter('error', IgnoredParameterWarning)
        fsd.load_model(payload_only, scene='payload')
        fsd.load_model('stewart_6dof')
        fsd.load_model(CONFIG / 'stewart_tsai2000.yaml')
        fsd.load_model()
        fsd.load_model(_dump(tmp_path, _tree('stewart_6dof')))      # a copy of the packaged file
    three = tmp_path / 'three.yaml'
    three.write_text(HEADER + '    payload:\n      mass: 80.0\n')
    with pytest.warns(IgnoredParameterWarning, match='payload.mass'):
        fsd.load_model(three)
