"""`solve` from poses alone (issue 14 #8): the rates and accelerations are
estimated as the node estimates them, and a note says so."""
from __future__ import annotations

import numpy as np
import pytest

import flight_sim_dynamics as fsd
from flight_sim_dynamics.cli import csv_io
from flight_sim_dynamics.cli import main as cli
from flight_sim_dynamics.machines.staicu.trajectories import paper_example, sample_times

POSES = ('t', 'surge', 'heave', 'roll')


def _write(path, names, columns):
    csv_io.write_csv(path, names, np.column_stack(columns))


def _forces(path):
    table = csv_io.read_csv(path, required=(), allow_extra=True, text_columns=('status',))
    return np.column_stack([table[f'force_{leg}'] for leg in 'abc'])


@pytest.mark.parametrize('given', ['poses', 'poses+rates'])
def test_solve_estimates_what_is_missing_like_the_node(tmp_path, capsys, given):
    t = sample_times(1000.0)
    q, qd, qdd = paper_example('general', t)
    names, columns = list(POSES), [t, q]
    if given == 'poses+rates':
        names += ['surge_rate', 'heave_rate', 'roll_rate']
        columns.append(qd)
    traj, out = tmp_path / 'traj.csv', tmp_path / 'out.csv'
    _write(traj, names, columns)
    assert cli.main(['solve', str(traj), '-o', str(out)]) == 0
    err = capsys.readouterr().err
    assert 'estimated from the poses' in err and 'backward2' in err
    assert ('rates and accelerations' in err) == (given == 'poses')
    exact = fsd.solve_batch(fsd.load_model(), q, qd, qdd).force
    error = np.abs(_forces(out) - exact)
    # the estimate starts from rest (row 0-2), then follows to a small error at 1 kHz
    assert np.max(error[3:]) < 0.5, np.max(error[3:])
    assert np.max(error[3:]) > 0.0      # estimated, not the exact values


def test_a_partial_group_is_an_error_naming_it(tmp_path, capsys):
    t = sample_times(100.0)
    q, qd, _ = paper_example('general', t)
    traj = tmp_path / 'traj.csv'
    _write(traj, [*POSES, 'surge_rate', 'heave_rate'], [t, q, qd[:, :2]])
    assert cli.main(['solve', str(traj), '-o', str(tmp_path / 'o.csv')]) == 2
    err = capsys.readouterr().err
    assert err.startswith('error: ') and "'roll_rate'" in err and 'line 1' in err
    assert not (tmp_path / 'o.csv').exists()


def test_a_gap_restarting_the_estimate_is_reported(tmp_path, capsys):
    t = np.array([0.0, 0.01, 0.02, 1.5, 1.51])      # 1.48 s step > estimator.max_gap
    q, _, _ = paper_example('general', t)
    traj = tmp_path / 'traj.csv'
    _write(traj, list(POSES), [t, q])
    assert cli.main(['solve', str(traj), '-o', str(tmp_path / 'o.csv')]) == 0
    err = capsys.readouterr().err
    assert 'starts again from rest at 1 row(s), first line 5' in err
