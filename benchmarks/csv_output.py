"""The CSV writer of ``flight-sim-dynamics solve`` against numpy's and the
standard library's own float formatting, and ``solve`` end to end.

    python -m benchmarks.csv_output [--rows 100000] [--runs 3]

Prints two tables (figures only):

1. formatting the output of a ``--rows``-row solve (22 numeric columns, and 58
   with ``--joints``) to CSV text in this process, best of ``--runs``, for the
   package's writer (``csv_io.format_table``) and each candidate route; every
   route is checked to read back bit for bit;
2. ``python -m flight_sim_dynamics solve`` of a ``--rows``-row trajectory CSV
   as a subprocess (wall time, median of ``--runs``): with the package's
   writer, with each candidate route patched in, and to ``.npz`` when the
   package writes it.
"""
from __future__ import annotations

import argparse
import io
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Callable

import numpy as np

import flight_sim_dynamics as fsd
from flight_sim_dynamics.cli import csv_io
from flight_sim_dynamics.cli import main as cli

ROOT = Path(__file__).resolve().parents[1]


def route_repr(data: np.ndarray) -> bytes:
    """Python's repr of every value (shortest text that reads back exactly)."""
    return ''.join(','.join(map(repr, row)) + '\n' for row in data.tolist()).encode()


def route_percent_17g(data: np.ndarray) -> bytes:
    """'%.17g' of every value, one format string per row."""
    fmt = ','.join(['%.17g'] * data.shape[1]) + '\n'
    return ''.join(fmt % tuple(row) for row in data.tolist()).encode()


def route_savetxt(data: np.ndarray) -> bytes:
    """numpy.savetxt with '%.17g'."""
    buf = io.BytesIO()
    np.savetxt(buf, data, fmt='%.17g', delimiter=',')
    return buf.getvalue()


def patched_writer(route: Callable[[np.ndarray], bytes]) -> Callable[..., None]:
    """csv_io.write_csv with ``route`` formatting the numbers (the words of a
    text column appended row by row, as a writer built on it would).
    """
    def write_csv(path, names, data, text=None) -> None:
        header = ','.join(names) + (',' + text[0] if text else '') + '\n'
        body = route(np.asarray(data, dtype=float))
        if text:
            body = b''.join(row + b',' + word.encode() + b'\n'
                            for row, word in zip(body.split(b'\n'), text[1]))
        with csv_io.atomic_output(path) as f:
            f.write(header.encode() + body)
    return write_csv


CANDIDATES: dict[str, Callable[[np.ndarray], bytes]] = {
    'repr per value': route_repr, "'%.17g' per row": route_percent_17g,
    "np.savetxt '%.17g'": route_savetxt}


def best_of(runs: int, fn: Callable[[], object]) -> float:
    best = float('inf')
    for _ in range(runs):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best


def reads_back(text: bytes, data: np.ndarray) -> bool:
    back = np.loadtxt(io.StringIO(text.decode('ascii')), delimiter=',', ndmin=2)
    return back.shape == data.shape and np.array_equal(back.view(np.int64), data.view(np.int64))


def trajectory(rows: int) -> np.ndarray:
    t = np.arange(rows) / 1000.0
    q, qd, qdd = fsd.trajectories.paper_example('general', t % 3.0)
    return np.column_stack([t, q, qd, qdd])


# The same solve, with csv_io.write_csv replaced by one on a candidate route:
# the route's function name, then the solve's argv.
PATCHED = '''
import sys
from benchmarks import csv_output
from flight_sim_dynamics.cli import csv_io, main
csv_io.write_csv = csv_output.patched_writer(getattr(csv_output, sys.argv[1]))
sys.exit(main.main(sys.argv[2:]))
'''


def end_to_end(cmd: list[str], runs: int, env: dict[str, str]) -> float:
    walls = []
    for _ in range(runs):
        t0 = time.perf_counter()
        proc = subprocess.run(cmd, cwd=ROOT, env=env, capture_output=True, text=True)
        walls.append(time.perf_counter() - t0)
        if proc.returncode != 0:
            raise RuntimeError(f'{cmd}: {proc.stderr}')
    return statistics.median(walls)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('--rows', type=int, default=100_000)
    parser.add_argument('--runs', type=int, default=3)
    args = parser.parse_args(argv)
    model = fsd.load_model()
    traj = trajectory(args.rows)
    text = (','.join(csv_io.TRAJECTORY_COLUMNS) + '\n').encode() + route_repr(traj)
    table = csv_io.parse_csv(text, 'bench.csv', required=csv_io.TRAJECTORY_COLUMNS)
    print(f'1. CSV text of a {args.rows:,}-row solve output, best of {args.runs} (s)')
    print(f"{'route':<28}{'22 columns':>12}{'58 columns':>12}{'MB (22)':>10}  exact")
    outputs = {}
    for joints in (False, True):
        _, data, _ = cli.solve_table(model, table, joints=joints)
        outputs[joints] = data
    routes = {'csv_io.format_table (package)': csv_io.format_table, **CANDIDATES}
    for name, fn in routes.items():
        times = [best_of(args.runs, lambda: fn(outputs[j])) for j in (False, True)]
        body = fn(outputs[False])
        exact = reads_back(body, outputs[False]) and reads_back(fn(outputs[True]), outputs[True])
        print(f'{name:<28}{times[0]:>12.3f}{times[1]:>12.3f}{len(body) / 1e6:>10.1f}  '
              f"{'yes' if exact else 'NO'}")
    env = dict(os.environ)
    env['PYTHONPATH'] = os.pathsep.join(filter(None, [str(ROOT), env.get('PYTHONPATH')]))
    print(f'\n2. `solve` of a {args.rows:,}-row CSV as a subprocess, median of {args.runs} (s)')
    with tempfile.TemporaryDirectory() as tmp:
        src = Path(tmp) / 'traj.csv'
        src.write_bytes(text)
        solve = ['solve', str(src), '-o']
        base = [sys.executable, '-m', 'flight_sim_dynamics']
        rows = [('package writer, -o out.csv', base + solve + [f'{tmp}/out.csv'])]
        rows += [(f'{name}, -o out.csv',
                  [sys.executable, '-c', PATCHED, fn.__name__] + solve
                  + [f'{tmp}/out.csv']) for name, fn in CANDIDATES.items()]
        rows.append(('-o out.npz', base + solve + [f'{tmp}/out.npz']))
        for name, cmd in rows:
            try:
                wall = f'{end_to_end(cmd, args.runs, env):.2f}'
            except RuntimeError as exc:
                wall = 'failed: ' + ' '.join(str(exc).split())[-60:]
            print(f'{name:<36}{wall:>8}')
    print(f'\nload average: {" ".join(f"{v:.2f}" for v in os.getloadavg())}')
    return 0


if __name__ == '__main__':
    sys.exit(main())
