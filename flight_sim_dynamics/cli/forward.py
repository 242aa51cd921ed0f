"""``flight-sim-dynamics forward``: the pose (surge, heave, roll) from three
measured leg lengths, or from every row of a CSV of them (forward kinematics,
see :func:`flight_sim_dynamics.forward_kinematics`).
"""
from __future__ import annotations

import argparse
import sys

import numpy as np

import flight_sim_dynamics as fsd

from . import csv_io
from .common import CliError, load_model

LENGTH_COLUMNS = ('length_a', 'length_b', 'length_c')
POSE_COLUMNS = ('surge', 'heave', 'roll')


def configure(p: argparse.ArgumentParser) -> None:
    """The options of ``forward``."""
    p.add_argument('lengths', nargs='*', type=float, metavar='L',
                   help='three leg lengths L_A L_B L_C (m, joint centre to joint centre)')
    p.add_argument('--csv', metavar='CSV', default=None,
                   help="instead: a CSV with columns length_a,length_b,length_c, e.g. the "
                        "output of solve (a column t is copied through, others ignored); "
                        "writes [t,]surge,heave,roll,status to -o")
    p.add_argument('-o', '--output', metavar='CSV', default=None,
                   help="output CSV for --csv ('-' for standard output)")
    p.add_argument('--params', metavar='YAML', default=None,
                   help='parameter file (default: the packaged parameters)')


def poses_from_lengths(model: fsd.Model, lengths: np.ndarray) -> list[fsd.ForwardSolution]:
    """Forward kinematics of every row of ``lengths`` (N, 3: L_A, L_B, L_C),
    each started from the pose of the row before (a trajectory moves
    continuously: the same assembly mode, few iterations); a row that fails
    so, and the row after one without a pose, start from the centre.
    """
    results = []
    initial = (0.0, 0.0, 0.0)
    for row in lengths:
        result = fsd.forward_kinematics(model, row, initial)
        if result.status != fsd.Status.OK and initial != (0.0, 0.0, 0.0):
            result = fsd.forward_kinematics(model, row)
        initial = tuple(result.pose) if result.status == fsd.Status.OK else (0.0, 0.0, 0.0)
        results.append(result)
    return results


def run(args: argparse.Namespace) -> int:
    """Pose from measured leg lengths (safeguarded Newton, see forward_kinematics)."""
    model = load_model(args.params)
    if args.csv is None:
        if len(args.lengths) != 3:
            raise CliError(f'expected three leg lengths L_A L_B L_C, got {len(args.lengths)}')
        result = fsd.forward_kinematics(model, args.lengths)
        surge, heave, roll = (float(v) for v in result.pose)
        print(f'surge={surge!r} heave={heave!r} roll={roll!r} status={result.status} '
              f'residual={result.residual:.3g} iterations={result.iterations}'
              + (f' detail={result.detail!r}' if result.detail else ''))
        return 0 if result.status == fsd.Status.OK else 1
    if args.lengths or args.output is None:
        raise CliError('--csv takes no lengths on the command line, and needs -o OUTPUT')
    table = csv_io.read_csv(args.csv, required=LENGTH_COLUMNS, allow_extra=True,
                            text_columns=('status',))
    results = poses_from_lengths(model, np.column_stack([table[n] for n in LENGTH_COLUMNS]))
    status = [str(r.status) for r in results]
    extra = ['t'] if 't' in table.names else []
    data = np.column_stack([table[n] for n in extra] + [np.array([r.pose for r in results])])
    csv_io.write_csv(args.output, tuple(extra) + POSE_COLUMNS, data, text=('status', status))
    bad = sum(s != 'ok' for s in status)
    if bad:
        print(f'warning: {table.path}: {bad} of {len(status)} rows have no pose '
              '(status column)', file=sys.stderr)
    return 0
