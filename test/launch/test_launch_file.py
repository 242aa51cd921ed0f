"""launch/flight_sim_dynamics.launch.py: for ROS installs (``launch`` and
``launch_ros`` are not on PyPI, so this test skips itself without them). It
loads the launch description and checks its arguments and actions; the
node it starts is tested as a process in test/ros/.
"""
from __future__ import annotations

import importlib.util
from pathlib import Path

import pytest

pytestmark = pytest.mark.ros

LAUNCH_FILE = Path(__file__).resolve().parents[2] / 'launch' / 'flight_sim_dynamics.launch.py'


def test_launch_file_is_installed_with_the_package():
    """setup.py installs every launch/*.launch.py to share/<package>/launch."""
    setup = (LAUNCH_FILE.parents[1] / 'setup.py').read_text()
    assert LAUNCH_FILE.is_file()
    assert "'/launch', sorted(glob('launch/*.launch.py'))" in setup


def test_launch_description_declares_its_arguments():
    pytest.importorskip('launch')
    pytest.importorskip('launch_ros')
    from launch.actions import DeclareLaunchArgument
    spec = importlib.util.spec_from_file_location('fsd_launch', LAUNCH_FILE)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    description = module.generate_launch_description()
    names = {a.name for a in description.entities if isinstance(a, DeclareLaunchArgument)}
    assert names == {'params_file', 'namespace', 'scene', 'autostart', 'planner',
                     'use_sim_time', 'twin'}
