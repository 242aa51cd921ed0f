"""The cost of the machine dispatch: ``fsd.solve`` (which finds the model's
machine) against the machine's own ``solve``, per call, for both machines, in
one run (the two timed alternately, repeat by repeat).

    python -m benchmarks.dispatch [--repeats 15] [--calls 20000] [--quick]
"""
from __future__ import annotations

import argparse
import statistics
import time
from typing import Callable, Sequence

import numpy as np

import flight_sim_dynamics as fsd
from flight_sim_dynamics.machines.staicu import solver
from flight_sim_dynamics.machines.stewart import solver as stewart_solver

from ._common import ROOT, header, table


def per_call_us(call: Callable, model: object, rows: list[tuple], calls: int) -> float:
    """Microseconds per ``call(model, q, qd, qdd)`` over ``rows``, cycled."""
    n = len(rows)
    start = time.perf_counter()
    for i in range(calls):
        call(model, *rows[i % n])
    return (time.perf_counter() - start) / calls * 1e6


def motions(dof: int, n: int = 200) -> list[tuple]:
    """``n`` samples (q, qd, qdd) of a smooth motion in every coordinate, as lists."""
    t = np.linspace(0.0, 2.0, n)[:, None]
    w = np.arange(1, dof + 1)[None, :]
    q, qd, qdd = 0.02 * np.sin(w * t), 0.02 * w * np.cos(w * t), -0.02 * w * w * np.sin(w * t)
    return list(zip(q.tolist(), qd.tolist(), qdd.tolist()))


def main(argv: Sequence[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog='python -m benchmarks.dispatch',
                                description=__doc__.splitlines()[0])
    p.add_argument('--repeats', type=int, default=15, help='median of this many runs')
    p.add_argument('--calls', type=int, default=20_000, help='solves per run')
    p.add_argument('--quick', action='store_true', help='3 runs of 2,000 calls')
    args = p.parse_args(argv)
    repeats, calls = (3, 2000) if args.quick else (args.repeats, args.calls)
    cases = [('3-DOF (kernel)' if solver.kernel.enabled() else '3-DOF (Python)',
              fsd.load_model(), solver.solve, motions(3)),
             ('hexapod', fsd.load_model(ROOT / 'config' / 'stewart_6dof.yaml'),
              stewart_solver.solve, motions(6))]
    rows = []
    for label, model, direct, samples in cases:
        per_call_us(fsd.solve, model, samples, calls // 10)        # warm-up
        times: dict[str, list[float]] = {'direct': [], 'fsd': []}
        for _ in range(repeats):
            times['direct'].append(per_call_us(direct, model, samples, calls))
            times['fsd'].append(per_call_us(fsd.solve, model, samples, calls))
        d, f = statistics.median(times['direct']), statistics.median(times['fsd'])
        ratio = statistics.median(b / a for a, b in zip(times['direct'], times['fsd']))
        rows.append([label, f'{d:.3f}', f'{f:.3f}', f'{f - d:+.3f}', f'{ratio:.3f}x'])
    print(header(f'median of {repeats} runs of {calls:,} solves, alternately'))
    print(table(['machine', "machine's solve us/call", 'fsd.solve us/call', 'difference us',
                 'fsd / machine (median ratio)'], rows))
    return 0


if __name__ == '__main__':
    raise SystemExit(main())
