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
import os
import statistics
import time
from typing import Callable, Sequence

import numpy as np
import pinocchio as pin
import yaml

from flight_sim_dynamics.config.files import PACKAGED_SECTION
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
    """The default machine's parameters (its file's ``ros__parameters``), as
    docs/design/stewart.md prints the file.
    """
    text = (ROOT / 'docs' / 'design' / 'stewart.md').read_text(encoding='utf-8')
    return next(yaml.safe_load(b)[PACKAGED_SECTION]['ros__parameters']
                for b in re.findall(r'```yaml\n(.*?)```', text, flags=re.S)
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


#: What the kernel's solve leaves to the first read (joint angles without joint-angle
#: limits, the exact condition where the status does not need it).
DEFERRED = ('joints', 'spherical_angles', 'jacobian_condition')


def per_sample_us(hexapod: model.StewartModel, states: tuple, read_all: bool = False) -> float:
    """The second of two calls: the first brings the allocator to its steady
    state for N (the other figures' large arrays in between return its memory
    to the system, and a fresh page costs microseconds on a virtual machine).
    ``read_all``: the call and the first read of every field it defers.
    """
    solver.solve_batch(hexapod, *states)
    start = time.perf_counter()
    sol = solver.solve_batch(hexapod, *states)
    if read_all:
        for name in DEFERRED:
            getattr(sol, name)
    return (time.perf_counter() - start) / len(states[0]) * 1e6


def on_one_cpu(fn: Callable[[], float]) -> float:
    """``fn()`` with the calling thread on one CPU: the kernel, which counts
    the calling thread's usable CPUs at each batch, then starts no thread.
    """
    cpus = os.sched_getaffinity(0)
    os.sched_setaffinity(0, {min(cpus)})
    try:
        return fn()
    finally:
        os.sched_setaffinity(0, cpus)


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

    paths = [('kernel', True), ('numpy', False)] if kernel.available() else [('numpy', False)]
    timed = {}      # label -> (kernel on, function of no argument -> us)
    for label, on in paths:
        fast = on or len(paths) == 1
        timed[f'solve ({label})'] = (on, lambda n=calls if fast else calls // 10: per_call_us(
            lambda *s: solver.solve(hexapod, *s), samples, n))
        timed[f'forward_dynamics ({label})'] = (on, lambda n=calls // 4 if fast else calls // 40:
                                                per_call_us(lambda *s: forward_dynamics.
                                                            forward_dynamics(hexapod, *s),
                                                            fd_rows, n))
        for n in sizes:
            timed[f'solve_batch ({label}) N={n}'] = (on, lambda n=n: per_sample_us(
                hexapod, motion(n)))
        if on:
            timed[f'solve_batch, every field read ({label}) N={sizes[-1]}'] = (
                on, lambda: per_sample_us(hexapod, motion(sizes[-1]), read_all=True))
        if on and len(os.sched_getaffinity(0)) > 1:      # the ledger's threads row, same run
            timed[f'solve_batch, one thread ({label}) N={sizes[-1]}'] = (
                on, lambda: on_one_cpu(lambda: per_sample_us(hexapod, motion(sizes[-1]))))
    timed[f'pin.rnea, reference tree (nv = {tree.model.nv})'] = (
        False, lambda: per_call_us(rnea, tree_states, calls * 10))
    timed['reference forces (closure + rnea + J^-T)'] = (
        False, lambda: per_call_us(tree.forces, arrays, calls // 4))
    for label, on in paths:                                     # warm-up, the batch's buffers
        with use_kernel(on):
            solver.solve(hexapod, *samples[0])
            solver.solve_batch(hexapod, *motion(sizes[-1]))
    runs = {name: [] for name in timed}
    for _ in range(repeats):        # interleaved: a repeat's figures share the host's load
        for name, (on, fn) in timed.items():
            with use_kernel(on):
                runs[name].append(fn())
    us = {name: statistics.median(values) for name, values in runs.items()}
    rnea_name = next(name for name in us if name.startswith('pin.rnea'))

    def ratio(a: str, b: str) -> float:
        """Median over the repeats of a / b."""
        return statistics.median(x / y for x, y in zip(runs[a], runs[b]))

    print(header(f'median of {repeats} interleaved repeats; default 6-DOF machine, random '
                 'motions about home; solve given lists of floats'))
    per_call = [name for name in us if not name.startswith('solve_batch')]
    print(table(['per call', 'us', 'x pin.rnea'],
                [[name, f'{us[name]:.2f}', f'{ratio(name, rnea_name):.2f}x']
                 for name in per_call]))
    print()
    rows = []
    for label, _ in paths:
        names = [f'solve_batch ({label}) N={n}' for n in sizes]
        rows.append([f'{label}, us/sample', *(f'{us[name]:.3f}' for name in names)])
        rows.append([f'{label}: x pin.rnea', *(f'{ratio(name, rnea_name):.2f}x'
                                                for name in names)])
        rows.append([f'{label}: solve / this',
                     *(f'{ratio(f"solve ({label})", name):.1f}x' for name in names)])
        alone = f'solve_batch, one thread ({label}) N={sizes[-1]}'
        if alone in us:     # the threads' gain: one thread against one per usable CPU
            rows.append([f'{label}, us/sample, one thread', *([''] * (len(sizes) - 1)),
                         f'{us[alone]:.3f}'])
            gain = ratio(f'solve_batch ({label}) N={sizes[-1]}', alone)
            rows.append([f'{label}: threads save', *([''] * (len(sizes) - 1)),
                         f'{100 * (1 - gain):.0f} %'])
        read = f'solve_batch, every field read ({label}) N={sizes[-1]}'
        if read in us:      # what the first read of the deferred fields adds
            rows.append([f'{label}, us/sample, then {", ".join(DEFERRED)} read',
                         *([''] * (len(sizes) - 1)), f'{us[read]:.3f}'])
    print(table(['solve_batch', *(f'N={n:,}' for n in sizes)], rows))
    if len(paths) == 2:
        last = f'N={sizes[-1]}'
        per_rnea = ratio('solve (kernel)', rnea_name)
        batch_gain = ratio('solve (kernel)', f'solve_batch (kernel) {last}')
        solve_kept = ratio('solve (kernel)', 'solve (numpy)')
        batch_kept = ratio(f'solve_batch (kernel) {last}', f'solve_batch (numpy) {last}')
        print()
        print(table(['target', 'figure', 'target', 'met'], [
            ['solve (kernel) / pin.rnea', f'{per_rnea:.2f}', f'<= {SOLVE_PER_RNEA:g}',
             'yes' if per_rnea <= SOLVE_PER_RNEA else 'no'],
            [f'solve / solve_batch per sample, kernel, N={sizes[-1]:,}', f'{batch_gain:.1f}',
             f'>= {BATCH_GAIN:g}', 'yes' if batch_gain >= BATCH_GAIN else 'no'],
            ['kernel gain on solve, 1 - kernel / numpy', f'{100 * (1 - solve_kept):.1f} %',
             '>= 25 %', 'yes' if solve_kept <= 0.75 else 'no'],
            [f'kernel gain on solve_batch, N={sizes[-1]:,}', f'{100 * (1 - batch_kept):.1f} %',
             '>= 25 %', 'yes' if batch_kept <= 0.75 else 'no']]))
    return 0


if __name__ == '__main__':
    raise SystemExit(main())
