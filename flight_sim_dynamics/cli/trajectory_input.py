"""The input of ``flight-sim-dynamics solve``: a trajectory CSV, with its rate
and acceleration columns given or, like the node does for a planner that
sends poses only, estimated from the poses (causal backward differences of
:class:`~..core.estimator.DerivativeEstimator`, said on standard error).
"""
from __future__ import annotations

import dataclasses
import os
import sys

import numpy as np

from . import csv_io
from .csv_io import TRAJECTORY_COLUMNS
from ..core.model import Model
from ..core.estimator import DerivativeEstimator

POSE_INPUT = ('t', 'surge', 'heave', 'roll')
RATE_COLUMNS = ('surge_rate', 'heave_rate', 'roll_rate')
ACC_COLUMNS = ('surge_acc', 'heave_acc', 'roll_acc')


def _given_groups(data: bytes) -> tuple[bool, bool]:
    """Whether the header gives the rate columns and the acceleration columns.
    A group is estimated only when none of its three columns is named: a
    partial group is read as given, so that the reader reports the missing
    column (with "did you mean") like any other.
    """
    end = data.find(b'\n')
    header = (data if end < 0 else data[:end]).decode('utf-8', 'replace').lstrip('\ufeff')
    names = {n.strip() for n in header.split(',')}
    return tuple(any(n in names for n in group) for group in (RATE_COLUMNS, ACC_COLUMNS))


def estimate_rates(model: Model, table: csv_io.Table, rates: bool, accelerations: bool
                   ) -> csv_io.Table:
    """The table with its missing rate and/or acceleration columns estimated
    the way the node estimates them (:class:`~..core.estimator.DerivativeEstimator`
    with the packaged ``estimator.method`` and ``estimator.max_gap``: causal
    backward differences, a gap restarts from rest).
    """
    estimator = DerivativeEstimator(model.values.get('estimator.method', 'backward2'),
                                    model.values.get('estimator.max_gap', 0.5))
    t, q = table['t'], table.data[:, [table.names.index(n) for n in POSE_INPUT[1:]]]
    qd_in = table.data[:, [table.names.index(n) for n in RATE_COLUMNS]] if rates else None
    qd, qdd = np.empty_like(q), np.empty_like(q)
    for i in range(len(table)):
        given = tuple(qd_in[i]) if qd_in is not None else None
        qd[i], qdd[i] = estimator.update(float(t[i]), tuple(q[i]), given, None)
    added, columns = [], []
    if not rates:
        added += RATE_COLUMNS
        columns.append(qd)
    if not accelerations:
        added += ACC_COLUMNS
        columns.append(qdd)
    return dataclasses.replace(table, names=table.names + tuple(added),
                               data=np.column_stack([table.data, *columns]))



def read_trajectory(path: str | os.PathLike[str], model: Model) -> csv_io.Table:
    """The trajectory table of ``path`` with every column of
    :data:`~.csv_io.TRAJECTORY_COLUMNS`: read, or estimated when the file
    gives poses only (or poses and rates); notes on standard error name what
    was ignored and what was estimated.
    """
    raw = csv_io.read_bytes(path)
    display = '<stdin>' if os.fspath(path) == '-' else os.fspath(path)
    rates, accelerations = _given_groups(raw)
    required = POSE_INPUT + (RATE_COLUMNS if rates else ()) + (ACC_COLUMNS if accelerations
                                                                 else ())
    table = csv_io.parse_csv(raw, display, required=required, skip_extra=True)
    if table.skipped:
        print(f"note: {table.path}: ignoring column{'s' if len(table.skipped) > 1 else ''} "
              f"{', '.join(repr(n) for n in table.skipped)}; solve reads "
              + ','.join(TRAJECTORY_COLUMNS), file=sys.stderr)
    if not (rates and accelerations):
        table = estimate_rates(model, table, rates, accelerations)
        what = ' and '.join(w for w, given in (('rates', rates), ('accelerations',
                                                                      accelerations))
                            if not given)
        method = model.values.get('estimator.method', 'backward2')
        print(f'note: {table.path}: no {what} columns: estimated from the poses as the node '
              f'does ({method} backward differences, causal; the first rows start from '
              'rest)', file=sys.stderr)
        gap = model.values.get('estimator.max_gap', 0.5)
        steps = np.diff(table['t'])
        restarts = int(np.count_nonzero(~((steps > 0.0) & (steps <= gap))))
        if restarts:
            first = int(np.argmax(~((steps > 0.0) & (steps <= gap)))) + 1
            print(f'warning: {table.path}: the estimate starts again from rest at {restarts} '
                  f'row(s), first line {int(table.lines[first])}: t does not increase, or '
                  f'steps by more than estimator.max_gap = {gap:g} s', file=sys.stderr)
    return table
