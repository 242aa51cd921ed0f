"""Sections 1-3 of the performance benchmark: per-cycle solve, batch solve,
CSV end to end (in this process and a subprocess; no rclpy).
"""
from __future__ import annotations

import argparse
import gc
import os
import statistics
import subprocess
import sys
import time
from functools import partial
from pathlib import Path

import numpy as np

import flight_sim_dynamics as fsd
from flight_sim_dynamics.cli import csv_io
from flight_sim_dynamics.cli import main as cli
from flight_sim_dynamics.cli.csv_io import TRAJECTORY_COLUMNS
from flight_sim_dynamics.cli import bench_cases


from .common import (ROOT, ROUND_OFF_N, TARGET_BATCH_PER_S, TARGET_CSV_S, TARGET_QS_US,
                     TARGET_SOLVE_MEDIAN_US, TARGET_SOLVE_P99_US, as_states, at_least, at_most,
                     load1, log, Row, sequence_states, tiled)


# ----------------------------------------------------------------------------
# 1. Per-cycle solve
# ----------------------------------------------------------------------------
def section_solve(args: argparse.Namespace, rows: list[Row]) -> dict:
    log(f'1. per-cycle fsd.solve: {args.cycles} cycles per scene')
    full = fsd.load_model(scene='full')
    qs = fsd.load_model(scene='quasi_static')
    states = as_states(*sequence_states(100.0))
    cases = {'full': bench_cases.Case(partial(fsd.solve, full), states),
             'quasi_static': bench_cases.Case(partial(fsd.solve, qs), states)}
    load_start = load1()
    timing = bench_cases.time_cases(cases, args.cycles, args.block, args.warmup)
    # sol.cond on demand: the first access of the cached property (an SVD)
    n_cond = min(args.cycles, 2000)
    sols = [fsd.solve(full, *states[k % len(states)]) for k in range(n_cond)]
    clock = time.perf_counter_ns
    cond_ns = []
    gc.collect()
    for s in sols:
        t0 = clock()
        s.cond
        cond_ns.append(clock() - t0)
    load_end = load1()
    out = {'n_states': len(states), 'load': (load_start, load_end), 'cond_n': n_cond}
    for name, t in timing.items():
        ns = t.samples
        out[name] = dict(median=t.median_us, p99=t.p99_us, block_p99=t.block_p99_us,
                         p999=float(np.percentile(ns, 99.9)) / 1e3,
                         max=float(ns.max()) / 1e3, min=float(ns.min()) / 1e3,
                         mean=float(ns.mean()) / 1e3, n=int(ns.size))
    c = np.array(cond_ns, dtype=float) / 1e3
    out['cond'] = dict(median=float(np.median(c)), p99=float(np.percentile(c, 99)))
    f, q = out['full'], out['quasi_static']
    rows.append(Row('1', '`fsd.solve` full, median', f'{f["median"]:.0f} us',
                    f'<= {TARGET_SOLVE_MEDIAN_US:g} us',
                    at_most(f['median'], TARGET_SOLVE_MEDIAN_US, 'us', '{:.0f}'), load_end))
    rows.append(Row('1', '`fsd.solve` full, p99', f'{f["p99"]:.0f} us '
                    f'(typical block {f["block_p99"]:.0f})', f'<= {TARGET_SOLVE_P99_US:g} us',
                    at_most(f['p99'], TARGET_SOLVE_P99_US, 'us', '{:.0f}'), load_end))
    rows.append(Row('1', '`fsd.solve` quasi_static, median', f'{q["median"]:.0f} us '
                    f'(p99 {q["p99"]:.0f})', f'<= {TARGET_QS_US:g} us',
                    at_most(q['median'], TARGET_QS_US, 'us', '{:.0f}'), load_end))
    rows.append(Row('1', '`sol.cond` on demand (SVD), median', f'{out["cond"]["median"]:.0f} us',
                    'off the per-cycle path', 'met: on demand only (the node: once per '
                    'diagnostics period)', load_end))
    return out


# ----------------------------------------------------------------------------
# 2. solve_batch
# ----------------------------------------------------------------------------
def section_batch(args: argparse.Namespace, rows: list[Row]) -> dict:
    n = args.batch_n
    log(f'2. solve_batch: N = {n}, {args.batch_repeats} calls; agreement on {args.agree_n}')
    full = fsd.load_model(scene='full')
    Q, Qd, Qdd = tiled(sequence_states(1000.0), n)
    fsd.solve_batch(full, Q[:1000], Qd[:1000], Qdd[:1000])        # warm-up
    times = []
    for _ in range(args.batch_repeats):
        gc.collect()
        t0 = time.perf_counter()
        fsd.solve_batch(full, Q, Qd, Qdd)
        times.append(time.perf_counter() - t0)
    best, med = n / min(times), n / statistics.median(times)
    # agreement: every field of solve_batch against fsd.solve, sample by sample
    m = args.agree_n
    q, qd, qdd = sequence_states(1000.0)
    idx = np.linspace(0, len(q) - 1, m).round().astype(int)
    b = fsd.solve_batch(full, q[idx], qd[idx], qdd[idx])
    diffs = {name: 0.0 for name in ('force', 'length', 'rate', 'acceleration',
                                    'joint_rates', 'joint_accelerations')}
    status_mismatch = 0
    for j, k in enumerate(idx):
        s = fsd.solve(full, q[k], qd[k], qdd[k])
        for name in diffs:
            d = float(np.max(np.abs(np.asarray(getattr(s, name)) - getattr(b, name)[j])))
            diffs[name] = max(diffs[name], d)
        status_mismatch += str(s.status) != str(b.status[j])
    peak = float(np.abs(b.force).max())
    load = load1()
    out = dict(n=n, times=times, best=best, median=med, agree_n=m, diffs=diffs, peak=peak,
               status_mismatch=status_mismatch, load=load)
    rows.append(Row('2', f'`solve_batch` throughput, N = {n:,}',
                    f'{best / 1e3:.0f} k samples/s (median {med / 1e3:.0f} k)',
                    f'>= {TARGET_BATCH_PER_S / 1e3:.0f} k samples/s',
                    at_least(best, TARGET_BATCH_PER_S, 'samples/s', '{:,.0f}'), load))
    ok = diffs['force'] <= ROUND_OFF_N and status_mismatch == 0
    rows.append(Row('2', f'batch vs per-cycle, max abs force difference ({m} samples)',
                    f'{diffs["force"]:.1e} N (peak force {peak:.0f} N)',
                    f'round-off (<= {ROUND_OFF_N:g} N)',
                    'met' if ok else f'MISSED: {diffs["force"]:.1e} N, '
                    f'{status_mismatch} status mismatches', load))
    return out


# ----------------------------------------------------------------------------
# 3. CSV end to end
# ----------------------------------------------------------------------------
def section_csv(args: argparse.Namespace, rows: list[Row], workdir: Path) -> dict:
    n = args.csv_rows
    log(f'3. CSV end to end: {n} rows, {args.csv_runs} runs')
    q, qd, qdd = tiled(sequence_states(1000.0), n)
    t = np.arange(n) / 1000.0
    src, dst = workdir / 'big.csv', workdir / 'out.csv'
    csv_io.write_csv(src, TRAJECTORY_COLUMNS, np.column_stack([t, q, qd, qdd]))
    env = dict(os.environ)
    env['PYTHONPATH'] = os.pathsep.join(filter(None, [str(ROOT), env.get('PYTHONPATH')]))
    cmd = [sys.executable, '-m', 'flight_sim_dynamics', 'solve', str(src), '-o', str(dst)]
    walls = []
    for _ in range(args.csv_runs):
        dst.unlink(missing_ok=True)
        t0 = time.perf_counter()
        proc = subprocess.run(cmd, cwd=ROOT, env=env, capture_output=True, text=True)
        walls.append(time.perf_counter() - t0)
        if proc.returncode != 0:
            raise RuntimeError(f'solve failed: {proc.stderr}')
    with open(dst, 'rb') as f:
        header = f.readline().decode().strip().split(',')
        out_rows = sum(1 for _ in f)
    cols_out = len([h for h in header if h != 'status'])     # numeric columns written
    # where the time goes: interpreter + imports, then the stages in this process
    t0 = time.perf_counter()
    subprocess.run([sys.executable, '-c', 'import flight_sim_dynamics.cli'], cwd=ROOT, env=env,
                   check=True)
    startup = time.perf_counter() - t0
    model = fsd.load_model()
    t0 = time.perf_counter()
    tab = csv_io.read_csv(str(src), required=TRAJECTORY_COLUMNS)
    t_read = time.perf_counter() - t0
    t0 = time.perf_counter()
    names, data, status = cli.solve_table(model, tab)
    t_solve = time.perf_counter() - t0
    t0 = time.perf_counter()
    csv_io.write_csv(str(dst), names, data, text=('status', status))
    t_write = time.perf_counter() - t0
    load = load1()
    med = statistics.median(walls)
    out = dict(n=n, walls=walls, median=med, rows_out=out_rows, cols_out=cols_out,
               startup=startup,
               read=t_read, solve=t_solve, write=t_write, bytes=src.stat().st_size, load=load)
    rows.append(Row('3', f'{n:,}-row CSV through `flight-sim-dynamics solve`, wall',
                    f'{med:.2f} s (median of {len(walls)})', f'< {TARGET_CSV_S:g} s',
                    at_most(med, TARGET_CSV_S, 's', '{:.2f}'), load))
    return out


