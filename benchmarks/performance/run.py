"""Command line of the performance benchmark: ``python -m benchmarks.performance``."""
from __future__ import annotations

import argparse
import json
import math
import shutil
import sys
import tempfile
import time
from pathlib import Path
from typing import Any, Sequence

import numpy as np


from .. import node_stream

from .common import DEFAULT_OUT, DOCS_OUT, ROOT, Row, load1, log, summary_table
from .report import (markdown, speed_reference_us, tree_state)
from .profiles import (profile_node, profile_solver)
from .solve import (section_batch, section_csv, section_solve)
from .node import (section_executors, section_node, section_soak)


# ----------------------------------------------------------------------------
# Command line
# ----------------------------------------------------------------------------
def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog='python -m benchmarks.performance',
        description='Performance benchmark of flight_sim_dynamics against the issue\'s '
                    f'targets: prints a table and writes a markdown report ({DEFAULT_OUT} '
                    'unless told otherwise).')
    where = p.add_mutually_exclusive_group()
    where.add_argument('--out', default=str(DEFAULT_OUT), metavar='MD',
                       help=f'report to write (default {DEFAULT_OUT})')
    where.add_argument('--update-docs', action='store_true',
                       help=f'write the report to {DOCS_OUT.relative_to(ROOT)} (replacing the '
                            'committed one)')
    p.add_argument('--json', default=None, metavar='FILE', help='also write the raw results')
    p.add_argument('--quick', action='store_true',
                   help='a smoke run of a few seconds per section (figures meaningless)')
    p.add_argument('--no-node', action='store_true',
                   help='skip the ROS parts (node, echo, soak, node profile)')
    p.add_argument('--no-soak', action='store_true', help='skip the soak')
    p.add_argument('--cycles', type=int, default=None, help='timed solves per scene (10000)')
    p.add_argument('--block', type=int, default=250, help='calls per timing block (250)')
    p.add_argument('--warmup', type=int, default=300, help='untimed solves per scene first')
    p.add_argument('--batch-n', type=int, default=None, help='solve_batch samples (100000)')
    p.add_argument('--batch-repeats', type=int, default=None, help='solve_batch calls (5)')
    p.add_argument('--agree-n', type=int, default=None,
                   help='samples compared batch vs per-cycle (2000)')
    p.add_argument('--csv-rows', type=int, default=None, help='rows of the CSV (100000)')
    p.add_argument('--csv-runs', type=int, default=None, help='CSV runs, median of (3)')
    p.add_argument('--rate', type=float, default=1000.0, help='node stream rate, Hz (1000)')
    p.add_argument('--node-seconds', type=float, default=None,
                   help='seconds of each of the echo and node streams (60)')
    p.add_argument('--node-rounds', type=int, default=None,
                   help='rounds of (echo, node, node fed by JointTrajectory) at --rate; the '
                        'targets are judged on the round with the least hypervisor steal (3)')
    p.add_argument('--context-rate', type=float, default=200.0,
                   help='also measured when the node does not keep up at --rate (200; 0: no)')
    p.add_argument('--context-seconds', type=float, default=None,
                   help='seconds of the context streams (30)')
    p.add_argument('--compare-seconds', type=float, default=None,
                   help='seconds of the echo (at --rate) and the node (at --context-rate) '
                        'with the other executor, for the executor choice (20; 0: skip)')
    p.add_argument('--soak-minutes', type=float, default=None, help='soak length (10)')
    p.add_argument('--soak-rate', type=float, default=None,
                   help='soak rate, Hz (default: --rate if the node keeps up there, else '
                        '--context-rate)')
    p.add_argument('--soak-sample', type=float, default=None,
                   help='seconds between RSS samples in the soak (10)')
    p.add_argument('--executor', choices=('events', 'single'), default='events',
                   help='executor of the node and of the echo (events)')
    p.add_argument('--domain-id', type=int, default=87, help='ROS_DOMAIN_ID (87)')
    p.add_argument('--profile-solves', type=int, default=None,
                   help='fsd.solve calls under cProfile (3000)')
    p.add_argument('--profile-seconds', type=float, default=None,
                   help='seconds of the node under each profiler (15)')
    p.add_argument('--profile-top', type=int, default=15, help='rows of each profile table')
    p.add_argument('--cprofile-rate', type=float, default=100.0,
                   help='stream rate of the node under cProfile, Hz (100: a rate it sustains '
                        'under the profiler, so the figures are per setpoint, not overload)')
    p.add_argument('--node-profiler', choices=('auto', 'py-spy', 'cprofile', 'both', 'none'),
                   default='auto',
                   help='auto: py-spy (if installed) and cProfile of the node')
    return p


QUICK = dict(cycles=600, block=100, warmup=30, batch_n=5000, batch_repeats=2, agree_n=100,
             csv_rows=5000, csv_runs=1, node_seconds=3.0, node_rounds=1, context_seconds=2.0,
             compare_seconds=2.0,
             soak_minutes=0.25, soak_sample=5.0, profile_solves=200, profile_seconds=3.0)
FULL = dict(cycles=10_000, batch_n=100_000, batch_repeats=5, agree_n=2000, csv_rows=100_000,
            csv_runs=3, node_seconds=60.0, node_rounds=3, context_seconds=30.0,
            compare_seconds=20.0,
            soak_minutes=10.0,
            soak_sample=10.0, profile_solves=3000, profile_seconds=15.0)


def parse_args(argv: Sequence[str]) -> argparse.Namespace:
    """The command line, with the QUICK or FULL defaults filled in."""
    args = build_parser().parse_args(list(argv))
    defaults = QUICK if args.quick else FULL
    for key, value in defaults.items():
        if getattr(args, key, None) is None:
            setattr(args, key, value)
    if args.quick:
        args.warmup = min(args.warmup, QUICK['warmup'])
        args.block = min(args.block, QUICK['block'])
    return args


def main(argv: Sequence[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    args = parse_args(argv)
    started = time.time()
    t_start = time.monotonic()
    rows: list[Row] = []
    res: dict[str, Any] = {'args': vars(args), 'notes': [], 'tree': (tree_state(), ''),
                           'speed': (speed_reference_us(), math.nan)}
    if args.quick:
        res['notes'].append('--quick: a smoke run, the figures are not meaningful')
    workdir = Path(tempfile.mkdtemp(prefix='fsd_perf_'))
    log(f'load average {load1():.2f}; work directory {workdir}')
    try:
        res['solve'] = section_solve(args, rows)
        res['batch'] = section_batch(args, rows)
        res['csv'] = section_csv(args, rows, workdir)
        res['profile_solver'] = profile_solver(args)
        if not args.no_node:
            env = node_stream.ros_env(args.domain_id)
            res['depth'] = node_stream.node_qos_depth()
            res['node'] = section_node(args, rows, env, workdir)
            if args.compare_seconds > 0:
                res['executors'] = section_executors(args, rows, env, workdir, res['node'])
            if args.node_profiler != 'none':
                res['profile_node'] = profile_node(args, env, workdir)
            if not args.no_soak and args.soak_minutes > 0:
                res['soak'] = section_soak(args, rows, env, workdir, res['node'])
                if args.soak_minutes != FULL['soak_minutes'] and not args.quick:
                    res['notes'].append(f'soak shortened to {args.soak_minutes:g} min '
                                        f'(--soak-minutes) to keep the whole run near 20 min')
            else:
                rows.append(Row('5', 'soak', 'skipped (--no-soak)', '-', '-', load1()))
        else:
            rows.append(Row('4', 'node latency', 'skipped (--no-node)', '-', '-', load1()))
            rows.append(Row('5', 'soak', 'skipped (--no-node)', '-', '-', load1()))
    finally:
        shutil.rmtree(workdir, ignore_errors=True)
    wall = time.monotonic() - t_start
    res['tree'] = (res['tree'][0], tree_state())
    res['speed'] = (res['speed'][0], speed_reference_us())
    print(summary_table(rows))
    print(f'# load average {" ".join(f"{x:.2f}" for x in node_stream.load_average())}; '
          f'whole run {wall / 60:.1f} min')
    text = markdown(res, rows, argv, started, wall)
    out = DOCS_OUT if args.update_docs else Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = out.with_name(out.name + '.tmp')
    tmp.write_text(text)
    tmp.replace(out)
    log(f'wrote {out}')
    if args.json:
        def default(o: Any) -> Any:
            if isinstance(o, np.ndarray):
                return o.tolist()
            if isinstance(o, (np.floating, np.integer)):
                return o.item()
            return str(o)
        res_json = {k: v for k, v in res.items()}
        if 'node' in res_json:
            res_json['node'] = {'runs': res['node']['runs']}
        Path(args.json).write_text(json.dumps(dict(rows=[r.__dict__ for r in rows],
                                                   results=res_json), default=default,
                                              indent=1))
    return 0

