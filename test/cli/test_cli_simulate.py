"""``flight-sim-dynamics simulate``: the twin on files. Round trips through
files (example -> solve -> simulate --forces gives the motion back;
--reference of a file and --motion of the same motion agree), the closed
loop's options, a run that stops, and bad input (one ``error:`` line, exit
status 2, no output file)."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from flight_sim_dynamics.cli import csv_io
from flight_sim_dynamics.cli.simulate import ERROR_COLUMNS, OUTPUT_COLUMNS
from flight_sim_dynamics.config.files import default_params_path
from test_cli import one_error_line, run_cli

pytestmark = pytest.mark.ros

RATE = '1000'


def read(path: Path) -> csv_io.Table:
    return csv_io.read_csv(path, required=(), allow_extra=True, text_columns=('status',))


def statuses(path: Path) -> list[str]:
    lines = path.read_text().splitlines()
    assert lines[0].endswith(',status')
    return [line.rsplit(',', 1)[1] for line in lines[1:]]


@pytest.fixture(scope='module')
def general(tmp_path_factory) -> tuple[Path, Path]:
    """The paper's general motion at 1 kHz and solve's output for it."""
    folder = tmp_path_factory.mktemp('general')
    traj, solved = folder / 'general.csv', folder / 'solved.csv'
    assert run_cli('example', 'general', '--rate', RATE, '-o', str(traj)).returncode == 0
    assert run_cli('solve', str(traj), '-o', str(solved)).returncode == 0
    return traj, solved


def test_open_loop_round_trip_through_files(general, tmp_path):
    traj, solved = general
    out = tmp_path / 'sim.csv'
    done = run_cli('simulate', '--forces', str(solved), '-o', str(out))
    assert done.returncode == 0, done.stderr
    assert done.stderr == ''
    sim, ref = read(out), read(traj)
    assert sim.names == OUTPUT_COLUMNS
    assert set(statuses(out)) == {'ok'}
    assert len(sim) == len(ref)
    for name in csv_io.TRAJECTORY_COLUMNS:
        tolerance = 1e-6 if not name.endswith(('_rate', '_acc')) else 1e-5
        assert np.max(np.abs(sim[name] - ref[name])) < tolerance, name
    for name in ('length_a', 'rate_b', 'force_c'):
        np.testing.assert_allclose(sim[name], read(solved)[name], rtol=0, atol=1e-6)


def test_forces_in_any_column_order(tmp_path):
    path = tmp_path / 'forces.csv'
    path.write_text('force_c,t,force_a,force_b\n33.2,0,38.6,33.2\n33.2,0.01,38.6,33.2\n')
    out = tmp_path / 'sim.csv'
    done = run_cli('simulate', '--forces', str(path), '-o', str(out), '--step', '0.001')
    assert done.returncode == 0, done.stderr
    sim = read(out)
    assert len(sim) == 11
    np.testing.assert_allclose(sim['force_a'], 38.6)
    np.testing.assert_allclose(sim['force_c'], 33.2)


def test_closed_loop_from_a_file_equals_the_built_in_motion(general, tmp_path):
    traj, _ = general
    a, b = tmp_path / 'a.csv', tmp_path / 'b.csv'
    assert run_cli('simulate', '--reference', str(traj), '-o', str(a)).returncode == 0
    assert run_cli('simulate', '--motion', 'general', '-o', str(b)).returncode == 0
    sa, sb = read(a), read(b)
    assert sa.names == OUTPUT_COLUMNS + ERROR_COLUMNS
    for name in ('surge', 'heave', 'roll', 'length_a'):
        np.testing.assert_allclose(sa[name], sb[name], rtol=0, atol=1e-9)
    # full feed-forward with the exact plant: tracked to rounding
    for name in ERROR_COLUMNS:
        assert np.max(np.abs(sb[name])) < 1e-6, name


def test_feedforward_scenes_gains_and_a_heavier_plant(tmp_path):
    heavy = tmp_path / 'heavy.yaml'
    text = default_params_path().read_text()
    assert 'mass: 140.0' in text
    heavy.write_text(text.replace('mass: 140.0', 'mass: 180.0'))
    errors = {}
    for label, options in {
            'exact': ['--plant-scene', 'payload', '--feedforward', 'payload'],
            'mismatch': ['--plant-params', str(heavy), '--plant-scene', 'payload',
                         '--feedforward', 'payload'],
            'quasi_static': ['--plant-params', str(heavy), '--plant-scene', 'payload',
                             '--feedforward', 'quasi_static'],
            'none': ['--plant-params', str(heavy), '--plant-scene', 'payload',
                     '--feedforward', 'none'],
            'stiff': ['--plant-params', str(heavy), '--plant-scene', 'payload',
                      '--feedforward', 'none', '--bandwidth', '15']}.items():
        out = tmp_path / f'{label}.csv'
        done = run_cli('simulate', '--motion', 'vertical', '-o', str(out), *options)
        assert done.returncode == 0, (label, done.stderr)
        sim = read(out)
        errors[label] = max(np.max(np.abs(sim[f'length_error_{leg}'])) for leg in 'abc')
    assert errors['exact'] < 1e-6 < errors['mismatch'] < errors['quasi_static'] < errors['none']
    assert errors['stiff'] < errors['none']
    out = tmp_path / 'gains.csv'
    done = run_cli('simulate', '--motion', 'vertical', '-o', str(out), '--feedforward', 'none',
                   '--gains', '8000', '4000', '4000', '500', '250', '250')
    assert done.returncode == 0, done.stderr


def test_a_run_that_leaves_the_workspace_stops_with_exit_status_1(tmp_path):
    forces = tmp_path / 'f.csv'
    forces.write_text('t,force_a,force_b,force_c\n0,40,300,300\n2,40,300,300\n')
    out = tmp_path / 'sim.csv'
    done = run_cli('simulate', '--forces', str(forces), '-o', str(out))
    assert done.returncode == 1
    assert 'warning: simulation stopped: ' in done.stderr and 'rows written' in done.stderr
    sim = read(out)
    assert 0 < sim['t'][-1] < 2.0
    assert np.all(np.isfinite(sim.data))


def test_initial_state_option(tmp_path):
    forces = tmp_path / 'f.csv'
    forces.write_text('t,force_a,force_b,force_c\n0,0,0,0\n0.01,0,0,0\n')
    out = tmp_path / 'sim.csv'
    done = run_cli('simulate', '--forces', str(forces), '-o', str(out),
                   '--initial', '0', '0.5', '0', '0', '0.25', '0')
    assert done.returncode == 0, done.stderr
    sim = read(out)
    assert sim['heave'][0] == 0.5 and sim['heave_rate'][0] == 0.25
    assert sim['heave_rate'][-1] < 0.25      # gravity, no force


@pytest.mark.parametrize('content, args, message', [
    ('t,force_a,force_b\n0,1,2\n1,1,2\n', [], "missing column 'force_c'"),
    ('t,force_a,force_b,force_c\n0,1,2,3\n0,1,2,3\n', [], r'times must increase strictly'),
    ('t,force_a,force_b,force_c\n0,1,2,nan\n1,1,2,3\n', [], 'line 2'),
    ('t,force_a,force_b,force_c\n0,1,2,3\n', [], 'at least 2'),
    ('t,force_a,force_b,force_c\n0,1,2,3\n1,1,2,3\n', ['--feedforward', 'full'],
     '--feedforward: closed loop only'),
    ('t,force_a,force_b,force_c\n0,1,2,3\n1,1,2,3\n', ['--gains', *'123456'],
     '--gains: closed loop only'),
    ('t,force_a,force_b,force_c\n0,1,2,3\n1,1,2,3\n', ['--plant-scene', 'quasi_static'],
     "scene 'quasi_static' computes no inertia"),
    ('t,force_a,force_b,force_c\n0,1,2,3\n1,1,2,3\n', ['--plant-scene', 'nope'],
     "--plant-scene: scene 'nope': no such scene"),
    ('t,force_a,force_b,force_c\n0,1,2,3\n1,1,2,3\n', ['--plant-params', 'missing.yaml'],
     '--plant-params missing.yaml: no such file'),
    ('t,force_a,force_b,force_c\n0,1,2,3\n1,1,2,3\n', ['--step', '0'],
     'step must be a positive'),
    ('t,force_a,force_b,force_c\n0,1,2,3\n1,1,2,3\n', ['--motion', 'general'],
     'not allowed with argument'),
    ('t,force_a,force_b,force_c\n0,1,2,3\n1,1,2,3\n', ['--initial', '0', 'x', '0', '0', '0', '0'],
     "invalid float value: 'x'"),
])
def test_bad_input_is_one_error_line_and_no_output(tmp_path, content, args, message):
    forces = tmp_path / 'f.csv'
    forces.write_text(content)
    out = tmp_path / 'sim.csv'
    done = run_cli('simulate', '--forces', str(forces), '-o', str(out), *args, cwd=tmp_path)
    assert done.returncode == 2, done.stderr
    assert message in one_error_line(done.stderr), done.stderr
    assert not out.exists()


@pytest.mark.parametrize('args, message', [
    ([], 'one of the arguments --forces --reference --motion is required'),
    (['--motion', 'general', '--feedforward', 'nope'], "--feedforward: scene 'nope'"),
    (['--motion', 'general', '--bandwidth', '-1'], 'servo bandwidth must be > 0 Hz'),
    (['--motion', 'general', '--gains', '1', '1', '1', '1', '1', '-1'], 'servo kd must be'),
    (['--motion', 'nope'], "invalid choice: 'nope'"),
])
def test_bad_closed_loop_options_are_one_error_line(tmp_path, args, message):
    out = tmp_path / 'sim.csv'
    done = run_cli('simulate', '-o', str(out), *args)
    assert done.returncode == 2, done.stderr
    assert message in one_error_line(done.stderr), done.stderr
    assert not out.exists()


def test_an_unreachable_reference_file_is_a_clear_error(tmp_path):
    traj = tmp_path / 'traj.csv'
    traj.write_text(','.join(csv_io.TRAJECTORY_COLUMNS) + '\n'
                    '0,0,-0.8,0,0,0,0,0,0,0\n1,0,-0.8,0,0,0,0,0,0,0\n')
    done = run_cli('simulate', '--reference', str(traj), '-o', str(tmp_path / 'o.csv'))
    assert done.returncode == 2
    assert 'the reference motion at t = 0 s: unreachable' in one_error_line(done.stderr)


def test_help_lists_simulate():
    done = run_cli('--help')
    assert 'simulate' in done.stdout
    done = run_cli('simulate', '--help')
    assert '--feedforward' in done.stdout and '--plant-params' in done.stdout
