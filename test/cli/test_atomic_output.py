"""What ``-o PATH`` does to what is already at PATH (issue 12 #12): devices
and FIFOs are written through, never replaced; a symlink's target is
replaced; a replaced file keeps its mode; a read-only file is refused; a
SIGTERM or SIGHUP during the write leaves no temporary file behind."""
from __future__ import annotations

import os
import signal
import stat
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from flight_sim_dynamics.cli.csv_io import CsvError, atomic_output, write_csv

ROOT = Path(__file__).resolve().parents[2]


def _write(path, data=b'new\n'):
    with atomic_output(path) as f:
        f.write(data)


def _leftovers(folder: Path) -> list[str]:
    return [p.name for p in folder.iterdir() if p.name.endswith('.tmp')]


def test_dev_null_is_written_through_not_replaced():
    _write('/dev/null')
    assert stat.S_ISCHR(os.stat('/dev/null').st_mode)


def test_a_fifo_is_written_through(tmp_path):
    fifo = tmp_path / 'pipe'
    os.mkfifo(fifo)
    got = []
    reader = threading.Thread(target=lambda: got.append(fifo.read_bytes()))
    reader.start()
    _write(fifo, b'through the pipe\n')
    reader.join(timeout=10)
    assert got == [b'through the pipe\n']
    assert stat.S_ISFIFO(os.stat(fifo).st_mode)
    assert not _leftovers(tmp_path)


def test_a_symlink_is_followed_and_stays_a_link(tmp_path):
    target = tmp_path / 'real.csv'
    target.write_bytes(b'old\n')
    link = tmp_path / 'link.csv'
    link.symlink_to(target)
    _write(link)
    assert link.is_symlink() and target.read_bytes() == b'new\n'


def test_a_replaced_file_keeps_its_mode(tmp_path):
    out = tmp_path / 'out.csv'
    out.write_bytes(b'old\n')
    out.chmod(0o640)
    _write(out)
    assert out.read_bytes() == b'new\n'
    assert stat.S_IMODE(out.stat().st_mode) == 0o640


def test_a_read_only_file_is_refused_and_kept(tmp_path):
    out = tmp_path / 'out.csv'
    out.write_bytes(b'old\n')
    out.chmod(0o444)
    with pytest.raises(CsvError, match='read-only') as info:
        _write(out)
    assert str(out) in str(info.value) and '.tmp' not in str(info.value)
    assert out.read_bytes() == b'old\n' and not _leftovers(tmp_path)


def test_errors_name_the_users_path_not_the_temporary_file(tmp_path):
    with pytest.raises(CsvError) as info:
        _write(tmp_path / 'missing' / 'out.csv')
    assert 'out.csv' in str(info.value) and '.tmp' not in str(info.value)


@pytest.mark.ros
@pytest.mark.parametrize('signum', [signal.SIGTERM, signal.SIGHUP])
def test_a_signal_during_the_write_leaves_no_temporary_file(tmp_path, signum):
    out = tmp_path / 'out.csv'
    code = ('import sys, time\n'
            'from flight_sim_dynamics.cli.csv_io import atomic_output\n'
            f'with atomic_output({str(out)!r}) as f:\n'
            "    f.write(b'x' * 1_000_000); f.flush()\n"
            "    print('writing', flush=True)\n"
            '    time.sleep(60)\n')
    proc = subprocess.Popen([sys.executable, '-c', code], cwd=ROOT, stdout=subprocess.PIPE,
                            text=True)
    assert proc.stdout.readline().strip() == 'writing'
    assert _leftovers(tmp_path)                  # the write is under way
    proc.send_signal(signum)
    assert proc.wait(timeout=30) == 128 + signum
    assert not _leftovers(tmp_path) and not out.exists()


@pytest.mark.ros
def test_the_cli_writes_through_dev_null(tmp_path):
    traj = tmp_path / 'traj.csv'
    assert subprocess.run([sys.executable, '-m', 'flight_sim_dynamics', 'example', 'vertical',
                           '-o', str(traj)], cwd=ROOT).returncode == 0
    proc = subprocess.run([sys.executable, '-m', 'flight_sim_dynamics', 'solve', str(traj),
                           '-o', '/dev/null'], cwd=ROOT, capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    assert stat.S_ISCHR(os.stat('/dev/null').st_mode)


@pytest.mark.ros
def test_the_leftover_of_a_killed_write_is_removed_by_the_next_write(tmp_path):
    """SIGKILL runs no handler: the temporary file stays; the next write to the
    same output removes it once it is a minute old and its writer gone, and
    touches no other file."""
    out = tmp_path / 'o.csv'
    code = ('import os, signal, sys\nfrom flight_sim_dynamics.cli.csv_io import atomic_output\n'
            'with atomic_output(sys.argv[1]) as f:\n    f.write(b"partial")\n    f.flush()\n'
            '    os.kill(os.getpid(), signal.SIGKILL)\n')
    done = subprocess.run([sys.executable, '-c', code, str(out)], cwd=ROOT, timeout=60)
    assert done.returncode == -signal.SIGKILL
    left = [p for p in tmp_path.iterdir() if p.name.endswith('.tmp')]
    assert len(left) == 1 and left[0].name.startswith('.o.csv.'), left
    other = tmp_path / '.o.csv.notours.tmp'
    other.write_text('x')
    live = tmp_path / f'.o.csv.{os.getpid()}.abcdefgh.tmp'     # its writer runs (this test)
    live.write_text('x')
    write_csv(out, ['a'], np.array([[1.0]]))           # too recent: kept
    assert left[0].exists()
    old = time.time() - 120
    for path in (left[0], other, live):
        os.utime(path, (old, old))
    write_csv(out, ['a'], np.array([[2.0]]))
    assert not left[0].exists() and other.exists() and live.exists()
    assert out.read_text() == 'a\n2\n'
