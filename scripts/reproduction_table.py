"""The figures and tables of docs/reproduction.md, every number read back
from the files of ``flight-sim-dynamics example``, ``solve`` and ``plot``.

    python -m scripts.reproduction_table --figures docs --update docs/reproduction.md
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
from flight_sim_dynamics.machines.staicu.trajectories import PAPER_EXAMPLES

from . import replace_block

BLOCK = 'reproduction-table'
#: Differences below this are round-off: printed as such, not as digits that
#: change with the machine.
ROUND_OFF = 1e-9


def run(argv: list[str]) -> None:
    if cli.main(argv) != 0:
        raise SystemExit(f'flight-sim-dynamics {" ".join(argv)} failed')


def reproduce(work: Path, figures: Path | None) -> dict[str, tuple[csv_io.Table, np.ndarray]]:
    """Run the commands; the solve output and the poses, by example."""
    for sub in ('traj', 'out'):
        (work / sub).mkdir(parents=True, exist_ok=True)
    results = {}
    for name in PAPER_EXAMPLES:
        traj, out = work / 'traj' / f'{name}.csv', work / 'out' / f'{name}.csv'
        run(['example', name, '-o', str(traj)])
        run(['solve', str(traj), '-o', str(out)])
        if figures is not None:
            figures.mkdir(parents=True, exist_ok=True)
            run(['plot', str(out), '-o', str(figures / f'{name}.png')])
        table = csv_io.read_csv(out, required=cli.PLOT_COLUMNS, allow_extra=True,
                                text_columns=('status',))
        poses = csv_io.read_csv(traj, required=csv_io.TRAJECTORY_COLUMNS)
        results[name] = table, np.column_stack([poses[c] for c in ('surge', 'heave', 'roll')])
    return results


def num(x: float, digits: int) -> str:
    return f'{x:.{digits}f}'.replace('-', '−') if x != 0 else f'{0:.{digits}f}'


def small(x: float) -> str:
    return f'< {ROUND_OFF:g}' if x < ROUND_OFF else f'{x:.3g}'


def markdown(results: dict[str, tuple[csv_io.Table, np.ndarray]]) -> str:
    rate = 1.0 / float(np.median(np.diff(next(iter(results.values()))[0]['t'])))
    out = [f'Peak values over t in [0, 3] s, sampled at {rate:g} Hz (signed value at the '
           'peak of the magnitude, and when it occurs):', '',
           '| example | actuator | peak \\|force\\| (N) | at t (s) | force range (N) '
           '| peak \\|power\\| (W) | at t (s) | work ∫P dt (J) |',
           '|---|---|---:|---:|---:|---:|---:|---:|']
    for name, (tab, _) in results.items():
        t = tab['t']
        for i, leg in enumerate('abc'):
            f, p = tab[f'force_{leg}'], tab[f'power_{leg}']
            jf, jp = int(np.argmax(np.abs(f))), int(np.argmax(np.abs(p)))
            out.append(f'| {name if i == 0 else ""} | {leg.upper()} | {num(f[jf], 3)} '
                       f'| {t[jf]:.2f} | {num(f.min(), 2)} … {num(f.max(), 2)} '
                       f'| {num(p[jp], 3)} | {t[jp]:.2f} | {num(np.trapezoid(p, t), 3)} |')
    out += ['', 'Checks on the same files. *Static* forces hold the same poses at rest '
            '(`solve_batch` with zero rates and accelerations); their difference from the '
            'dynamic forces is the share of inertia.', '',
            '| example | max \\|f_B − f_C\\| (N) | max \\|P_B − P_C\\| (W) '
            '| max \\|P\\| at t = 0, 3 s (W) | forces A, B, C at t = 0 (N) '
            '| static forces at t = 0 (N) | max \\|f − f_static\\| (N) |',
            '|---|---:|---:|---:|---:|---:|---:|']
    model = fsd.load_model()
    for name, (tab, q) in results.items():
        force = np.column_stack([tab[f'force_{x}'] for x in 'abc'])
        power = np.column_stack([tab[f'power_{x}'] for x in 'abc'])
        static = fsd.solve_batch(model, q, np.zeros_like(q), np.zeros_like(q)).force
        out.append(f'| {name} | {small(np.max(np.abs(force[:, 1] - force[:, 2])))} '
                   f'| {small(np.max(np.abs(power[:, 1] - power[:, 2])))} '
                   f'| {small(np.max(np.abs(power[[0, -1]])))} '
                   f'| {", ".join(num(v, 3) for v in force[0])} '
                   f'| {", ".join(num(v, 3) for v in static[0])} '
                   f'| {np.max(np.abs(force - static)):.3f} |')
    return '\n'.join(out) + '\n'


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog='python -m scripts.reproduction_table',
                                     description=__doc__.split('\n\n')[0])
    parser.add_argument('--figures', type=Path, metavar='DIR',
                        help='also plot each example to DIR/<example>.png')
    parser.add_argument('--work', type=Path, metavar='DIR',
                        help='keep the trajectory and result CSVs in DIR')
    parser.add_argument('--update', type=Path, metavar='MD',
                        help='replace the marked table block in this Markdown file')
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        text = markdown(reproduce(args.work or Path(tmp), args.figures))
    print(text, end='')
    if args.update is not None:
        replace_block(args.update, BLOCK, text)
    return 0


if __name__ == '__main__':
    sys.exit(main())
