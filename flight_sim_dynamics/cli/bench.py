"""What accuracy costs in time: ``flight-sim-dynamics bench``.

For every packaged scene and for the single-effect variants of the ``full``
model (``full`` without one of its effects, ``full`` with friction) this
measures

* the time of one control cycle, :func:`flight_sim_dynamics.solve` in this
  process (median and 99th percentile over ``--cycles`` calls, states cycled
  through the samples of the four test motions), and the throughput of
  :func:`flight_sim_dynamics.solve_batch` (samples per second);
* the actuator-force error against the ``full`` model (maximum and RMS over
  the samples and the three legs, in N and in % of the full model's peak
  |force| on that motion) on the paper's three motions and on a violent
  motion-cueing-like motion (:func:`violent_motion`);

and the accuracy cost of not receiving accelerations (estimated by the node's
:class:`~flight_sim_dynamics.core.estimator.DerivativeEstimator` from exact twists,
or rates and accelerations both from poses, sampled at 60, 250 and 1000 Hz),
plus the other speed/accuracy trades the solver offers (the ``cond(Q)``
diagnostic, ``solve_batch`` on one sample). It prints the tables and writes
``<out-dir>/scenes.md`` and ``<out-dir>/scenes.png`` (time per cycle against
force error, one point per variant): ``out/`` by default, the repository's
``docs/`` only with ``--update-docs``.

Timing method: the timed cases (variants) are interleaved call by call, in
an order shuffled anew for each state, so background load on a shared
machine hits all of them alike; each call is timed alone with
``time.perf_counter_ns``; the differences to ``full`` are medians of the
differences of per-block medians (blocks of ``--block`` states, paired), with
a sign test over the blocks. No rclpy needed.

The measurements are in :mod:`.bench_cases`, the tables, page and figure in
:mod:`.bench_report`.
"""
from __future__ import annotations

import argparse
import math
import os
import sys
import time
from functools import partial
from typing import Sequence

import numpy as np

import flight_sim_dynamics as fsd

from ..core.motions import TEST_MOTIONS as MOTIONS
from ..core.motions import duration, motion, sample_times
from ..core.estimator import ESTIMATORS
from .bench_cases import (Case, EstimatorCall, Results, batch_throughput, estimator_cases,
                          motion_set, solve_cond, time_cases, variant_errors, variants)
from .bench_report import (additions_table, estimator_table, extras_table, load_average,
                           machine_header, main_table, markdown, plot, rms_table,
                           summary_table, write_text)

#: Where ``--update-docs`` writes: the repository's docs/ (run from its root).
DOCS_DIR = 'docs'
DEFAULT_OUT_DIR = 'out'


def command_line(args: argparse.Namespace) -> list[str]:
    """The options of this run that differ from the defaults (as typed)."""
    defaults = build_parser().parse_args([])
    out = []
    where = (['--out-dir', args.out_dir] if args.out_dir is not None else []) + \
        (['--update-docs'] if args.update_docs else [])
    if args.quick:
        return ['--quick'] + where + (['--no-plot'] if args.no_plot else [])
    out += where
    for name in ('cycles', 'block', 'warmup', 'batch_repeats', 'error_rate'):
        value = getattr(args, name)
        if value != getattr(defaults, name):
            out += ['--' + name.replace('_', '-'), f'{value:g}' if isinstance(value, float)
                    else str(value)]
    if args.no_plot:
        out.append('--no-plot')
    return out


# ----------------------------------------------------------------------------
# Command line
# ----------------------------------------------------------------------------
def configure(p: argparse.ArgumentParser) -> None:
    p.add_argument('--cycles', type=int, default=10_000, metavar='N',
                   help='timed fsd.solve calls per variant (default 10000)')
    p.add_argument('--block', type=int, default=250, metavar='N',
                   help='calls per interleaved timing block (default 250)')
    p.add_argument('--warmup', type=int, default=300, metavar='N',
                   help='untimed calls per variant first (default 300)')
    p.add_argument('--batch-repeats', type=int, default=15, metavar='N',
                   help='solve_batch calls per variant for the throughput (best of; '
                        'default 15)')
    p.add_argument('--error-rate', type=float, default=1000.0, metavar='HZ',
                   help='sampling rate of the motions for the force errors (default 1000)')
    p.add_argument('--quick', action='store_true',
                   help='a fast smoke run (200 cycles, blocks of 50, 200 Hz errors, '
                        '2 batch repeats): numbers only roughly meaningful')
    where = p.add_mutually_exclusive_group()
    where.add_argument('--out-dir', default=None, metavar='DIR',
                       help=f'where scenes.md and scenes.png go (default {DEFAULT_OUT_DIR})')
    where.add_argument('--update-docs', action='store_true',
                       help=f'write them to {DOCS_DIR}/ instead, replacing the committed '
                            'ones (run from the repository root)')
    p.add_argument('--no-plot', action='store_true', help='do not write scenes.png')


def output_dir(args: argparse.Namespace) -> str:
    """The directory the page and the figure go to: ``--out-dir``, ``out`` by
    default, the repository's docs/ with ``--update-docs`` (which must be
    there: the tool never creates a docs/ elsewhere).
    """
    if not args.update_docs:
        return args.out_dir or DEFAULT_OUT_DIR
    if not os.path.isfile(os.path.join(DOCS_DIR, 'scenes.md')):
        raise ValueError(f'--update-docs: no {DOCS_DIR}/scenes.md here; run it from the '
                         'repository root, or give --out-dir')
    return DOCS_DIR


def run(args: argparse.Namespace) -> int:
    """Run the benchmark (the ``bench`` subcommand's handler); returns 0."""
    t_start = time.perf_counter()
    header = machine_header(command_line(args))
    if args.quick:
        args.cycles, args.block, args.warmup = 200, 50, 20
        args.error_rate, args.batch_repeats = 200.0, 2
    for name in ('cycles', 'block', 'batch_repeats'):
        if getattr(args, name) < 1:
            raise ValueError(f'--{name.replace("_", "-")} must be at least 1')
    if args.warmup < 0 or not (math.isfinite(args.error_rate) and args.error_rate >= 10.0):
        raise ValueError('--warmup must be >= 0 and --error-rate >= 10 Hz')
    out_dir = output_dir(args)
    os.makedirs(out_dir, exist_ok=True)

    def progress(msg: str) -> None:
        print(f'[bench] {msg}', file=sys.stderr, flush=True)

    vs = variants()
    full = vs[0].model
    ms = motion_set(full, args.error_rate)
    progress('force errors of the variants')
    errors = {v.key: variant_errors(v, ms) for v in vs}
    progress('estimator errors')
    est = estimator_cases(full, ms.peak)

    # States for the per-cycle timing: the four motions at 100 Hz, plain floats.
    states = []
    for name in MOTIONS:
        q, qd, qdd = motion(name, sample_times(100.0, duration(name)))
        states += [(tuple(a.tolist()), tuple(b.tolist()), tuple(c.tolist()))
                   for a, b, c in zip(q, qd, qdd)]
    batch1 = [tuple(np.array([s], dtype=float) for s in state) for state in states]
    cases = {v.key: Case(partial(fsd.solve, v.model), states) for v in vs}
    extras = {
        'full + cond(Q)': 'full solve and reading `sol.cond`, the exact 2-norm condition '
                          'number of Q (an SVD, computed on first access only)',
        'solve_batch, N = 1': '`fsd.solve_batch(full, ...)` on a batch of one sample',
    }
    cases['full + cond(Q)'] = Case(partial(solve_cond, full), states)
    cases['solve_batch, N = 1'] = Case(partial(fsd.solve_batch, full), batch1)
    for method in ESTIMATORS:
        for twist in (True, False):
            key = f'estimator {method}, {"pose + twist" if twist else "pose only"}'
            extras[key] = (f'`DerivativeEstimator("{method}").update` alone (250 Hz stamps), '
                           + ('accelerations from exact twists' if twist
                              else 'rates and accelerations from poses'))
            cases[key] = Case(EstimatorCall(method, 250.0, twist), states)
    progress(f'timing {len(cases)} cases x {args.cycles} cycles')
    timing = time_cases(cases, args.cycles, args.block, args.warmup, progress)

    progress('solve_batch throughput')
    Q = np.concatenate([ms.q[m] for m in MOTIONS])
    Qd = np.concatenate([ms.qd[m] for m in MOTIONS])
    Qdd = np.concatenate([ms.qdd[m] for m in MOTIONS])
    throughput = batch_throughput({v.key: v.model for v in vs}, Q, Qd, Qdd, args.batch_repeats)
    single = np.array([fsd.solve(full, *s).force for s in states])
    arrays = [np.array([s[i] for s in states]) for i in range(3)]
    max_diff = float(np.abs(fsd.solve_batch(full, *arrays).force - single).max())

    res = Results(variants=vs, timing=timing, throughput=throughput, errors=errors,
                  estimators=est, peaks=ms.peak, error_rate=args.error_rate,
                  cycles=args.cycles, block=args.block, n_states=len(states),
                  batch_samples=len(Q), batch_repeats=args.batch_repeats, extras=extras,
                  max_abs_batch_vs_single=max_diff)
    res.wall_s = time.perf_counter() - t_start
    text = markdown(res, header, load_average())
    md_path = os.path.join(out_dir, 'scenes.md')
    write_text(md_path, text)
    if not args.no_plot:
        plot(res, os.path.join(out_dir, 'scenes.png'))
    print('## Summary\n\n' + summary_table(res) + '\n')
    print(main_table(res) + '\n')
    print(rms_table(res) + '\n')
    print(additions_table(res) + '\n')
    print(estimator_table(res) + '\n')
    print(extras_table(res))
    progress(f'wrote {md_path}' + ('' if args.no_plot else
                                   f' and {os.path.join(out_dir, "scenes.png")}')
             + f' in {time.perf_counter() - t_start:.0f} s')
    return 0


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog='flight-sim-dynamics bench',
        description='Measure solve time per cycle against force error for every scene and '
                    'single-effect variant, and the cost of estimating missing '
                    'accelerations; writes scenes.md and scenes.png (to out/ unless told '
                    'otherwise).')
    configure(p)
    return p


def main(argv: Sequence[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    args = build_parser().parse_args(argv)
    return run(args)


if __name__ == '__main__':
    sys.exit(main())
