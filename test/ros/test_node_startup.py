"""Start-up refusals (issue 12 #7): a bad parameter, params file, scene or ROS
argument ends the node with exactly one ``error:`` line on stderr and exit
status 2, never a traceback."""
from __future__ import annotations

import subprocess
import sys

import pytest

from node_harness import ROOT

pytestmark = pytest.mark.ros

CASES = {
    'negative mass': (['-p', 'bodies.platform.mass:=-1.0'], 'bodies.platform.mass'),
    'nan mass': (['-p', 'bodies.platform.mass:=.nan'], 'bodies.platform.mass'),
    # statically typed (issue 15 #2): the schema's reason, not rclpy's
    'string for a double': (['-p', 'bodies.platform.mass:=abc'], 'expected a number'),
    'bool for a double': (['-p', 'gravity:=true'], 'expected a number'),
    'strings for doubles': (['-p', 'bodies.rod.com:=[a,b,c]'], 'bodies.rod.com'),
    'double for an integer': (['-p', 'sync.max_pending:=1.5'], 'expected an integer'),
    'missing params file': (['--params-file', '{tmp}/missing.yaml'], 'missing.yaml'),
    'binary params file': (['--params-file', '{tmp}/binary.yaml'], 'binary.yaml'),
    'params file rcl cannot parse': (['--params-file', '{tmp}/mixed.yaml'], 'mixed.yaml'),
    'binary scene file': (['-p', 'scene:={tmp}/scene.yaml'], 'scene'),
    'endless scene file': (['-p', 'scene:=/dev/zero'], '/dev/zero'),
    'malformed ROS arguments': (['--remap'], 'invalid ROS arguments'),
    'bad QoS override': (['-p', 'qos_overrides./pose_setpoint.subscription.depth:=0'],
                         'depth must be >= 1'),
}


@pytest.mark.parametrize('case', sorted(CASES))
def test_bad_start_up_is_one_error_line_and_exit_2(case, tmp_path):
    (tmp_path / 'binary.yaml').write_bytes(b'\x00\x01\x02binary')
    (tmp_path / 'scene.yaml').write_bytes(b'\x00\xff' * 10)
    (tmp_path / 'mixed.yaml').write_text(
        'flight_sim_dynamics:\n  ros__parameters:\n    friction:\n'
        '      viscous: [0, 0.5, 1]\n')
    args, words = CASES[case]
    args = [a.replace('{tmp}', str(tmp_path)) for a in args]
    assert_refused('flight_sim_dynamics.ros.node', args, words)


def assert_refused(module: str, args: list[str], words: str) -> None:
    proc = subprocess.run([sys.executable, '-m', module, '--ros-args', *args],
                          cwd=ROOT, capture_output=True, text=True, timeout=60)
    assert proc.returncode == 2, proc.stdout + proc.stderr
    assert 'Traceback' not in proc.stderr + proc.stdout, proc.stderr
    errors = [line for line in proc.stderr.splitlines() if line.startswith('error:')]
    assert len(errors) == 1, proc.stderr
    assert words in errors[0], errors[0]


@pytest.mark.parametrize('module', ['flight_sim_dynamics.ros.sim_node',
                                    'flight_sim_dynamics.ros.planner'])
@pytest.mark.parametrize('case', ['missing params file', 'malformed ROS arguments'])
def test_the_other_executables_refuse_alike(module, case, tmp_path):
    """The twin and the demo planner read their arguments with the node's
    code (``node.own_options``): the planner printed a traceback for bad ROS
    arguments, the twin rcl's message for a missing params file."""
    args, words = CASES[case]
    assert_refused(module, [a.replace('{tmp}', str(tmp_path)) for a in args], words)
