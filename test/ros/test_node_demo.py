"""The README's demo and the entry points' --help."""
from __future__ import annotations

import re
import subprocess
import sys

import numpy as np
import pytest

import flight_sim_dynamics as fsd
from node_harness import ROOT

pytestmark = pytest.mark.ros


@pytest.mark.parametrize('module', ['ros.node', 'ros.planner', 'ros.motion_cueing', 'cli.demo'])
def test_help(module):
    out = subprocess.run([sys.executable, '-m', f'flight_sim_dynamics.{module}', '--help'],
                         cwd=ROOT, capture_output=True, text=True, timeout=30)
    assert out.returncode == 0, out.stderr
    assert 'usage' in out.stdout


def fine(line: str) -> bool:
    """The demo's last status: OK, or WARN for a twist or accel that arrived
    after its setpoint was answered (a busy host delays one stream; every
    setpoint is still answered, asserted apart), nothing else.
    """
    return bool(re.search(r'status (OK|WARN \(rejected \(late\)\))$', line))


def test_demo_runs_and_plots(tmp_path):
    png = tmp_path / 'demo.png'
    out = subprocess.run([sys.executable, '-m', 'flight_sim_dynamics.cli.demo', '-o', str(png),
                          '--motions', 'vertical', '--rate', '100'],
                         cwd=ROOT, capture_output=True, text=True, timeout=60)
    assert out.returncode == 0, out.stdout + out.stderr
    assert png.stat().st_size > 10_000
    lines = [line for line in out.stdout.splitlines() if 'rate' in line and 'forces A/B/C' in line]
    assert len(lines) >= 2, out.stdout
    assert fine(lines[-1]), lines[-1]
    sent, received, missing = map(int, re.search(
        r'sent (\d+) setpoints, received (\d+) actuator_states \((\d+) missing\)',
        out.stdout).groups())
    assert sent == received == 301 and missing == 0, out.stdout[-2000:]


@pytest.mark.slow
def test_demo_on_the_hexapod_with_the_twin(tmp_path):
    """``demo --params config/stewart_6dof.yaml --twin``: node, planner and twin
    on the hexapod; every setpoint of the motion-cueing sequence (7.5 s at
    100 Hz) answered with six forces, the twin's six coordinates plotted
    against the commanded ones and tracking them (RMS errors against the motion's)."""
    png = tmp_path / 'demo.png'
    out = subprocess.run([sys.executable, '-m', 'flight_sim_dynamics.cli.demo', '-o', str(png),
                          '--params', str(ROOT / 'config' / 'stewart_6dof.yaml'),
                          '--motions', 'cueing', '--rate', '100', '--twin'],
                         cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stdout + out.stderr
    assert png.stat().st_size > 10_000 and (tmp_path / 'demo_twin.png').stat().st_size > 10_000
    lines = [line for line in out.stdout.splitlines() if 'forces 1/2/3/4/5/6' in line]
    assert len(lines) >= 2 and fine(lines[-1]), out.stdout
    assert len(lines[-1].split('forces 1/2/3/4/5/6')[1].split('N')[0].split()) == 6
    sent, received, missing = map(int, re.search(
        r'sent (\d+) setpoints, received (\d+) actuator_states \((\d+) missing\)',
        out.stdout).groups())
    assert sent == received == 751 and missing == 0, out.stdout[-2000:]
    twin = next(line for line in out.stdout.splitlines() if line.startswith('[demo] twin: '))
    rms = {name: float(v) * 1e-3 for name, v in
           re.findall(r'(surge|sway|heave|roll|pitch|yaw) [\d.]+ / ([\d.]+) m', twin)}
    machine = fsd.machine_of(fsd.load_model(ROOT / 'config' / 'stewart_6dof.yaml'))
    assert set(rms) == set(machine.coordinates), twin
    # each coordinate's RMS error against the RMS of its motion about the start (a
    # twin that stays there: 100 %; wrong sign: 200 %); beside the test tiers up to
    # 23 % (surge, 12 mm of 52), where late commands spiked the max to 87 mm (a quiet
    # host: max errors of 1-4 mm or mrad)
    _, q, _, _ = machine.motions['cueing'].sampled(100.0)
    moved = np.sqrt(np.mean((q - q[0]) ** 2, axis=0))
    for name, motion in zip(machine.coordinates, moved):
        assert rms[name] < 0.5 * motion, (name, twin)
