"""The 6-DOF hexapod's solve cost (flight_sim_dynamics.machines.stewart, numpy):
``solve`` per call, ``solve_batch`` per sample, ``forward_dynamics`` per call,
next to pinocchio's ``rnea`` on the independent reference's 24-joint tree of
the same machine (test/reference/stewart_reference.py), in one run.

    python -m benchmarks.stewart [--repeats 5] [--quick]
"""
from __future__ import annotations

import argparse
import importlib.util
import re
import statistics
import time
from typing import Sequence

import numpy as np
import pinocchio as pin
import yaml

from flight_sim_dynamics.machines.stewart import forward_dynamics, model, solver

from ._common import ROOT, header, table


def _reference():
    """test/reference/stewart_reference.py, loaded by its path (it is no package)."""
    spec = importlib.util.spec_from_file_location(
        'stewart_reference', ROOT / 'test' / 'reference' / 'stewart_reference.py')
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def default_machine() -> dict:
    """The default machine's parameter file, as docs/design/stewart.md prints it."""
    text = (ROOT / 'docs' / 'design' / 'stewart.md').read_text(encoding='utf-8')
    return next(yaml.safe_load(b) for b in re.findall(r'```yaml\n(.*?)```', text, flags=re.S)
                if 'machine: stewart_6dof' in b and '[...]' not in b)


def motion(n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """N samples of a motion-cueing-like random motion about home."""
    rng = np.random.default_rng(0)
    return (rng.uniform(-0.1, 0.1, (n, 6)), rng.normal(0.0, 0.5, (n, 6)),
            rng.normal(0.0, 5.0, (n, 6)))


def per_call_us(fn, rows: list, calls: int) -> float:
    start = time.perf_counter()
    for i in range(calls):
        fn(*rows[i % len(rows)])
    return (time.perf_counter() - start) / calls * 1e6


def per_sample_us(hexapod: model.StewartModel, states: tuple) -> float:
    start = time.perf_counter()
    solver.solve_batch(hexapod, *states)
    return (time.perf_counter() - start) / len(states[0]) * 1e6


def main(argv: Sequence[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog='python -m benchmarks.stewart',
                                description=__doc__.splitlines()[0])
    p.add_argument('--repeats', type=int, default=5, help='median of this many runs')
    p.add_argument('--quick', action='store_true', help='1 run, fewer calls, N up to 1k')
    args = p.parse_args(argv)
    repeats = 1 if args.quick else args.repeats
    calls = 200 if args.quick else 2000
    sizes = (1, 100, 1_000) if args.quick else (1, 100, 1_000, 10_000, 100_000)
    params = default_machine()
    hexapod = model.from_dict(params)
    sr = _reference()
    tree = sr.PinocchioHexapod(sr.machine_from_dict(params))
    q, qd, qdd = motion(200)
    samples = [tuple(a[i] for a in (q, qd, qdd)) for i in range(200)]
    tree_states = [tree.motion(*s)[:3] for s in samples]      # (x, v, a) of the closed tree
    forces = solver.solve_batch(hexapod, q, qd, qdd).force
    fd_rows = [(q[i], qd[i], forces[i]) for i in range(200)]

    def rnea(x, v, a):
        return pin.rnea(tree.model, tree.data, x, v, a)

    def median(fn, rows, n):
        return statistics.median(per_call_us(fn, rows, n) for _ in range(repeats))

    solver.solve(hexapod, *samples[0])                      # warm-up
    per_call = [
        ('solve (numpy, batch of one)', median(lambda *s: solver.solve(hexapod, *s), samples,
                                               calls)),
        ('forward_dynamics (numpy)', median(
            lambda *s: forward_dynamics.forward_dynamics(hexapod, *s), fd_rows, calls // 4)),
        (f'pin.rnea, reference tree (nv = {tree.model.nv})', median(rnea, tree_states,
                                                                      calls * 10)),
        ('reference forces (closure + rnea + J^-T)', median(tree.forces, samples, calls // 4)),
    ]
    batch = [statistics.median(per_sample_us(hexapod, motion(n)) for _ in range(repeats))
             for n in sizes]
    print(header(f'median of {repeats}; default 6-DOF machine, random motions about home'))
    rnea_us = per_call[2][1]
    print(table(['per call', 'us', 'x pin.rnea'],
                [[name, f'{us:.2f}', f'{us / rnea_us:.1f}x'] for name, us in per_call]))
    print()
    print(table(['solve_batch', *(f'N={n:,}' for n in sizes)],
                [['us/sample', *(f'{us:.2f}' for us in batch)],
                 ['solve / this', *(f'{per_call[0][1] / us:.1f}x' for us in batch)]]))
    return 0


if __name__ == '__main__':
    raise SystemExit(main())
