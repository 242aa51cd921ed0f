"""Parameter file loading and validation: nothing is guessed silently."""
from pathlib import Path

import numpy as np
import pytest
import yaml

import flight_sim_dynamics as fsd
from flight_sim_dynamics.config import parameters
from flight_sim_dynamics.config.files import PACKAGED_SECTION, read_params_sections
from flight_sim_dynamics.config.machine_files import model_of_values
from flight_sim_dynamics.config.parameters import ParameterError
from flight_sim_dynamics.machines import default_machine

CONFIG = Path(__file__).resolve().parents[2] / 'config' / 'flight_sim_dynamics.yaml'


def _write(tmp_path, tree):
    path = tmp_path / 'params.yaml'
    path.write_text(yaml.safe_dump({'flight_sim_dynamics': {'ros__parameters': tree}}))
    return path


def _tree():
    return yaml.safe_load(CONFIG.read_text())[PACKAGED_SECTION]['ros__parameters']


def test_packaged_file_equals_schema_defaults():
    values = read_params_sections(CONFIG)
    defaults = parameters.defaults()
    for spec in parameters.MODEL_PARAMETERS:
        expected = defaults[spec.name]
        if spec.kind == 'string':
            assert values[spec.name] == expected, spec.name
        else:
            assert values[spec.name] == pytest.approx(expected, rel=1e-15), spec.name


def test_default_model_loads_from_packaged_file():
    model = fsd.load_model()
    assert model.geometry.h == 1.4 and model.gravity == 9.81
    assert model.bodies['platform'].mass == 5.0
    np.testing.assert_allclose(np.diag(model.bodies['platform'].inertia),
                               [0.6, 5 * (1.2 ** 2 + 1.4 ** 2) / 12, 5 * 1.4 ** 2 / 12])


def test_integer_for_float_is_the_same_number(tmp_path):
    tree = _tree()
    tree['bodies']['platform']['mass'] = 5
    model = fsd.load_model(_write(tmp_path, tree))
    assert model.bodies['platform'].mass == 5.0


def _mutate(tree, path, value):
    node = tree
    for part in path[:-1]:
        node = node[part]
    if value is KeyError:
        del node[path[-1]]
    else:
        node[path[-1]] = value


@pytest.mark.parametrize('path, value, key, words', [
    (('geometry', 'd9'), 0.3, 'geometry.d9', 'unknown'),
    (('bodies', 'rod', 'colour'), 'red', 'bodies.rod.colour', 'unknown'),
    (('geometry', 'h'), 'long', 'geometry.h', 'expected a number'),
    (('geometry', 'h'), True, 'geometry.h', 'expected a number'),
    (('geometry', 'l5'), -1.3, 'geometry.l5', 'must be >'),
    (('geometry', 'b'), 0.0, 'geometry.b', 'must be >'),
    (('geometry', 'b'), float('nan'), 'geometry.b', 'finite'),
    (('bodies', 'rod', 'mass'), 0.0, 'bodies.rod.mass', 'must be >'),
    (('bodies', 'crank_d', 'mass'), -1.5, 'bodies.crank_d.mass', 'must be >'),
    (('bodies', 'rod', 'com'), [0.7, 0.0], 'bodies.rod.com', 'expected 3 numbers'),
    (('bodies', 'rod', 'inertia'), [0, 0.1, 0, 0, 0.2, 0, 0, 0, 0.2],
     'bodies.rod.inertia', 'not symmetric'),
    (('bodies', 'rod', 'inertia'), [-0.1, 0, 0, 0, 0.2, 0, 0, 0, 0.2],
     'bodies.rod.inertia', 'positive semi-definite'),
    (('bodies', 'rod', 'inertia'), [1.0, 0, 0, 0, 0.2, 0, 0, 0, 0.2],
     'bodies.rod.inertia', 'triangle inequality'),
    (('gravity',), -9.81, 'gravity', 'must be >='),
    (('geometry', 'l5'), 3.0, 'geometry.l5', 'cannot close'),
    (('geometry', 'l6'), 0.3, 'geometry.l6', 'cannot close'),
])
def test_invalid_values_name_key_and_value(tmp_path, path, value, key, words):
    tree = _tree()
    _mutate(tree, path, value)
    with pytest.raises(ParameterError) as info:
        fsd.load_model(_write(tmp_path, tree))
    assert info.value.key == key
    assert words in str(info.value)
    assert f"'{key}' = " in str(info.value)      # names the key, then shows the value


def test_missing_model_parameter_in_values_names_it():
    # moved from test_invalid_values_name_key_and_value: a partial *file* now
    # overrides the packaged defaults (test_partial_file_overrides_packaged_defaults);
    # a set of *values* built by hand must still be complete
    values = parameters.defaults()
    del values['geometry.d1']
    with pytest.raises(ParameterError) as info:
        model_of_values(default_machine(), values, 'values')
    assert info.value.key == 'geometry.d1'
    assert 'missing' in str(info.value)
    assert "'geometry.d1' = " in str(info.value)


def test_file_problems_are_reported(tmp_path):
    with pytest.raises(ParameterError, match='cannot read'):
        fsd.load_model(tmp_path / 'nope.yaml')
    bad = tmp_path / 'bad.yaml'
    bad.write_text('flight_sim_dynamics: [unclosed')
    with pytest.raises(ParameterError, match='not valid YAML'):
        fsd.load_model(bad)
    other = tmp_path / 'other.yaml'
    other.write_text(yaml.safe_dump({'some_node': {'ros__parameters': {'a': 1}}}))
    with pytest.raises(ParameterError, match="no section for node"):
        fsd.load_model(other)


def test_wildcard_section_applies(tmp_path):
    path = tmp_path / 'wild.yaml'
    path.write_text(yaml.safe_dump({'/**': {'ros__parameters': _tree()}}))
    assert fsd.load_model(path).geometry.d5 == 1.35


def test_changed_mass_changes_static_forces(tmp_path):
    tree = _tree()
    tree['bodies']['platform']['mass'] = 10.0
    heavy = fsd.load_model(_write(tmp_path, tree))
    base = fsd.solve(fsd.load_model(), [0, 0, 0], [0, 0, 0], [0, 0, 0]).force
    assert np.all(fsd.solve(heavy, [0, 0, 0], [0, 0, 0], [0, 0, 0]).force > base)
