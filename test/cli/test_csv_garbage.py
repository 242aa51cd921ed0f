"""Garbage at the CSV level, beyond what test_cli.py already covers.

test_cli.py checks NaN / inf / 1e999 / text / empty cells / short and long
rows / blank lines / empty files / bad headers, one at a time, with the line
and column named and no output file left. This file adds:

* huge but *finite* numbers (1e308, 1e150, 1e200, subnormals): they are not
  an error of the file; each row gets its status (invalid_input when the
  results would overflow, unreachable, limit, near_singular), and the output
  holds no NaN or infinity: the strict reader reads it back, and it equals
  solve_batch on the same rows exactly;
* binary garbage, NUL bytes, UTF-16, garbage on standard input with the
  output on standard output: one error line, nothing written anywhere;
* garbage injected at a random cell of a valid file (Hypothesis): the error
  names that line and column, and an old output file is left untouched.

``test_regression_*`` pins a bug found here (fixed: ASCII digits only).
"""
from __future__ import annotations

import io
import os
import sys

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import flight_sim_dynamics as fsd
from flight_sim_dynamics.cli import main as cli
from flight_sim_dynamics.cli import csv_io
from flight_sim_dynamics.cli.csv_io import TRAJECTORY_COLUMNS

MODEL = fsd.load_model()
HEADER = ','.join(TRAJECTORY_COLUMNS)


def examples(fraction: float = 1.0) -> int:
    """max_examples: a fraction of the loaded Hypothesis profile's (conftest.py)."""
    return max(5, int(settings.default.max_examples * fraction))


def one_error_line(stderr: str) -> str:
    lines = stderr.strip().splitlines()
    assert len(lines) == 1, stderr
    assert lines[0].startswith('error: ') and 'Traceback' not in stderr, stderr
    return lines[0]


def read_output(path, joints: bool = False) -> tuple[csv_io.Table, list[str]]:
    """The solve output through the strict reader (it refuses NaN and inf), and
    the status column (independently, as text)."""
    names = cli.OUTPUT_COLUMNS + (cli.JOINT_COLUMNS if joints else ())
    table = csv_io.read_csv(path, required=names, allow_extra=True, text_columns=('status',))
    assert table.names == names
    lines = open(path, encoding='ascii').read().splitlines()
    assert lines[0] == ','.join(names) + ',status'
    return table, [line.rsplit(',', 1)[1] for line in lines[1:]]


def fmt(value: float) -> str:
    return repr(float(value))


# rows (t, q, qd, qdd) -> expected status
HUGE_ROWS = [
    ((0.0, 0, 0, 0, 0, 0, 0, 0, 0, 0), 'ok'),
    ((1e308, 0, 0, 0, 1e308, 0, 0, 0, 0, 0), 'invalid_input'),      # rates overflow
    ((2.0, 0, 0, 0, 1e150, 0, 0, 0, 0, 0), 'invalid_input'),        # powers overflow
    ((3.0, 0, 0, 0, 0, 0, 0, 1e200, 0, 0), 'limit'),                # forces 1e200 N
    ((4.0, 1e308, -1e308, 1e308, 0, 0, 0, 0, 0, 0), 'unreachable'),
    ((5.0, 0, 0, 1.0608370074727034, 0, 0, 0, 0, 0, 0), 'near_singular'),   # det J ~ 0
    ((6.0, 0, 0, 1.06, 1e155, 0, 0, 0, 0, 0), 'near_singular'),      # overflow, near
    ((7.0, 0, 0, 0, 0, 0, 0, 1.8e307, 0, 0), 'limit'),              # forces ~1.8e308 N
    ((8.0, 5e-324, -5e-324, 2.2250738585072014e-308, 1e-300, 0, 0, 0, 0, 0), 'ok'),
    ((9.0, 0, 0, 0, 0, 0, -1e300, 0, 0, 1e300), 'invalid_input'),
    ((-1e308, 0.05, 0.1, 0.26, 0.1, 0.1, 0.2, 1, 1, 2), 'ok'),     # t is only copied
]


@pytest.mark.parametrize('joints', [False, True])
def test_huge_finite_values_are_row_statuses_not_errors(tmp_path, capsys, joints):
    data = np.array([row for row, _ in HUGE_ROWS], dtype=float)
    src, out = tmp_path / 'traj.csv', tmp_path / 'out.csv'
    src.write_text(HEADER + '\n' + '\n'.join(','.join(map(fmt, r)) for r in data) + '\n')
    assert cli.main(['solve', str(src), '-o', str(out)] + (['--joints'] if joints else [])) == 0
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith('warning: ')
    assert f'{sum(s != "ok" for _, s in HUGE_ROWS)} of {len(HUGE_ROWS)} rows are not ok' in err[0]
    table, status = read_output(out, joints)          # strict: no nan, no inf
    assert status == [s for _, s in HUGE_ROWS]
    sol = fsd.solve_batch(MODEL, data[:, 1:4], data[:, 4:7], data[:, 7:10])
    assert status == [str(s) for s in sol.status]
    assert np.array_equal(table['t'], data[:, 0])
    for field in ('length', 'stroke', 'rate', 'force', 'power', 'acceleration'):
        for i, leg in enumerate('abc'):
            assert np.array_equal(table[f'{field}_{leg}'], getattr(sol, field)[:, i])
    assert np.array_equal(table['kinematic_condition'], sol.kinematic_condition)
    void = np.isin(status, ['unreachable', 'invalid_input'])
    assert np.all(table.data[void][:, 1:] == 0.0)      # every number but t
    assert sorted(p.name for p in tmp_path.iterdir()) == ['out.csv', 'traj.csv']


@settings(max_examples=examples(0.3), suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.lists(st.tuples(*[st.one_of(st.floats(-1.5, 1.5),
                                      st.floats(allow_nan=False, allow_infinity=False))] * 10),
                min_size=1, max_size=12))
def test_any_finite_numbers_give_a_readable_output(tmp_path, rows):
    """Any finite numbers in every cell: exit 0, the output is complete and
    strictly readable (no NaN or inf written), its statuses are solve_batch's."""
    data = np.array(rows, dtype=float)
    src, out = tmp_path / 'traj.csv', tmp_path / 'out.csv'
    src.write_text(HEADER + '\n' + '\n'.join(','.join(map(fmt, r)) for r in data) + '\n')
    stderr = io.StringIO()
    saved, sys.stderr = sys.stderr, stderr
    try:
        assert cli.main(['solve', str(src), '-o', str(out)]) == 0
    finally:
        sys.stderr = saved
    table, status = read_output(out)
    assert len(table) == len(rows)
    sol = fsd.solve_batch(MODEL, data[:, 1:4], data[:, 4:7], data[:, 7:10])
    assert status == [str(s) for s in sol.status]
    assert np.array_equal(table['force_a'], sol.force[:, 0])
    assert stderr.getvalue().count('\n') <= 1


@pytest.mark.parametrize('content, words', [
    (bytes(range(256)) * 4, 'line 1'),
    (b'\x00' * 64, 'line 1'),
    ((HEADER + '\n0,0,0,0,0,0,0,0,0,0\n').encode('utf-16'), 'not valid UTF-8'),
    ((HEADER + '\n0,0,0,0,0,0,0,0,0,0\n').encode('utf-32'), 'line 1'),
    ((HEADER + '\n0,0,0,0\x00,0,0,0,0,0,0\n').encode(), 'line 2, column 4 (roll)'),
    ((HEADER + '\n0,0,0,0,0,0,0,0,0,0\n\x1a').encode(), 'line 3'),
    (b'\xef\xbb\xbf' + HEADER.encode() + b'\n0,0,0,0,0,0,0,0,0,0\n' + b'\xff\xfe', 'line 3'),
    (HEADER.replace(',', ';').encode() + b'\n0;0;0;0;0;0;0;0;0;0\n', 'line 1'),
    (HEADER.replace(',', '\t').encode() + b'\n0\t0\t0\t0\t0\t0\t0\t0\t0\t0\n', 'line 1'),
    ((HEADER + '\n' + '0,' * 9 + '1' + '0' * 400 + '\n').encode(), 'not a finite number'),
    ((HEADER + '\n' + '0,' * 9 + '-0x1p3\n').encode(), 'line 2, column 10'),
    ((HEADER + '\n' + '0,' * 9 + 'Infinity\n').encode(), 'line 2, column 10'),
    ((HEADER + '\n' + '0,' * 9 + '1e-400\n').encode(), None),   # underflows to 0: fine
], ids=lambda v: repr(v)[:40])
def test_binary_and_foreign_garbage(tmp_path, capsys, content, words):
    src, out = tmp_path / 'traj.csv', tmp_path / 'out.csv'
    src.write_bytes(content)
    rc = cli.main(['solve', str(src), '-o', str(out)])
    captured = capsys.readouterr()
    if words is None:
        assert rc == 0 and out.exists()
        return
    assert rc == 2
    line = one_error_line(captured.err)
    assert words in line and str(src) in line
    assert captured.out == ''
    assert sorted(p.name for p in tmp_path.iterdir()) == ['traj.csv']


def test_garbage_on_stdin_writes_nothing_to_stdout(capfdbinary, monkeypatch):
    text = HEADER + '\n0,0,0,0,0,0,0,0,0,0\n1,0,nan,0,0,0,0,0,0,0\n'
    monkeypatch.setattr(sys, 'stdin', io.TextIOWrapper(io.BytesIO(text.encode())))
    assert cli.main(['solve', '-', '-o', '-']) == 2
    captured = capfdbinary.readouterr()
    assert captured.out == b''
    line = one_error_line(captured.err.decode())
    assert '<stdin>, line 3, column 3 (heave)' in line


GARBAGE_TOKENS = ['nan', 'NaN', '-nan', 'inf', '-inf', 'Infinity', '1e999', '-1e400000',
                  '', ' ', 'abc', '0x10', '1_0', '--1', '+-1', '1e', '.', 'e5', '1.2.3',
                  '1 2', '"1"', "'1'", 'None', 'null', 'true', '1/2', '1e5.5', '\x00', '\t']


@settings(max_examples=examples(0.3), suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(rows=st.integers(1, 30), row=st.integers(0, 29), column=st.integers(0, 9),
       token=st.sampled_from(GARBAGE_TOKENS))
def test_garbage_in_any_cell_is_named_and_nothing_is_written(tmp_path, rows, row, column,
                                                            token):
    row = row % rows
    cells = [['0.01'] * 10 for _ in range(rows)]
    cells[row][column] = token
    src, out = tmp_path / 'traj.csv', tmp_path / 'out.csv'
    src.write_bytes((HEADER + '\n' + '\n'.join(','.join(r) for r in cells) + '\n').encode())
    out.write_text('old contents\n')
    stderr = io.StringIO()
    saved, sys.stderr = sys.stderr, stderr
    try:
        assert cli.main(['solve', str(src), '-o', str(out)]) == 2
    finally:
        sys.stderr = saved
    line = one_error_line(stderr.getvalue())
    assert f'line {row + 2}, column {column + 1} ({TRAJECTORY_COLUMNS[column]})' in line, line
    assert out.read_text() == 'old contents\n'
    assert sorted(p.name for p in tmp_path.iterdir()) == ['out.csv', 'traj.csv']
    os.unlink(out)


@pytest.mark.parametrize('token', ['\u0661', '\uff11', '\u0663.\u0665', '\U0001d7cf',
                                   '1e\u0663'], ids=ascii)
def test_unicode_digits_are_not_decimal_numbers(tmp_path, capsys, token):
    """Arabic-Indic, full-width or mathematical digits, which float() accepts,
    are not the decimal numbers a file holds: the cell is an error naming its
    line and column, and nothing is written."""
    src, out = tmp_path / 'traj.csv', tmp_path / 'out.csv'
    src.write_text(HEADER + '\n' + '0,' * 9 + token + '\n', encoding='utf-8')
    rc = cli.main(['solve', str(src), '-o', str(out)])
    err = capsys.readouterr().err
    assert rc == 2, 'the cell was read as a number'
    assert 'line 2, column 10 (roll_acc)' in one_error_line(err)
    assert not out.exists()
