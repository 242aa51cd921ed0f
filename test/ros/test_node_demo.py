"""The README's demo and the entry points' --help."""
from __future__ import annotations

import re
import subprocess
import sys

import pytest

from node_harness import ROOT

pytestmark = pytest.mark.ros


@pytest.mark.parametrize('module', ['ros.node', 'ros.planner', 'cli.demo'])
def test_help(module):
    out = subprocess.run([sys.executable, '-m', f'flight_sim_dynamics.{module}', '--help'],
                         cwd=ROOT, capture_output=True, text=True, timeout=30)
    assert out.returncode == 0, out.stderr
    assert 'usage' in out.stdout


def test_demo_runs_and_plots(tmp_path):
    png = tmp_path / 'demo.png'
    out = subprocess.run([sys.executable, '-m', 'flight_sim_dynamics.cli.demo', '-o', str(png),
                          '--motions', 'vertical', '--rate', '100'],
                         cwd=ROOT, capture_output=True, text=True, timeout=60)
    assert out.returncode == 0, out.stdout + out.stderr
    assert png.stat().st_size > 10_000
    lines = [line for line in out.stdout.splitlines() if 'rate' in line and 'forces A/B/C' in line]
    assert len(lines) >= 2, out.stdout
    assert 'status OK' in lines[-1]
    sent, received, missing = map(int, re.search(
        r'sent (\d+) setpoints, received (\d+) actuator_states \((\d+) missing\)',
        out.stdout).groups())
    assert sent == received == 301 and missing == 0, out.stdout[-2000:]
