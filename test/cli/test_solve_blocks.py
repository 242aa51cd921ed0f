"""``solve`` streams (issue 29: 1 M hexapod rows peaked at 1.9 GB): it reads,
solves and writes SOLVE_BLOCK_ROWS rows at a time, and the output is the one
a single block gives, byte for byte (CSV) or array for array (.npz), with the
same notes and warnings; an error in any block names its file and line and
leaves no output, partial or temporary."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

import flight_sim_dynamics as fsd
from flight_sim_dynamics.cli import csv_io
from flight_sim_dynamics.cli import main as cli
from flight_sim_dynamics.cli.columns import trajectory_columns

ROOT = Path(__file__).resolve().parents[2]
HEXAPOD_FILE = str(ROOT / 'config' / 'stewart_6dof.yaml')


def trajectory_text(machine, rows: int = 40, *, rates: bool = True) -> str:
    """A trajectory of ``rows`` rows with what a block boundary could break:
    a restart of t, a row out of reach, an extra column, CRLF line ends and
    trailing blank lines (rates and accelerations left out unless ``rates``)."""
    motion = machine.motions[machine.examples[0]]
    t = np.linspace(0.0, motion.duration, rows)
    q, qd, qdd = motion.trajectory(t)
    t[rows // 2:] -= 0.3 * motion.duration         # t steps back: the estimate restarts
    q[rows // 3, 0] = 5.0                            # out of reach: not ok
    names = ('t',) + machine.coordinates
    data = [t, q]
    if rates:
        names = trajectory_columns(machine)
        data += [qd, qdd]
    lines = [','.join(names + ('comment',))]
    lines += [','.join(map(repr, row)) + ',7' for row in np.column_stack(data).tolist()]
    return '\r\n'.join(lines) + '\r\n\r\n  \n'


def solve(tmp_path: Path, monkeypatch, capsys, text: str, params: list[str], rows: int,
          output: str) -> tuple[bytes | dict, str, list[int]]:
    """Output, standard error and the rows of each solve_batch call of ``solve``
    reading ``rows`` rows at a time."""
    (tmp_path / 'traj.csv').write_bytes(text.encode())
    monkeypatch.setattr(cli, 'SOLVE_BLOCK_ROWS', rows)
    sizes = []
    batch = fsd.solve_batch
    monkeypatch.setattr(fsd, 'solve_batch', lambda model, q, *a: (sizes.append(len(q)),
                                                                   batch(model, q, *a))[1])
    out = tmp_path / output
    capsys.readouterr()
    assert cli.main(['solve', str(tmp_path / 'traj.csv'), '-o', str(out), *params]) == 0
    err = capsys.readouterr().err
    if output.endswith('.npz'):
        with np.load(out) as npz:
            return {k: npz[k].tolist() for k in npz.files}, err, sizes
    return out.read_bytes(), err, sizes


@pytest.mark.parametrize('machine_params', [[], ['--params', HEXAPOD_FILE]],
                         ids=['3-DOF', 'hexapod'])
@pytest.mark.parametrize('rates', [True, False], ids=['given', 'estimated'])
@pytest.mark.parametrize('output', ['out.csv', 'out.npz'])
def test_blocks_give_what_one_block_gives(tmp_path, monkeypatch, capsys, machine_params, rates,
                                          output):
    machine = fsd.machine_of(fsd.load_model(*machine_params[1:]))
    text = trajectory_text(machine, rates=rates)
    extra = ['--joints'] if machine_params else ['--cond']
    whole, whole_err, sizes = solve(tmp_path, monkeypatch, capsys, text,
                                    machine_params + extra, 10 ** 6, output)
    assert sizes == [40] and 'not ok' in whole_err and 'comment' in whole_err
    assert ('starts again from rest' in whole_err) is not rates
    for rows in (1, 3, 7, 39, 40, 41):
        got, err, sizes = solve(tmp_path, monkeypatch, capsys, text, machine_params + extra,
                                rows, output)
        assert got == whole and err == whole_err, rows
        assert max(sizes) <= rows and sum(sizes) == 40


def test_the_reader_gives_the_files_rows_in_blocks(tmp_path):
    """CsvReader.tables: the rows and line numbers of read_csv, block by block,
    blank lines within the file still an error wherever the blocks end."""
    path = tmp_path / 'a.csv'
    path.write_bytes(b'a,b\n1,2\n3,4\n\n\n5,6\n')
    for rows in (1, 2, 3, 4, None):
        with csv_io.CsvReader.open(path) as reader, pytest.raises(csv_io.CsvError) as info:
            list(reader.tables(required=('a', 'b'), rows=rows))
        assert info.value.line == 4, rows
    path.write_bytes(b'\xef\xbb\xbfa,b\r\n' + b''.join(b'%d,%d\r\n' % (i, -i) for i in range(10))
                     + b'\r\n \n')
    whole = csv_io.read_csv(path, required=('a', 'b'))
    for rows in (1, 3, 10, 11):
        with csv_io.CsvReader.open(path) as reader:
            blocks = list(reader.tables(required=('a', 'b'), rows=rows))
        assert max(len(b) for b in blocks) <= rows
        assert np.array_equal(np.concatenate([b.data for b in blocks]), whole.data)
        assert np.concatenate([b.lines for b in blocks]).tolist() == whole.lines.tolist()


@pytest.mark.parametrize('output', ['out.csv', 'out.npz'])
@pytest.mark.parametrize('bad, line', [('nan', 33), ('', 37), ('1e999', 40)])
def test_an_error_in_a_later_block_names_its_line_and_leaves_no_output(
        tmp_path, monkeypatch, capsys, output, bad, line):
    machine = fsd.machine_of(fsd.load_model())
    rows = trajectory_text(machine).split('\r\n')
    rows[line - 1] = rows[line - 1].replace(rows[line - 1].split(',')[2], bad, 1) if bad \
        else ''
    (tmp_path / 'traj.csv').write_text('\r\n'.join(rows))
    monkeypatch.setattr(cli, 'SOLVE_BLOCK_ROWS', 4)
    before = sorted(p.name for p in tmp_path.iterdir())
    for existing in (None, b'the previous output\n'):
        if existing is not None:
            (tmp_path / output).write_bytes(existing)
            before = sorted(p.name for p in tmp_path.iterdir())
        capsys.readouterr()
        assert cli.main(['solve', str(tmp_path / 'traj.csv'), '-o', str(tmp_path / output)]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert err[-1].startswith('error: ') and f'line {line}' in err[-1], err
        assert str(tmp_path / 'traj.csv') in err[-1]
        assert sorted(p.name for p in tmp_path.iterdir()) == before      # nothing left over
        if existing is not None:
            assert (tmp_path / output).read_bytes() == existing


def test_blocks_of_a_long_file_keep_its_line_numbers(tmp_path, monkeypatch, capsys):
    """The first row that is not ok is placed by its line, whichever block holds it."""
    machine = fsd.machine_of(fsd.load_model())
    text = trajectory_text(machine, rows=200)
    monkeypatch.setattr(cli, 'SOLVE_BLOCK_ROWS', 16)
    (tmp_path / 'traj.csv').write_text(text)
    assert cli.main(['solve', str(tmp_path / 'traj.csv'), '-o', str(tmp_path / 'o.csv')]) == 0
    warning = [w for w in capsys.readouterr().err.splitlines() if 'not ok' in w]
    assert len(warning) == 1 and f'first at line {200 // 3 + 2}:' in warning[0], warning
    table = csv_io.read_csv(tmp_path / 'o.csv', required=('t',), allow_extra=True,
                            text_columns=('status',))
    assert len(table) == 200 and table.text['status'][200 // 3] != 'ok'
    assert not math.isnan(table.data.sum())
