"""The 6-DOF hexapod's solve cost (flight_sim_dynamics.machines.stewart):
``solve`` per call and ``solve_batch`` per sample through the compiled kernel
and through the numpy code (the reference), ``forward_dynamics`` per call,
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

from flight_sim_dynamics.core.kernel import use_kernel
from flight_sim_dynamics.machines.stewart import forward_dynamics, kernel, model, solver

from ._common import ROOT, header, table

#: The issue's targets: solve within this many pin.rnea ...
SOLVE_PER_RNEA = 1.5
#: ... and solve_batch at least this many times faster per sample than solve.
BATCH_GAIN = 5.0


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
    p.add_argument('--quick', action='store_true', help='1 run, fewer calls, N up to 10k')
    args = p.parse_args(argv)
    repeats = 1 if args.quick else args.repeats
    calls = 200 if args.quick else 2000
    sizes = (1_000, 10_000) if args.quick else (1_000, 100_000)
    params = default_machine()
    hexapod = model.from_dict(params)
    sr = _reference()
    tree = sr.PinocchioHexapod(sr.machine_from_dict(params))
    q, qd, qdd = motion(200)
    arrays = [tuple(a[i] for a in (q, qd, qdd)) for i in range(200)]
    samples = [tuple(a.tolist() for a in s) for s in arrays]  # lists of floats
    tree_states = [tree.motion(*s)[:3] for s in arrays]       # (x, v, a) of the closed tree
    forces = solver.solve_batch(hexapod, q, qd, qdd).force
    fd_rows = [(q[i], qd[i], forces[i]) for i in range(200)]

    def rnea(x, v, a):
        return pin.rnea(tree.model, tree.data, x, v, a)

    def median(fn, rows, n):
        return statistics.median(per_call_us(fn, rows, n) for _ in range(repeats))

    paths = [('kernel', True), ('numpy', False)] if kernel.available() else [('numpy', False)]
    per_call, batch = [], {}
    for label, on in paths:
        with use_kernel(on):
            solver.solve(hexapod, *samples[0])                  # warm-up
            solver.solve_batch(hexapod, *motion(sizes[-1]))     # and the batch's buffers
            per_call.append((f'solve ({label})', median(
                lambda *s: solver.solve(hexapod, *s), samples, calls if on else calls // 10)))
            per_call.append((f'forward_dynamics ({label})', median(
                lambda *s: forward_dynamics.forward_dynamics(hexapod, *s), fd_rows,
                calls // 4 if on else calls // 40)))
            batch[label] = [statistics.median(per_sample_us(hexapod, motion(n))
                                              for _ in range(repeats)) for n in sizes]
    rnea_us = median(rnea, tree_states, calls * 10)
    per_call += [(f'pin.rnea, reference tree (nv = {tree.model.nv})', rnea_us),
                 ('reference forces (closure + rnea + J^-T)', median(tree.forces, arrays,
                                                                     calls // 4))]
    print(header(f'median of {repeats}; default 6-DOF machine, random motions about home; '
                 'solve given lists of floats'))
    print(table(['per call', 'us', 'x pin.rnea'],
                [[name, f'{us:.2f}', f'{us / rnea_us:.2f}x'] for name, us in per_call]))
    print()
    rows = [[f'{label}, us/sample', *(f'{us:.3f}' for us in values)]
            for label, values in batch.items()]
    solve_us = dict(per_call)
    for label, values in batch.items():
        rows.append([f'{label}: solve / this', *(f'{solve_us[f"solve ({label})"] / us:.1f}x'
                                                 for us in values)])
    print(table(['solve_batch', *(f'N={n:,}' for n in sizes)], rows))
    if 'kernel' in batch:
        solve_k, solve_n = solve_us['solve (kernel)'], solve_us['solve (numpy)']
        print()
        print(table(['target', 'figure', 'target', 'met'], [
            ['solve (kernel) / pin.rnea', f'{solve_k / rnea_us:.2f}', f'<= {SOLVE_PER_RNEA:g}',
             'yes' if solve_k / rnea_us <= SOLVE_PER_RNEA else 'no'],
            [f'solve / solve_batch per sample, kernel, N={sizes[-1]:,}',
             f'{solve_k / batch["kernel"][-1]:.1f}', f'>= {BATCH_GAIN:g}',
             'yes' if solve_k / batch['kernel'][-1] >= BATCH_GAIN else 'no'],
            ['kernel gain on solve, 1 - kernel / numpy', f'{100 * (1 - solve_k / solve_n):.1f} %',
             '>= 25 %', 'yes' if solve_k / solve_n <= 0.75 else 'no'],
            [f'kernel gain on solve_batch, N={sizes[-1]:,}',
             f'{100 * (1 - batch["kernel"][-1] / batch["numpy"][-1]):.1f} %', '>= 25 %',
             'yes' if batch['kernel'][-1] / batch['numpy'][-1] <= 0.75 else 'no']]))
    return 0


if __name__ == '__main__':
    raise SystemExit(main())
