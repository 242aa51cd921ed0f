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
    rows, status = [], []
    initial = (0.0, 0.0, 0.0)
    for lengths in np.column_stack([table[n] for n in LENGTH_COLUMNS]):
        result = fsd.forward_kinematics(model, lengths, initial)
        if result.status != fsd.Status.OK:   # the next row starts again from the centre
            result = fsd.forward_kinematics(model, lengths)
        initial = tuple(result.pose) if result.status == fsd.Status.OK else (0.0, 0.0, 0.0)
        rows.append(result.pose)
        status.append(str(result.status))
    extra = ['t'] if 't' in table.names else []
    data = np.column_stack([table[n] for n in extra] + [np.array(rows)])
    csv_io.write_csv(args.output, tuple(extra) + POSE_COLUMNS, data, text=('status', status))
    bad = sum(s != 'ok' for s in status)
    if bad:
        print(f'warning: {table.path}: {bad} of {len(status)} rows have no pose '
              '(status column)', file=sys.stderr)
    return 0
