"""``flight-sim-dynamics solve`` end to end on a --rows-row trajectory CSV (a
built-in motion of the machine of --params, every column; default the 3-DOF
machine's general motion): wall time of the command as a subprocess, CSV out
and .npz out, median of --repeats, and its peak resident memory (the largest of
the runs: solve reads, solves and writes in blocks of rows, so that it does not
grow with the file).

    python -m benchmarks.csv [--rows 100000] [--repeats 3] [--quick]
    python -m benchmarks.csv --params config/stewart_6dof.yaml --motion violent
"""
from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Sequence

import numpy as np

import flight_sim_dynamics as fsd
from flight_sim_dynamics.cli.columns import trajectory_columns
from flight_sim_dynamics.core.machine import Machine

from ._common import ROOT, header, table


def write_trajectory(path: Path, rows: int, machine: Machine, motion: str) -> None:
    """``rows`` samples of ``motion`` over its duration."""
    t = np.linspace(0.0, machine.motions[motion].duration, rows)
    q, qd, qdd = machine.motions[motion].trajectory(t)
    np.savetxt(path, np.column_stack([t, q, qd, qdd]), fmt='%.17g', delimiter=',',
               header=','.join(trajectory_columns(machine)), comments='')


#: Run by a small Python process between the benchmark and the command: it
#: forks the command from itself and prints its ru_maxrss (KiB). Linux carries
#: a process's peak across exec (its memory before exec counts), so a command
#: forked straight from the benchmark would count the benchmark's trajectory.
_LAUNCHER = """
import os, sys
pid = os.fork()
if pid == 0:
    null = os.open(os.devnull, os.O_WRONLY)
    os.dup2(null, 1)
    os.dup2(null, 2)
    os.execvp(sys.argv[1], sys.argv[1:])
_, status, usage = os.wait4(pid, 0)
print(usage.ru_maxrss)
sys.exit(os.waitstatus_to_exitcode(status))
"""


def wall_s_and_peak_mib(argv: list[str]) -> tuple[float, float]:
    """Wall time (s) and peak resident memory (MiB, the kernel's ru_maxrss of
    the command alone: :data:`_LAUNCHER`, whose start, about 10 ms, the wall
    time includes) of a run.
    """
    start = time.perf_counter()
    done = subprocess.run([sys.executable, '-I', '-S', '-c', _LAUNCHER, *argv], cwd=ROOT,
                          stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
    wall = time.perf_counter() - start
    if done.returncode:
        raise subprocess.CalledProcessError(done.returncode, argv)
    return wall, int(done.stdout) / 1024.0       # KiB on Linux


def main(argv: Sequence[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog='python -m benchmarks.csv',
                                description=__doc__.split('\n\n')[0])
    p.add_argument('--rows', type=int, default=100_000)
    p.add_argument('--repeats', type=int, default=3, help='median of')
    p.add_argument('--quick', action='store_true', help='1,000 rows, 1 run')
    p.add_argument('--params', default=None, help='parameter file: the machine (default 3-DOF)')
    p.add_argument('--motion', default='general', help='a built-in motion of the machine')
    args = p.parse_args(argv)
    rows, repeats = (1_000, 1) if args.quick else (args.rows, args.repeats)
    if rows < 2 or repeats < 1:
        p.error('--rows must be >= 2 and --repeats >= 1')
    machine = fsd.machine_of(fsd.load_model(args.params))
    if args.motion not in machine.motions:
        p.error(f"--motion: choose one of {', '.join(machine.motions)}")
    with tempfile.TemporaryDirectory(prefix='fsd_bench_') as tmp:
        src = Path(tmp) / 'trajectory.csv'
        write_trajectory(src, rows, machine, args.motion)
        solve = [sys.executable, '-m', 'flight_sim_dynamics', 'solve', str(src), '-o']
        if args.params is not None:
            solve[-1:-1] = ['--params', str(Path(args.params).resolve())]
        start = [sys.executable, '-c', 'import flight_sim_dynamics.cli.main']
        figures = []
        for label, cmd in (('CSV in, CSV out', solve + [f'{tmp}/out.csv']),
                           ('CSV in, .npz out', solve + [f'{tmp}/out.npz']),
                           ('start-up only (import)', start)):
            runs = [wall_s_and_peak_mib(cmd) for _ in range(repeats)]
            s = statistics.median(wall for wall, _ in runs)
            per_row = '-' if cmd is start else f'{1e6 * s / rows:.2f}'
            figures.append([label, f'{s:.3f}', per_row, f'{max(peak for _, peak in runs):.0f}'])
        size = src.stat().st_size / 2 ** 20
    print(header(f'{machine.title}, {args.motion} motion, {rows:,} rows ({size:.0f} MiB), '
                 f'median of {repeats}'))
    print(table(['flight-sim-dynamics solve', 'wall s', 'us per row', 'peak MiB'], figures))
    return 0


if __name__ == '__main__':
    raise SystemExit(main())
