"""One parameter file for the dynamics node and the motion-cueing node: the
machine and its ``cueing`` group (the defaults of the cueing node's
``cueing.*``, under its own overrides), a bad value in it ending the start
with one ``error:`` line, the 3-DOF machine's file, and the demo replaying a
vehicle log through both.
"""
from __future__ import annotations

import re
import subprocess
import sys

import pytest
import yaml
from rcl_interfaces.srv import GetParameters

from flight_sim_dynamics.config.schema import CUEING_NODE_NAME
from flight_sim_dynamics.config.files import PACKAGED_SECTION
from flight_sim_dynamics.machines import FLIGHT_SIMULATOR
from flight_sim_dynamics.ros.messages import LATE, OVERFLOW, QUIET_REASONS
from flight_sim_dynamics.ros.process import CUEING_MODULE, node_command, node_env
from cueing_harness import dynamics_counts, start_chain, write_vehicle_log
from node_harness import PARAMS_FILE, ROOT, Client, NodeProcess, stamp_ns

pytestmark = pytest.mark.ros

STEWART = ROOT / 'config' / 'stewart_6dof.yaml'


def params_file(tmp_path, **cueing):
    """The hexapod's packaged file with ``cueing`` as its cueing group."""
    doc = yaml.safe_load(STEWART.read_text())
    doc[PACKAGED_SECTION]['ros__parameters']['cueing'] = cueing
    path = tmp_path / 'hexapod.yaml'
    path.write_text(yaml.safe_dump(doc))
    return path


def test_the_files_cueing_group_gives_the_defaults_under_the_nodes_overrides(tmp_path):
    path = params_file(tmp_path, rate=250.0, tilt={'gain': [0.3, 0.4]},
                       translation={'gain': [0.2, 0.2, 0.2]})
    cue = NodeProcess('-p', 'cueing.translation.gain:=[0.1, 0.1, 0.1]', params_file=path,
                      module=CUEING_MODULE)
    client = Client('cueing_file_client')
    try:
        get = client.node.create_client(GetParameters, f'/{CUEING_NODE_NAME}/get_parameters')
        client.srv['cue_get'] = get
        client.watch = cue
        names = ['cueing.rate', 'cueing.tilt.gain', 'cueing.translation.gain',
                 'cueing.rotation.gain', 'params_file']
        values = client.call('cue_get', GetParameters.Request(names=names), timeout=20.0).values
        assert values[0].double_value == 250.0                           # the file's
        assert list(values[1].double_array_value) == [0.3, 0.4]          # the file's
        assert list(values[2].double_array_value) == [0.1, 0.1, 0.1]     # the node's own
        assert list(values[3].double_array_value) == [0.6, 0.6, 0.6]     # the default
        assert values[4].string_value == str(path)
        assert '250 Hz' in cue.output()
    finally:
        client.close()
        cue.stop()


def test_a_bad_value_in_the_files_cueing_group_ends_the_start(tmp_path):
    path = params_file(tmp_path, tilt={'gain': [0.3, 0.4, 0.5]})
    out = subprocess.run(node_command(path, module=CUEING_MODULE), env=node_env(), cwd=ROOT,
                         capture_output=True, text=True, timeout=60)
    assert out.returncode == 2, out.stdout + out.stderr
    assert out.stderr.startswith('error: ') and 'cueing.tilt.gain' in out.stderr, out.stderr


def test_the_demo_replays_a_vehicle_log_through_both_nodes(tmp_path):
    path = params_file(tmp_path, rate=200.0, translation={'omega': [3.0, 3.0, 3.0],
                                                          'omega_b': [0.0, 0.0, 0.0]},
                       rotation={'omega': [3.0, 3.0, 3.0]}, tilt={'omega': [4.0, 4.0],
                                                                   'rate_limit': 0.2})
    log = tmp_path / 'vehicle.csv'
    write_vehicle_log(log)
    png = tmp_path / 'demo.png'
    out = subprocess.run([sys.executable, '-m', 'flight_sim_dynamics.cli.demo', '-o', str(png),
                          '--params', str(path), '--cueing', '--vehicle', str(log)],
                         cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stdout + out.stderr
    assert png.stat().st_size > 10_000
    sent, received, missing = map(int, re.search(
        r'sent (\d+) setpoints, received (\d+) actuator_states \((\d+) missing\)',
        out.stdout).groups())
    # the log (2 s) and the washout back to neutral, at 200 Hz
    assert sent == received > 2 * 200 and missing == 0, out.stdout[-2000:]
    cueing = next(line for line in out.stdout.splitlines()
                  if line.startswith('[demo] cueing diagnostics'))
    accepted, rejected = map(int, re.search(r'vehicle_imu accepted (\d+), rejected (\d+)',
                                            cueing).groups())
    assert accepted >= 201 and rejected == 0, cueing      # the log's 201 samples, the probes
    node = next(line for line in out.stdout.splitlines()
                if line.startswith('[demo] node diagnostics'))
    assert 'limit exceeded 0' in node, node


def test_the_demo_refuses_a_vehicle_log_going_back_naming_its_line(tmp_path):
    log = tmp_path / 'vehicle.csv'
    log.write_text('t,f_x,f_y,f_z,omega_x,omega_y,omega_z\n0,0,0,9.8,0,0,0\n'
                   '0.01,0,0,9.8,0,0,0\n0.005,0,0,9.8,0,0,0\n')
    out = subprocess.run([sys.executable, '-m', 'flight_sim_dynamics.cli.demo', '--cueing',
                          '--vehicle', str(log), '-o', str(tmp_path / 'x.png')],
                         cwd=ROOT, capture_output=True, text=True, timeout=60)
    assert out.returncode == 2 and 'line 4' in out.stderr and 'backwards' in out.stderr, \
        out.stderr


def test_a_name_the_node_does_not_know_ends_the_start(tmp_path):
    """A typo is not dropped: the machine's own names (a '/**' section gives them
    to every node) are the only ones the cueing node passes over."""
    typo = subprocess.run(node_command(STEWART, ['-p', 'cueing.rat:=500.0'],
                                       module=CUEING_MODULE),
                          env=node_env(), cwd=ROOT, capture_output=True, text=True, timeout=60)
    assert typo.returncode == 2, typo.stdout + typo.stderr
    assert "'cueing.rat'" in typo.stderr and "did you mean 'cueing.rate'" in typo.stderr
    everyone = tmp_path / 'everyone.yaml'
    everyone.write_text(STEWART.read_text().replace(f'{PACKAGED_SECTION}:', '/**:', 1))
    cue = NodeProcess(params_file=everyone, module=CUEING_MODULE)
    try:
        assert cue.wait_output('active: cueing', 30.0), cue.output()
    finally:
        cue.stop()


def test_the_3dof_machine_is_cued_on_its_own_coordinates():
    """The packaged 3-DOF file (its cueing group: surge, heave, roll) for both
    nodes: sway, pitch and yaw not cued, every setpoint answered ok."""
    node, cue, client = start_chain(PARAMS_FILE, ('-p', 'cueing.rate:=200.0',
                                                  '-p', 'diagnostics.period:=0.25'))
    try:
        before = dynamics_counts(client)
        first, last = client.replay(2.0)
        stamps = [s for s, _ in client.poses if first <= s <= last]
        assert client.spin_until(lambda: {stamp_ns(m) for _, m in client.actuator}.issuperset(
            stamps), 5.0), 'setpoints not answered'
        after = dynamics_counts(client)
        for key in ('rejected total', 'limit exceeded', 'near singular'):
            assert after[key] == before[key], (key, before, after)
        motion = [p for s, p in client.poses if first <= s <= last]
        peak = [max(abs(p[i]) for p in motion) for i in range(6)]
        # surge, heave, roll move; sway, pitch, yaw stay at zero
        assert peak[0] > 1e-3 and peak[2] > 1e-4 and peak[3] > 1e-4, peak
        assert peak[1] == peak[4] == peak[5] == 0.0, peak
        values = client.cue_diagnostics(lambda v: True)
        assert values['channels not cued'] == 'sway, pitch, yaw'
        assert values['machine'] == FLIGHT_SIMULATOR.title
    finally:
        client.close()
        cue.stop()
        node.stop()


@pytest.mark.slow
@pytest.mark.parametrize('machine_file', [STEWART, PARAMS_FILE], ids=['hexapod', '3-DOF'])
def test_a_violent_vehicle_through_both_nodes_is_answered_ok(tmp_path, machine_file):
    """The built-in ``violent`` motion (multi-g spikes, a 10 g crash, rates up
    to 3 rad/s; 20 s) through the packaged file's cueing group and limiter at
    200 Hz: every setpoint answered, no message rejected for what it holds (a
    busy host may deliver a twist after its pose was answered: ``late``, or
    push it out of the pending stamps: ``overflow``; and may match the
    dynamics node's three subscriptions to the cueing node's publishers at
    different moments, the first messages then ``joining`` or ``warming_up``,
    the node's quiet reasons), no actuator limit exceeded."""
    png = tmp_path / 'violent.png'
    out = subprocess.run([sys.executable, '-m', 'flight_sim_dynamics.cli.demo', '-o', str(png),
                          '--params', str(machine_file), '--cueing', '--vehicle', 'violent',
                          '--rate', '200'],
                         cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stdout + out.stderr
    sent, received, missing = map(int, re.search(
        r'sent (\d+) setpoints, received (\d+) actuator_states \((\d+) missing\)',
        out.stdout).groups())
    assert sent == received > 20 * 200 and missing == 0, out.stdout[-2000:]
    node = next(line for line in out.stdout.splitlines()
                if line.startswith('[demo] node diagnostics'))
    assert 'limit exceeded 0' in node, node
    rejected = re.search(r'rejected (\d+)(?: \(([^)]*)\))?,', node)
    reasons = {part.split()[0] for part in (rejected.group(2) or '').split(', ') if part}
    assert reasons <= {LATE, OVERFLOW} | QUIET_REASONS, node
    assert (int(rejected.group(1)) == 0) == (not reasons), node
