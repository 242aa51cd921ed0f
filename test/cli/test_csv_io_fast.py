"""The CSV layer and ``solve``'s glue against plain references:

* writing: every value is written as a plain per-value reference gives it
  (the shortest decimal that reads back exactly, the nearest such; repr's
  layout; no '.0' on integral values), and extreme values (subnormals, -0.0,
  1e308, integers, many digits) read back bit for bit through read_csv;
  blocks, text columns (long, non-ASCII, NUL) and empty tables;
* reading: the parser (numpy's C parser plus a count of commas, a line scan
  to name a bad cell) accepts exactly the files a plain strict reader accepts,
  ragged and blank rows included, with the same numbers;
* solve: solve_table gives what solve_batch gives, and the warning names the
  first row not ok; running one subcommand does not import the modules of the
  others.
"""
from __future__ import annotations

import math
import re
from fractions import Fraction
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import flight_sim_dynamics as fsd
from flight_sim_dynamics.cli import main as cli
from flight_sim_dynamics.cli import csv_io
from flight_sim_dynamics.cli.csv_io import TRAJECTORY_COLUMNS


def formatted(data: np.ndarray, step: int = 1024) -> bytes:
    """The rows as write_csv writes them."""
    return b''.join(csv_io._format_blocks(np.asarray(data, dtype=np.float64), None, step))

ROOT = Path(__file__).resolve().parents[2]
MODEL = fsd.load_model()


# ----------------------------------------------------------------------------
# Writing
# ----------------------------------------------------------------------------
def shortest_decimal(x: float) -> tuple[str, int]:
    """(digits, decimal exponent) of the decimal with the fewest significant
    digits that reads back as x > 0, the nearest to x among those (a tie to
    the even last digit): for a number of digits k, the correctly rounded one
    and its two neighbours (next to a power of two the gaps below and above x
    differ). The fewest k by bisection over 1..17: if a k-digit decimal reads
    back as x, so does a (k + 1)-digit one (one of those three: the interval
    that reads back as x holds x and that decimal times 10)."""
    def fits(k: int) -> tuple[list[int], int]:
        mantissa, exponent = f'{x:.{k - 1}e}'.split('e')
        m, p = int(mantissa.replace('.', '')), int(exponent) - (k - 1)
        return [c for c in (m - 1, m, m + 1) if c > 0 and float(f'{c}e{p}') == x], p

    low, high = 1, 17                   # 17 digits always read back
    while low < high:
        middle = (low + high) // 2
        if fits(middle)[0]:
            high = middle
        else:
            low = middle + 1
    found, p = fits(low)
    assert found, x
    best = min(found, key=lambda c: (abs(Fraction(c) * Fraction(10) ** p - Fraction(x)),
                                     c % 2))     # a tie: the even digit
    digits = str(best)
    return digits.rstrip('0'), p + len(digits) - 1


def reference_text(v: float) -> str:
    """The text of one value, plainly: the shortest decimal that reads back as
    v (above); fixed notation for decimal exponents -4..15, else d.ddde+XX
    (repr's layout); an integral value without a fraction."""
    if v != v:
        return 'nan'
    if math.isinf(v):
        return '-inf' if v < 0 else 'inf'
    sign = '-' if math.copysign(1.0, v) < 0 else ''
    if v == 0:
        return sign + '0'
    digits, e = shortest_decimal(abs(v))
    if 0 <= e < 16:
        whole, frac = digits.ljust(e + 1, '0')[:e + 1], digits[e + 1:]
        return sign + whole + ('.' + frac if frac else '')
    if -4 <= e < 0:
        return sign + '0.' + '0' * (-e - 1) + digits
    return (sign + digits[0] + ('.' + digits[1:] if len(digits) > 1 else '')
            + f"e{'-' if e < 0 else '+'}{abs(e):02d}")


def extreme_values() -> np.ndarray:
    rng = np.random.default_rng(2024)
    tiny = np.finfo(float).tiny
    p2 = 2.0 ** np.arange(-1074, 1024)
    p10 = 10.0 ** np.arange(-323, 309)
    ints = np.array([1, 2, 10, 123, 2 ** 31, 2 ** 53 - 1, 2 ** 53, 2 ** 53 + 2, 10 ** 15,
                     10 ** 16, 10 ** 17, 123456789012345680, 99999999999999999], dtype=float)
    special = np.array([0.0, -0.0, 5e-324, -5e-324, 1e-323, tiny, np.nextafter(tiny, 0),
                        np.nextafter(tiny, 1), 1e308, -1e308, np.finfo(float).max,
                        -np.finfo(float).max, 1e-250, 1e250, np.nextafter(1e-250, 0),
                        np.nextafter(1e250, np.inf), 0.1, 0.2, 0.1 + 0.2, 1 / 3, 2 / 3,
                        np.pi, 1e16, 1e17, 9.999999999999999e16, 1e-5, 1e-4, 9.9999e-5,
                        0.00025360037982946615, 5e-5, 123456.7890123456, 0.5, 1e-310])
    bits = rng.integers(0, 2 ** 64, size=20000, dtype=np.uint64).view(np.float64)
    values = np.concatenate([
        special, ints, -ints, p2, np.nextafter(p2, 0), np.nextafter(p2, np.inf), p10,
        np.nextafter(p10, 0), np.nextafter(p10, np.inf), bits[np.isfinite(bits)],
        rng.standard_normal(5000) * 10.0 ** rng.integers(-12, 12, 5000),
        np.round(rng.standard_normal(5000) * 1e6) / 1e3,            # few digits
        rng.integers(-10 ** 9, 10 ** 9, 2000).astype(float)])      # integers as floats
    return values[np.isfinite(values)]


def test_format_values_match_the_plain_reference():
    values = np.concatenate([extreme_values(), [np.inf, -np.inf, np.nan]])
    table = formatted(values.reshape(-1, 1)).decode().split('\n')
    assert table[-1] == '' and len(table) == values.size + 1
    for v, text in zip(values, table[:-1]):
        assert text == reference_text(float(v)), (repr(float(v)), text)
    row = formatted(values[:5].reshape(1, -1)).decode()
    assert row == ','.join(reference_text(float(v)) for v in values[:5]) + '\n'


@pytest.mark.parametrize('ncol', [1, 3, 22])
def test_extreme_values_read_back_bit_for_bit(tmp_path, ncol):
    values = extreme_values()
    n = values.size // ncol * ncol
    data = np.random.default_rng(ncol).permutation(values)[:n].reshape(-1, ncol)
    names = [f'c{j}' for j in range(ncol)]
    path = tmp_path / 'x.csv'
    csv_io.write_csv(path, names, data)
    table = csv_io.read_csv(path, required=names)
    assert table.data.view(np.int64).tolist() == data.view(np.int64).tolist()  # -0.0 too
    lines = path.read_bytes().decode('ascii').split('\n')
    assert lines[-1] == '' and len(lines) == data.shape[0] + 2
    expected = [','.join(reference_text(float(v)) for v in row) for row in data[:300]]
    assert lines[1:301] == expected


@pytest.mark.parametrize('chunk_values', [1, 7, 100, 8192, 10 ** 6])
def test_written_blocks_match_the_reference(chunk_values):
    rng = np.random.default_rng(chunk_values)
    data = rng.standard_normal((257, 5)) * 10.0 ** rng.integers(-300, 300, size=(257, 5))
    data[3] = 0.0
    data[4, 1] = -0.0
    data[5, 2] = 5e-324
    text = formatted(data, max(1, chunk_values // 5)).decode()
    assert text == ''.join(','.join(reference_text(float(v)) for v in row) + '\n'
                           for row in data)
    assert formatted(np.empty((0, 3))) == b''


@pytest.mark.parametrize('words', [
    ['ok', 'limit', 'ok', 'near_singular', 'unreachable', 'invalid_input'],
    ['', 'ok', ''],                                    # empty words
    ['w' * 47, 'x' * 100, 'ok'],                       # longer than one 48-byte slot
    ['caf\u00e9', '\u0394', 'ok'],                     # non-ASCII (UTF-8)
    ['a\0b', 'ok', 'c'],                               # a NUL: the row-by-row path
    [f'w{i}' for i in range(3)],
])
def test_text_column(tmp_path, words):
    rng = np.random.default_rng(1)
    n = 50
    data = rng.standard_normal((n, 2))
    values = [words[i % len(words)] for i in range(n)]
    csv_io.write_csv(tmp_path / 'o.csv', ('a', 'b'), data, text=('status', values))
    expected = 'a,b,status\n' + ''.join(
        f'{reference_text(float(r[0]))},{reference_text(float(r[1]))},{w}\n'
        for r, w in zip(data, values))
    assert (tmp_path / 'o.csv').read_bytes() == expected.encode()


def test_text_column_errors_and_empty_table(tmp_path):
    data = np.zeros((2, 1))
    for values in (['ok'], ['ok', 'a,b'], ['ok', 'a\nb']):
        with pytest.raises(ValueError, match='one word per row'):
            csv_io.write_csv(tmp_path / 'o.csv', ('a',), data, text=('status', values))
    assert not (tmp_path / 'o.csv').exists()
    csv_io.write_csv(tmp_path / 'e.csv', ('a', 'b'), np.empty((0, 2)), text=('status', []))
    assert (tmp_path / 'e.csv').read_bytes() == b'a,b,status\n'


# ----------------------------------------------------------------------------
# Reading
# ----------------------------------------------------------------------------
STRICT_CELL = re.compile(r'[ \t]*[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?[ \t]*', re.ASCII)


def reference_read(body: bytes, ncol: int) -> np.ndarray | None:
    """A plain strict reader: every line (trailing blank lines aside) holds
    ncol finite decimal numbers; None when it does not."""
    rows = []
    for raw in body.rstrip(b' \t\r\n').split(b'\n'):
        cells = raw.decode('utf-8').rstrip('\r').split(',')
        if len(cells) != ncol or not all(STRICT_CELL.fullmatch(c) for c in cells):
            return None
        rows.append([float(c) for c in cells])
    values = np.array(rows)
    return values if np.all(np.isfinite(values)) else None


def parse_both(body: bytes, ncol: int) -> tuple[np.ndarray | None, np.ndarray | None]:
    header = ','.join(f'c{j}' for j in range(ncol)).encode() + b'\n'
    try:
        ours = csv_io.parse_csv(header + body, 'x', required=[f'c{j}' for j in range(ncol)]).data
    except csv_io.CsvError:
        ours = None
    return ours, reference_read(body, ncol)


@pytest.mark.parametrize('body, ncol', [
    (b'1,2,3\n4,5,6', 3),
    (b'1,2,3\r\n4,5,6', 3),                 # CRLF
    (b'1,2,3,4\n5,6', 3),                   # ragged rows, the right number of commas
    (b'1,2\n3,4,5,6', 3),
    (b'1,2,3\n\n4,5,6', 3),                 # a blank line inside
    (b'1\n\n2', 1),
    (b'1\n \n2', 1),                        # a blank line of spaces, one column
    (b'1,2,3\n , , \n4,5,6', 3),
    (b'1,2,3,\n4,5,6', 3),                  # trailing comma
    (b'1,2,3\n4,5,6,', 3),
    (b',1,2\n4,5,6', 3),
    (b'1,2,3\r4,5,6', 3),                   # a lone CR
    (b'1,,3\n4,5,6', 3),
    (b' 1 ,\t2\t, 3 \n4,5,6', 3),           # spaces and tabs around cells
    (b'1e5,-2.5e-3,+.5\n5.,0001,-0', 3),
    (b'1e999,2,3', 3),                      # a finite literal that overflows
    (b'1,2,3\n4,5,6\n7,8', 3),
])
def test_parser_reads_what_a_strict_reader_reads_on_whole_files(body, ncol):
    ours, reference = parse_both(body, ncol)
    assert (ours is None) == (reference is None)
    if ours is not None:
        assert ours.view(np.int64).tolist() == reference.view(np.int64).tolist()


def test_parser_reads_what_a_strict_reader_reads_on_random_files():
    rng = np.random.default_rng(3)
    cells = ['1', '-0', '2.5e-3', '', ' ', '1,2', '7\n8', '.5', '5.', 'e', '+-1', '\r',
             '0.1', '1e5', '1\n', '\n3']
    for _ in range(400):
        ncol = int(rng.integers(1, 4))
        rows = [','.join(str(rng.choice(cells)) for _ in range(ncol))
                for _ in range(int(rng.integers(1, 5)))]
        body = '\n'.join(rows).encode()
        if not body.strip():
            continue
        ours, reference = parse_both(body, ncol)
        assert (ours is None) == (reference is None), body
        if ours is not None:
            assert np.array_equal(ours, reference), body


def test_read_csv_errors_name_line_and_column(tmp_path):
    header = 'a,b,c\n'
    good = ''.join(f'{i},{i + 0.5},{-i}\n' for i in range(1000))
    for bad, where in [('1,2\n', 'line 502, column 3 (c)'),
                       ('1,2,3,4\n', 'line 502, column 4'),
                       ('1,x,3\n', "line 502, column 2 (b): 'x' is not a number"),
                       ('1,2,1e999\n', "line 502, column 3 (c): '1e999' is not a finite"),
                       ('\n', 'line 502: empty line')]:
        lines = good.splitlines(keepends=True)
        (tmp_path / 'x.csv').write_text(header + ''.join(lines[:500]) + bad
                                        + ''.join(lines[500:]))
        with pytest.raises(csv_io.CsvError) as info:
            csv_io.read_csv(tmp_path / 'x.csv', required=('a', 'b', 'c'))
        assert where in str(info.value), str(info.value)
    (tmp_path / 'x.csv').write_text(header + good + '\n\n \n')    # trailing blank lines: fine
    assert len(csv_io.read_csv(tmp_path / 'x.csv', required=('a', 'b', 'c'))) == 1000
    for empty in ('', '  \n\n'):
        (tmp_path / 'x.csv').write_text(empty)
        with pytest.raises(csv_io.CsvError, match='line 1: the file is empty'):
            csv_io.read_csv(tmp_path / 'x.csv', required=('a', 'b', 'c'))


# ----------------------------------------------------------------------------
# solve: the glue
# ----------------------------------------------------------------------------
def mixed_trajectory(n: int = 600) -> csv_io.Table:
    """A trajectory with rows of every status (ok, limit, near_singular,
    unreachable, invalid_input) scattered over it."""
    t = np.arange(n) / 100.0
    q, qd, qdd = fsd.trajectories.paper_example('general', t % 3.0)
    data = np.column_stack([t, q, qd, qdd])
    rng = np.random.default_rng(5)
    idx = rng.permutation(n)
    data[idx[:30], 1] = 5.0                                         # unreachable
    data[idx[30:60], 7] = 1e200                                     # limit (forces)
    data[idx[60:90], 1:4] = (0.0, 0.0, 1.0608370074727034)          # near_singular
    data[idx[90:100], 4] = 1e308                                    # invalid_input
    text = formatted(data).decode()
    return csv_io.parse_csv((','.join(TRAJECTORY_COLUMNS) + '\n' + text).encode(), 'mixed.csv',
                            required=TRAJECTORY_COLUMNS)


@pytest.mark.parametrize('kwargs', [{}, {'joints': True}, {'joints': True, 'exact_cond': True}])
def test_solve_table_matches_plain_assembly(capsys, kwargs):
    table = mixed_trajectory()
    names, data, status = cli.solve_table(MODEL, table, **kwargs)
    warning = capsys.readouterr().err
    d = table.data
    col = {name: j for j, name in enumerate(table.names)}
    sol = fsd.solve_batch(MODEL, d[:, [col['surge'], col['heave'], col['roll']]],
                          d[:, [col['surge_rate'], col['heave_rate'], col['roll_rate']]],
                          d[:, [col['surge_acc'], col['heave_acc'], col['roll_acc']]])
    columns = [d[:, col['t']]]
    for field in ('length', 'stroke', 'rate', 'force', 'power', 'acceleration'):
        columns.extend(np.asarray(getattr(sol, field)).T)
    columns += [sol.beta, sol.kinematic_condition, sol.jacobian_condition]
    if kwargs.get('exact_cond'):
        columns.append(sol.cond)
    if kwargs.get('joints'):
        for field in ('joints', 'joint_rates', 'joint_accelerations'):
            columns.extend(np.asarray(getattr(sol, field)).T)
    assert np.array_equal(data, np.column_stack(columns))
    assert len(names) == data.shape[1]
    words = [str(s) for s in sol.status]
    assert status == words and set(words) == {'ok', 'limit', 'near_singular', 'unreachable',
                                              'invalid_input'}
    bad = [i for i, w in enumerate(words) if w != 'ok']
    counts = {w: words.count(w) for w in set(words) - {'ok'}}
    summary = ', '.join(f'{counts[w]} {w}' for w in sorted(counts))
    assert warning == (f'warning: mixed.csv: {len(bad)} of {len(words)} rows are not ok '
                       f'({summary}); first at line {bad[0] + 2}: {sol.status[bad[0]]}: '
                       f'{sol.detail[bad[0]]}\n')


@pytest.mark.ros
def test_solve_imports_only_what_it_needs(tmp_path):
    """`solve` configures its own subparser only: the modules behind the other
    subcommands (bench, workspace, plotting, animate) and matplotlib are not
    imported (a machine's own modules are: its Machine record names them);
    --help still lists every subcommand."""
    traj = tmp_path / 'traj.csv'
    t = np.arange(5) / 10.0
    q, qd, qdd = fsd.trajectories.paper_example('general', t)
    csv_io.write_csv(traj, TRAJECTORY_COLUMNS, np.column_stack([t, q, qd, qdd]))
    code = ('import sys; from flight_sim_dynamics.cli import main as cli; '
            f'rc = cli.main(["solve", {str(traj)!r}, "-o", {str(tmp_path / "o.csv")!r}]); '
            'print(sorted(m for m in sys.modules if m.startswith("flight_sim_dynamics") '
            'or m.startswith("matplotlib"))); sys.exit(rc)')
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    out = subprocess.run([sys.executable, '-c', code], env=env, capture_output=True, text=True,
                         timeout=120)
    assert out.returncode == 0, out.stderr
    loaded = out.stdout
    for module in ('cli.bench', 'cli.workspace', 'cli.plotting', 'cli.animate', 'cli.simulate',
                   'matplotlib'):
        assert module not in loaded, loaded
    assert (tmp_path / 'o.csv').read_text().startswith('t,length_a')
    help_text = cli.build_parser('solve').format_help()
    for name in cli.SUBCOMMANDS:
        assert name in help_text
