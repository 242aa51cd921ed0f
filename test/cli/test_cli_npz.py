"""``solve -o out.npz``: the same columns as the CSV output, as named arrays
(numpy's .npz), read back exactly; ``plot`` reads it too; bad .npz files are
one error line."""
from __future__ import annotations

import numpy as np
import pytest

from flight_sim_dynamics.cli import csv_io
from flight_sim_dynamics.cli import main as cli
from flight_sim_dynamics.cli.csv_io import TRAJECTORY_COLUMNS
from flight_sim_dynamics.machines.staicu.trajectories import paper_example, sample_times


def one_error_line(stderr: str) -> str:
    lines = stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith('error: '), stderr
    return lines[0]


@pytest.fixture
def trajectory(tmp_path):
    """A trajectory CSV with rows of several statuses (ok, unreachable, limit)."""
    t = sample_times(20.0)
    q, qd, qdd = paper_example('general', t)
    data = np.column_stack([t, q, qd, qdd])
    data[5, 1] = 5.0                    # unreachable
    data[9, 7] = 1e200                  # limit (forces)
    path = tmp_path / 'traj.csv'
    csv_io.write_csv(path, TRAJECTORY_COLUMNS, data)
    return path


@pytest.mark.parametrize('extra', [[], ['--joints', '--cond']])
def test_npz_holds_the_csv_columns_exactly(tmp_path, trajectory, capsys, extra):
    assert cli.main(['solve', str(trajectory), '-o', str(tmp_path / 'o.csv'), *extra]) == 0
    csv_warning = capsys.readouterr().err
    assert cli.main(['solve', str(trajectory), '-o', str(tmp_path / 'o.npz'), *extra]) == 0
    assert capsys.readouterr().err == csv_warning and 'unreachable' in csv_warning
    header = (tmp_path / 'o.csv').read_text().splitlines()[0].split(',')
    table = csv_io.read_csv(tmp_path / 'o.csv', required=header[:-1], allow_extra=True,
                            text_columns=('status',))
    status = [line.rsplit(',', 1)[1] for line in
              (tmp_path / 'o.csv').read_text().splitlines()[1:]]
    with np.load(tmp_path / 'o.npz') as npz:           # no pickle needed
        assert npz['names'].tolist() == header and header[-1] == 'status'
        assert sorted(npz.files) == sorted(header + ['names'])
        for j, name in enumerate(header[:-1]):
            assert npz[name].dtype == np.float64 and npz[name].shape == (len(table),)
            assert npz[name].view(np.int64).tolist() == table.data[:, j].view(np.int64).tolist()
        assert npz['status'].dtype.kind == 'U' and npz['status'].tolist() == status
    assert {'ok', 'unreachable', 'limit'} <= set(status)


def test_npz_by_suffix_only(tmp_path, trajectory):
    assert cli.main(['solve', str(trajectory), '-o', str(tmp_path / 'O.NPZ')]) == 0
    assert (tmp_path / 'O.NPZ').read_bytes()[:2] == b'PK'          # a zip archive
    assert cli.main(['solve', str(trajectory), '-o', str(tmp_path / 'o.npz.csv')]) == 0
    assert (tmp_path / 'o.npz.csv').read_text().startswith('t,length_a,')


def test_solve_help_documents_npz_and_status(capsys):
    with pytest.raises(SystemExit):
        cli.build_parser('solve').parse_args(['solve', '--help'])
    out = capsys.readouterr().out
    # argparse wraps long column lists anywhere: compare without white space
    assert 'jacobian_condition,status' in ''.join(out.split())
    text = ' '.join(out.split())
    assert '.npz' in text and 'status as strings' in text and 'names' in text


def test_plot_reads_npz(tmp_path, trajectory):
    assert cli.main(['solve', str(trajectory), '-o', str(tmp_path / 'o.npz')]) == 0
    assert cli.main(['plot', str(tmp_path / 'o.npz'), '-o', str(tmp_path / 'f.svg'),
                     '--title', 'from npz']) == 0
    assert 'from npz' in (tmp_path / 'f.svg').read_text()
    table = csv_io.read_npz(tmp_path / 'o.npz', required=cli.PLOT_COLUMNS)
    assert table.names == cli.PLOT_COLUMNS and table.data.shape == (61, 7)


def test_bad_npz_is_one_error_line(tmp_path, capsys):
    cases = {
        'garbage.npz': lambda p: p.write_bytes(b'not a zip'),
        'nonames.npz': lambda p: np.savez(p, t=np.zeros(3)),
        'missing.npz': lambda p: csv_io.write_npz(p, ('t', 'force_a'), np.zeros((3, 2))),
        'nan.npz': lambda p: csv_io.write_npz(p, cli.PLOT_COLUMNS,
                                              np.full((3, 7), np.nan)),
    }
    expected = {'garbage.npz': 'cannot read as .npz', 'nonames.npz': "no 'names' array",
                'missing.npz': "missing columns 'force_b'", 'nan.npz': 'column 1 (t)'}
    for name, make in cases.items():
        make(tmp_path / name)
        out = tmp_path / 'f.png'
        assert cli.main(['plot', str(tmp_path / name), '-o', str(out)]) == 2
        line = one_error_line(capsys.readouterr().err)
        assert name in line and expected[name] in line, line
        assert not out.exists()


def test_write_npz_checks_its_arguments(tmp_path):
    with pytest.raises(ValueError, match='column names'):
        csv_io.write_npz(tmp_path / 'x.npz', ('a',), np.zeros((2, 2)))
    with pytest.raises(ValueError, match='one word per row'):
        csv_io.write_npz(tmp_path / 'x.npz', ('a',), np.zeros((2, 1)), text=('s', ['ok']))
    with pytest.raises(ValueError, match='distinct'):
        csv_io.write_npz(tmp_path / 'x.npz', ('names',), np.zeros((2, 1)))
    assert not (tmp_path / 'x.npz').exists()
