"""A CSV written by a second process (``table_writer(parallel=True)``, the
``cue`` of a long log): the same bytes as written in one process; a write
error is one CsvError naming the user's path; a block that raises leaves no
file and no process behind."""
from __future__ import annotations

import multiprocessing

import numpy as np
import pytest

from flight_sim_dynamics.cli.csv_io import CsvError, _FormatterProcess, table_writer

# every test forks the formatting process (parallel=True, _FormatterProcess): the ros
# tier's (setup.cfg: starts a process)
pytestmark = pytest.mark.ros


def _blocks(seed=0):
    rng = np.random.default_rng(seed)
    data = rng.normal(size=(5000, 4)) * 10.0 ** rng.integers(-8, 8, size=(5000, 4))
    data[::7, 1] = np.round(data[::7, 1])           # integral values: written without '.0'
    words = [('ok', 'limit')[k % 2] for k in range(5000)]
    return [(data[lo:lo + 1500], words[lo:lo + 1500]) for lo in range(0, 5000, 1500)]


@pytest.mark.parametrize('text', [None, 'status'])
def test_the_same_bytes_as_written_in_one_process(tmp_path, text):
    written = {}
    for parallel in (False, True):
        path = tmp_path / f'{parallel}.csv'
        with table_writer(path, ['a', 'b', 'c', 'd'], text, parallel=parallel) as write:
            for data, words in _blocks():
                write(data, None if text is None else words)
        written[parallel] = path.read_bytes()
    assert written[True] == written[False]
    assert written[True].count(b'\n') == 5001
    assert multiprocessing.active_children() == []


def test_a_write_error_names_the_users_path():
    with pytest.raises(CsvError) as info:
        with table_writer('/dev/full', ['a', 'b', 'c', 'd'], parallel=True) as write:
            for data, _ in _blocks() * 50:
                write(data)
    assert '/dev/full' in str(info.value)
    assert multiprocessing.active_children() == []


def test_a_block_that_raises_leaves_no_file_and_no_process(tmp_path):
    path = tmp_path / 'out.csv'
    with pytest.raises(RuntimeError):
        with table_writer(path, ['a', 'b', 'c', 'd'], parallel=True) as write:
            write(_blocks()[0][0])
            raise RuntimeError('the caller fails')
    assert list(tmp_path.iterdir()) == []
    assert multiprocessing.active_children() == []


def test_a_writer_given_up_ends_on_its_own(tmp_path):
    """Closed before its last block, the writing process sees the end of its
    blocks and exits (exit code 0), not terminated: it holds no copy of the
    pipe's sending end."""
    data, words = _blocks()[0]
    with open(tmp_path / 'out.csv', 'wb') as f:
        writer = _FormatterProcess(f, tmp_path / 'out.csv')
        writer.send(data, words)
        writer.close()
    assert writer._process.exitcode == 0
