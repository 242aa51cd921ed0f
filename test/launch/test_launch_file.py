"""launch/flight_sim_dynamics.launch.py. ``launch`` and ``launch_ros`` are
not on PyPI: the launch description itself is checked only where they are
installed (a ROS install; skipped otherwise). Which file each machine gets,
and what the node, the twin and the planner are given, is checked everywhere:
the launch file runs against minimal stand-ins of the few launch classes it
uses, which record what it builds.
"""
from __future__ import annotations

import importlib.util
import sys
import types
from pathlib import Path

import pytest

from flight_sim_dynamics.config.files import read_params_sections
from flight_sim_dynamics.config.machine_files import launch_params_file

ROOT = Path(__file__).resolve().parents[2]
LAUNCH_FILE = ROOT / 'launch' / 'flight_sim_dynamics.launch.py'
ARGUMENTS = {'machine', 'params_file', 'namespace', 'scene', 'autostart', 'planner',
             'use_sim_time', 'twin', 'cueing'}


def load(name: str = 'fsd_launch'):
    spec = importlib.util.spec_from_file_location(name, LAUNCH_FILE)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_launch_file_is_installed_with_the_package():
    """setup.py installs every launch/*.launch.py to share/<package>/launch."""
    setup = (LAUNCH_FILE.parents[1] / 'setup.py').read_text()
    assert LAUNCH_FILE.is_file()
    assert "'/launch', sorted(glob('launch/*.launch.py'))" in setup


def test_machine_picks_the_packaged_file_and_params_file_ones_own():
    config = ROOT / 'config'
    assert launch_params_file() == config / 'flight_sim_dynamics.yaml'
    assert launch_params_file('stewart_6dof') == config / 'stewart_6dof.yaml'
    assert launch_params_file('stewart_tsai2000') == config / 'stewart_tsai2000.yaml'
    assert launch_params_file('flight_sim_dynamics') == config / 'flight_sim_dynamics.yaml'
    assert launch_params_file('', '/tmp/mine.yaml') == Path('/tmp/mine.yaml')
    with pytest.raises(ValueError, match='stewart_6dof'):       # did you mean
        launch_params_file('stewart6dof')
    with pytest.raises(ValueError, match='not both'):
        launch_params_file('stewart_6dof', '/tmp/mine.yaml')


class _Recorded:
    """A launch class's stand-in: keeps what it was built with."""

    def __init__(self, *args, **kwargs) -> None:
        self.args, self.kwargs = args, kwargs


class _Configuration:
    def __init__(self, name: str) -> None:
        self.name = name

    def perform(self, context: dict[str, str]) -> str:
        return context[self.name]


def _stand_ins(monkeypatch) -> None:
    modules = {name: types.ModuleType(name) for name in (
        'launch', 'launch.actions', 'launch.substitutions', 'launch_ros', 'launch_ros.actions')}
    modules['launch'].LaunchDescription = _Recorded
    modules['launch.actions'].DeclareLaunchArgument = _Recorded
    modules['launch.actions'].OpaqueFunction = _Recorded
    modules['launch.substitutions'].LaunchConfiguration = _Configuration
    modules['launch_ros.actions'].LifecycleNode = type('LifecycleNode', (_Recorded,), {})
    modules['launch_ros.actions'].Node = type('Node', (_Recorded,), {})
    for name, module in modules.items():
        monkeypatch.setitem(sys.modules, name, module)


def launched(monkeypatch, **given: str) -> dict[str, _Recorded]:
    """The actions the launch file builds for the arguments ``given`` (the
    declared defaults for the rest), by executable."""
    _stand_ins(monkeypatch)
    description = load('fsd_launch_stand_ins').generate_launch_description()
    entities = description.args[0]
    declared = {e.args[0]: e.kwargs['default_value'] for e in entities
                if e.args and e.kwargs.get('default_value') is not None}
    assert set(declared) == ARGUMENTS
    context = {**declared, **given}
    function, = (e.kwargs['function'] for e in entities if 'function' in e.kwargs)
    return {node.kwargs['executable']: node for node in function(context)}


def test_the_hexapod_is_launched_with_its_packaged_file(monkeypatch):
    stewart = str(ROOT / 'config' / 'stewart_6dof.yaml')
    nodes = launched(monkeypatch, machine='stewart_6dof', twin='true', planner='true')
    # a path in launch_ros's parameters reaches the node as --params-file PATH
    assert nodes['dynamics_node'].kwargs['parameters'] == [
        stewart, {'autostart': True, 'use_sim_time': False}]
    assert read_params_sections(stewart)['machine'] == 'stewart_6dof'
    assert type(nodes['dynamics_node']).__name__ == 'LifecycleNode'
    twin = nodes['platform_sim'].kwargs
    assert twin['parameters'][0]['plant.params_file'] == stewart
    assert twin['remappings'] == [('actuator_commands', 'actuator_states')]
    arguments = nodes['flight-sim-dynamics'].kwargs['arguments']
    assert arguments[arguments.index('--params') + 1] == stewart


def test_a_namespaced_node_gets_the_packaged_file_itself(monkeypatch):
    """The node in a namespace is handed the file, as --params-file hands it: the
    packaged files' section reaches it by rcl's rule (``/**/flight_sim_dynamics``)."""
    stewart = str(ROOT / 'config' / 'stewart_6dof.yaml')
    nodes = launched(monkeypatch, machine='stewart_6dof', namespace='sim')
    assert nodes['dynamics_node'].kwargs['namespace'].name == 'namespace'
    assert nodes['dynamics_node'].kwargs['parameters'][0] == stewart
    values = read_params_sections(stewart, '/sim/flight_sim_dynamics')
    assert values == read_params_sections(stewart) and values['machine'] == 'stewart_6dof'


def test_the_default_is_the_3dof_machine_and_a_params_file_wins(monkeypatch, tmp_path):
    nodes = launched(monkeypatch)
    assert set(nodes) == {'dynamics_node'}
    assert nodes['dynamics_node'].kwargs['parameters'] == [
        str(ROOT / 'config' / 'flight_sim_dynamics.yaml'),
        {'autostart': True, 'use_sim_time': False}]
    mine = tmp_path / 'mine.yaml'
    mine.write_text('/sim/flight_sim_dynamics:\n  ros__parameters:\n    limits:\n'
                    '      max_force: 900.0\n/other:\n  ros__parameters:\n    gravity: 1.0\n')
    nodes = launched(monkeypatch, params_file=str(mine), scene='payload', twin='true',
                     namespace='sim')
    assert nodes['dynamics_node'].kwargs['parameters'] == [
        str(mine), {'autostart': True, 'use_sim_time': False, 'scene': 'payload'}]
    assert read_params_sections(mine, '/sim/flight_sim_dynamics') == {'limits.max_force': 900.0}
    assert nodes['platform_sim'].kwargs['parameters'][0]['plant.params_file'] == str(mine)
    with pytest.raises(ValueError, match='not packaged'):
        launched(monkeypatch, machine='hexapod')


def test_the_cueing_flag_starts_motion_cueing_on_the_nodes_file(monkeypatch):
    stewart = str(ROOT / 'config' / 'stewart_6dof.yaml')
    nodes = launched(monkeypatch, machine='stewart_6dof', cueing='true', twin='true',
                     namespace='sim', scene='payload', autostart='false')
    assert set(nodes) == {'dynamics_node', 'motion_cueing', 'platform_sim'}
    cueing = nodes['motion_cueing']
    assert type(cueing).__name__ == 'LifecycleNode'
    assert cueing.kwargs['name'] == 'motion_cueing'
    assert cueing.kwargs['namespace'].name == 'namespace'
    assert cueing.kwargs['parameters'] == [{'params_file': stewart, 'autostart': False,
                                            'use_sim_time': False, 'scene': 'payload'}]
    assert 'motion_cueing' not in launched(monkeypatch, machine='stewart_6dof')


@pytest.mark.ros
def test_launch_description_declares_its_arguments():
    pytest.importorskip('launch')
    pytest.importorskip('launch_ros')
    from launch.actions import DeclareLaunchArgument
    description = load().generate_launch_description()
    names = {a.name for a in description.entities if isinstance(a, DeclareLaunchArgument)}
    assert names == ARGUMENTS
