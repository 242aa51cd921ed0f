"""A third machine as a plugin (issue 30): the 2-DOF tilt platform of
site/fsd_tilt_2dof.py, found through the real entry-point mechanism (the folder
site/ holds the module and its fsd_tilt_2dof-0.1.dist-info, put on the path:
in-process by a fixture, for subprocesses by PYTHONPATH), served by the shared
code with nothing of it named there: load_model, solve, solve_batch, the
command line's solve and simulate, the dynamics node. Its forces are checked
against a reference written here apart from the plugin: the statics of the
platform's free body, finite differences of its leg lengths, and the power
balance f . dL/dt = dE/dt."""
from __future__ import annotations

import csv
import importlib
import io
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import flight_sim_dynamics as fsd
from flight_sim_dynamics import machines as registry
from flight_sim_dynamics.config.errors import ParameterError
from flight_sim_dynamics.core.interpolation import Reference
from plugin_site import DIST, HEADER, NAME, PARAMS

def plugin_env() -> dict[str, str]:
    """A subprocess's environment: the plugin's folder on PYTHONPATH (the
    package itself the installed one)."""
    env = dict(os.environ)
    env['PYTHONPATH'] = str(DIST) + (os.pathsep + env['PYTHONPATH'] if env.get('PYTHONPATH')
                                     else '')
    env.pop('FLIGHT_SIM_DYNAMICS_DEBUG', None)
    env['MPLBACKEND'] = 'Agg'
    return env


def cli(*args: str, cwd: Path) -> subprocess.CompletedProcess:
    """The installed command line, as a user runs it."""
    exe = shutil.which('flight-sim-dynamics', path=str(Path(sys.executable).parent))
    command = [exe] if exe else [sys.executable, '-m', 'flight_sim_dynamics']
    return subprocess.run(command + list(args), cwd=cwd, env=plugin_env(),
                          capture_output=True, text=True, timeout=300)


# -- the independent reference (the file's numbers, read here by yaml) ------------------
def reference_params() -> dict:
    import yaml
    p = yaml.safe_load(PARAMS.read_text())['flight_sim_dynamics']['ros__parameters']
    return {'a': p['geometry']['arm'], 'h': p['geometry']['depth'], 'g': p['gravity'],
            'm': p['platform']['mass'], 'c': np.array(p['platform']['com'], dtype=float),
            'I': np.array(p['platform']['inertia'], dtype=float).reshape(3, 3)}


def rotation(q) -> np.ndarray:
    """R = Rx(roll) Ry(pitch): intrinsic x then y (scipy)."""
    # (imported here: at module level every xdist worker paid 0.18 s for it at collection)
    from scipy.spatial.transform import Rotation
    return Rotation.from_euler('XY', q).as_matrix()


def legs(p: dict, q) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(platform points in the world, base points, leg lengths)."""
    a, h = p['a'], p['h']
    local = np.array([[a, 0.0, 0.0], [0.0, a, 0.0]])
    world = local @ rotation(q).T
    base = local - [0.0, 0.0, h]
    return world, base, np.linalg.norm(world - base, axis=1)


def static_forces(p: dict, q) -> np.ndarray:
    """Forces holding the platform at rest at q: the moments about the post's
    top of the legs' forces and of the weight, along the universal joint's two
    axes (base x, the platform's y), vanish (the joint takes the rest)."""
    world, base, length = legs(p, q)
    unit = (world - base) / length[:, None]
    axes = (np.array([1.0, 0.0, 0.0]), rotation([q[0], 0.0]) @ [0.0, 1.0, 0.0])
    weight = np.cross(rotation(q) @ p['c'], [0.0, 0.0, -p['m'] * p['g']])
    A = np.array([[axis @ np.cross(world[i], unit[i]) for i in range(2)] for axis in axes])
    return np.linalg.solve(A, -np.array([axis @ weight for axis in axes]))


def energy(p: dict, q_of_t, t: float, dt: float = 1e-5) -> float:
    """Kinetic plus potential energy at t: the angular velocity from dR/dt R^T
    (central differences), inertia about the post's top by parallel axes."""
    R = rotation(q_of_t(t))
    Rdot = (rotation(q_of_t(t + dt)) - rotation(q_of_t(t - dt))) / (2 * dt)
    W = Rdot @ R.T
    omega = np.array([W[2, 1], W[0, 2], W[1, 0]])
    c = p['c']
    I_O = p['I'] + p['m'] * (c @ c * np.eye(3) - np.outer(c, c))
    return 0.5 * omega @ (R @ I_O @ R.T) @ omega + p['m'] * p['g'] * (R @ c)[2]


def wobble(t: float) -> np.ndarray:
    """A motion written here: q(t), smooth, not from rest."""
    return np.array([0.12 * np.sin(1.3 * t) + 0.02, -0.09 * np.sin(2.1 * t + 0.4)])


def wobble_rates(t: float, dt: float = 1e-5) -> tuple[np.ndarray, np.ndarray]:
    qd = (wobble(t + dt) - wobble(t - dt)) / (2 * dt)
    qdd = np.array([-0.12 * 1.3 ** 2 * np.sin(1.3 * t),
                    0.09 * 2.1 ** 2 * np.sin(2.1 * t + 0.4)])
    return qd, qdd


# -- found through its entry point -------------------------------------------------------
def test_the_plugin_is_a_machine_of_the_registry(plugin):
    assert plugin.name == NAME and plugin.dof == 2
    names = [m.name for m in registry.machines()]
    assert names[0] == registry.DEFAULT and NAME in names
    assert NAME in registry.known_names()
    assert fsd.machine_of(fsd.load_model(PARAMS)) is plugin


def test_without_its_folder_on_the_path_it_is_no_machine(tmp_path):
    registry.clear_cache()
    assert NAME not in [m.name for m in registry.machines()]
    path = tmp_path / 'p.yaml'
    path.write_text(PARAMS.read_text())
    with pytest.raises(ParameterError) as info:
        fsd.load_model(path)
    assert info.value.key == 'machine' and 'stewart_6dof' in str(info.value)


def test_a_broken_plugin_is_left_out_with_a_warning_naming_its_entry_point(monkeypatch,
                                                                          tmp_path):
    info = tmp_path / 'broken-1.0.dist-info'
    info.mkdir()
    (info / 'METADATA').write_text('Metadata-Version: 2.1\nName: broken\nVersion: 1.0\n')
    (info / 'entry_points.txt').write_text('[flight_sim_dynamics.machines]\n'
                                           'broken = no_such_module_here:MACHINE\n')
    monkeypatch.syspath_prepend(str(tmp_path))
    importlib.invalidate_caches()
    registry.clear_cache()
    try:
        with pytest.warns(registry.MachinePluginWarning, match='broken = no_such_module_here'):
            names = [m.name for m in registry.machines()]
        assert names[:2] == ['flight_simulator_3dof', 'stewart'] and 'broken' not in names
        assert fsd.solve(fsd.load_model(), [0.0] * 3, [0.0] * 3, [0.0] * 3).status == 'ok'
        path = tmp_path / 'b.yaml'
        path.write_text(HEADER + '    machine: broken\n')
        with pytest.raises(ParameterError) as error:
            fsd.load_model(path)
        assert error.value.key == 'machine'
        assert 'no_such_module_here' in str(error.value) and 'ModuleNotFoundError' in str(
            error.value)
    finally:
        monkeypatch.undo()
        registry.clear_cache()


# -- its forces against the reference --------------------------------------------------
@pytest.mark.parametrize('q', [(0.0, 0.0), (0.15, -0.1), (-0.2, 0.25), (0.05, 0.3)])
def test_statics_match_the_free_body_closed_form(model, q):
    sol = fsd.solve(model, q, [0.0, 0.0], [0.0, 0.0])
    assert sol.status == 'ok', sol.detail
    np.testing.assert_allclose(sol.force, static_forces(reference_params(), q), rtol=1e-9,
                               atol=1e-9)


def test_home_statics_by_hand(model):
    """At home the legs are vertical: f1 a = m g c_x, f2 a = m g c_y."""
    p = reference_params()
    f = fsd.solve(model, [0.0, 0.0], [0.0, 0.0], [0.0, 0.0]).force
    np.testing.assert_allclose(f, [p['m'] * p['g'] * p['c'][0] / p['a'],
                                   p["m"] * p["g"] * p["c"][1] / p["a"]], rtol=1e-12)


@pytest.mark.parametrize('t', [0.3, 1.7])
def test_lengths_rates_and_accelerations_by_finite_differences(model, t):
    p, dt = reference_params(), 1e-4
    qd, qdd = wobble_rates(t)
    sol = fsd.solve(model, wobble(t), qd, qdd)
    lengths = [legs(p, wobble(s))[2] for s in (t - dt, t, t + dt)]
    np.testing.assert_allclose(sol.length, lengths[1], rtol=1e-12)
    np.testing.assert_allclose(sol.stroke, lengths[1] - p['h'], atol=1e-12)
    np.testing.assert_allclose(sol.rate, (lengths[2] - lengths[0]) / (2 * dt), atol=1e-8)
    np.testing.assert_allclose(sol.acceleration,
                               (lengths[2] - 2 * lengths[1] + lengths[0]) / dt ** 2, atol=1e-5)
    np.testing.assert_allclose(sol.jacobian @ qd, sol.rate, atol=1e-12)


@pytest.mark.parametrize('t', [0.6, 2.2])
def test_power_balance(model, t):
    """f . dL/dt = dE/dt (massless legs, no friction: the legs' power is the
    platform's energy rate)."""
    p, dt = reference_params(), 1e-4
    qd, qdd = wobble_rates(t)
    sol = fsd.solve(model, wobble(t), qd, qdd)
    dE = (energy(p, wobble, t + dt) - energy(p, wobble, t - dt)) / (2 * dt)
    np.testing.assert_allclose(sol.power, sol.force * sol.rate)
    assert float(np.sum(sol.power)) == pytest.approx(dE, rel=1e-5, abs=1e-6)


def test_solve_batch_is_solve_row_by_row_and_statuses(model):
    q = np.array([[0.0, 0.0], [0.1, -0.2], [np.nan, 0.0], [0.0, 0.8]])
    qd = np.array([[0.0, 0.0], [0.3, 0.1], [0.0, 0.0], [0.0, 0.0]])
    qdd = np.array([[1.0, 0.0], [-0.5, 2.0], [0.0, 0.0], [0.0, 0.0]])
    batch = fsd.solve_batch(model, q, qd, qdd)
    assert [str(s) for s in batch.status] == ['ok', 'ok', 'invalid_input', 'limit']
    assert 'stroke' in batch.detail[3]
    for i in range(len(q)):
        one = fsd.solve(model, q[i], qd[i], qdd[i])
        np.testing.assert_array_equal(one.force, batch.force[i])
        assert one.status == batch.status[i]
    assert np.all(batch.force[2] == 0) and np.all(np.isfinite(batch.force))


def test_forward_kinematics_and_dynamics_invert_the_solve(model):
    q, qd, qdd = [0.1, -0.15], [0.2, -0.1], [0.7, 0.3]
    sol = fsd.solve(model, q, qd, qdd)
    back = fsd.forward_kinematics(model, sol.length)
    assert back.status == 'ok'
    np.testing.assert_allclose(back.pose, q, atol=1e-9)
    fd = fsd.forward_dynamics(model, q, qd, sol.force)
    assert fd.status == 'ok'
    np.testing.assert_allclose(fd.acceleration, qdd, atol=1e-9)


@pytest.mark.parametrize('end', [pytest.param(0.25, id='0.25s'),
                                 pytest.param(1.0, id='1s', marks=pytest.mark.slow)])
def test_the_in_process_twin_tracks_its_motion(model, end):
    """The Python path (a plugin has no kernel): 4.7 CPU-s a simulated second,
    so the unit tier runs its first 0.25 s, the slow tier its first second. With
    the full feed-forward the error is 5e-12 rad (its largest over the second
    reached within 0.1 s), so the bound is 1e-6 rad: a feed-forward of a mass 5 %
    off gives 1.1e-4 rad within 0.25 s (2e-4 over the second; the bound was
    1e-3, which a mass 20 % off did not reach within the second)."""
    motion = fsd.machine_of(model).motions['wobble']
    sim = fsd.simulate(model, reference=Reference(motion.trajectory, 0.0, end),
                       feedforward=model)
    assert sim.outcome == 'ok' and sim.t[-1] == pytest.approx(end)
    assert sim.tracking()['roll_max'] < 1e-6


# -- the command line (the installed package, the plugin on PYTHONPATH) -------------------
def write_trajectory(path: Path, times: np.ndarray) -> np.ndarray:
    rows = []
    for t in times:
        qd, qdd = wobble_rates(t)
        rows.append([t, *wobble(t), *qd, *qdd])
    with path.open('w', newline='') as f:
        out = csv.writer(f)
        out.writerow(['t', 'roll', 'pitch', 'roll_rate', 'pitch_rate', 'roll_acc', 'pitch_acc'])
        out.writerows(rows)
    return np.array(rows)


@pytest.mark.ros
def test_cli_solve(tmp_path):
    rows = write_trajectory(tmp_path / 'traj.csv', np.linspace(0.0, 2.0, 21))
    done = cli('solve', 'traj.csv', '-o', 'out.csv', '--params', str(PARAMS), cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    table = list(csv.DictReader(io.StringIO((tmp_path / 'out.csv').read_text())))
    assert list(table[0]) == ['t', 'length_1', 'length_2', 'stroke_1', 'stroke_2', 'rate_1',
                              'rate_2', 'force_1', 'force_2', 'power_1', 'power_2',
                              'acceleration_1', 'acceleration_2', 'jacobian_condition',
                              'status']
    assert {r['status'] for r in table} == {'ok'}
    p = reference_params()
    for row, (t, *_) in zip(table, rows):
        q = wobble(t)
        np.testing.assert_allclose([float(row['length_1']), float(row['length_2'])],
                                   legs(p, q)[2], rtol=1e-9)
    # at rest the forces are the statics of the reference
    rest = tmp_path / 'rest.csv'
    rest.write_text('t,roll,pitch,roll_rate,pitch_rate,roll_acc,pitch_acc\n'
                    '0,0.15,-0.1,0,0,0,0\n')
    done = cli('solve', 'rest.csv', '-o', 'rest_out.csv', '--params', str(PARAMS),
               '--joints', cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    row, = csv.DictReader(io.StringIO((tmp_path / 'rest_out.csv').read_text()))
    np.testing.assert_allclose([float(row['force_1']), float(row['force_2'])],
                               static_forces(p, (0.15, -0.1)), rtol=1e-9)
    assert float(row['post_roll']) == 0.15 and 'leg_2_length_acc' in row


@pytest.mark.ros
def test_cli_simulate_follows_a_reference(tmp_path):
    # the wobble's first second as samples (the Python path: a plugin has no kernel)
    write_trajectory(tmp_path / 'traj.csv', np.linspace(0.0, 1.0, 101))
    done = cli('simulate', '--params', str(PARAMS), '--reference', 'traj.csv', '-o', 'sim.csv',
               cwd=tmp_path)
    assert done.returncode == 0, done.stderr + done.stdout
    table = list(csv.DictReader(io.StringIO((tmp_path / 'sim.csv').read_text())))
    assert {'roll', 'pitch', 'force_1', 'force_2', 'roll_error', 'length_error_2'} <= set(table[0])
    assert {r['status'] for r in table} == {'ok'}
    assert max(abs(float(r['pitch_error'])) for r in table) < 1e-3
    assert 'tracking error' in done.stdout


def test_the_node_schema_declares_machine_for_a_plugin_that_does_not(plugin):
    """The plugin's parameter_specs leave 'machine' out: the node declares it
    anyway (the node's parameter), its value the file's name."""
    from flight_sim_dynamics.config.node_schema import node_schema
    assert all(s.name != 'machine' for s in plugin.parameter_specs)
    schema = node_schema(NAME)
    assert schema.machine is plugin and 'machine' in schema.specs
    assert schema.defaults['machine'] == NAME


def test_names_a_file_may_give_include_the_plugins(plugin, tmp_path):
    """An unknown name lists the plugin's; its keys in a file naming no machine
    are told as its, with the line to add (it has no packaged file)."""
    path = tmp_path / 'typo.yaml'
    path.write_text(HEADER + '    machine: tilt_2dfo\n')
    with pytest.raises(ParameterError) as info:
        fsd.load_model(path)
    assert info.value.key == 'machine' and "did you mean 'tilt_2dof'?" in str(info.value)
    unnamed = tmp_path / 'unnamed.yaml'
    unnamed.write_text(HEADER + '    geometry:\n      arm: 0.4\n')
    with pytest.raises(ParameterError) as info:
        fsd.load_model(unnamed)
    assert info.value.key == 'machine'
    assert "machine 'tilt_2dof'" in str(info.value) and "'machine: tilt_2dof'" in str(info.value)
