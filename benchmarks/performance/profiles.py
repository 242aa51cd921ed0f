"""Profiles of the performance benchmark: the parts of ``fsd.solve``, the
batch by threads, the node under load (py-spy and/or cProfile).
"""
from __future__ import annotations

import argparse
import gc
import math
import pstats
import shutil
import sys
import time
from pathlib import Path
from typing import Any, Callable

import numpy as np

import flight_sim_dynamics as fsd
from flight_sim_dynamics.core import kernel

from .. import node_stream

from .common import (ROOT, as_states, log, sequence_states, tiled)
from .node import (stream_dict)


# ----------------------------------------------------------------------------
# Profiles
# ----------------------------------------------------------------------------
def _short(key: tuple) -> str:
    """A cProfile stats key (file, line, function) as ``path:line(function)``,
    the path relative to the repository or to site-packages.
    """
    filename, line, func = key
    if filename == '~':
        return func
    p = Path(filename)
    try:
        name = str(p.resolve().relative_to(ROOT))
    except ValueError:
        parts = p.parts
        name = ('/'.join(parts[parts.index('site-packages') + 1:]) if 'site-packages' in parts
                else p.name)
    return f'{name}:{line}({func})'


def _per_call_us(fn: Callable[[], Any], n: int, repeats: int = 5) -> float:
    """Best of ``repeats`` runs of n calls, us per call (the load only adds time)."""
    best = math.inf
    for _ in range(repeats):
        t0 = time.perf_counter()
        for _ in range(n):
            fn()
        best = min(best, time.perf_counter() - t0)
    return 1e6 * best / n


def profile_solver(args: argparse.Namespace) -> dict:
    """Where the time of one ``fsd.solve`` goes: the compiled kernel alone, its
    Python wrapper, and the Python reference code for comparison; and the
    batch with one thread, all threads and the Python reference code.
    """
    n = args.profile_solves
    log(f'profile: the parts of fsd.solve ({n} calls each)')
    states = as_states(*sequence_states(100.0))
    q, qd, qdd = states[50]
    out: dict[str, Any] = dict(n=n, kernel=kernel.enabled(),
                               kernel_path=getattr(kernel._kernel, '__file__', None))
    for scene in ('full', 'quasi_static'):
        model = fsd.load_model(scene=scene)
        part: dict[str, float] = {}
        if kernel.enabled():
            params, bits = kernel.prepared(model)
            buf = np.empty(kernel.OUT_SIZE)
            c_solve = kernel._kernel.solve
            part['kernel'] = _per_call_us(lambda: c_solve(params, bits, buf, *q, *qd, *qdd), n)
            part['solve_row'] = _per_call_us(lambda: kernel.solve_row(model, q, qd, qdd), n)
        part['solve'] = _per_call_us(lambda: fsd.solve(model, q, qd, qdd), n)
        part['read'] = _per_call_us(lambda: fsd.solve(model, q, qd, qdd).force[0], n)
        with kernel.use_kernel(False):
            part['python'] = _per_call_us(lambda: fsd.solve(model, q, qd, qdd),
                                          max(n // 20, 20), 3)
        out[scene] = part
    full = fsd.load_model(scene='full')
    nb = min(args.batch_n, 100_000)
    Q, Qd, Qdd = tiled(sequence_states(1000.0), nb)
    batch: dict[str, float] = dict(n=nb, threads=kernel.usable_cores())
    if kernel.enabled():
        saved = kernel.THREAD_MIN_SAMPLES
        try:
            kernel.THREAD_MIN_SAMPLES = nb + 1          # one thread
            batch['one_thread'] = nb / min(_timed(lambda: fsd.solve_batch(full, Q, Qd, Qdd))
                                           for _ in range(3))
        finally:
            kernel.THREAD_MIN_SAMPLES = saved
        batch['threads_rate'] = nb / min(_timed(lambda: fsd.solve_batch(full, Q, Qd, Qdd))
                                         for _ in range(3))
    m = min(nb, 20_000)
    with kernel.use_kernel(False):
        batch['python'] = m / _timed(lambda: fsd.solve_batch(full, Q[:m], Qd[:m], Qdd[:m]))
    out['batch'] = batch
    return out


def _timed(fn: Callable[[], Any]) -> float:
    gc.collect()
    t0 = time.perf_counter()
    fn()
    return time.perf_counter() - t0


def find_py_spy() -> str | None:
    local = Path(sys.executable).parent / 'py-spy'
    return str(local) if local.exists() else shutil.which('py-spy')


def parse_py_spy_raw(path: Path, top: int) -> dict:
    """Self (leaf) and total (anywhere on the stack) samples per function
    from py-spy's raw (collapsed stacks) output.
    """
    self_c: dict[str, int] = {}
    total_c: dict[str, int] = {}
    n = 0
    for line in Path(path).read_text().splitlines():
        stack, _, count = line.rpartition(' ')
        try:
            c = int(count)
        except ValueError:
            continue
        frames = stack.split(';')
        n += c
        leaf = frames[-1]
        self_c[leaf] = self_c.get(leaf, 0) + c
        for f in set(frames):
            total_c[f] = total_c.get(f, 0) + c

    def clean(f: str) -> str:
        return f.replace(str(ROOT) + '/', '')
    top_self = sorted(self_c.items(), key=lambda kv: -kv[1])[:top]
    # what the Python thread was doing, by the first matching frame of each stack
    groups = {'solve (fsd.solve via solve_setpoint)': 0,
              'publish (rclpy Publisher.publish: DDS write of the JointStates)': 0,
              'executor: take the serialized setpoints, dispatch, wake-ups': 0,
              'diagnostics timer': 0,
              'node Python: callbacks, synchroniser, checks, message fields': 0,
              'other': 0}
    keys = list(groups)
    other_leaves: dict[str, int] = {}
    for line in Path(path).read_text().splitlines():
        stack, _, count = line.rpartition(' ')
        try:
            c = int(count)
        except ValueError:
            continue
        frames = stack.split(';')
        if any('solve_setpoint' in f for f in frames):
            groups[keys[0]] += c
        elif any('Publisher.publish' in f for f in frames):
            groups[keys[1]] += c
        elif any('_on_diagnostics_timer' in f for f in frames):
            groups[keys[3]] += c
        elif any('DynamicsNode' in f for f in frames):
            groups[keys[4]] += c
        elif any(f.startswith('spin (') for f in frames):
            groups[keys[2]] += c       # native code, or building the Python message objects
        else:
            groups[keys[5]] += c
            other_leaves[frames[-1]] = other_leaves.get(frames[-1], 0) + c
    top_total = sorted(total_c.items(), key=lambda kv: -kv[1])[:top]
    return dict(samples=n, groups=[dict(group=g, pct=100.0 * c / max(n, 1))
                                   for g, c in groups.items()],
                other_leaves=[dict(func=clean(f), pct=100.0 * c / max(n, 1)) for f, c in
                              sorted(other_leaves.items(), key=lambda kv: -kv[1])[:5]],
                self=[dict(func=clean(f), pct=100.0 * c / n) for f, c in top_self],
                total=[dict(func=clean(f), pct=100.0 * c / n) for f, c in top_total])


def profile_node(args: argparse.Namespace, env: dict, workdir: Path) -> dict:
    out: dict[str, Any] = {}
    which = args.node_profiler
    spy = find_py_spy()
    use_spy = which in ('py-spy', 'both') or (which == 'auto' and spy is not None)
    use_cprof = which in ('cprofile', 'both') or (which == 'auto')
    rate = args.rate
    secs = args.profile_seconds
    out['cprofile_rate'] = args.cprofile_rate
    if use_spy:
        if spy is None:
            out['py_spy_error'] = 'py-spy not installed'
        else:
            log(f'profile: node at {rate:g} Hz for {secs:g} s under py-spy (attached)')
            raw = workdir / 'node_py_spy.txt'
            try:
                r = node_stream.run_stream('node', rate, secs + 2.0, env=env,
                                          executor=args.executor, workdir=workdir,
                                          py_spy=(spy, raw, secs))
                if raw.exists() and raw.stat().st_size:
                    out['py_spy'] = parse_py_spy_raw(raw, args.profile_top)
                    out['py_spy']['run'] = stream_dict(r)
                else:
                    spy_logs = list(workdir.glob('*_spy.log'))
                    out['py_spy_error'] = ('py-spy wrote nothing: ' + (
                        spy_logs[-1].read_text()[-500:] if spy_logs else '?'))
            except Exception as exc:  # noqa: BLE001 - a profile is a bonus, not the benchmark
                out['py_spy_error'] = f'{type(exc).__name__}: {exc}'
    if use_cprof:
        log(f'profile: node at {args.cprofile_rate:g} Hz for {secs:g} s under cProfile')
        prof_file = workdir / 'node.prof'
        try:
            r = node_stream.run_stream('node', args.cprofile_rate, secs, env=env,
                                      executor=args.executor,
                                      workdir=workdir, cprofile_out=prof_file)
            st = pstats.Stats(str(prof_file))
            answered = max(r.answered, 1)
            # The spin loop itself: the C++ executor's call (idle waiting, and taking,
            # deserialising and dispatching in native code: cProfile cannot tell them
            # apart) and rclpy.ok() of node.spin, whose entry predates the SIGUSR1 that
            # enabled the profiler (so cProfile charges it the whole wait). Reported
            # apart, not in the shares.
            def is_loop(k: tuple) -> bool:
                return ('spin_until_future_complete' in k[2] or 'spin_once' in k[2]
                        or (k[2] == 'ok' and k[0].endswith('context.py')))
            wait = sum(v[2] for k, v in st.stats.items() if is_loop(k))
            total_tt = sum(v[2] for k, v in st.stats.items() if not is_loop(k))
            top = sorted(((k, v) for k, v in st.stats.items() if not is_loop(k)),
                         key=lambda kv: -kv[1][2])[:args.profile_top]
            out['cprofile'] = dict(
                answered=r.answered, sent=r.sent, total_calls=st.total_calls / answered,
                total_us=1e6 * total_tt / answered, wait_us=1e6 * wait / answered,
                top=[dict(func=_short(k), calls=v[1] / answered,
                          tottime_us=1e6 * v[2] / answered, cumtime_us=1e6 * v[3] / answered,
                          pct=100.0 * v[2] / total_tt) for k, v in top],
                run=stream_dict(r))
            # the node's own functions, cumulative per answered setpoint
            mine = []
            for name in ('_on_pose', '_on_twist', '_on_accel', '_process', 'solve_setpoint',
                         'solve', 'publish', '_on_diagnostics_timer', '_on_poll_timer',
                         'pose_input', 'rate_input', 'update', 'add', 'unfollowable',
                         'check_limits', 'solved'):
                hits = [(k, v) for k, v in st.stats.items() if k[2] == name
                        and ('flight_sim_dynamics' in k[0] or 'rclpy' in k[0])]
                for k, v in hits:
                    mine.append(dict(func=_short(k), calls=v[1] / answered,
                                     cumtime_us=1e6 * v[3] / answered))
            out['cprofile']['mine'] = sorted(mine, key=lambda d: -d['cumtime_us'])
        except Exception as exc:  # noqa: BLE001
            out['cprofile_error'] = f'{type(exc).__name__}: {exc}'
    return out


