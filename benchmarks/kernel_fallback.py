"""Compiled kernel against the Python reference solve, in one process.

    python -m benchmarks.kernel_fallback [--cycles 2000] [--batch-n 100000]

Prints a table: ``fsd.solve`` per call and ``fsd.solve_batch`` throughput,
through the kernel (src/kernel.c) and through the Python code of
``flight_sim_dynamics.core`` (``kernel.use_kernel(False)``, what an install
without a C compiler runs), plus the ratio. States cycle through the paper's
general motion (scene ``full``). Every figure is the median of ``--repeats``
runs, interleaved; the machine's load average is printed with them.
"""
from __future__ import annotations

import argparse
import os
import statistics
import time

import numpy as np

import flight_sim_dynamics as fsd
from flight_sim_dynamics.core import kernel


def _states(n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    return fsd.trajectories.paper_example('general', np.linspace(0.0, 3.0, n))


def _per_call_us(model: fsd.Model, states: tuple, cycles: int) -> float:
    Q, Qd, Qdd = (a.tolist() for a in states)
    k = len(Q)
    start = time.perf_counter()
    for i in range(cycles):
        j = i % k
        fsd.solve(model, Q[j], Qd[j], Qdd[j])
    return (time.perf_counter() - start) / cycles * 1e6


def _batch_rate(model: fsd.Model, states: tuple) -> float:
    start = time.perf_counter()
    fsd.solve_batch(model, *states)
    return len(states[0]) / (time.perf_counter() - start)


def _median(function, repeats: int) -> float:
    return statistics.median(function() for _ in range(repeats))


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--cycles', type=int, default=2000)
    parser.add_argument('--batch-n', type=int, default=100_000)
    parser.add_argument('--repeats', type=int, default=5)
    args = parser.parse_args(argv)
    if not kernel.available():
        raise SystemExit(f'the kernel is not built ({kernel.IMPORT_ERROR}): nothing to compare')
    model = fsd.load_model()
    single, batch = _states(200), _states(args.batch_n)
    rows = []
    for label, on in (('kernel (C)', True), ('Python', False)):
        with kernel.use_kernel(on):
            fsd.solve_batch(model, *_states(10))           # warm-up
            per_call = _median(lambda: _per_call_us(model, single, args.cycles), args.repeats)
            rate = _median(lambda: _batch_rate(model, batch), args.repeats)
        rows.append((label, per_call, rate))
    saved = kernel.THREAD_MIN_SAMPLES
    kernel.THREAD_MIN_SAMPLES = args.batch_n + 1             # one thread
    try:
        one_thread = _median(lambda: _batch_rate(model, batch), args.repeats)
    finally:
        kernel.THREAD_MIN_SAMPLES = saved
    print(f'load average {os.getloadavg()[0]:.2f}, usable cores {kernel.usable_cores()}, '
          f'{args.cycles} solves x {args.repeats}, batch N = {args.batch_n}')
    print(f'{"path":<12} {"solve us/call":>14} {"batch samples/s":>16}')
    for label, per_call, rate in rows:
        print(f'{label:<12} {per_call:>14.1f} {rate:>16,.0f}')
    print(f'{"kernel, 1 thread":<27} {one_thread:>16,.0f}')
    (_, kc, kb), (_, pc, pb) = rows
    print(f'{"Python / kernel":<12} {pc / kc:>13.1f}x {kb / pb:>15.1f}x')


if __name__ == '__main__':
    main()
