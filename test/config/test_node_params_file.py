"""The node reads a parameter file by the same rule as load_model (issue 14
#5): the node as a separate process; and ROS 2's own parser (rcl, which
reads --params-file for the node) reads every value the library accepts as
the library does (issue 12 #10)."""
import json
import math
import subprocess
import sys
import textwrap

import pytest

import flight_sim_dynamics as fsd
from flight_sim_dynamics.config import yaml_io
from flight_sim_dynamics.config.errors import ParameterError
from node_harness import ROOT, Client, NodeProcess

pytestmark = pytest.mark.ros

HEADER = 'flight_sim_dynamics:\n  ros__parameters:\n'


def _start(params_file) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, '-m', 'flight_sim_dynamics.ros.node',
                           '--ros-args', '--params-file', str(params_file)],
                          cwd=ROOT, capture_output=True, text=True, timeout=60)


def test_unknown_name_in_params_file_refuses_to_start(tmp_path):
    path = tmp_path / 'typo.yaml'
    path.write_text(HEADER + '    geometry:\n      d7: 0.4\n')
    proc = _start(path)
    out = proc.stdout + proc.stderr
    assert proc.returncode == 2, out
    assert "'geometry.d7'" in out and "did you mean 'geometry.d5'?" in out
    assert str(path) in out
    assert 'Traceback' not in out


@pytest.mark.parametrize('value, words', [('1:30', 'expected a number'),
                                          ('0x10', 'expected a number'),
                                          ('1.0e6', '<= 100000')])
def test_value_the_library_refuses_refuses_the_node_too(tmp_path, value, words):
    path = tmp_path / 'bad.yaml'
    path.write_text(HEADER + f'    bodies:\n      rod:\n        mass: {value}\n')
    proc = _start(path)
    out = proc.stdout + proc.stderr
    assert proc.returncode == 2, out
    assert 'bodies.rod.mass' in out and words in out


def test_partial_file_with_qos_overrides_runs_the_node(tmp_path):
    """One mass and a QoS override: the node starts (packaged values for the
    rest) with the file's mass and QoS; load_model reads the same file."""
    path = tmp_path / 'partial.yaml'
    path.write_text(HEADER + '    bodies:\n      platform:\n        mass: 6.5\n'
                    '    qos_overrides:\n      /pose_setpoint:\n        subscription:\n'
                    '          depth: 50\n')
    assert fsd.load_model(path).bodies['platform'].mass == 6.5
    node = NodeProcess(params_file=path)
    client = Client('partial_file_client')
    try:
        client.wait_for_node(node)
        assert client.get_params(['bodies.platform.mass', 'bodies.rod.mass',
                                  'qos_overrides./pose_setpoint.subscription.depth']) \
            == [6.5, 1.5, 50]
    finally:
        client.close()
        assert node.stop() == 0, node.output()


def test_parameters_ros_owns_are_accepted_in_a_params_file(tmp_path):
    """use_sim_time and start_type_description_service, as every ROS node
    takes them (launch's parameters=[{'use_sim_time': True}] writes such a
    file): the node starts on sim time; load_model ignores them."""
    path = tmp_path / 'ros.yaml'
    path.write_text(HEADER + '    use_sim_time: true\n    start_type_description_service: false\n'
                    '    bodies:\n      platform:\n        mass: 6.5\n')
    assert fsd.load_model(path).bodies['platform'].mass == 6.5
    node = NodeProcess(params_file=path)
    client = Client('ros_owned_client')
    try:
        client.wait_for_node(node)
        assert client.get_params(['use_sim_time', 'bodies.platform.mass']) == [True, 6.5]
    finally:
        client.close()
        assert node.stop() == 0, node.output()


#: Values the library accepts, each with what the library reads.
ACCEPTED = ['9.81', '1e3', '2.5e-3', '1E+1', '+.5', '5.', '7', '-0', '.inf', '-.inf', '.nan',
            "'yes'", '"0x10"', 'true', 'false', 'simulator_base', '[1.0, 2.0e-3, 3.]',
            '[1, 2, 3]', '[true, false]', '[a, b]', '9223372036854775807']

_RCL_READER = textwrap.dedent('''
    import json, math, sys
    import rclpy
    from rclpy.node import Node
    rclpy.init(args=['reader', '--ros-args', '--params-file', sys.argv[1]])
    node = Node('reader_node', automatically_declare_parameters_from_overrides=True)
    out = {}
    for name in sorted(node.list_parameters([], 0).names):
        value = node.get_parameter(name).value
        if isinstance(value, (list, tuple)) or hasattr(value, 'tolist'):
            value = list(value)
        out[name] = repr(value)
    print(json.dumps(out))
''')


def test_rcl_reads_every_accepted_value_as_the_library_does(tmp_path):
    path = tmp_path / 'values.yaml'
    path.write_text('reader_node:\n  ros__parameters:\n'
                    + ''.join(f'    k{i}: {text}\n' for i, text in enumerate(ACCEPTED)))
    ours = yaml_io.read_yaml(path)['reader_node']['ros__parameters']
    proc = subprocess.run([sys.executable, '-c', _RCL_READER, str(path)], capture_output=True,
                          text=True, timeout=60)
    assert proc.returncode == 0, proc.stderr
    rcl = json.loads(proc.stdout.strip().splitlines()[-1])
    for i, text in enumerate(ACCEPTED):
        mine = ours[f'k{i}']
        assert rcl[f'k{i}'] == repr(mine), (text, rcl[f'k{i}'], mine)


def test_what_rcl_reads_differently_is_refused_as_a_number(tmp_path):
    """Plain values that rcl reads otherwise than the library (YAML 1.1 forms,
    C number syntax): wherever the library expects a number, it refuses them,
    naming the key; so the library and the node never run on different
    numbers. The comparison with rcl is made here, so the list stays honest."""
    values = ['1:30', '0b101', '0x10', '010', '1_000', '~', 'null', '2001-12-14', 'y', 'yes',
              'off', 'inf', 'nan', '0x1p3', '99999999999999999999', '!!float 1']
    path = tmp_path / 'values.yaml'
    path.write_text('reader_node:\n  ros__parameters:\n'
                    + ''.join(f'    k{i}: {text}\n' for i, text in enumerate(values)))
    ours = yaml_io.read_yaml(path)['reader_node']['ros__parameters']
    proc = subprocess.run([sys.executable, '-c', _RCL_READER, str(path)], capture_output=True,
                          text=True, timeout=60)
    assert proc.returncode == 0, proc.stderr
    rcl = json.loads(proc.stdout.strip().splitlines()[-1])
    differing = 0
    for i, text in enumerate(values):
        theirs = eval(rcl[f'k{i}'], {'__builtins__': {}}, {'inf': math.inf, 'nan': math.nan})
        mine = ours[f'k{i}']
        if type(theirs) is type(mine) or {type(theirs), type(mine)} == {int, float}:
            if theirs == mine or (theirs != theirs and mine != mine):    # nan: nan
                continue
        differing += 1
        one = tmp_path / f'one{i}.yaml'
        one.write_text(f'flight_sim_dynamics:\n  ros__parameters:\n    gravity: {text}\n')
        with pytest.raises(ParameterError, match='gravity'):
            fsd.load_model(one)
    assert differing >= len(values) // 2        # the list is of values that do differ
