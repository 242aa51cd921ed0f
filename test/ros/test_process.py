"""How the node, the twin and the marker renderer are started as processes
(ros/process.py): the command line and the package the child imports.
"""
from __future__ import annotations

import os
import re
import subprocess
import sys
import sysconfig
from pathlib import Path

import pytest

from flight_sim_dynamics.ros import process
from node_harness import ROOT


def test_children_run_with_a_safe_sys_path():
    """``python -m`` puts the working directory first on sys.path: a child started
    in a source checkout would import the un-built source tree (no compiled
    kernel) instead of the package the parent runs. -P leaves it out.
    """
    cmd = process.node_command('p.yaml', ['-p', 'a:=1'], module=process.SIM_MODULE)
    assert cmd[0] == sys.executable
    assert '-P' in cmd[1:cmd.index('-m')]
    assert cmd[cmd.index('-m') + 1] == process.SIM_MODULE
    assert process.python_module('x.y')[-2:] == ['-m', 'x.y']
    assert '-P' in process.python_module('x.y')


def _imported_package(cwd: Path, package_parent: str, monkeypatch) -> str:
    """Where a child started by :func:`process.python_module` in ``cwd`` takes
    ``flight_sim_dynamics`` from, the parent's package being in ``package_parent``.
    """
    monkeypatch.setattr(process, 'PACKAGE_PARENT', package_parent)
    env = process.node_env(dict(os.environ, PYTHONVERBOSE='1'))
    out = subprocess.run([*process.python_module(process.SIM_MODULE), '--help'], cwd=cwd,
                         env=env, capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr[-2000:]
    # python -v: "# code object from '<folder>/flight_sim_dynamics/[__pycache__/]__init__..."
    found = re.search(r"(/[^\s']*)/flight_sim_dynamics/(?:__pycache__/)?__init__\.",
                      out.stderr)
    assert found, out.stderr[-2000:]
    return str(Path(found.group(1)).resolve())


@pytest.mark.ros
def test_a_child_started_at_the_repository_root_imports_the_installed_package(monkeypatch):
    """The demo run from the repository root as the README writes it: the
    console script's package is the installed one; its children take that one too.
    """
    installed = sysconfig.get_paths()['purelib']
    if not (Path(installed) / 'flight_sim_dynamics' / '__init__.py').is_file():
        pytest.skip('flight_sim_dynamics is not installed in this interpreter')
    assert (ROOT / 'flight_sim_dynamics' / '__init__.py').is_file()
    assert _imported_package(ROOT, installed, monkeypatch) == str(Path(installed).resolve())


@pytest.mark.ros
def test_a_child_ignores_a_package_in_its_working_directory(tmp_path, monkeypatch):
    decoy = tmp_path / 'flight_sim_dynamics'
    decoy.mkdir()
    (decoy / '__init__.py').write_text("raise ImportError('the decoy was imported')\n")
    assert _imported_package(tmp_path, process.PACKAGE_PARENT, monkeypatch) == \
        str(Path(process.PACKAGE_PARENT).resolve())
