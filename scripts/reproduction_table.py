#!/usr/bin/env python3
"""Reproduce the paper's three examples with the command line and tabulate
the peak actuator forces and powers.

    python -m scripts.reproduction_table                  # print the tables
    python -m scripts.reproduction_table --figures docs   # also write docs/<example>.png
    python -m scripts.reproduction_table --figures docs --update docs/reproduction.md

(from the repository root).

For each example (vertical, rectilinear, general) this runs exactly the
documented commands, through ``flight_sim_dynamics.cli.main``:

    flight-sim-dynamics example NAME -o WORK/traj/NAME.csv       (100 Hz, 0..3 s)
    flight-sim-dynamics solve WORK/traj/NAME.csv -o WORK/out/NAME.csv
    flight-sim-dynamics plot WORK/out/NAME.csv -o FIGURES/NAME.png   (with --figures)

and reads the solve output back. Every number printed comes from those
files: nothing is typed by hand. ``--update FILE`` replaces the text between
the markers ``<!-- reproduction-table:begin -->`` and
``<!-- reproduction-table:end -->`` in FILE with the tables.
"""
from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import numpy as np

import flight_sim_dynamics as fsd
from flight_sim_dynamics.cli import csv_io
from flight_sim_dynamics.cli import main as cli
from flight_sim_dynamics.core.trajectories import PAPER_EXAMPLES

BEGIN = '<!-- reproduction-table:begin -->'
END = '<!-- reproduction-table:end -->'
LEGS = ('A', 'B', 'C')


def run(argv: list[str]) -> None:
    rc = cli.main(argv)
    if rc != 0:
        raise SystemExit(f'flight-sim-dynamics {" ".join(argv)} failed with exit status {rc}')


def reproduce(work: Path, figures: Path | None, rate: float | None
              ) -> tuple[dict[str, csv_io.Table], dict[str, np.ndarray]]:
    """Run the commands; returns the solve outputs and the poses (surge,
    heave, roll) read from the trajectory files, by example.
    """
    (work / 'traj').mkdir(parents=True, exist_ok=True)
    (work / 'out').mkdir(parents=True, exist_ok=True)
    tables, poses = {}, {}
    for name in PAPER_EXAMPLES:
        traj = work / 'traj' / f'{name}.csv'
        out = work / 'out' / f'{name}.csv'
        run(['example', name, '-o', str(traj)] + ([] if rate is None else ['--rate', str(rate)]))
        run(['solve', str(traj), '-o', str(out)])
        if figures is not None:
            figures.mkdir(parents=True, exist_ok=True)
            run(['plot', str(out), '-o', str(figures / f'{name}.png')])
        # the solve output has a text column (status) besides the numbers
        tables[name] = csv_io.read_csv(out, required=cli.PLOT_COLUMNS, allow_extra=True,
                                       text_columns=('status',))
        traj_table = csv_io.read_csv(traj, required=csv_io.TRAJECTORY_COLUMNS)
        poses[name] = np.column_stack([traj_table[c] for c in ('surge', 'heave', 'roll')])
    return tables, poses


def _peak(t: np.ndarray, y: np.ndarray) -> tuple[float, float]:
    i = int(np.argmax(np.abs(y)))
    return float(y[i]), float(t[i])


def _num(x: float, digits: int = 2) -> str:
    return f'{x:.{digits}f}'.replace('-', '−') if x != 0 else f'{0:.{digits}f}'


def markdown(tables: dict[str, csv_io.Table], trajectories: dict[str, np.ndarray]) -> str:
    rate = 1.0 / float(np.median(np.diff(next(iter(tables.values()))['t'])))
    out = []
    out.append(f'Peak values over t in [0, 3] s, sampled at {rate:g} Hz '
               '(signed value at the peak of the magnitude, and when it occurs):\n')
    out.append('| example | actuator | peak \\|force\\| (N) | at t (s) | force range (N) '
               '| peak \\|power\\| (W) | at t (s) | work ∫P dt (J) |')
    out.append('|---|---|---:|---:|---:|---:|---:|---:|')
    for name, tab in tables.items():
        t = tab['t']
        for i, leg in enumerate(LEGS):
            f = tab[f'force_{leg.lower()}']
            p = tab[f'power_{leg.lower()}']
            fpk, tf = _peak(t, f)
            ppk, tp = _peak(t, p)
            work = float(np.trapezoid(p, t))
            out.append(f'| {name if i == 0 else ""} | {leg} | {_num(fpk, 3)} | {tf:.2f} '
                       f'| {_num(f.min(), 2)} … {_num(f.max(), 2)} | {_num(ppk, 3)} | {tp:.2f} '
                       f'| {_num(work, 3)} |')
    out.append('')
    out.append('Checks on the same files. *Static* forces are those that hold the same '
               'poses at rest (`solve_batch` with zero rates and accelerations); their '
               'difference from the dynamic forces is the share of inertia.\n')
    out.append('| example | max \\|f_B − f_C\\| (N) | max \\|P_B − P_C\\| (W) '
               '| max \\|P\\| at t = 0, 3 s (W) | forces A, B, C at t = 0 (N) '
               '| static forces at t = 0 (N) | max \\|f − f_static\\| (N) |')
    out.append('|---|---:|---:|---:|---:|---:|---:|')
    model = fsd.load_model()
    for name, tab in tables.items():
        fb, fc = tab['force_b'], tab['force_c']
        pb, pc = tab['power_b'], tab['power_c']
        ends = np.abs(np.concatenate([[tab[f'power_{x}'][0], tab[f'power_{x}'][-1]]
                                      for x in 'abc']))
        force = np.column_stack([tab[f'force_{x}'] for x in 'abc'])
        q = trajectories[name]
        static = fsd.solve_batch(model, q, np.zeros_like(q), np.zeros_like(q)).force
        f0 = ', '.join(_num(v, 3) for v in force[0])
        s0 = ', '.join(_num(v, 3) for v in static[0])
        out.append(f'| {name} | {np.max(np.abs(fb - fc)):.3g} | {np.max(np.abs(pb - pc)):.3g} '
                   f'| {np.max(ends):.3g} | {f0} | {s0} | {np.max(np.abs(force - static)):.3f} |')
    return '\n'.join(out) + '\n'


def update(path: Path, text: str) -> None:
    doc = path.read_text()
    try:
        head, rest = doc.split(BEGIN, 1)
        _, tail = rest.split(END, 1)
    except ValueError:
        raise SystemExit(f'{path}: markers {BEGIN} ... {END} not found') from None
    path.write_text(f'{head}{BEGIN}\n{text}{END}{tail}')


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog='python -m scripts.reproduction_table',
                                     description=__doc__.split('\n\n')[0])
    parser.add_argument('--figures', type=Path, default=None, metavar='DIR',
                        help='also plot each example to DIR/<example>.png')
    parser.add_argument('--work', type=Path, default=None, metavar='DIR',
                        help='keep the trajectory and result CSVs in DIR (default: a '
                             'temporary directory)')
    parser.add_argument('--rate', type=float, default=None,
                        help='sampling rate in Hz (default: the CLI default, 100 Hz)')
    parser.add_argument('--update', type=Path, default=None, metavar='MD',
                        help='replace the marked table block in this Markdown file')
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        tables, poses = reproduce(args.work or Path(tmp), args.figures, args.rate)
        text = markdown(tables, poses)
    print(text, end='')
    if args.update is not None:
        update(args.update, text)
    return 0


if __name__ == '__main__':
    sys.exit(main())
