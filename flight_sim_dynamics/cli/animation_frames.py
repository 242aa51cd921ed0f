"""What each frame of ``flight-sim-dynamics animate`` draws (no matplotlib
here: the numbers, tested as numbers; cli/animate.py draws them).

The input is what ``solve`` writes (CSV or .npz): ``t``, the leg lengths
``length_a,b,c`` and forces ``force_a,b,c``, and its ``status`` words. It
holds no pose, so the pose of each frame is recovered from its leg lengths
by forward kinematics (:func:`.forward.poses_from_lengths`; a pose is the
one whose lengths are these, to 1e-12 m) unless the file also has
``surge,heave,roll`` columns. The drawn points are then the solver's
(:func:`~flight_sim_dynamics.core.mechanism.mechanism_points` of eq. 5-8,
the rule of the RViz markers too), in the REP-103 simulator base frame.

A row without a solution (status ``unreachable`` or ``invalid_input``, which
``solve`` writes as zeros; or, without a status column, all leg lengths 0)
is not drawn as a machine with zero forces: its frame repeats the last pose
drawn (at first the central configuration) marked unsolved and without
forces, as the markers do.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

import flight_sim_dynamics as fsd

from . import csv_io, npz_io
from .common import CliError
from .forward import LENGTH_COLUMNS, POSE_COLUMNS, poses_from_lengths
from ..core.kinematics import UnreachablePoseError, inverse_geometry
from ..core.mechanism import Point3, mechanism_points
from ..core.vectors import backend

FORCE_COLUMNS = ('force_a', 'force_b', 'force_c')
#: Columns the animation needs (others are ignored).
REQUIRED = ('t',) + LENGTH_COLUMNS + FORCE_COLUMNS
#: Statuses whose rows hold no solution (every number 0).
VOID = (str(fsd.Status.UNREACHABLE), str(fsd.Status.INVALID_INPUT))

_SCALAR = backend(False)


@dataclass(frozen=True)
class Solved:
    """The columns of a solved trajectory the animation reads."""

    path: str
    t: np.ndarray            # (N,) s
    lengths: np.ndarray      # (N, 3) m, L_A, L_B, L_C
    force: np.ndarray        # (N, 3) N, f_A, f_B, f_C
    status: list[str]        # one word per row ('ok' when the file has none)
    pose: np.ndarray | None  # (N, 3) surge, heave, roll if the file has them

    def __len__(self) -> int:
        return len(self.t)


@dataclass(frozen=True)
class Frame:
    """One frame: row ``row`` of the input at time ``t``. ``solved`` False:
    the row has no solution, ``points`` are the last pose drawn (or the
    central configuration), ``force`` None and ``note`` says why and which.
    """

    row: int
    t: float
    status: str
    solved: bool
    points: dict[str, Point3]
    force: tuple[float, float, float] | None
    note: str = ''


def read_solved(path: str) -> Solved:
    """Read the output of ``solve`` (CSV, '-' for standard input, or .npz)."""
    if npz_io.is_npz(path):
        table = npz_io.read_npz(path, required=REQUIRED, optional=POSE_COLUMNS)
        words = npz_io.text_column(path, 'status')
    else:
        data = csv_io.read_bytes(path)
        shown = '<stdin>' if path == '-' else path
        table = csv_io.parse_csv(data, shown, required=REQUIRED, allow_extra=True,
                                 text_columns=('status',))
        words = csv_io.text_column(data, 'status')
    if words is None:
        words = ['ok'] * len(table)
    elif len(words) != len(table):
        raise csv_io.CsvError(f'{len(words)} status words for {len(table)} rows',
                              path=table.path, name='status')
    pose = None
    if all(n in table.names for n in POSE_COLUMNS):
        pose = np.column_stack([table[n] for n in POSE_COLUMNS])
    return Solved(path=table.path, t=table['t'].copy(),
                  lengths=np.column_stack([table[n] for n in LENGTH_COLUMNS]),
                  force=np.column_stack([table[n] for n in FORCE_COLUMNS]),
                  status=list(words), pose=pose)


def frame_rows(t: np.ndarray, fps: float, every: int | None) -> np.ndarray:
    """Indices of the rows drawn: every ``every``-th row, or (None) a stride
    that plays the trajectory at about real time at ``fps`` frames per second
    (from the median time step of ``t``).
    """
    if every is None:
        steps = np.diff(t)
        step = float(np.median(steps)) if steps.size else 0.0
        every = max(1, round(1.0 / (fps * step))) if step > 0 else 1
    return np.arange(0, len(t), every)


def unsolved(solved: Solved) -> np.ndarray:
    """Rows without a solution (status, or every leg length 0)."""
    void = np.isin(np.asarray(solved.status, dtype=object), VOID)
    return void | np.all(solved.lengths == 0.0, axis=1)


def frames(model: fsd.Model, solved: Solved, rows: np.ndarray) -> list[Frame]:
    """The frames of ``rows`` (module docstring: poses, unsolved rows)."""
    rows = np.asarray(rows, dtype=int)
    void = unsolved(solved)[rows]
    if solved.pose is not None:
        poses = [solved.pose[i] for i in rows]
        why = [''] * len(rows)
    else:
        found = poses_from_lengths(model, solved.lengths[rows[~void]])
        it = iter(found)
        poses, why = [], []
        for v in void:
            r = None if v else next(it)
            ok = r is not None and r.status == fsd.Status.OK
            poses.append(r.pose if ok else None)
            why.append('' if v or ok else f'no pose of these leg lengths ({r.status})')
    last = mechanism_points(model, inverse_geometry(model, (0.0, 0.0, 0.0), _SCALAR))
    shown = 'the central configuration'
    out = []
    for k, i in enumerate(rows):
        points = None
        if not void[k] and poses[k] is not None:
            q = tuple(float(v) for v in poses[k])
            try:
                points = mechanism_points(model, inverse_geometry(model, q, _SCALAR))
            except UnreachablePoseError as exc:      # a pose column of the file
                why[k] = f'pose unreachable: {exc}'
        word = solved.status[i]
        if points is None:
            out.append(Frame(int(i), float(solved.t[i]), word, False, last, None,
                             f"{why[k] or 'no solution'}; grey: {shown}"))
        else:
            last, shown = points, 'the last solved pose'
            out.append(Frame(int(i), float(solved.t[i]), word, True, points,
                             tuple(float(f) for f in solved.force[i])))
    return out


def check_options(fps: float, every: int | None, dpi: int) -> None:
    """The rendering options, or a CliError naming the bad one."""
    if not (math.isfinite(fps) and 0 < fps <= 100):
        raise CliError(f'--fps must be a number of frames per second in (0, 100], got {fps:g}')
    if every is not None and every < 1:
        raise CliError(f'--every must be a positive number of rows, got {every}')
    if not 10 <= dpi <= 600:
        raise CliError(f'--dpi must be between 10 and 600, got {dpi}')
