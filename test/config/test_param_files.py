"""The one rule for parameter files (library, command line, node) and the
safe YAML reader: every bad file is one ParameterError naming it (issue 12
#10, issue 14 #5)."""
import os
import time
from pathlib import Path

import numpy as np
import pytest
import yaml

import flight_sim_dynamics as fsd
from flight_sim_dynamics.config import schema, yaml_io
from flight_sim_dynamics.config.cueing import split_cueing
from flight_sim_dynamics.config.errors import ParameterError
from flight_sim_dynamics.config.files import (PACKAGED_SECTION, params_files_in,
                                              read_params_sections, section_applies,
                                              without_ros)
from flight_sim_dynamics.config.machine_files import load_node_values
from flight_sim_dynamics.core.inertia import inertia_tensor
from flight_sim_dynamics.core.parameter_spec import ModelValueError
from flight_sim_dynamics.config.node_schema import check_node_params_files
from flight_sim_dynamics.config.scenes import SceneError
from flight_sim_dynamics.machines.staicu.model import BODY_NAMES

CONFIG = Path(__file__).resolve().parents[2] / 'config' / 'flight_sim_dynamics.yaml'
HEADER = 'flight_sim_dynamics:\n  ros__parameters:\n'


def _file(tmp_path, body: str, name: str = 'p.yaml') -> Path:
    path = tmp_path / name
    path.write_text(HEADER + ''.join(f'    {line}\n' for line in body.splitlines()))
    return path


#: A bound that only a hang exceeds (a read that waits for a writer or reads without
#: end), not a speed target.
HANG = 10.0


def _raises(path, *words):
    """load_model(path) raises ParameterError (nothing else) naming all ``words``."""
    t0 = time.perf_counter()
    with pytest.raises(ParameterError) as info:
        fsd.load_model(path)
    elapsed = time.perf_counter() - t0
    for word in words:
        assert word in str(info.value), (word, str(info.value))
    return info.value, elapsed


# -- the one rule --------------------------------------------------------------
def test_partial_file_overrides_packaged_defaults(tmp_path):
    model = fsd.load_model(_file(tmp_path, 'bodies:\n  platform:\n    mass: 7.5'))
    default = fsd.load_model()
    assert model.bodies['platform'].mass == 7.5
    assert model.geometry == default.geometry
    assert model.bodies['rod'].mass == default.bodies['rod'].mass
    assert model.values['geometry.d1'] == 0.4


def test_missing_geometry_key_takes_the_packaged_value(tmp_path):
    tree = yaml.safe_load(CONFIG.read_text())
    del tree[PACKAGED_SECTION]['ros__parameters']['geometry']['d1']
    path = tmp_path / 'no_d1.yaml'
    path.write_text(yaml.safe_dump(tree))
    assert fsd.load_model(path).geometry.d1 == fsd.load_model().geometry.d1


@pytest.mark.parametrize('body, key, suggestion', [
    ('geometry:\n  d7: 0.4', 'geometry.d7', 'geometry.d5'),
    ('bodies:\n  platfrom:\n    mass: 5.0', 'bodies.platfrom.mass', 'bodies.platform.mass'),
    ('gravty: 9.81', 'gravty', 'gravity'),
    ('output:\n  frameid: base', 'output.frameid', 'output.frame_id'),
])
def test_unknown_name_is_an_error_with_did_you_mean_and_the_file(tmp_path, body, key,
                                                                  suggestion):
    path = _file(tmp_path, body)
    error, _ = _raises(path, f"'{key}'", 'unknown parameter', str(path),
                       f"did you mean '{suggestion}'?")
    assert error.key == key


def test_qos_overrides_are_the_nodes_and_ignored_by_load_model(tmp_path):
    path = _file(tmp_path, 'qos_overrides:\n  /pose_setpoint:\n    subscription:\n'
                           '      depth: 50\nbodies:\n  rod:\n    mass: 2.0')
    values, qos = without_ros(read_params_sections(path))
    assert qos == {'qos_overrides./pose_setpoint.subscription.depth': 50}
    assert values == {'bodies.rod.mass': 2.0}
    assert fsd.load_model(path).bodies['rod'].mass == 2.0


def test_sections_apply_as_rcl_applies_them(tmp_path):
    assert section_applies('/**', '/sim/flight_sim_dynamics')
    assert section_applies('flight_sim_dynamics', '/flight_sim_dynamics')
    assert section_applies('/sim/flight_sim_dynamics', '/sim/flight_sim_dynamics')
    assert section_applies('/*/flight_sim_dynamics', '/sim/flight_sim_dynamics')
    assert section_applies('/**/flight_sim_dynamics', '/a/b/flight_sim_dynamics')
    assert not section_applies('/other/flight_sim_dynamics', '/sim/flight_sim_dynamics')
    assert not section_applies('some_node', '/flight_sim_dynamics')
    path = tmp_path / 'ns.yaml'
    path.write_text('/sim/flight_sim_dynamics:\n  ros__parameters:\n    gravity: 9.0\n'
                    'other:\n  ros__parameters:\n    anything: 1\n')
    assert read_params_sections(path, '/sim/flight_sim_dynamics') == {'gravity': 9.0}
    with pytest.raises(ParameterError, match='no section for node'):
        read_params_sections(path)


#: rclpy 7.1.6 (Jazzy), measured: a node named flight_sim_dynamics in namespace
#: '' and 'sim', --params-file of a file whose one section is the key: whether
#: the node has the section's parameter
RCL_SECTIONS = [
    ('flight_sim_dynamics', '/flight_sim_dynamics', True),
    ('flight_sim_dynamics', '/sim/flight_sim_dynamics', False),
    ('/**/flight_sim_dynamics', '/flight_sim_dynamics', True),
    ('/**/flight_sim_dynamics', '/sim/flight_sim_dynamics', True),
    ('/sim/flight_sim_dynamics', '/flight_sim_dynamics', False),
    ('/sim/flight_sim_dynamics', '/sim/flight_sim_dynamics', True),
]


@pytest.mark.parametrize('section, node, applies', RCL_SECTIONS)
def test_a_section_applies_where_rcl_applies_it(tmp_path, section, node, applies):
    """A bare name is the node of that name in the root namespace only."""
    assert section_applies(section, node) is applies
    path = tmp_path / 'one_section.yaml'
    path.write_text(yaml.safe_dump({section: {'ros__parameters': {'gravity': 5.0}}}))
    if applies:
        assert read_params_sections(path, node) == {'gravity': 5.0}
    else:
        with pytest.raises(ParameterError, match='no section for node'):
            read_params_sections(path, node)


def test_the_packaged_files_reach_the_node_in_any_namespace():
    for path in sorted(CONFIG.parent.glob('*.yaml')):
        tree = yaml.safe_load(path.read_text(encoding='utf-8'))
        assert list(tree) == [PACKAGED_SECTION], path
        for node in ('/flight_sim_dynamics', '/sim/flight_sim_dynamics',
                     '/a/b/flight_sim_dynamics'):
            assert read_params_sections(path, node) == read_params_sections(path), (path, node)
        assert read_params_sections(path)['gravity'] > 0


def test_a_namespaced_node_takes_the_packaged_hexapod_and_refuses_a_bare_section(tmp_path):
    """The packaged file reaches /sim/flight_sim_dynamics; a file of one's own whose
    bare section names the machine does not, and ends the start by that name."""
    hexapod = str(CONFIG.parent / 'stewart_6dof.yaml')
    check_node_params_files(['--ros-args', '--params-file', hexapod],
                            '/sim/flight_sim_dynamics', 'stewart_6dof')
    bare = tmp_path / 'bare.yaml'
    bare.write_text(yaml.safe_dump({'flight_sim_dynamics': {
        'ros__parameters': {'machine': 'stewart_6dof'}}}))
    check_node_params_files(['--ros-args', '--params-file', str(bare)],
                            '/flight_sim_dynamics', 'stewart_6dof')
    with pytest.raises(ParameterError) as error:
        check_node_params_files(['--ros-args', '--params-file', str(bare)],
                                '/sim/flight_sim_dynamics', None)
    assert error.value.key == 'machine' and error.value.value == 'stewart_6dof'


def test_params_files_in_a_ros_command_line():
    args = ['node', '--executor', 'single', '--ros-args', '--params-file', 'a.yaml', '-p',
            'x:=1', '--', '--params-file', 'not_ros.yaml', '--ros-args', '--params-file',
            'b.yaml']
    assert params_files_in(args) == ['a.yaml', 'b.yaml']


def test_check_params_files_applies_the_rule_to_a_command_line(tmp_path):
    good = _file(tmp_path, 'bodies:\n  rod:\n    mass: 2.0', 'good.yaml')
    bad = _file(tmp_path, 'geometry:\n  d7: 0.4', 'bad.yaml')
    check_node_params_files(['n', '--ros-args', '--params-file', str(good)])
    with pytest.raises(ParameterError, match="did you mean 'geometry.d5'") as info:
        check_node_params_files(['n', '--ros-args', '--params-file', str(good),
                                 '--params-file', str(bad)])
    assert str(bad) in str(info.value)     # the file of the name


# -- bad files: one ParameterError naming the file, quickly ------------------------
BILLION_LAUGHS = ('lol: &a ["lol","lol","lol","lol","lol","lol","lol","lol","lol"]\n'
                  + ''.join(f'l{i}: &{chr(98 + i)} [' + ','.join(['*' + chr(97 + i)] * 9)
                            + ']\n' for i in range(9)))


@pytest.mark.parametrize('content, words', [
    (HEADER + '    gravity: ' + '1' + '0' * 400 + '\n', ['gravity', 'expected a number']),
    (HEADER + '    gravity: ' + '9' * 5000 + '\n', ['gravity', 'expected a number']),
    (HEADER.encode() + b'    scene: caf\xe9\n', ['not UTF-8', 'offset']),
    (HEADER + '    geometry: &g {d1: *g}\n', ['anchors and aliases']),
    (BILLION_LAUGHS, ['anchors and aliases']),
    (HEADER + '    gravity: &g 9.81\n', ['anchors and aliases']),
    (HEADER + '    gravity: 9.81\n    gravity: 9.0\n', ['gravity', 'given twice']),
    (HEADER + '    geometry: ' + '{a: ' * 2000 + '1' + '}' * 2000 + '\n', ['nested too deeply']),
    (b'\x00\x01\x02binary', ['NUL bytes']),
    (HEADER + '    gravity: [unclosed\n', ['not valid YAML']),
    (HEADER + '    gravity: 9.81\n---\nx: 1\n', ['not valid YAML']),
    ('- just\n- a list\n', ['expected a map']),
    ('', ['expected a map']),
    (HEADER + '    bodies:\n      rod:\n        com: [[1.0], 0.0, 0.0]\n', ['bodies.rod.com',
                                                                          'element 0']),
    (HEADER + '    bodies:\n      rod:\n        com: []\n', ['bodies.rod.com', 'got 0']),
    (HEADER + '    1: 2.0\n', ["'1'", 'unknown parameter']),
    (HEADER + '    ? [a, b]\n    : 1\n', ['not valid YAML']),
    # an explicit tag its text does not fit (a mutated file found it: a bare ValueError)
    (HEADER + '    gravity: !!float 1\n      -2.0, 0.0]\n', ['not valid YAML']),
    (HEADER + '    gravity: !!int x\n', ['not valid YAML']),
])
def test_bad_file_is_one_parameter_error_naming_it(tmp_path, content, words):
    path = tmp_path / 'bad.yaml'
    (path.write_bytes if isinstance(content, bytes) else path.write_text)(content)
    error, elapsed = _raises(path, *words)
    assert str(path) in str(error) or error.key in str(error)
    assert elapsed < HANG, elapsed


@pytest.mark.parametrize('inertia', ['1.0e308', '1.0e+300', '.inf', '.nan', '-1.0e308'])
def test_huge_or_non_finite_inertia_is_a_parameter_error(tmp_path, inertia):
    path = _file(tmp_path, f'bodies:\n  rod:\n    inertia: [{inertia}, 0.0, 0.0, 0.0, '
                           f'{inertia}, 0.0, 0.0, 0.0, {inertia}]')
    _raises(path, 'bodies.rod.inertia')


def test_check_inertia_never_raises_linalg_errors():
    for bad in (-1e308, float('inf'), float('nan')):
        with pytest.raises(ModelValueError):
            inertia_tensor('x', [bad, 0, 0, 0, bad, 0, 0, 0, bad])
    # a possible tensor near the float range is checked without overflow (the
    # schema's bound, 1e6 kg m^2, is validation's business)
    tensor = inertia_tensor('x', [1e308, 0, 0, 0, 1e308, 0, 0, 0, 1e308])
    assert tensor[0, 0] == 1e308


def test_special_files_are_refused_without_reading_them_whole(tmp_path):
    _raises(Path('/dev/zero'), 'larger than', str(yaml_io.MAX_FILE_BYTES))
    _raises(tmp_path, 'is a directory')
    _raises(tmp_path / 'nope.yaml', 'cannot read')
    big = tmp_path / 'big.yaml'
    big.write_text(HEADER + '    # ' + 'x' * yaml_io.MAX_FILE_BYTES + '\n')
    _raises(big, 'larger than')


def test_fifo_without_writer_is_not_waited_for(tmp_path):
    fifo = tmp_path / 'fifo.yaml'
    os.mkfifo(fifo)
    _, elapsed = _raises(fifo, 'expected a map')      # no writer: empty
    assert elapsed < HANG


def test_fifo_with_a_writer_is_read(tmp_path):
    fifo = tmp_path / 'fifo.yaml'
    os.mkfifo(fifo)
    text = HEADER + '    gravity: 9.5\n'
    keep = os.open(fifo, os.O_RDONLY | os.O_NONBLOCK)   # a reader: opening to write won't block
    try:
        fifo.write_text(text)        # into the pipe, which keeps it while a reader is open
        assert fsd.load_model(fifo).gravity == 9.5
    finally:
        os.close(keep)


# -- values the library and the node (rcl) would read differently ---------------------
#: Plain values that are numbers or booleans only to YAML 1.1 or only to rcl: strings
#: (or null) here, so refused by the type check wherever a number is expected.
AMBIGUOUS = ['1:30', '1:30.5', '0x10', '-0x10', '0o10', '0b101', '0x1p3', '010', '1_000', '1.0_0',
             'yes', 'no', 'on', 'off', 'Yes', 'OFF', 'y', 'n', '~', 'null', 'NULL', '',
             '2001-12-14', 'inf', '-Infinity', 'nan', '1' + '0' * 30]


@pytest.mark.parametrize('text', AMBIGUOUS)
def test_yaml11_only_and_rcl_ambiguous_values_are_refused_naming_the_key(tmp_path, text):
    error, _ = _raises(_file(tmp_path, f'bodies:\n  rod:\n    mass: {text}'),
                       "'bodies.rod.mass'", 'expected a number', 'p.yaml')
    assert error.key == 'bodies.rod.mass'
    if text:    # in a list, the element is named
        _raises(_file(tmp_path, f'friction:\n  viscous: [1.0, {text}, 1.0]'),
                'friction.viscous', 'element 1')


@pytest.mark.parametrize('text', ["'yes'", '"0x10"', "'1:30'", "'~'"])
def test_quoted_values_are_strings(tmp_path, text):
    path = _file(tmp_path, f'output:\n  frame_id: {text}')
    assert load_node_values(path)['output.frame_id'] == text[1:-1]


@pytest.mark.parametrize('text, value', [('1e3', 1000.0), ('2.5e-3', 0.0025), ('1E+1', 10.0),
                                         ('+.5', 0.5), ('5.', 5.0), ('7', 7.0)])
def test_yaml12_numbers_are_read_as_rcl_reads_them(tmp_path, text, value):
    path = _file(tmp_path, f'bodies:\n  rod:\n    mass: {text}')
    assert fsd.load_model(path).bodies['rod'].mass == value


# -- physical bounds (issue 12 #5) ----------------------------------------------------
@pytest.mark.parametrize('body, key, words', [
    ('bodies:\n  platform:\n    com: [1.0e300, 0.0, 0.0]', 'bodies.platform.com', '<= 100'),
    ('bodies:\n  platform:\n    com: [0.0, -101.0, 0.0]', 'bodies.platform.com', '>= -100'),
    ('bodies:\n  rod:\n    mass: 1.0e6', 'bodies.rod.mass', '<= 100000'),
    ('payload:\n  mass: 2.0e5', 'payload.mass', '<= 100000'),
    ('payload:\n  com: [0.0, 0.0, 200.0]', 'payload.com', 'element 2'),
    ('bodies:\n  rod:\n    inertia: [2.0e6, 0.0, 0.0, 0.0, 2.0e6, 0.0, 0.0, 0.0, 2.0e6]',
     'bodies.rod.inertia', '<= 1e+06'),
    ('friction:\n  viscous: [1.0, -1.0, 1.0]', 'friction.viscous', '>= 0'),
    ('output:\n  frame_id: ' + 'f' * 257, 'output.frame_id', 'longer than 256'),
    ('output:\n  joint_states_frame_id: ' + 'f' * 300, 'output.joint_states_frame_id',
     'longer than 256'),
    ('scene: ' + 'a/' * 2100 + '.yaml', 'scene', 'longer than 4096'),
    ('sync:\n  max_pending: 1000000', 'sync.max_pending', '<= 100000'),
    ('estimator:\n  method: backwards', 'estimator.method', "did you mean 'backward'"),
])
def test_every_parameter_is_physically_bounded(tmp_path, body, key, words):
    error, _ = _raises(_file(tmp_path, body), words)
    assert error.key == key


def test_every_number_and_string_of_the_schema_has_a_bound():
    for spec in schema.ALL_PARAMETERS:
        if spec.kind in ('double', 'double_array', 'integer'):
            assert spec.minimum is not None and spec.maximum is not None, spec.name
        elif spec.kind == 'string':
            assert spec.choices or spec.max_length, spec.name
        assert spec.range_text, spec.name


def test_long_values_are_cut_in_messages(tmp_path):
    error, _ = _raises(_file(tmp_path, 'output:\n  frame_id: ' + 'f' * 100000), 'characters')
    assert len(str(error)) < 1000


def test_body_defaults_follow_core_body_names():
    names = [spec.name.split('.')[1] for spec in schema.MODEL_PARAMETERS
             if spec.name.startswith('bodies.') and spec.name.endswith('.mass')]
    assert names == list(BODY_NAMES)


# -- scenes ---------------------------------------------------------------------------------
def _scene(tmp_path, text):
    path = tmp_path / 'my_scene.yaml'
    path.write_text(text)
    return path


EFFECTS = ('effects: {gravity: true, platform_inertia: true, payload: false, leg_inertia: true,'
           ' crank_inertia: true, velocity_products: true, friction: false}\n')


@pytest.mark.parametrize('text, words', [
    (EFFECTS.replace('gravity', 'gravty'), ["unknown effect(s): gravty", "did you mean 'gravity'"]),
    (EFFECTS + 'descripton: x\n', ['unknown key(s): descripton', "did you mean 'description'"]),
    (EFFECTS + 'parameters: {payload: {mas: 3.0}}\n',
     ["'payload.mas' is not a model parameter", "did you mean 'payload.mass'"]),
    (EFFECTS.replace('true', 'yes', 1), ['gravity', 'true or false']),
    (EFFECTS + 'parameters: {payload: {mass: 0x10}}\n', ['payload.mass', 'expected a number']),
    ('effects: &e {gravity: true}\nx: *e\n', ['anchors and aliases']),
    (BILLION_LAUGHS, ['anchors and aliases']),
])
def test_bad_scene_file_is_one_scene_error(tmp_path, text, words):
    path = _scene(tmp_path, text)
    with pytest.raises(SceneError) as info:
        fsd.load_model(scene=path)
    for word in words:
        assert word in str(info.value), (word, str(info.value))


def test_binary_or_endless_scene_file_is_one_scene_error(tmp_path):
    path = tmp_path / 'bin.yaml'
    path.write_bytes(b'\x7fELF\x00\x00')
    with pytest.raises(SceneError, match='NUL bytes'):
        fsd.load_model(scene=path)
    with pytest.raises(SceneError, match='larger than'):
        fsd.load_model(scene='/dev/zero')


def test_misspelt_scene_name_gets_did_you_mean():
    with pytest.raises(SceneError, match="did you mean 'payload'"):
        fsd.load_model(scene='paylod')


def test_packaged_files_read_by_the_strict_reader():
    values, qos = without_ros(read_params_sections(CONFIG))
    assert not qos and set(split_cueing(values, str(CONFIG))[0]) <= set(schema.SPECS)
    assert np.isclose(fsd.load_model().gravity, 9.81)


def test_a_number_followed_by_more_is_a_string_not_a_crash(tmp_path):
    """Found by the file fuzz: '1e400' then a continuation line is one plain
    scalar, '1e400 0.0, ...', which the YAML 1.2 float rule matched by its
    start; it is a string, so a ParameterError naming the key."""
    path = tmp_path / 'p.yaml'
    path.write_text('flight_sim_dynamics:\n  ros__parameters:\n    bodies:\n      piston_c:\n'
                    '        inertia: 1e400\n                  0.0, 0.1, 0.0]\n')
    with pytest.raises(ParameterError, match='bodies.piston_c.inertia'):
        fsd.load_model(path)


def test_a_file_written_by_launch_ros_is_read(tmp_path):
    """launch_ros writes a launch file's parameters given as a dict with list
    values as PyYAML tuples (!!python/tuple); rcl reads them as lists, so does
    the node's reader (its machine and values come from that file)."""
    path = tmp_path / 'launch_params_x'
    path.write_text('/sim/flight_sim_dynamics:\n  ros__parameters:\n'
                    '    machine: stewart_6dof\n'
                    '    geometry.home: !!python/tuple\n    - 0.0\n    - 0.0\n    - 1.1\n')
    values = read_params_sections(path, '/sim/flight_sim_dynamics')
    assert values == {'machine': 'stewart_6dof', 'geometry.home': [0.0, 0.0, 1.1]}
