"""``simulate``'s inputs as a user gives them, in-process: forces the spline
cannot hold, input sizes, the scene of a parameter file, .npz and poses-only
inputs, the summary it prints, the plot of its output."""
from __future__ import annotations

import re
import warnings

import numpy as np
import pytest

from flight_sim_dynamics.cli import csv_io
from flight_sim_dynamics.cli import main as cli
from flight_sim_dynamics.config.files import default_params_path
from flight_sim_dynamics.core.interpolation import ForceHistory

HEADER = 't,force_a,force_b,force_c\n'


def one_error(err: str) -> str:
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith('error: '), err
    return lines[0]


def read(path) -> csv_io.Table:
    return csv_io.read_csv(path, required=(), allow_extra=True, text_columns=('status',))


@pytest.mark.parametrize('big', ['1e308', '-1.7e308', '1e306'])
def test_forces_too_large_to_interpolate_are_refused_never_written_as_nan(tmp_path, capsys,
                                                                           big):
    forces, out = tmp_path / 'f.csv', tmp_path / 'o.csv'
    forces.write_text(HEADER + f'0,0,0,0\n0.01,{big},0,{big}\n0.02,0,0,0\n0.03,0,0,0\n'
                      '0.04,0,0,0\n0.05,0,0,0\n')
    with warnings.catch_warnings():
        warnings.simplefilter('error')          # no numpy overflow warning either
        assert cli.main(['simulate', '--forces', str(forces), '-o', str(out)]) == 2
    error = one_error(capsys.readouterr().err)
    assert f'{forces}, line 3' in error and 'force_a = ' in error      # names the cell
    assert not out.exists()


def test_large_forces_the_spline_holds_are_simulated_without_nan(tmp_path, capsys):
    forces, out = tmp_path / 'f.csv', tmp_path / 'o.csv'
    forces.write_text(HEADER + '0,0,0,0\n0.01,1e300,-1e300,1e300\n0.02,0,0,0\n0.03,0,0,0\n')
    assert cli.main(['simulate', '--forces', str(forces), '-o', str(out)]) in (0, 1)
    assert out.exists() and 'nan' not in out.read_text()
    assert np.all(np.isfinite(read(out).data))


def test_force_history_refuses_what_it_cannot_interpolate():
    t = np.arange(6) * 0.01
    force = np.zeros((6, 3))
    force[3, 1] = 1e308
    with pytest.raises(ValueError, match='t = 0.03 s'):
        ForceHistory(t, force)
    force[3, 1] = 1e250
    assert np.all(np.isfinite(ForceHistory(t, force)(np.linspace(0, 0.05, 101))))


@pytest.mark.parametrize('stdin', [False, True])
def test_a_forces_file_larger_than_the_cap_is_one_error_line(tmp_path, capsys, monkeypatch,
                                                             stdin):
    from flight_sim_dynamics.cli import simulate
    monkeypatch.setattr(simulate, 'MAX_INPUT_BYTES', 4096)
    rows = ''.join(f'{k * 1e-3!r},1,2,3\n' for k in range(400))     # > 4 KiB, valid
    forces, out = tmp_path / 'f.csv', tmp_path / 'o.csv'
    forces.write_text(HEADER + rows)
    if stdin:
        monkeypatch.setattr('sys.stdin', open(forces))
    assert cli.main(['simulate', '--forces', '-' if stdin else str(forces), '-o', str(out)]) == 2
    assert 'MiB' in one_error(capsys.readouterr().err)
    assert not out.exists()


def test_the_cap_leaves_a_file_under_it_alone(tmp_path, monkeypatch):
    from flight_sim_dynamics.cli import simulate
    monkeypatch.setattr(simulate, 'MAX_INPUT_BYTES', 4096)
    forces, out = tmp_path / 'f.csv', tmp_path / 'o.csv'
    forces.write_text(HEADER + '0,1,2,3\n0.01,1,2,3\n')
    assert cli.main(['simulate', '--forces', str(forces), '-o', str(out)]) == 0
    assert len(read(out)) == 11


@pytest.mark.parametrize('rows, options, shown', [
    ('0,0,0,0\n0.2,0,0,0\n0.1,0,0,0\n', [], '0.1'),            # t decreases
    ('0,0,0,0\n0.03,0,0,0\n', ['--step', '1e-300'], 'e+'),     # 3e+298 steps
    ('0,0,0,0\n1,0,0,0\n', ['--step', '5e-324'], 'inf'),       # a step count past floats
])
def test_error_lines_show_plain_short_numbers(tmp_path, capsys, rows, options, shown):
    forces, out = tmp_path / 'f.csv', tmp_path / 'o.csv'
    forces.write_text(HEADER + rows)
    assert cli.main(['simulate', '--forces', str(forces), '-o', str(out), *options]) == 2
    line = one_error(capsys.readouterr().err)
    assert 'np.' not in line and 'internal error' not in line and shown in line, line
    assert len(line) < 200 and not re.search(r'\d{18}', line), line


def test_servo_gains_that_overflow_are_an_error_with_plain_numbers(tmp_path, capsys):
    with warnings.catch_warnings():
        warnings.simplefilter('error')
        assert cli.main(['simulate', '--motion', 'vertical', '--bandwidth', '1e200',
                         '-o', str(tmp_path / 'o.csv')]) == 2
    line = one_error(capsys.readouterr().err)
    assert 'np.' not in line and 'inf' in line, line


# ---------------------------------------------------------------------------
# simulate as solve: the same machine, the same inputs; a result printed
# ---------------------------------------------------------------------------
@pytest.fixture(scope='module')
def vertical(tmp_path_factory):
    """The vertical example at 1 kHz (simulate's default step), a params file
    whose scene is payload, and solve's output for it (CSV and .npz)."""
    folder = tmp_path_factory.mktemp('vertical')
    traj, params = folder / 'vertical.csv', folder / 'payload.yaml'
    params.write_text(default_params_path().read_text().replace('scene: full', 'scene: payload'))
    assert cli.main(['example', 'vertical', '--rate', '1000', '-o', str(traj)]) == 0
    for out in ('solved.csv', 'solved.npz'):
        assert cli.main(['solve', str(traj), '--params', str(params), '-o',
                         str(folder / out)]) == 0
    return folder


def test_a_params_files_scene_is_simulated_as_solve_reads_it(vertical, tmp_path):
    solved = read(vertical / 'solved.csv')
    out = tmp_path / 'sim.csv'
    assert cli.main(['simulate', '--reference', str(vertical / 'vertical.csv'), '--params',
                     str(vertical / 'payload.yaml'), '-o', str(out)]) == 0
    sim = read(out)
    assert len(sim) == len(solved)
    for leg in 'abc':                   # tracked exactly: the forces are solve's
        np.testing.assert_allclose(sim[f'force_{leg}'], solved[f'force_{leg}'], atol=1e-3)
    out = tmp_path / 'open.csv'         # open loop, the plant from the same file
    assert cli.main(['simulate', '--forces', str(vertical / 'solved.csv'), '--plant-params',
                     str(vertical / 'payload.yaml'), '-o', str(out)]) == 0
    assert np.max(np.abs(read(out)['heave'] - read(vertical / 'vertical.csv')['heave'])) < 1e-6


def test_a_payload_the_scene_leaves_off_is_named_in_a_note(tmp_path, capsys):
    heavy = tmp_path / 'heavy.yaml'
    heavy.write_text(default_params_path().read_text().replace('mass: 140.0', 'mass: 180.0'))
    assert cli.main(['simulate', '--motion', 'vertical', '--plant-params', str(heavy),
                     '-o', str(tmp_path / 'o.csv')]) == 0
    err = capsys.readouterr().err
    assert 'note:' in err and 'payload.mass' in err, err
    assert cli.main(['simulate', '--motion', 'vertical', '--plant-params', str(heavy),
                     '--plant-scene', 'payload', '-o', str(tmp_path / 'p.csv')]) == 0
    assert capsys.readouterr().err == ''
    assert not np.array_equal(read(tmp_path / 'o.csv')['force_a'],
                              read(tmp_path / 'p.csv')['force_a'])


def test_simulate_prints_a_one_line_tracking_summary(tmp_path, capsys):
    out = tmp_path / 'o.csv'
    assert cli.main(['simulate', '--motion', 'vertical', '--bandwidth', '2', '--feedforward',
                     'none', '-o', str(out)]) == 0
    lines = capsys.readouterr().out.strip().splitlines()
    assert len(lines) == 1, lines
    sim = read(out)
    peak = max(np.max(np.abs(sim[f'length_error_{leg}'])) for leg in 'abc')
    assert f'{peak:.3g}' in lines[0] and str(len(sim)) in lines[0], lines[0]
    assert cli.main(['simulate', '--motion', 'vertical', '-o', '-']) == 0     # the CSV on stdout
    captured = capsys.readouterr()
    assert captured.out.startswith('t,') and len(captured.err.strip().splitlines()) == 1


def test_plot_draws_simulates_output_with_its_powers(tmp_path):
    pytest.importorskip('matplotlib')
    out, png = tmp_path / 'o.csv', tmp_path / 'o.png'
    assert cli.main(['simulate', '--motion', 'vertical', '-o', str(out)]) == 0
    assert cli.main(['plot', str(out), '-o', str(png)]) == 0
    assert png.read_bytes().startswith(b'\x89PNG')


def test_reference_may_be_poses_only_as_for_solve(vertical, tmp_path, capsys):
    full = read(vertical / 'vertical.csv')
    poses = tmp_path / 'poses.csv'
    csv_io.write_csv(poses, ('t', 'surge', 'heave', 'roll'),
                     np.column_stack([full[n] for n in ('t', 'surge', 'heave', 'roll')]))
    out = tmp_path / 'o.csv'
    assert cli.main(['simulate', '--reference', str(poses), '-o', str(out)]) == 0
    assert 'note:' in capsys.readouterr().err
    assert np.max(np.abs(read(out)['heave'] - full['heave'])) < 1e-3


def test_forces_may_be_solves_npz(vertical, tmp_path):
    a, b = tmp_path / 'a.csv', tmp_path / 'b.csv'
    for forces, out in (('solved.npz', a), ('solved.csv', b)):
        assert cli.main(['simulate', '--forces', str(vertical / forces), '--params',
                         str(vertical / 'payload.yaml'), '-o', str(out)]) == 0
    assert a.read_text() == b.read_text()


def test_plot_of_simulates_output_shows_its_tracking_error(tmp_path, monkeypatch):
    """The closed loop's leg length error, one curve per leg in mm; solve's
    output (no error columns) keeps its two axes."""
    pytest.importorskip('matplotlib')
    from matplotlib.figure import Figure
    saved = []
    original = Figure.savefig
    monkeypatch.setattr(Figure, 'savefig',
                        lambda self, *a, **k: (saved.append(self), original(self, *a, **k)))
    out = tmp_path / 'o.csv'
    assert cli.main(['simulate', '--motion', 'violent', '-o', str(out)]) == 0
    assert cli.main(['plot', str(out), '-o', str(tmp_path / 'o.png')]) == 0
    fig, = saved
    sim = read(out)
    drawn = [np.asarray(line.get_ydata()) for ax in fig.axes for line in ax.get_lines()]
    for leg in 'abc':
        want = 1e3 * sim[f'length_error_{leg}']
        assert np.abs(want).max() > 0.0
        assert any(len(y) == len(want) and np.allclose(y, want) for y in drawn), leg
