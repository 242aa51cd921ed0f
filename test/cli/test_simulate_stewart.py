"""``simulate`` on a hexapod, in-process: the plant's parameter file names the
machine; columns t,force_1..force_6 in, the six coordinates, their rates and
accelerations and length_/rate_/force_1..6 out; --initial takes twelve
numbers, --gains twelve; a 3-DOF forces file or wrong counts are one error line.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import flight_sim_dynamics as fsd
from flight_sim_dynamics.cli import csv_io
from flight_sim_dynamics.cli import main as cli
from flight_sim_dynamics.cli.simulate import columns

PARAMS = str(Path(__file__).resolve().parents[2] / 'config' / 'stewart_6dof.yaml')
HEXA = fsd.load_model(PARAMS)
NAMES = columns(fsd.machine_of(HEXA))
AMPLITUDE = np.array([0.05, 0.04, 0.03, 0.06, 0.05, 0.08])
W = 2.0 * np.pi * np.array([0.7, 0.9, 1.1, 0.8, 1.3, 0.6])


def one_error(err: str) -> str:
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith('error: '), err
    return lines[0]


def read(path) -> csv_io.Table:
    return csv_io.read_csv(path, required=(), allow_extra=True, text_columns=('status',))


def test_the_hexapod_columns():
    assert NAMES.forces == ('t',) + tuple(f'force_{i}' for i in range(1, 7))
    assert NAMES.trajectory[:7] == ('t', 'surge', 'sway', 'heave', 'roll', 'pitch', 'yaw')
    assert NAMES.output[-18:] == (tuple(f'length_{i}' for i in range(1, 7))
                                  + tuple(f'rate_{i}' for i in range(1, 7))
                                  + tuple(f'force_{i}' for i in range(1, 7)))
    assert NAMES.errors[:6] == tuple(f'{c}_error' for c in fsd.machine_of(HEXA).coordinates)


def test_open_loop_round_trip_through_a_file(tmp_path, capsys):
    t = np.linspace(0.0, 0.3, 301)
    q = AMPLITUDE * np.sin(W * t[:, None])
    qd = AMPLITUDE * W * np.cos(W * t[:, None])
    qdd = -AMPLITUDE * W * W * np.sin(W * t[:, None])
    force = fsd.solve_batch(HEXA, q, qd, qdd).force
    forces, out = tmp_path / 'f.csv', tmp_path / 'o.csv'
    csv_io.write_csv(forces, NAMES.forces, np.column_stack([t, force]))
    initial = [str(x) for x in np.concatenate([q[0], qd[0]])]
    assert cli.main(['simulate', '--params', PARAMS, '--forces', str(forces), '-o', str(out),
                     '--initial', *initial]) == 0
    assert '301 rows' in capsys.readouterr().out
    sim = read(out)
    assert sim.names == NAMES.output
    pose = np.column_stack([sim[c] for c in NAMES.trajectory[1:7]])
    np.testing.assert_allclose(pose, q, rtol=0, atol=1e-6)
    np.testing.assert_allclose(np.column_stack([sim[f'force_{i}'] for i in range(1, 7)]), force,
                               rtol=1e-6)


@pytest.mark.parametrize('content, args, message', [
    ('t,force_a,force_b,force_c\n0,1,2,3\n1,1,2,3\n', [], "missing columns 'force_1'"),
    (None, ['--initial', '0', '0', '0', '0', '0', '0'], '--initial: expected 12 numbers'),
    (None, ['--initial', *['0'] * 11, 'nan'], 'initial qd'),
])
def test_bad_hexapod_input_is_one_error_line(tmp_path, capsys, content, args, message):
    forces, out = tmp_path / 'f.csv', tmp_path / 'o.csv'
    forces.write_text(content or ','.join(NAMES.forces) + '\n0' + ',1' * 6 + '\n1' + ',1' * 6
                      + '\n')
    assert cli.main(['simulate', '--params', PARAMS, '--forces', str(forces), '-o', str(out),
                     *args]) == 2
    assert message in one_error(capsys.readouterr().err)
    assert not out.exists()


def test_hexapod_gains_are_twelve_numbers(tmp_path, capsys):
    out = tmp_path / 'o.csv'
    assert cli.main(['simulate', '--params', PARAMS, '--motion', 'any', '-o', str(out),
                     '--gains', *'123456']) == 2
    assert '--gains: expected 12 numbers' in one_error(capsys.readouterr().err)
    assert not out.exists()
