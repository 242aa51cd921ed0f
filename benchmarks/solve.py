"""Solve cost: ``fsd.solve`` per call, ``fsd.solve_batch`` per sample and
``fsd.forward_kinematics`` per call (the lengths of the general motion's poses,
and lengths no pose has), through the compiled kernel and through the Python
code (FSD_KERNEL=0), in one run.

    python -m benchmarks.solve [--repeats 5] [--quick]
"""
from __future__ import annotations

import argparse
import statistics
import time
from typing import Sequence

import numpy as np

import flight_sim_dynamics as fsd
from flight_sim_dynamics.core import kernel as core_kernel
from flight_sim_dynamics.machines.staicu import kernel

from ._common import header, table


def states(n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """N samples of the paper's general motion over 3 s."""
    return fsd.trajectories.paper_example('general', np.linspace(0.0, 3.0, n))


def per_call_us(model: fsd.Model, calls: int) -> float:
    rows = list(zip(*(a.tolist() for a in states(200))))
    start = time.perf_counter()
    for i in range(calls):
        fsd.solve(model, *rows[i % 200])
    return (time.perf_counter() - start) / calls * 1e6


def per_sample_us(model: fsd.Model, batch: tuple) -> float:
    start = time.perf_counter()
    fsd.solve_batch(model, *batch)
    return (time.perf_counter() - start) / len(batch[0]) * 1e6


#: lengths no pose has: far too long, and one leg of next to no length
UNREACHABLE = ([1e6, 1e6, 1e6], [1.2, 1e-9, 1.2])


def forward_us(model: fsd.Model, lengths: list) -> float:
    """``fsd.forward_kinematics`` from the centre, µs per call."""
    start = time.perf_counter()
    for L in lengths:
        fsd.forward_kinematics(model, L)
    return (time.perf_counter() - start) / len(lengths) * 1e6


def main(argv: Sequence[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog='python -m benchmarks.solve',
                                description=__doc__.splitlines()[0])
    p.add_argument('--repeats', type=int, default=5, help='median of this many runs')
    p.add_argument('--quick', action='store_true', help='1 run, N up to 10k')
    args = p.parse_args(argv)
    repeats = 1 if args.quick else args.repeats
    sizes = (1_000, 10_000) if args.quick else (1_000, 10_000, 100_000)
    calls = 200 if args.quick else 2000
    model = fsd.load_model()
    paths = [('kernel', True), ('Python', False)] if kernel.available() else [('Python', False)]
    figures: dict[str, list[float]] = {}
    reachable = [list(L) for L in fsd.solve_batch(model, *states(calls // 20)).length]
    for label, on in paths:
        with core_kernel.use_kernel(on):
            fsd.solve_batch(model, *states(10))                  # warm-up
            row = [statistics.median(per_call_us(model, calls) for _ in range(repeats))]
            for n in sizes:
                batch = states(n)
                row.append(statistics.median(per_sample_us(model, batch)
                                             for _ in range(repeats)))
            row.append(statistics.median(forward_us(model, reachable) for _ in range(repeats)))
            row.append(statistics.median(forward_us(model, UNREACHABLE) * 1e-3
                                         for _ in range(repeats)))
        figures[label] = row
    print(header(f'median of {repeats}; {calls} solves per run'))
    rows = [[label] + [f'{v:.2f}' for v in values] for label, values in figures.items()]
    if len(figures) == 2:
        rows.append(['Python / kernel'] + [f'{p / k:.1f}x' for k, p in
                                           zip(figures['kernel'], figures['Python'])])
    print(table(['path', 'solve us/call'] + [f'solve_batch us/sample N={n:,}' for n in sizes]
                + ['forward_kinematics us/call', 'unreachable lengths: ms/call'], rows))
    return 0


if __name__ == '__main__':
    raise SystemExit(main())
