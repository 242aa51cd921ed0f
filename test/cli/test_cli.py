"""The command line (``flight-sim-dynamics`` / ``python -m flight_sim_dynamics``)
and its CSV layer: example -> solve -> plot round trips, exact number
round trips, strict input checking (line and column named, exit status 2,
no output file left behind, an old output file left untouched)."""
from __future__ import annotations

import math
import os
import re
import subprocess
import sys
import types
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import flight_sim_dynamics as fsd
from flight_sim_dynamics.cli import main as cli
from flight_sim_dynamics.cli import csv_io
from flight_sim_dynamics.cli.csv_io import TRAJECTORY_COLUMNS
from flight_sim_dynamics.machines.staicu.trajectories import (PAPER_EXAMPLES, paper_example,
                                                              sample_times)


def formatted(data: np.ndarray, step: int = 1024) -> bytes:
    """The rows as write_csv writes them."""
    return b''.join(csv_io._format_blocks(np.asarray(data, dtype=np.float64), None, step))


def exact(x: float) -> str:
    """The shortest decimal that reads back as x, without an integral '.0'."""
    text = repr(float(x))
    return text[:-2] if text.endswith('.0') else text

ROOT = Path(__file__).resolve().parents[2]
MODEL = fsd.load_model()
HEADER = ','.join(TRAJECTORY_COLUMNS)
REQUIRED_OUTPUT = ('t,length_a,length_b,length_c,stroke_a,stroke_b,stroke_c,rate_a,rate_b,'
                   'rate_c,force_a,force_b,force_c,power_a,power_b,power_c').split(',')
PNG_SIGNATURE = b'\x89PNG\r\n\x1a\n'


def run_cli(*args: str, cwd: Path | None = None) -> subprocess.CompletedProcess:
    """Run the CLI as a user would, in a fresh interpreter."""
    env = dict(os.environ)
    env['PYTHONPATH'] = str(ROOT) + (os.pathsep + env['PYTHONPATH'] if env.get('PYTHONPATH')
                                     else '')
    env.pop('FLIGHT_SIM_DYNAMICS_DEBUG', None)
    env['MPLBACKEND'] = 'Agg'
    return subprocess.run([sys.executable, '-m', 'flight_sim_dynamics', *args], cwd=cwd,
                          env=env, capture_output=True, text=True, timeout=300)


def read_plain(path: Path) -> tuple[list[str], np.ndarray]:
    """An independent reader: the csv text, Python's float(). A last column
    `status` (words) is checked to be all 'ok' and left out."""
    lines = path.read_text().splitlines()
    header = lines[0].split(',')
    rows = [line.split(',') for line in lines[1:]]
    if header[-1] == 'status':
        assert all(row[-1] == 'ok' for row in rows), 'a row is not ok'
        header, rows = header[:-1], [row[:-1] for row in rows]
    data = np.array([[float(v) for v in row] for row in rows])
    return header, data.reshape(len(lines) - 1, len(header))


def one_error_line(stderr: str) -> str:
    lines = stderr.strip().splitlines()
    assert len(lines) == 1, stderr
    assert lines[0].startswith('error: '), stderr
    assert 'Traceback' not in stderr
    return lines[0]


def write_trajectory(path: Path, name: str = 'general', rate: float = 20.0) -> np.ndarray:
    t = sample_times(rate)
    q, qd, qdd = paper_example(name, t)
    data = np.column_stack([t, q, qd, qdd])
    csv_io.write_csv(path, TRAJECTORY_COLUMNS, data)
    return data


# ----------------------------------------------------------------------------
# The user's round trip, in a subprocess: example -> solve -> plot
# ----------------------------------------------------------------------------
@pytest.mark.ros
def test_round_trip_as_a_user(tmp_path):
    r = run_cli('example', 'vertical', '-o', 'traj.csv', cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    r = run_cli('solve', 'traj.csv', '-o', 'out.csv', cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    r = run_cli('plot', 'out.csv', '-o', 'fig.png', cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert r.stdout == '' and r.stderr == ''

    header, traj = read_plain(tmp_path / 'traj.csv')
    assert header == list(TRAJECTORY_COLUMNS)
    t = sample_times(cli.DEFAULT_RATE_HZ)          # default: 100 Hz, 0..3 s
    assert len(traj) == 301 and np.array_equal(traj[:, 0], t)
    q, qd, qdd = paper_example('vertical', t)
    assert np.array_equal(traj[:, 1:], np.column_stack([q, qd, qdd]))

    header, out = read_plain(tmp_path / 'out.csv')
    assert header[:len(REQUIRED_OUTPUT)] == REQUIRED_OUTPUT
    col = {name: j for j, name in enumerate(header)}
    sol = fsd.solve_batch(MODEL, q, qd, qdd)
    for field in ('length', 'stroke', 'rate', 'force', 'power'):
        for i, leg in enumerate('abc'):
            assert np.array_equal(out[:, col[f'{field}_{leg}']], getattr(sol, field)[:, i])
    # the paper: forces and powers of B and C equal throughout the vertical example
    assert np.allclose(out[:, col['force_b']], out[:, col['force_c']], rtol=1e-12, atol=1e-12)
    assert np.allclose(out[:, col['power_b']], out[:, col['power_c']], rtol=1e-12, atol=1e-12)

    png = (tmp_path / 'fig.png').read_bytes()
    assert png.startswith(PNG_SIGNATURE) and len(png) > 10_000
    assert sorted(p.name for p in tmp_path.iterdir()) == ['fig.png', 'out.csv', 'traj.csv']


@pytest.mark.ros
def test_error_as_a_user(tmp_path):
    (tmp_path / 'traj.csv').write_text(HEADER + '\n' + '0,' * 9 + 'x\n')
    r = run_cli('solve', 'traj.csv', '-o', 'out.csv', cwd=tmp_path)
    assert r.returncode == 2
    line = one_error_line(r.stderr)
    assert 'line 2' in line and 'column 10 (roll_acc)' in line and "'x'" in line
    assert r.stdout == ''
    assert sorted(p.name for p in tmp_path.iterdir()) == ['traj.csv']


def test_help_and_usage_errors(capsys):
    assert cli.main([]) == 2                      # no subcommand: help on stderr
    assert 'solve' in capsys.readouterr().err
    assert cli.main(['example', '--help']) == 0
    assert '100' in capsys.readouterr().out       # the default rate is documented
    for argv in (['nope'], ['example', 'nope', '-o', 'x.csv'], ['solve', 'x.csv'],
                 ['example', 'vertical', '--rate', 'abc', '-o', 'x.csv']):
        assert cli.main(argv) == 2
        one_error_line(capsys.readouterr().err)


# ----------------------------------------------------------------------------
# example
# ----------------------------------------------------------------------------
@pytest.mark.parametrize('name', sorted(PAPER_EXAMPLES))
@pytest.mark.parametrize('rate', [100.0, 7.0, 250.0])
def test_example_equals_paper_example(tmp_path, name, rate):
    out = tmp_path / f'{name}.csv'
    argv = ['example', name, '-o', str(out)] + ([] if rate == 100.0 else ['--rate', str(rate)])
    assert cli.main(argv) == 0
    header, data = read_plain(out)
    assert header == list(TRAJECTORY_COLUMNS)
    t = sample_times(rate)
    q, qd, qdd = paper_example(name, t)
    assert np.array_equal(data, np.column_stack([t, q, qd, qdd]))   # exact round trip


@pytest.mark.parametrize('rate', ['0', '-5', 'nan', 'inf', '1e12'])
def test_example_bad_rate(tmp_path, capsys, rate):
    out = tmp_path / 'x.csv'
    assert cli.main(['example', 'vertical', '--rate', rate, '-o', str(out)]) == 2
    assert '--rate' in one_error_line(capsys.readouterr().err)
    assert not out.exists()


def test_example_to_stdout(capfdbinary):
    assert cli.main(['example', 'rectilinear', '--rate', '2', '-o', '-']) == 0
    text = capfdbinary.readouterr().out.decode()
    assert text.splitlines()[0] == HEADER and len(text.splitlines()) == 8


# ----------------------------------------------------------------------------
# solve
# ----------------------------------------------------------------------------
def solve_cli(tmp_path, text: str, *extra: str) -> tuple[int, Path]:
    src = tmp_path / 'traj.csv'
    src.write_text(text)
    out = tmp_path / 'out.csv'
    return cli.main(['solve', str(src), '-o', str(out), *extra]), out


def test_solve_equals_solve_batch(tmp_path):
    data = write_trajectory(tmp_path / 'traj.csv', 'general', rate=40.0)
    out = tmp_path / 'out.csv'
    assert cli.main(['solve', str(tmp_path / 'traj.csv'), '-o', str(out), '--joints',
                     '--cond']) == 0
    header, res = read_plain(out)
    assert tuple(header) == cli.OUTPUT_COLUMNS + ('cond',) + cli.JOINT_COLUMNS
    for name in fsd.JOINT_NAMES:
        assert name in header and f'{name}_rate' in header
    col = {name: j for j, name in enumerate(header)}
    sol = fsd.solve_batch(MODEL, data[:, 1:4], data[:, 4:7], data[:, 7:10])
    assert np.array_equal(res[:, col['t']], data[:, 0])
    for field in ('length', 'stroke', 'rate', 'acceleration', 'force', 'power'):
        for i, leg in enumerate('abc'):
            assert np.array_equal(res[:, col[f'{field}_{leg}']], getattr(sol, field)[:, i])
    assert np.array_equal(res[:, col['beta']], sol.beta)
    assert np.array_equal(res[:, col['cond']], sol.cond)
    assert np.array_equal(res[:, col['kinematic_condition']], sol.kinematic_condition)
    assert np.array_equal(res[:, col['jacobian_condition']], sol.jacobian_condition)
    for j, name in enumerate(fsd.JOINT_NAMES):
        assert np.array_equal(res[:, col[name]], sol.joints[:, j])
        assert np.array_equal(res[:, col[f'{name}_rate']], sol.joint_rates[:, j])
        assert np.array_equal(res[:, col[f'{name}_acc']], sol.joint_accelerations[:, j])


def test_solve_column_order_does_not_matter(tmp_path):
    data = write_trajectory(tmp_path / 'a.csv', 'general', rate=10.0)
    perm = np.random.default_rng(3).permutation(len(TRAJECTORY_COLUMNS))
    names = [TRAJECTORY_COLUMNS[j] for j in perm]
    # hand-written, with spaces, CRLF line ends and plain '%r' numbers
    lines = [' , '.join(names)] + [', '.join(repr(float(v)) for v in row[perm]) for row in data]
    (tmp_path / 'b.csv').write_bytes(('\r\n'.join(lines) + '\r\n').encode())
    for name in ('a', 'b'):
        assert cli.main(['solve', str(tmp_path / f'{name}.csv'),
                         '-o', str(tmp_path / f'{name}_out.csv')]) == 0
    assert (tmp_path / 'a_out.csv').read_bytes() == (tmp_path / 'b_out.csv').read_bytes()


def test_solve_with_params_file(tmp_path):
    write_trajectory(tmp_path / 'traj.csv', 'vertical', rate=10.0)
    params = (ROOT / 'config' / 'flight_sim_dynamics.yaml').read_text()
    heavier = params.replace('gravity: 9.81', 'gravity: 19.62', 1)
    assert heavier != params
    (tmp_path / 'p.yaml').write_text(heavier)
    assert cli.main(['solve', str(tmp_path / 'traj.csv'), '-o', str(tmp_path / 'g1.csv')]) == 0
    assert cli.main(['solve', str(tmp_path / 'traj.csv'), '-o', str(tmp_path / 'g2.csv'),
                     '--params', str(tmp_path / 'p.yaml')]) == 0
    h, f1 = read_plain(tmp_path / 'g1.csv')
    _, f2 = read_plain(tmp_path / 'g2.csv')
    j = h.index('force_a')
    assert np.all(f2[:, j] > 1.5 * f1[:, j])     # twice the weight to hold up


@pytest.mark.parametrize('edit, expected', [
    (('gravity: 9.81', 'gravity: -3'), ["'gravity'", '-3']),
    (('d1: 0.4', 'd1: zero'), ["'geometry.d1'", 'zero']),
    (('d1: 0.4', 'd9: 0.4'), ['geometry.d9']),
])
def test_solve_bad_params_names_key(tmp_path, capsys, edit, expected):
    write_trajectory(tmp_path / 'traj.csv', 'vertical', rate=10.0)
    params = (ROOT / 'config' / 'flight_sim_dynamics.yaml').read_text()
    bad = params.replace(edit[0], edit[1], 1)
    assert bad != params
    (tmp_path / 'bad.yaml').write_text(bad)
    out = tmp_path / 'out.csv'
    rc = cli.main(['solve', str(tmp_path / 'traj.csv'), '-o', str(out),
                   '--params', str(tmp_path / 'bad.yaml')])
    assert rc == 2
    line = one_error_line(capsys.readouterr().err)
    for text in expected:
        assert text in line
    assert not out.exists()


def test_solve_scene_changes_forces_and_bad_scene_is_named(tmp_path, capsys):
    write_trajectory(tmp_path / 'traj.csv', 'general', rate=10.0)
    assert cli.main(['solve', str(tmp_path / 'traj.csv'), '-o', str(tmp_path / 'full.csv')]) == 0
    assert cli.main(['solve', str(tmp_path / 'traj.csv'), '-o', str(tmp_path / 'qs.csv'),
                     '--scene', 'quasi_static']) == 0
    h, full = read_plain(tmp_path / 'full.csv')
    _, qs = read_plain(tmp_path / 'qs.csv')
    forces = [h.index(f'force_{leg}') for leg in 'abc']
    assert 0 < np.abs(full[:, forces] - qs[:, forces]).max() < 2.0   # inertia: under 1 N here
    out = tmp_path / 'bad.csv'
    assert cli.main(['solve', str(tmp_path / 'traj.csv'), '-o', str(out),
                     '--scene', 'turbulence']) == 2
    line = one_error_line(capsys.readouterr().err)
    assert "scene 'turbulence'" in line and 'quasi_static' in line
    assert not out.exists()


def test_bad_scene_blames_scene_not_params(tmp_path, capsys):
    """Issue 14: a bad --scene is reported as --scene, not as --params
    (SceneError is a ParameterError; its handler must come first)."""
    write_trajectory(tmp_path / 'traj.csv', 'vertical', rate=10.0)
    out = tmp_path / 'o.csv'
    assert cli.main(['solve', str(tmp_path / 'traj.csv'), '-o', str(out),
                     '--scene', 'nonexistent']) == 2
    line = one_error_line(capsys.readouterr().err)
    assert line.startswith("error: --scene: scene 'nonexistent'"), line
    assert '--params' not in line and not out.exists()


def test_a_3dof_trajectory_for_a_hexapods_params_file_is_refused_naming_both(tmp_path, capsys):
    write_trajectory(tmp_path / 'traj.csv', 'vertical', rate=10.0)
    out = tmp_path / 'o.csv'
    rc = cli.main(['solve', str(tmp_path / 'traj.csv'), '-o', str(out),
                   '--params', str(ROOT / 'config' / 'stewart_6dof.yaml')])
    line = one_error_line(capsys.readouterr().err)
    assert rc == 2 and '3-DOF' in line and 'hexapod' in line and 'line 1' in line
    assert not out.exists()


def test_solve_missing_params_file(tmp_path, capsys):
    write_trajectory(tmp_path / 'traj.csv', 'vertical', rate=10.0)
    rc = cli.main(['solve', str(tmp_path / 'traj.csv'), '-o', str(tmp_path / 'o.csv'),
                   '--params', str(tmp_path / 'nope.yaml')])
    assert rc == 2 and 'nope.yaml' in one_error_line(capsys.readouterr().err)


ROW = '0.5,0,0,0,0,0,0,0,0,0'
GOOD = f'{HEADER}\n0,0,0,0,0,0,0,0,0,0\n{ROW}\n'

# (file text, substrings the one-line message must contain)
MALFORMED = {
    'nan': (GOOD + '1,0,nan,0,0,0,0,0,0,0\n', ['line 4', 'column 3 (heave)', "'nan'"]),
    'NaN': (GOOD + '1,0,0,0,0,0,0,0,0,NaN\n', ['line 4', 'column 10 (roll_acc)']),
    'inf': (GOOD + '1,0,0,-inf,0,0,0,0,0,0\n', ['line 4', 'column 4 (roll)', 'finite']),
    'overflow': (GOOD + '1,0,0,0,1e999,0,0,0,0,0\n', ['line 4', 'column 5', 'finite']),
    'text': (f'{HEADER}\n0,0,abc,0,0,0,0,0,0,0\n', ['line 2', 'column 3 (heave)', "'abc'"]),
    'comma decimal': (f'{HEADER}\n0,0,0,0,0,0,0,0,0,"0,5"\n', ['line 2', 'column 10']),
    'two dots': (GOOD + '1,0,0,1.2.3,0,0,0,0,0,0\n', ['line 4', 'column 4 (roll)']),
    'underscore': (GOOD + '1,0,1_000,0,0,0,0,0,0,0\n', ['line 4', 'column 3']),
    'hex': (GOOD + '1,0,0x10,0,0,0,0,0,0,0\n', ['line 4', 'column 3']),
    'space inside': (GOOD + '1,0,1 2,0,0,0,0,0,0,0\n', ['line 4', 'column 3']),
    'empty cell': (GOOD + '1,0,,0,0,0,0,0,0,0\n', ['line 4', 'column 3 (heave)', 'missing']),
    'blank cell': (GOOD + '1,0,0,0,0,0,0,0,0,  \n', ['line 4', 'column 10', 'missing']),
    'short row': (GOOD + '1,0,0,0,0,0,0,0,0\n', ['line 4', 'column 10 (roll_acc)', 'missing']),
    'long row': (GOOD + '1,0,0,0,0,0,0,0,0,0,0\n', ['line 4', 'column 11', 'extra']),
    'one value': (f'{HEADER}\n0\n', ['line 2', 'column 2 (surge)', 'missing']),
    'blank line': (f'{HEADER}\n{ROW}\n\n{ROW}\n', ['line 3', 'empty line']),
    'spaces line': (f'{HEADER}\n{ROW}\n   \n{ROW}\n', ['line 3', 'empty line']),
    'late error': (f'{HEADER}\n' + f'{ROW}\n' * 500 + '1,0,0,0,0,0,0,0,0,z\n',
                   ['line 502', 'column 10 (roll_acc)']),
    'non-utf8': (GOOD.encode() + b'1,0,\xff,0,0,0,0,0,0,0\n', ['line 4']),
    'empty file': ('', ['line 1', 'empty']),
    'whitespace file': ('\n \n', ['line 1', 'empty']),
    'header only': (HEADER + '\n', ['line 2', 'no data rows']),
    'missing column': (HEADER.replace(',roll_acc', '') + '\n0,0,0,0,0,0,0,0,0\n',
                       ['line 1', "'roll_acc'", 'missing']),
    'duplicate column': (HEADER.replace('surge_rate', 'surge') + f'\n{ROW}\n',
                         ['line 1', 'column 5 (surge)', 'duplicate']),
    'renamed column': (HEADER.replace('heave,', 'Heave,') + f'\n{ROW}\n',
                       ['line 1', "'Heave'", "'heave'"]),
    'empty column name': (HEADER + ',\n' + ROW + ',1\n', ['line 1', 'column 11', 'empty']),
}


@pytest.mark.parametrize('case', sorted(MALFORMED))
def test_solve_malformed_input(tmp_path, capsys, case):
    text, expected = MALFORMED[case]
    src = tmp_path / 'traj.csv'
    src.write_bytes(text if isinstance(text, bytes) else text.encode())
    out = tmp_path / 'out.csv'
    assert cli.main(['solve', str(src), '-o', str(out)]) == 2
    captured = capsys.readouterr()
    line = one_error_line(captured.err)
    assert captured.out == ''
    for piece in expected:
        assert piece in line, (piece, line)
    assert str(src) in line
    assert not out.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ['traj.csv']   # no temp files


def test_unknown_column_is_an_error_of_the_strict_reader(tmp_path):
    """The reader refuses a column it was not asked for (moved here from
    MALFORMED: solve now ignores extra columns, see below)."""
    (tmp_path / 'traj.csv').write_text(HEADER + ',extra\n' + ROW + ',1\n')
    with pytest.raises(csv_io.CsvError) as info:
        csv_io.read_csv(tmp_path / 'traj.csv', required=TRAJECTORY_COLUMNS)
    for piece in ['line 1', 'column 11 (extra)', 'unknown']:
        assert piece in str(info.value)


@pytest.mark.parametrize('where', ['first', 'middle', 'last'])
def test_solve_ignores_extra_columns_with_a_note(tmp_path, capsys, where):
    """A user's CSV often has more columns (comments, other signals, text):
    solve reads its ten, names the others once in a note on stderr, and gives
    the same output as without them; errors still name the file's columns."""
    data = write_trajectory(tmp_path / 'plain.csv', 'general', rate=10.0)
    names = list(TRAJECTORY_COLUMNS)
    at = {'first': 0, 'middle': 4, 'last': len(names)}[where]
    names[at:at] = ['comment', 'speed']
    rows = [[exact(v) for v in row] for row in data]
    for i, row in enumerate(rows):
        row[at:at] = [f'text {i}!', '1e999' if i == 3 else 'x']    # never parsed
    (tmp_path / 'extra.csv').write_text(','.join(names) + '\n'
                                        + ''.join(','.join(r) + '\n' for r in rows))
    assert cli.main(['solve', str(tmp_path / 'plain.csv'), '-o', str(tmp_path / 'a.csv')]) == 0
    assert capsys.readouterr().err == ''
    assert cli.main(['solve', str(tmp_path / 'extra.csv'), '-o', str(tmp_path / 'b.csv')]) == 0
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 1 and err[0].startswith('note: ') and "'comment', 'speed'" in err[0]
    assert (tmp_path / 'a.csv').read_bytes() == (tmp_path / 'b.csv').read_bytes()
    # a bad value in a column solve reads: the file's own line and column numbers
    rows[2][names.index('roll')] = 'oops'
    rows[4].append('1')                                 # a ragged row further down
    (tmp_path / 'extra.csv').write_text(','.join(names) + '\n'
                                        + ''.join(','.join(r) + '\n' for r in rows))
    out = tmp_path / 'c.csv'
    assert cli.main(['solve', str(tmp_path / 'extra.csv'), '-o', str(out)]) == 2
    line = one_error_line(capsys.readouterr().err)
    assert f"line 4, column {names.index('roll') + 1} (roll): 'oops'" in line, line
    assert not out.exists()
    rows[2][names.index('roll')] = '0'
    (tmp_path / 'extra.csv').write_text(','.join(names) + '\n'
                                        + ''.join(','.join(r) + '\n' for r in rows))
    assert cli.main(['solve', str(tmp_path / 'extra.csv'), '-o', str(out)]) == 2
    line = one_error_line(capsys.readouterr().err)
    assert f'line 6, column {len(names) + 1}: extra value' in line, line


@pytest.mark.parametrize('case', ['nan', 'short row', 'header only'])
def test_solve_error_leaves_old_output_untouched(tmp_path, capsys, case):
    out = tmp_path / 'out.csv'
    out.write_text('old contents\n')
    os.utime(out, (1_000_000_000, 1_000_000_000))
    rc, _ = solve_cli(tmp_path, MALFORMED[case][0])
    assert rc == 2
    one_error_line(capsys.readouterr().err)
    assert out.read_text() == 'old contents\n'
    assert out.stat().st_mtime == 1_000_000_000
    assert sorted(p.name for p in tmp_path.iterdir()) == ['out.csv', 'traj.csv']


def test_unreachable_and_invalid_rows_get_their_status(tmp_path, capsys):
    """A pose the mechanism cannot take is not an error of the file: its row is
    written with status unreachable (and zeros), the others normally, and a
    warning names the first such line."""
    src = tmp_path / 'traj.csv'
    src.write_text(GOOD + '1,0,5,0,0,0,0,0,0,0\n' + ROW.replace('0.5,', '1.5,', 1) + '\n')
    out = tmp_path / 'out.csv'
    assert cli.main(['solve', str(src), '-o', str(out)]) == 0
    err = capsys.readouterr().err
    assert err.startswith('warning: ') and 'line 4' in err and 'unreachable' in err
    assert '1 unreachable' in err and 'loop D' in err
    lines = out.read_text().splitlines()
    assert lines[0].split(',')[-1] == 'status'
    assert [line.split(',')[-1] for line in lines[1:]] == ['ok', 'ok', 'unreachable', 'ok']
    row = [float(v) for v in lines[3].split(',')[1:-1]]
    assert row == [0.0] * len(row)


def test_solve_overwrites_old_output_on_success(tmp_path):
    out = tmp_path / 'out.csv'
    out.write_text('old contents\n')
    rc, _ = solve_cli(tmp_path, GOOD)
    assert rc == 0
    assert out.read_text().startswith('t,length_a,')
    umask = os.umask(0)
    os.umask(umask)
    assert out.stat().st_mode & 0o777 == 0o666 & ~umask     # not mkstemp's 0600


def test_solve_output_errors(tmp_path, capsys):
    src = tmp_path / 'traj.csv'
    src.write_text(GOOD)
    for target in (tmp_path / 'no' / 'dir' / 'out.csv', tmp_path):
        assert cli.main(['solve', str(src), '-o', str(target)]) == 2
        one_error_line(capsys.readouterr().err)
    assert cli.main(['solve', str(tmp_path / 'missing.csv'), '-o', str(tmp_path / 'o.csv')]) == 2
    assert 'missing.csv' in one_error_line(capsys.readouterr().err)
    assert not (tmp_path / 'o.csv').exists()


def test_parser_accepts_exactly_the_finite_decimal_cells():
    """Every cell made of the characters of numbers is read when it is a
    finite decimal number (the strict pattern), as float() reads it, and is
    otherwise an error naming its line and column (whatever the size of the
    file)."""
    rng = np.random.default_rng(7)
    alphabet = list('0123456789.eE+- \t')
    tokens = {''.join(rng.choice(alphabet, size=n)) for n in range(1, 7) for _ in range(1500)}
    tokens |= {'1', '+1', '-1.5', '.5', '5.', '1e5', '1E+5', '1e-05', ' 1 ', '1e', 'e1',
               '.', '+', '-', '1.e5', '.e5', '--1', '1e5e5', '0001', '+.5e-3'}
    strict = re.compile(r'[ \t]*[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?[ \t]*', re.ASCII)
    for tok in sorted(tokens):
        text = f'a,b,c\n0,{tok},0'.encode()
        valid = bool(strict.fullmatch(tok)) and math.isfinite(float(tok))
        try:
            table = csv_io.parse_csv(text, 'x', required=('a', 'b', 'c'))
        except csv_io.CsvError as exc:
            assert not valid and (exc.line, exc.column) == (2, 2), repr(tok)
        else:
            assert valid and table['b'][0] == float(tok), repr(tok)


# ----------------------------------------------------------------------------
# plot
# ----------------------------------------------------------------------------
def test_plot(tmp_path):
    write_trajectory(tmp_path / 'traj.csv', 'general', rate=20.0)
    out = tmp_path / 'general.csv'
    assert cli.main(['solve', str(tmp_path / 'traj.csv'), '-o', str(out)]) == 0
    assert cli.main(['plot', str(tmp_path / 'general.csv'), '-o', str(tmp_path / 'g.png')]) == 0
    png = (tmp_path / 'g.png').read_bytes()
    assert png.startswith(PNG_SIGNATURE) and png[12:16] == b'IHDR'
    width, height = int.from_bytes(png[16:20], 'big'), int.from_bytes(png[20:24], 'big')
    assert width >= 600 and height >= 500
    assert cli.main(['plot', str(tmp_path / 'general.csv'), '-o', str(tmp_path / 'g.svg'),
                     '--title', 'my title']) == 0
    svg = (tmp_path / 'g.svg').read_text()
    assert '<svg' in svg and 'my title' in svg    # matplotlib keeps texts as comments


def test_plot_figure_contents():
    t = np.linspace(0, 3, 31)
    f = np.column_stack([t, 2 * t, 3 * t])
    fig = cli_plotting().force_power_figure(t, f, -f, title='x')
    ax_f, ax_p = fig.axes
    assert 'N' in ax_f.get_ylabel() and 'W' in ax_p.get_ylabel() and 's' in ax_p.get_xlabel()
    for ax in (ax_f, ax_p):
        labels = [text.get_text() for text in ax.get_legend().get_texts()]
        assert labels == ['actuator A', 'actuator B', 'actuator C']
    assert np.array_equal(ax_p.get_lines()[2].get_ydata(), -3 * t)
    assert 'vertical' in cli_plotting().default_title('out/vertical.csv')
    assert 'Figs. 3 and 4' in cli_plotting().default_title('out/vertical.csv')
    assert 'Figs. 7 and 8' in cli_plotting().default_title('general.csv')
    # another machine's actuators: the file is not that example
    assert 'Figs.' not in cli_plotting().default_title('vertical.csv', tuple('123456'))


def cli_plotting():
    from flight_sim_dynamics.cli import plotting
    return plotting


@pytest.mark.parametrize('text, expected', [
    ('t,force_a,force_b,force_c,power_a,power_b\n0,1,2,3,4,5\n', ["'power_c'", 'line 1']),
    ('t,force_a,force_b,force_c,power_a,power_b,power_c\n0,1,2,3,4,5,x\n',
     ['line 2', 'column 7 (power_c)']),
])
def test_plot_bad_input(tmp_path, capsys, text, expected):
    (tmp_path / 'o.csv').write_text(text)
    assert cli.main(['plot', str(tmp_path / 'o.csv'), '-o', str(tmp_path / 'f.png')]) == 2
    line = one_error_line(capsys.readouterr().err)
    for piece in expected:
        assert piece in line
    assert not (tmp_path / 'f.png').exists()


def test_plot_bad_format(tmp_path, capsys):
    (tmp_path / 'o.csv').write_text('t,force_a,force_b,force_c,power_a,power_b,power_c\n'
                                    '0,1,2,3,4,5,6\n')
    assert cli.main(['plot', str(tmp_path / 'o.csv'), '-o', str(tmp_path / 'f.xyz')]) == 2
    assert 'png' in one_error_line(capsys.readouterr().err)
    assert not (tmp_path / 'f.xyz').exists()


# ----------------------------------------------------------------------------
# Forwarded subcommands (node, demo-planner, demo)
# ----------------------------------------------------------------------------
@pytest.mark.parametrize('command, module', [('node', 'flight_sim_dynamics.ros.node'),
                                             ('demo-planner', 'flight_sim_dynamics.ros.planner'),
                                             ('demo', 'flight_sim_dynamics.cli.demo')])
def test_forwarded_subcommands(monkeypatch, command, module):
    seen = []
    fake = types.ModuleType(module)
    fake.main = lambda argv=None: seen.append(argv) or 7
    monkeypatch.setitem(sys.modules, module, fake)
    argv = ['--ros-args', '--params-file', 'F.yaml', '-p', 'x:=1', '--help']
    assert cli.main([command, *argv]) == 7
    assert seen == [argv]


def test_forwarded_subcommand_exits(monkeypatch, capsys):
    fake = types.ModuleType('flight_sim_dynamics.ros.planner')

    def main(argv):
        if argv == ['--help']:
            raise SystemExit(0)
        raise RuntimeError('no ROS graph')

    fake.main = main
    monkeypatch.setitem(sys.modules, 'flight_sim_dynamics.ros.planner', fake)
    assert cli.main(['demo-planner', '--help']) == 0
    assert cli.main(['demo-planner']) == 2
    assert 'no ROS graph' in one_error_line(capsys.readouterr().err)


def test_forwarded_subcommand_unavailable(monkeypatch, capsys):
    monkeypatch.setitem(sys.modules, 'flight_sim_dynamics.cli.demo', None)   # import fails
    assert cli.main(['demo']) == 2
    assert 'demo' in one_error_line(capsys.readouterr().err)


# ----------------------------------------------------------------------------
# Exact number formatting
# ----------------------------------------------------------------------------
def roundtrips(values: np.ndarray) -> None:
    texts = formatted(values.reshape(-1, 1)).decode().split('\n')[:-1]
    for v, text in zip(values, texts, strict=True):
        assert text == exact(v)
        back = float(text)
        if np.isnan(v):
            assert text == 'nan'
            continue
        assert back == v and np.signbit(back) == np.signbit(v), (repr(v), text)
        assert re.fullmatch(r'-?(\d+(\.\d+)?(e[+-]\d{2,3})?|0\.\d+|inf)', text), text
        assert len(text.lstrip('-').replace('.', '').split('e')[0].lstrip('0')) <= 17


@settings(max_examples=500, deadline=None)
@given(st.floats(allow_nan=False))
def test_format_value_round_trips(x):
    roundtrips(np.array([x]))


def test_format_values_round_trip_bulk():
    rng = np.random.default_rng(11)
    bits = rng.integers(0, 2 ** 63, size=20000, dtype=np.int64).view(np.float64)
    p2 = 2.0 ** np.arange(-1074, 1024)
    p10 = 10.0 ** np.arange(-320, 309)
    values = np.concatenate([
        bits, -bits, rng.standard_normal(5000), np.arange(0, 3.01, 0.01), p2,
        np.nextafter(p2, 0), np.nextafter(p2, np.inf), p10, np.nextafter(p10, 0),
        np.nextafter(p10, np.inf),
        [0.0, -0.0, np.inf, -np.inf, np.nan, 5e-324, 1.7976931348623157e308, 0.1 + 0.2,
         1e16, 1e17, 9.999999999999999e16, 1e-5, 1e-4, 1e250, 1e-250]])
    roundtrips(values[np.isfinite(values) | np.isnan(values) | np.isinf(values)])


def test_format_value_is_short_when_it_can_be():
    for v, text in [(0.0, '0'), (-0.0, '-0'), (1.0, '1'), (0.01, '0.01'), (0.29, '0.29'),
                    (33.2041, '33.2041'), (-1.5, '-1.5'), (1e-5, '1e-05'), (1e17, '1e+17'),
                    (123.0, '123'), (0.1 + 0.2, '0.30000000000000004'), (2.5e-300, '2.5e-300')]:
        assert formatted([[v]]).decode() == text + '\n'


def test_written_rows_read_back():
    rng = np.random.default_rng(5)
    data = rng.standard_normal((3000, 7)) * 10.0 ** rng.integers(-8, 8, size=(3000, 7))
    data[5] = 0.0
    text = formatted(data, 1000 // 7).decode()
    lines = text.split('\n')
    assert lines[-1] == '' and len(lines) == 3001
    back = np.array([[float(v) for v in line.split(',')] for line in lines[:-1]])
    assert np.array_equal(back, data)


def test_forward_round_trip_from_the_command_line(tmp_path, capsys):
    """Leg lengths from `solve`, back to the poses by `forward --csv`."""
    write_trajectory(tmp_path / 'traj.csv', 'general', rate=10.0)
    assert cli.main(['solve', str(tmp_path / 'traj.csv'), '-o', str(tmp_path / 'out.csv')]) == 0
    assert cli.main(['forward', '--csv', str(tmp_path / 'out.csv'), '-o',
                     str(tmp_path / 'pose.csv')]) == 0
    header, pose = read_plain(tmp_path / 'pose.csv')
    assert header == ['t', 'surge', 'heave', 'roll']
    _, traj = read_plain(tmp_path / 'traj.csv')
    np.testing.assert_allclose(pose[:, 1:], traj[:, 1:4], atol=1e-9)
    # one pose on the command line; lengths outside the workspace: exit 1, status named
    L = fsd.solve(MODEL, [0.01, 0.02, 0.1], [0, 0, 0], [0, 0, 0]).length
    assert cli.main(['forward', *map(repr, L.tolist())]) == 0
    fields = dict(item.split('=', 1) for item in capsys.readouterr().out.split()[:4])
    assert fields['status'] == 'ok'
    np.testing.assert_allclose([float(fields[k]) for k in ('surge', 'heave', 'roll')],
                               [0.01, 0.02, 0.1], atol=1e-12)
    assert cli.main(['forward', '3', '3', '3']) == 1
    assert 'status=unreachable' in capsys.readouterr().out
    assert cli.main(['forward', '1', '2']) == 2


@pytest.mark.parametrize('command', ['solve', 'simulate', 'plot', 'link'])
def test_an_output_that_is_an_input_is_refused_and_the_input_kept(tmp_path, capsys, command):
    write_trajectory(tmp_path / 'traj.csv', 'vertical')
    assert cli.main(['solve', str(tmp_path / 'traj.csv'), '-o', str(tmp_path / 's.csv')]) == 0
    before = {p: p.read_bytes() for p in tmp_path.iterdir()}
    args = {'solve': ['solve', str(tmp_path / 'traj.csv'), '-o', str(tmp_path / 'traj.csv')],
            'simulate': ['simulate', '--forces', str(tmp_path / 's.csv'), '-o',
                         str(tmp_path / '.' / 's.csv')],
            'plot': ['plot', str(tmp_path / 's.csv'), '-o', str(tmp_path / 's.csv')],
            'link': ['solve', str(tmp_path / 'traj.csv'), '-o', str(tmp_path / 'l.csv')]}
    if command == 'link':
        (tmp_path / 'l.csv').symlink_to(tmp_path / 'traj.csv')
        before[tmp_path / 'l.csv'] = (tmp_path / 'l.csv').read_bytes()
    assert cli.main(args[command]) == 2
    one_error_line(capsys.readouterr().err)
    assert {p: p.read_bytes() for p in tmp_path.iterdir()} == before


def test_version(capsys):
    import flight_sim_dynamics as fsd
    assert cli.main(['--version']) == 0
    assert fsd.__version__ in capsys.readouterr().out


def test_the_demo_twin_figure_shows_its_labels_whole(tmp_path, monkeypatch):
    """demo_twin.png: every axis label inside the saved figure (constrained layout)."""
    pytest.importorskip('matplotlib')
    pytest.importorskip('rclpy')
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    from flight_sim_dynamics.cli import demo
    from flight_sim_dynamics.core.motion import PlannerSequence
    from flight_sim_dynamics.machines.staicu.motions import MOTIONS, PLANNER_MOTIONS
    saved = []
    original = Figure.savefig
    monkeypatch.setattr(Figure, 'savefig',
                        lambda self, *a, **k: (saved.append(self), original(self, *a, **k)))
    sequence = PlannerSequence(MOTIONS, list(PLANNER_MOTIONS))
    t = np.linspace(0.0, sequence.period, 500)
    commanded = np.array([sequence.sample(x)[0] for x in t])
    demo.plot_tracking(t, commanded + 1e-4, commanded, sequence, tmp_path / 'demo_twin.png')
    fig, = saved
    renderer = FigureCanvasAgg(fig).get_renderer()
    box = fig.bbox
    for ax in fig.axes:
        for label in (ax.yaxis.label, ax.xaxis.label):
            if label.get_text():
                extent = label.get_window_extent(renderer)
                assert box.x0 <= extent.x0 and extent.x1 <= box.x1, label.get_text()
                assert box.y0 <= extent.y0 and extent.y1 <= box.y1, label.get_text()


def test_the_demo_warns_when_the_twin_does_not_keep_real_time():
    """From the twin's diagnostics within the run: a twin at 0.15x real time
    (the Python loop) or one that dropped steps in a stall gets a warning, one
    keeping up none, and no factor at all is said too."""
    pytest.importorskip('rclpy')
    from flight_sim_dynamics.cli import demo
    slow = demo.twin_speed([0.4, 0.15, 0.16, 0.15, 0.14])
    assert slow.startswith('warning') and '0.20' in slow
    assert not demo.twin_speed([0.95, 1.0, 0.999, 1.0, 1.001]).startswith('warning')
    assert demo.twin_speed([0.95, 1.0, 0.999, 1.0, 1.001], dropped=120).startswith('warning')
    assert demo.twin_speed([]).startswith('warning')


def test_the_demo_counts_the_twins_dropped_steps_within_the_run():
    pytest.importorskip('rclpy')
    from flight_sim_dynamics.cli import demo
    monitor = types.SimpleNamespace(speed=[(0.5, math.nan, 3), (1.5, 0.4, 5), (2.5, 1.0, 5),
                                           (3.5, 0.5, 105), (4.5, 1.0, 110)])
    factors, dropped = demo.TwinMonitor.speed_within(monitor, 1.0, 4.0)
    assert factors == [0.4, 1.0, 0.5] and dropped == 102


@pytest.mark.parametrize('figure', ['forces', 'twin'])
@pytest.mark.parametrize('params', [None, 'stewart_6dof'])
def test_the_demo_figures_name_the_motions_clear_of_the_titles(tmp_path, monkeypatch, figure,
                                                               params):
    """demo.png and demo_twin.png: each motion's name above the first axes
    overlaps no title (the axes' own, the figure's)."""
    pytest.importorskip('matplotlib')
    pytest.importorskip('rclpy')
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    from matplotlib.text import Text

    from flight_sim_dynamics.cli import demo
    from flight_sim_dynamics.core.motion import PlannerSequence
    machine = fsd.machine_of(fsd.load_model(params))
    saved = []
    # the figure kept, not written: it is drawn below, where the names are measured (the
    # PNG written too took half the test's time; test_the_demo_twin_figure_shows_its_
    # labels_whole writes one)
    monkeypatch.setattr(Figure, 'savefig', lambda self, *a, **k: saved.append(self))
    sequence = PlannerSequence(machine.motions, list(machine.planner_motions))
    t = np.linspace(0.0, sequence.period, 400)
    q = np.array([sequence.sample(x)[0] for x in t])
    if figure == 'forces':
        monitor = types.SimpleNamespace(stamps=list((t * 1e9).astype(np.int64)),
                                        effort=(400.0 + 0 * q).tolist(),
                                        velocity=(0.1 + 0 * q).tolist())
        demo.plot(monitor, sequence, 0, tmp_path / 'demo.png', machine.leg_labels)
    else:
        demo.plot_tracking(t, q + 1e-4, q, sequence, tmp_path / 'demo_twin.png', machine)
    fig, = saved
    renderer = FigureCanvasAgg(fig).get_renderer()
    fig.draw(renderer)
    texts = [t for t in fig.findobj(Text) if t.get_visible() and t.get_text()]
    names = [t for t in texts if t.get_text() in machine.planner_motions]
    assert {t.get_text() for t in names} == set(machine.planner_motions)
    titles = [fig._suptitle] + [ax.title for ax in fig.axes]
    for title in (t for t in titles if t is not None and t.get_text()):
        box = title.get_window_extent(renderer)
        for name in names:
            assert not box.overlaps(name.get_window_extent(renderer)), \
                (title.get_text(), name.get_text())
