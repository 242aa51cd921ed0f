"""Regression (issue 30): ``solve`` and ``simulate --reference`` estimate missing
rates with the estimator settings of the parameter file of any machine; they
read them from the 3-DOF model's values only, so a hexapod file's
``estimator.method: backward`` was ignored."""
from __future__ import annotations

import numpy as np
import pytest

from flight_sim_dynamics.cli.main import main
from flight_sim_dynamics.config.machine_files import load_node_values

HEADER = 'flight_sim_dynamics:\n  ros__parameters:\n'


def poses_only(tmp_path, coordinates):
    t = np.linspace(0.0, 1.0, 51)
    q = np.column_stack([0.01 * (k + 1) * np.sin(3.0 * t + k) for k in range(len(coordinates))])
    path = tmp_path / 'poses.csv'
    np.savetxt(path, np.column_stack([t, q]), delimiter=',', header=','.join(('t',) + coordinates),
               comments='')
    return path


def solved(tmp_path, traj, params, capsys) -> tuple[np.ndarray, str]:
    out = tmp_path / f'out_{params.stem}.csv'
    assert main(['solve', str(traj), '-o', str(out), '--params', str(params)]) == 0
    err = capsys.readouterr().err
    return np.genfromtxt(out, delimiter=',', names=True, dtype=None, encoding=None), err


@pytest.mark.parametrize('machine, coordinates', [
    ('machine: stewart_6dof\n', ('surge', 'sway', 'heave', 'roll', 'pitch', 'yaw')),
    ('', ('surge', 'heave', 'roll'))])
def test_solve_uses_the_files_estimator_for_any_machine(tmp_path, capsys, machine,
                                                       coordinates):
    traj = poses_only(tmp_path, coordinates)
    default = tmp_path / 'default.yaml'
    default.write_text(HEADER + (f'    {machine}' if machine else '    gravity: 9.81\n'))
    backward = tmp_path / 'backward.yaml'
    backward.write_text(HEADER + (f'    {machine}' if machine else '')
                        + '    estimator:\n      method: backward\n')
    assert load_node_values(backward)['estimator.method'] == 'backward'
    assert load_node_values(default)['estimator.method'] == 'backward2'
    first, err_default = solved(tmp_path, traj, default, capsys)
    second, err_backward = solved(tmp_path, traj, backward, capsys)
    assert '(backward2 backward differences' in err_default
    assert '(backward backward differences' in err_backward
    column = next(n for n in first.dtype.names if n.startswith('acceleration_'))
    assert not np.allclose(first[column], second[column])


def test_the_node_values_of_a_file_of_ones_own_and_of_none(tmp_path):
    assert load_node_values()['estimator.max_gap'] == 0.5
    path = tmp_path / 'p.yaml'
    path.write_text(HEADER + '    machine: stewart_6dof\n    estimator:\n      max_gap: 0.25\n')
    assert load_node_values(path)['estimator.max_gap'] == 0.25
