"""Where the plugin of test/plugin_machine lives: ``site/`` holds its module
and its dist-info (the folder a test puts on the path), its parameter file."""
from __future__ import annotations

from pathlib import Path

HERE = Path(__file__).resolve().parent
DIST = HERE / 'site'
PARAMS = HERE / 'tilt_2dof.yaml'
NAME = 'tilt_2dof'
HEADER = 'flight_sim_dynamics:\n  ros__parameters:\n'
