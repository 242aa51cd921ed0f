"""The cueing group in params files (flight_sim_dynamics/config/cueing.py's
PARAMETER_SPECS): the loaders of models and nodes accept it, check it (an error
names the key and the file) and leave it out of the model; the packaged files
carry the machines' sets."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import flight_sim_dynamics as fsd
from flight_sim_dynamics.config.errors import ParameterError
from flight_sim_dynamics.config.files import read_params_sections
from flight_sim_dynamics.config.node_schema import check_node_params_files
from flight_sim_dynamics.config.cueing import defaults, split_cueing

ROOT = Path(__file__).resolve().parents[2]
HEXAPOD = ROOT / 'config' / 'stewart_6dof.yaml'
THREE_DOF = ROOT / 'config' / 'flight_sim_dynamics.yaml'


def group_of(path):
    return split_cueing(read_params_sections(path), str(path))[1]


def test_the_hexapod_file_has_the_design_set():
    params = group_of(HEXAPOD)
    for name in params.__dataclass_fields__:
        a, b = getattr(params, name), getattr(defaults(), name)
        assert np.array_equal(a, b) if isinstance(a, np.ndarray) else a == b, name


def test_the_three_dof_file_cues_surge_heave_and_roll_only():
    params = group_of(THREE_DOF)
    assert params.translation_gain[0] > 0 and params.translation_gain[2] > 0
    assert params.tilt_gain[1] > 0 and params.rotation_gain[0] > 0     # roll tilt from f_y
    assert params.translation_gain[1] == 0 and params.tilt_gain[0] == 0   # sway, pitch
    assert params.rotation_gain[1] == 0 and params.rotation_gain[2] == 0  # pitch, yaw


def _with_group(tmp_path, base: Path, group: str) -> Path:
    path = tmp_path / base.name
    text = base.read_text().split('    cueing:\n')[0]      # the packaged file without its group
    path.write_text(text + group)
    return path


@pytest.mark.parametrize('base', [HEXAPOD, THREE_DOF])
def test_a_file_with_part_of_a_group_loads_as_the_file_without_it(tmp_path, base):
    path = _with_group(tmp_path, base, '    cueing:\n      rate: 500.0\n      tilt:\n'
                                       '        gain: [0.1, 0.2]\n')
    (tmp_path / 'bare').mkdir()
    bare = _with_group(tmp_path / 'bare', base, '')
    q = np.zeros(len(fsd.machine_of(fsd.load_model(path)).coordinates))
    a = fsd.solve(fsd.load_model(path), q + 0.01, q, q + 0.1)
    b = fsd.solve(fsd.load_model(bare), q + 0.01, q, q + 0.1)
    assert np.array_equal(a.force, b.force)
    params = group_of(path)
    assert params.rate == 500.0 and np.array_equal(params.tilt_gain, [0.1, 0.2])


@pytest.mark.parametrize('base', [HEXAPOD, THREE_DOF])
@pytest.mark.parametrize('group, key', [
    ('    cueing:\n      rate: -1.0\n', 'cueing.rate'),
    ('    cueing:\n      translation:\n        gian: [1.0, 1.0, 1.0]\n',
     'cueing.translation.gian'),
    ('    cueing: 3\n', 'cueing'),
])
def test_a_bad_group_is_an_error_naming_key_and_file(tmp_path, base, group, key):
    path = _with_group(tmp_path, base, group)
    with pytest.raises(ParameterError) as caught:
        fsd.load_model(path)
    assert caught.value.key == key and str(path) in str(caught.value)


def test_the_nodes_rule_on_params_files_accepts_the_group():
    check_node_params_files(['--ros-args', '--params-file', str(HEXAPOD)],
                            machine='stewart_6dof')
    check_node_params_files(['--ros-args', '--params-file', str(THREE_DOF)])
