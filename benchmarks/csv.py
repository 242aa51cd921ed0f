"""``flight-sim-dynamics solve`` end to end on a --rows-row trajectory CSV (the
paper's general motion, every column): wall time of the command as a
subprocess, CSV out and .npz out, median of --repeats.

    python -m benchmarks.csv [--rows 100000] [--repeats 3] [--quick]
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
from flight_sim_dynamics.cli.csv_io import TRAJECTORY_COLUMNS

from ._common import ROOT, header, table



def write_trajectory(path: Path, rows: int) -> None:
    t = np.linspace(0.0, 3.0, rows)
    q, qd, qdd = fsd.trajectories.paper_example('general', t)
    np.savetxt(path, np.column_stack([t, q, qd, qdd]), fmt='%.17g', delimiter=',',
               header=','.join(TRAJECTORY_COLUMNS), comments='')


def wall_s(argv: list[str]) -> float:
    start = time.perf_counter()
    subprocess.run(argv, cwd=ROOT, check=True, stdout=subprocess.DEVNULL,
                   stderr=subprocess.DEVNULL)
    return time.perf_counter() - start


def main(argv: Sequence[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog='python -m benchmarks.csv',
                                description=__doc__.split('\n\n')[0])
    p.add_argument('--rows', type=int, default=100_000)
    p.add_argument('--repeats', type=int, default=3, help='median of')
    p.add_argument('--quick', action='store_true', help='1,000 rows, 1 run')
    args = p.parse_args(argv)
    rows, repeats = (1_000, 1) if args.quick else (args.rows, args.repeats)
    if rows < 2 or repeats < 1:
        p.error('--rows must be >= 2 and --repeats >= 1')
    with tempfile.TemporaryDirectory(prefix='fsd_bench_') as tmp:
        src = Path(tmp) / 'trajectory.csv'
        write_trajectory(src, rows)
        solve = [sys.executable, '-m', 'flight_sim_dynamics', 'solve', str(src), '-o']
        start = [sys.executable, '-c', 'import flight_sim_dynamics.cli.main']
        figures = []
        for label, cmd in (('CSV in, CSV out', solve + [f'{tmp}/out.csv']),
                           ('CSV in, .npz out', solve + [f'{tmp}/out.npz']),
                           ('start-up only (import)', start)):
            s = statistics.median(wall_s(cmd) for _ in range(repeats))
            per_row = '-' if cmd is start else f'{1e6 * s / rows:.2f}'
            figures.append([label, f'{s:.3f}', per_row])
    print(header(f'{rows:,} rows, median of {repeats}'))
    print(table(['flight-sim-dynamics solve', 'wall s', 'us per row'], figures))
    return 0


if __name__ == '__main__':
    raise SystemExit(main())
