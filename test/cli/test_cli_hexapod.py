"""The command line for a hexapod (the machine of ``--params``): example ->
solve -> plot as a user runs them, solve's numbers those of fsd.solve, the
columns named from the machine, forward kinematics back from the lengths,
and bad input (another machine's trajectory, NaN cells, unsolvable rows)."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from test_cli import PNG_SIGNATURE, one_error_line, read_plain, run_cli

import flight_sim_dynamics as fsd
from flight_sim_dynamics.cli import csv_io, plotting
from flight_sim_dynamics.cli import main as cli
from flight_sim_dynamics.cli.columns import output_columns, trajectory_columns
from flight_sim_dynamics.core.estimator import estimate_rows

ROOT = Path(__file__).resolve().parents[2]
HEXAPOD_FILE = str(ROOT / 'config' / 'stewart_6dof.yaml')
TSAI_FILE = str(ROOT / 'config' / 'stewart_tsai2000.yaml')
HEXAPOD = fsd.load_model(HEXAPOD_FILE)
MACHINE = fsd.machine_of(HEXAPOD)
COORDINATES = ('surge', 'sway', 'heave', 'roll', 'pitch', 'yaw')
LEGS = tuple(str(i) for i in range(1, 7))


def trajectory(path: Path, name: str = 'violent', rate: float = 50.0) -> np.ndarray:
    """The built-in motion ``name`` written as solve reads it; its rows."""
    t, q, qd, qdd = MACHINE.motions[name].sampled(rate)
    data = np.column_stack([t, q, qd, qdd])
    csv_io.write_csv(path, trajectory_columns(MACHINE), data)
    return data


# ----------------------------------------------------------------------------
# The user's story, in a subprocess: example -> solve -> plot
# ----------------------------------------------------------------------------
@pytest.mark.ros
def test_a_hexapod_round_trip_as_a_user(tmp_path):
    for argv in (('example', 'cueing', '--params', HEXAPOD_FILE, '-o', 'traj.csv'),
                 ('solve', 'traj.csv', '--params', HEXAPOD_FILE, '-o', 'out.csv'),
                 ('plot', 'out.csv', '-o', 'fig.png')):
        r = run_cli(*argv, cwd=tmp_path)
        assert r.returncode == 0 and r.stdout == '' and r.stderr == '', (argv, r.stderr)

    header, traj = read_plain(tmp_path / 'traj.csv')
    assert header == ['t', *COORDINATES, *(f'{c}_rate' for c in COORDINATES),
                      *(f'{c}_acc' for c in COORDINATES)]
    t, q, qd, qdd = MACHINE.motions['cueing'].sampled(cli.DEFAULT_RATE_HZ)
    assert np.array_equal(traj, np.column_stack([t, q, qd, qdd]))

    header, out = read_plain(tmp_path / 'out.csv')          # every row ok
    per_leg = [f'{field}_{leg}' for field in ('length', 'stroke', 'rate', 'force', 'power',
                                              'acceleration') for leg in LEGS]
    assert header == ['t', *per_leg, 'jacobian_condition']
    col = {name: j for j, name in enumerate(header)}
    for i in (0, 77, 301, len(t) - 1):                       # fsd.solve, row by row
        sol = fsd.solve(HEXAPOD, q[i], qd[i], qdd[i])
        for field in ('length', 'stroke', 'rate', 'acceleration', 'force', 'power'):
            for k, leg in enumerate(LEGS):
                assert out[i, col[f'{field}_{leg}']] == getattr(sol, field)[k]
        assert out[i, col['jacobian_condition']] == sol.jacobian_condition

    png = (tmp_path / 'fig.png').read_bytes()
    assert png.startswith(PNG_SIGNATURE) and len(png) > 10_000
    assert sorted(p.name for p in tmp_path.iterdir()) == ['fig.png', 'out.csv', 'traj.csv']


@pytest.mark.ros
def test_a_3dof_trajectory_for_a_hexapod_is_one_error_line_as_a_user(tmp_path):
    assert run_cli('example', 'general', '-o', 'traj.csv', cwd=tmp_path).returncode == 0
    r = run_cli('solve', 'traj.csv', '--params', HEXAPOD_FILE, '-o', 'out.csv', cwd=tmp_path)
    assert r.returncode == 2 and r.stdout == ''
    line = one_error_line(r.stderr)
    assert 'traj.csv, line 1' in line and '3-DOF' in line and 'hexapod' in line
    assert sorted(p.name for p in tmp_path.iterdir()) == ['traj.csv']


# ----------------------------------------------------------------------------
# example
# ----------------------------------------------------------------------------
@pytest.mark.parametrize('params, name', [(HEXAPOD_FILE, name) for name in MACHINE.examples]
                         + [(TSAI_FILE, 'tsai_2')])
def test_example_writes_the_machines_motion(tmp_path, params, name):
    out = tmp_path / 'traj.csv'
    assert cli.main(['example', name, '--params', params, '--rate', '40', '-o', str(out)]) == 0
    header, data = read_plain(out)
    assert tuple(header) == trajectory_columns(MACHINE)
    t, q, qd, qdd = MACHINE.motions[name].sampled(40.0)
    assert np.array_equal(data, np.column_stack([t, q, qd, qdd]))
    assert t[-1] == pytest.approx(MACHINE.motions[name].duration, abs=1 / 40)


def test_example_names_the_machines_motions(tmp_path, capsys):
    out = tmp_path / 'x.csv'
    assert cli.main(['example', 'vertical', '--params', HEXAPOD_FILE, '-o', str(out)]) == 2
    line = one_error_line(capsys.readouterr().err)
    assert "'vertical'" in line and 'hexapod' in line
    assert all(name in line for name in MACHINE.examples)
    assert cli.main(['example', 'cueing', '-o', str(out)]) == 2       # not the 3-DOF's
    line = one_error_line(capsys.readouterr().err)
    assert '3-DOF' in line and 'vertical' in line and not out.exists()


# ----------------------------------------------------------------------------
# solve
# ----------------------------------------------------------------------------
def test_solve_with_joints_equals_solve_batch(tmp_path):
    data = trajectory(tmp_path / 'traj.csv', 'violent', rate=200.0)
    out = tmp_path / 'out.npz'
    assert cli.main(['solve', str(tmp_path / 'traj.csv'), '--params', HEXAPOD_FILE, '--joints',
                     '-o', str(out)]) == 0
    table = csv_io.read_npz(out, required=output_columns(MACHINE))
    with np.load(out) as npz:
        names = tuple(npz['names'])
        assert set(npz['status']) == {'ok'}
        joint_names = [n for n in names if n.startswith('leg_')]
        joints = np.column_stack([npz[n] for n in joint_names])
    assert names == output_columns(MACHINE) + tuple(joint_names) + ('status',)
    assert len(joint_names) == 3 * 18 and joint_names[:3] == ['leg_1_theta_1', 'leg_1_theta_2',
                                                              'leg_1_length']
    sol = fsd.solve_batch(HEXAPOD, data[:, 1:7], data[:, 7:13], data[:, 13:19])
    for field in ('length', 'stroke', 'rate', 'acceleration', 'force', 'power'):
        got = np.column_stack([table[f'{field}_{leg}'] for leg in LEGS])
        assert np.array_equal(got, getattr(sol, field)), field
    n = len(data)
    assert np.array_equal(joints, np.column_stack([sol.joints.reshape(n, -1),
                                                   sol.joint_rates.reshape(n, -1),
                                                   sol.joint_accelerations.reshape(n, -1)]))


def test_solve_estimates_missing_rates_with_the_angles_unwrapped(tmp_path, capsys):
    """Poses only: rates and accelerations estimated as the node does; a yaw
    through +-pi is one turn, not a jump of 2 pi."""
    t = np.arange(0.0, 1.0, 0.01)
    q = np.zeros((t.size, 6))
    q[:, 5] = np.angle(np.exp(1j * (3.0 + 0.5 * t)))          # yaw wraps past pi at 0.28 s
    q[:, 2] = 0.05 * np.sin(3.0 * t)
    csv_io.write_csv(tmp_path / 'poses.csv', ('t',) + COORDINATES, np.column_stack([t, q]))
    out = tmp_path / 'out.csv'
    # a tilted platform (yaw about pi is outside this machine's strokes): the statuses say so
    assert cli.main(['solve', str(tmp_path / 'poses.csv'), '--params', HEXAPOD_FILE,
                     '-o', str(out)]) == 0
    assert 'estimated from the poses' in capsys.readouterr().err
    qd, qdd = estimate_rows(t, q, None, 'backward2', 0.5, angles=(3, 4, 5))
    assert np.abs(qd[1:, 5] - 0.5).max() < 1e-9                 # the yaw rate, unwrapped
    lines = out.read_text().splitlines()
    col = lines[0].split(',').index('rate_1')
    sol = fsd.solve_batch(HEXAPOD, q, qd, qdd)
    got = np.array([float(line.split(',')[col]) for line in lines[1:]])
    assert np.array_equal(got, sol.rate[:, 0])


def test_unsolvable_rows_get_their_status_and_zeros(tmp_path, capsys):
    names = trajectory_columns(MACHINE)
    rows = np.zeros((4, len(names)))
    rows[:, 0] = [0.0, 0.1, 0.2, 0.3]
    rows[1, names.index('heave')] = 1.0                 # legs past their longest: limit
    rows[2, names.index('heave')] = -1.0                # platform in the base plane: singular
    csv_io.write_csv(tmp_path / 'traj.csv', names, rows)
    out = tmp_path / 'out.csv'
    assert cli.main(['solve', str(tmp_path / 'traj.csv'), '--params', HEXAPOD_FILE,
                     '-o', str(out)]) == 0
    err = capsys.readouterr().err
    assert err.startswith('warning: ') and '2 of 4 rows are not ok' in err and 'line 3' in err
    lines = out.read_text().splitlines()
    assert [line.split(',')[-1] for line in lines[1:]] == ['ok', 'limit', 'near_singular', 'ok']
    forces = [lines[0].split(',').index(f'force_{leg}') for leg in LEGS]
    assert all(float(lines[3].split(',')[j]) == 0.0 for j in forces)
    assert all(float(lines[2].split(',')[j]) > 0.0 for j in forces)


@pytest.mark.parametrize('case, cell, expected', [
    ('nan', 'nan', ["'nan'", 'column 6 (pitch)']),
    ('inf', 'inf', ["'inf'", 'column 6 (pitch)']),
    ('empty', '', ['missing', 'column 6 (pitch)']),
])
def test_bad_cells_are_one_error_line_naming_line_and_column(tmp_path, capsys, case, cell,
                                                              expected):
    trajectory(tmp_path / 'traj.csv', 'gentle', rate=2.0)
    lines = (tmp_path / 'traj.csv').read_text().splitlines()
    cells = lines[3].split(',')
    cells[5] = cell
    lines[3] = ','.join(cells)
    (tmp_path / 'traj.csv').write_text('\n'.join(lines) + '\n')
    out = tmp_path / 'out.csv'
    assert cli.main(['solve', str(tmp_path / 'traj.csv'), '--params', HEXAPOD_FILE,
                     '-o', str(out)]) == 2
    line = one_error_line(capsys.readouterr().err)
    assert 'line 4' in line and all(piece in line for piece in expected), line
    assert not out.exists()


def test_a_hexapod_trajectory_for_the_3dof_machine_is_refused(tmp_path, capsys):
    """Not read as a 3-DOF one with sway, pitch and yaw dropped."""
    trajectory(tmp_path / 'traj.csv', 'gentle', rate=2.0)
    out = tmp_path / 'out.csv'
    assert cli.main(['solve', str(tmp_path / 'traj.csv'), '-o', str(out)]) == 2
    line = one_error_line(capsys.readouterr().err)
    assert 'line 1' in line and 'hexapod' in line and '3-DOF' in line and not out.exists()


def test_cond_and_wrong_lengths_are_usage_errors(tmp_path, capsys):
    trajectory(tmp_path / 'traj.csv', 'gentle', rate=2.0)
    out = tmp_path / 'out.csv'
    assert cli.main(['solve', str(tmp_path / 'traj.csv'), '--params', HEXAPOD_FILE, '--cond',
                     '-o', str(out)]) == 2
    assert '--cond' in one_error_line(capsys.readouterr().err) and not out.exists()
    assert cli.main(['forward', '1.2', '1.2', '1.2', '--params', HEXAPOD_FILE]) == 2
    assert 'six leg lengths' in one_error_line(capsys.readouterr().err)


@pytest.mark.parametrize('command', ['forward', 'animate'])
def test_forward_and_animate_tell_the_machine_from_the_columns(tmp_path, capsys, command):
    """Issue 29: without --params they read a hexapod's solve output as the 3-DOF
    machine's ("did you mean 'length_c'?"); either way round, the error names the
    table's machine and the files to give, as solve does for trajectories."""
    trajectory(tmp_path / 'traj.csv', 'gentle', rate=2.0)
    hexapod_out, three_dof_out = tmp_path / 'hexa.csv', tmp_path / 'paper.csv'
    assert cli.main(['solve', str(tmp_path / 'traj.csv'), '--params', HEXAPOD_FILE,
                     '-o', str(hexapod_out)]) == 0
    assert cli.main(['example', 'vertical', '--rate', '2', '-o', str(tmp_path / 'v.csv')]) == 0
    assert cli.main(['solve', str(tmp_path / 'v.csv'), '-o', str(three_dof_out)]) == 0
    capsys.readouterr()
    output = tmp_path / ('poses.csv' if command == 'forward' else 'still.png')
    for table, params, machine, other in ((hexapod_out, [], MACHINE, cli.DEFAULT_MACHINE),
                                          (three_dof_out, ['--params', HEXAPOD_FILE],
                                           cli.DEFAULT_MACHINE, MACHINE)):
        argv = (['forward', '--csv', str(table)] if command == 'forward'
                else ['animate', str(table)]) + params + ['-o', str(output)]
        assert cli.main(argv) == 2
        line = one_error_line(capsys.readouterr().err)
        assert str(table) in line and 'line 1' in line, line
        assert machine.title in line and other.title in line and 'did you mean' not in line
        assert all(f'{name}.yaml' in line for name in machine.parameter_files), line
        assert not output.exists()


# ----------------------------------------------------------------------------
# forward
# ----------------------------------------------------------------------------
def test_forward_gives_the_poses_back_from_solves_lengths(tmp_path):
    data = trajectory(tmp_path / 'traj.csv', 'violent', rate=20.0)
    assert cli.main(['solve', str(tmp_path / 'traj.csv'), '--params', HEXAPOD_FILE,
                     '-o', str(tmp_path / 'out.csv')]) == 0
    assert cli.main(['forward', '--csv', str(tmp_path / 'out.csv'), '--params', HEXAPOD_FILE,
                     '-o', str(tmp_path / 'poses.csv')]) == 0
    header, poses = read_plain(tmp_path / 'poses.csv')
    assert header == ['t', *COORDINATES]
    np.testing.assert_array_equal(poses[:, 0], data[:, 0])
    np.testing.assert_allclose(poses[:, 1:], data[:, 1:7], rtol=0, atol=1e-9)


def test_forward_of_six_lengths_prints_the_pose(capsys):
    q = np.array([0.05, -0.03, 0.1, 0.02, -0.04, 0.1])
    lengths = fsd.solve(HEXAPOD, q, np.zeros(6), np.zeros(6)).length
    assert cli.main(['forward', *map(repr, lengths.tolist()), '--params', HEXAPOD_FILE]) == 0
    words = dict(w.split('=', 1) for w in capsys.readouterr().out.split())
    assert words['status'] == 'ok'
    np.testing.assert_allclose([float(words[c]) for c in COORDINATES], q, rtol=0, atol=1e-12)


# ----------------------------------------------------------------------------
# plot
# ----------------------------------------------------------------------------
def test_plot_draws_six_legs_each_visible(tmp_path):
    """Six forces and powers, named; legs with equal forces (the hexapod's
    symmetric pairs) differ in width or dash."""
    trajectory(tmp_path / 'traj.csv', 'gentle', rate=10.0)
    assert cli.main(['solve', str(tmp_path / 'traj.csv'), '--params', HEXAPOD_FILE,
                     '-o', str(tmp_path / 'out.npz')]) == 0
    assert cli.main(['plot', str(tmp_path / 'out.npz'), '-o', str(tmp_path / 'fig.svg')]) == 0
    svg = (tmp_path / 'fig.svg').read_text()
    assert 'six actuators' in svg and all(f'actuator {leg}' in svg for leg in LEGS)
    table = csv_io.read_npz(tmp_path / 'out.npz', required=('t',) + tuple(
        f'{f}_{leg}' for f in ('force', 'power') for leg in LEGS))
    force = np.column_stack([table[f'force_{leg}'] for leg in LEGS])
    power = np.column_stack([table[f'power_{leg}'] for leg in LEGS])
    fig = plotting.force_power_figure(table['t'], force, power, title='x',
                                      actuators=LEGS)
    ax_f, ax_p = fig.axes
    lines = ax_f.get_lines()[:6]
    for line, expected in zip(lines, force.T):
        np.testing.assert_array_equal(line.get_ydata(), expected)
    styles = [(line.get_linewidth(), line.get_linestyle()) for line in lines]
    for a, b in ((0, 1), (2, 5), (3, 4)):        # equal at rest at home (stewart.md)
        assert styles[a] != styles[b]
    assert len({line.get_color() for line in lines}) == 6


def test_plot_names_the_missing_forces_of_the_machine_it_finds(tmp_path, capsys):
    csv_io.write_csv(tmp_path / 'o.csv', ('t', 'force_1', 'force_2'), np.zeros((3, 3)))
    assert cli.main(['plot', str(tmp_path / 'o.csv'), '-o', str(tmp_path / 'f.png')]) == 2
    line = one_error_line(capsys.readouterr().err)
    assert "'force_3'" in line and "'force_6'" in line and 'hexapod' in line



@pytest.mark.parametrize('serves', ['default', 'hexapod'])
def test_a_command_refuses_a_machine_it_does_not_serve(serves):
    """load_model(machines=...): a one-line CliError naming the file and both machines."""
    default = cli.DEFAULT_MACHINE
    params, machines = ((HEXAPOD_FILE, (default,)) if serves == 'default'
                        else (None, (MACHINE,)))
    with pytest.raises(cli.CliError) as info:
        cli.load_model(params, machines=machines)
    message = str(info.value)
    assert MACHINE.title in message and default.title in message
    assert (params or 'packaged') in message


def test_plot_of_forces_and_rates_computes_the_six_powers(tmp_path):
    """A simulate-like table (forces and leg rates, no powers): P = f dL/dt."""
    t = np.linspace(0.0, 1.0, 11)
    force = np.column_stack([t + k for k in range(6)])
    rate = np.column_stack([np.sin(t + k) for k in range(6)])
    names = ('t', *(f'force_{leg}' for leg in LEGS), *(f'rate_{leg}' for leg in LEGS))
    csv_io.write_csv(tmp_path / 'sim.csv', names, np.column_stack([t, force, rate]))
    assert cli.main(['plot', str(tmp_path / 'sim.csv'), '-o', str(tmp_path / 'f.svg')]) == 0
    assert 'six actuators' in (tmp_path / 'f.svg').read_text()
