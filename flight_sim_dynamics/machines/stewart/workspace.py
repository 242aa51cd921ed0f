"""The hexapod's workspace at rest, the numerics of ``flight-sim-dynamics
workspace --params <hexapod>``: maps of two pose coordinates with the other four
fixed (the surge-heave region at a given sway, roll, pitch and yaw; the
roll-pitch range at home for a given yaw), each cell solved at rest by
:func:`~.solver.solve_batch` and coloured by the actuator Jacobian's condition
(S21); the range of each coordinate alone through home; what bounds them.

A pose is reachable when its solve is not ``unreachable`` or ``invalid_input``
(a leg through its U-joint's singular direction, a degenerate length (S4),
(S5)) and its leg lengths, and its joint angles when their limits are set,
are within the limits (stewart.md, "Actuators, limits, effects"); speed and
force limits do not bound a pose at rest.
"""
from __future__ import annotations

import math
from typing import Sequence

import numpy as np

from ...core.status import Status
from ...core.workspace import (INSIDE, Cause, End, Option, PlaneMap, Range, Survey,
                               angles_check, bisect_segments, cell_centres, check_extent,
                               check_finite)
from .model import StewartModel
from .solver import COORDINATES, StewartSolution, solve_batch

#: Coordinates in radians (shown and given in degrees).
ANGLES = frozenset(range(3, 6))
#: The maps' default extent: this many times the farthest end of the ranges
#: through home of their two coordinates, either side of home.
MARGIN = 1.5
#: Default sway (m), roll, pitch, yaw (deg) of the surge-heave map.
DEFAULT_AT = (0.0, 0.0, 0.0, 0.0)
#: Default yaw angles (deg) of the roll-pitch maps, one map each.
DEFAULT_YAWS = (0.0, 20.0)
#: How far the single-coordinate ranges look from home (m; deg for angles).
LINE_REACH = (1.0, 1.0, 1.0, 90.0, 90.0, 180.0)

# What ends reachability at a sample (its cause code); per leg where it says so.
REACHABLE, UNREACHABLE, SHORT, LONG, U_JOINT, SPHERICAL = range(6)
CAUSES = {UNREACHABLE: 'unreachable', SHORT: 'leg {} at its shortest',
          LONG: 'leg {} at its longest', U_JOINT: 'U-joint {} angle',
          SPHERICAL: 'spherical joint {} angle'}
#: The same, of several legs at once.
CAUSES_OF_LEGS = {SHORT: 'legs {} at their shortest', LONG: 'legs {} at their longest',
                  U_JOINT: 'U-joints {} angles', SPHERICAL: 'spherical joints {} angles'}
#: Legs within this of the limit that stops a pose share it (m, rad).
TIE = 1e-9


def at_rest(model: StewartModel, q: np.ndarray) -> StewartSolution:
    """solve_batch of the poses q (N, 6) at rest."""
    return solve_batch(model, q, np.zeros_like(q), np.zeros_like(q))


def causes(model: StewartModel, sol: StewartSolution) -> tuple[np.ndarray, np.ndarray]:
    """Per sample of a batch solve at rest, what ends reachability: the cause
    code (REACHABLE if nothing; else the first of unreachable, a length limit,
    a joint-angle limit) and the legs at or beyond that limit (bit k: leg k + 1;
    within TIE of it: a symmetric machine's legs reach a limit together).
    """
    lim = model.limits
    n = len(sol.status)
    code, legs = np.full(n, REACHABLE, dtype=np.int8), np.zeros(n, dtype=np.int16)
    checks = [(SHORT, lim.length_min - sol.length), (LONG, sol.length - lim.length_max)]
    if lim.u_joint_max_angle is not None:
        checks.append((U_JOINT, np.abs(sol.joints[..., :2]).max(-1) - lim.u_joint_max_angle))
    if lim.spherical_joint_max_angle is not None:
        checks.append((SPHERICAL, sol.spherical_angles - lim.spherical_joint_max_angle))
    bits = 1 << np.arange(6)
    for cause, excess in reversed(checks):        # the first check wins: set it last
        hit = (excess > 0.0).any(axis=1)
        code[hit] = cause
        legs[hit] = ((excess[hit] > -TIE) * bits).sum(axis=1)
    void = np.isin(sol.status, (Status.UNREACHABLE, Status.INVALID_INPUT))
    code[void], legs[void] = UNREACHABLE, 0
    return code, legs


def cause_text(code: int, legs: int) -> str:
    """The words of a cause ('leg 3 at its longest', 'legs 1, 2 at their shortest')."""
    if code == REACHABLE:
        return 'nothing'
    which = [str(k + 1) for k in range(6) if legs >> k & 1]
    if len(which) > 1:
        return CAUSES_OF_LEGS[code].format(', '.join(which))
    return CAUSES[code].format(*which)


def to_pose(values: Sequence[float], axes: Sequence[int]) -> np.ndarray:
    """Numbers in display units (m, deg) of coordinates ``axes`` in SI (m, rad)."""
    return np.array([math.radians(v) if a in ANGLES else float(v) for v, a in zip(values, axes)])


_KINDS = {UNREACHABLE: 'unreachable (singular U-joint, degenerate leg)',
          SHORT: 'a leg shorter than length_min', LONG: 'a leg longer than length_max',
          U_JOINT: 'a joint angle beyond its limit', SPHERICAL: 'a joint angle beyond its limit'}


def _causes(code: np.ndarray, legs: np.ndarray) -> tuple[np.ndarray, tuple[Cause, ...]]:
    """The cells' codes into the survey's causes (one per cause and legs, in words)."""
    out = np.zeros(code.shape, dtype=np.int16)
    causes = [INSIDE]
    outside = code != REACHABLE
    for c, leg in sorted(set(zip(code[outside].tolist(), legs[outside].tolist()))):
        out[outside & (code == c) & (legs == leg)] = len(causes)
        causes.append(Cause(cause_text(c, leg), _KINDS[c], singular=c == UNREACHABLE))
    return out, tuple(causes)


def sample_plane(model: StewartModel, title: str, axes: tuple[int, int], fixed: np.ndarray,
                 extent: Sequence[float], resolution: int) -> PlaneMap:
    """Solve the ``resolution``-square grid of cell centres of ``extent``
    (x min, max, y min, max; m, deg) in the plane of ``axes`` through ``fixed``.
    """
    x = cell_centres(extent[0], extent[1], resolution)
    y = cell_centres(extent[2], extent[3], resolution)
    X, Y = np.meshgrid(x, y)
    q = np.tile(np.asarray(fixed, dtype=float), (X.size, 1))
    for k, values in zip(axes, (X.ravel(), Y.ravel())):
        q[:, k] = np.radians(values) if k in ANGLES else values
    sol = at_rest(model, q)
    code, legs = causes(model, sol)
    condition = np.where(code == REACHABLE, sol.jacobian_condition, np.nan)
    cell_cause, cell_causes = _causes(code.reshape(X.shape), legs.reshape(X.shape))
    condition = condition.reshape(X.shape)
    with np.errstate(invalid='ignore'):
        near = condition > model.limits.max_jacobian_condition
    return PlaneMap(title=title, names=tuple(COORDINATES[a] for a in axes),
                    units=tuple('deg' if a in ANGLES else 'm' for a in axes), x=x, y=y,
                    cause=cell_cause, causes=cell_causes, condition=condition,
                    near_singular=near)


def surge_heave_map(model: StewartModel, at: Sequence[float], extent: Sequence[float],
                    resolution: int) -> PlaneMap:
    """The surge-heave region at ``at`` = (sway m, roll, pitch, yaw deg)."""
    fixed = np.zeros(6)
    fixed[[1, 3, 4, 5]] = to_pose(at, (1, 3, 4, 5))
    title = (f'surge-heave at sway {at[0]:g} m, roll {at[1]:g}, pitch {at[2]:g}, '
             f'yaw {at[3]:g} deg')
    return sample_plane(model, title, (0, 2), fixed, extent, resolution)


def roll_pitch_map(model: StewartModel, yaw_deg: float, extent: Sequence[float],
                   resolution: int) -> PlaneMap:
    """The roll-pitch range at home's position for a yaw of ``yaw_deg``."""
    fixed = np.zeros(6)
    fixed[5] = math.radians(yaw_deg)
    return sample_plane(model, f'roll-pitch at home, yaw {yaw_deg:g} deg', (3, 4), fixed,
                        extent, resolution)


def line_range(model: StewartModel, axis: int, fixed: np.ndarray | None = None,
               reach: float | None = None, samples: int = 2001, iterations: int = 50
               ) -> tuple[End, End] | None:
    """The reachable range of coordinate ``axis`` alone through ``fixed`` (home
    by default), up to ``reach`` either side (m, deg): its ends, bisected to
    ~1e-12, and their causes; None if ``fixed`` itself is not reachable.
    """
    fixed = np.zeros(6) if fixed is None else np.asarray(fixed, dtype=float)
    reach = LINE_REACH[axis] if reach is None else reach
    scale = math.radians(1.0) if axis in ANGLES else 1.0
    base = float(fixed[axis]) / scale
    ends = []
    for sign in (-1.0, 1.0):
        xs = base + sign * np.linspace(0.0, reach, samples)
        inside = _inside(model, axis, fixed, xs * scale)[0]
        if not inside[0]:
            return None
        out = np.flatnonzero(~inside)
        if not out.size:
            ends.append(End(float(xs[-1]), 'end of the search'))
            continue
        # the crossing in the coordinate's own units (m, deg), as the search's
        (lo,), (hi,) = bisect_segments(
            lambda x: _inside(model, axis, fixed, x[:, 0] * scale)[0],
            [[xs[out[0] - 1]]], [[xs[out[0]]]], iterations)
        _, code, legs = _inside(model, axis, fixed, hi * scale)
        ends.append(End(float(lo[0]), cause_text(int(code[0]), int(legs[0]))))
    return ends[0], ends[1]


def _inside(model: StewartModel, axis: int, fixed: np.ndarray, values: np.ndarray
            ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(reachable, cause code, legs) of ``fixed`` with coordinate ``axis`` at ``values`` (SI)."""
    q = np.tile(fixed, (len(values), 1))
    q[:, axis] = values
    code, legs = causes(model, at_rest(model, q))
    return code == REACHABLE, code, legs


def home_condition(model: StewartModel) -> float:
    """The condition of J at home (S21)."""
    return float(at_rest(model, np.zeros((1, 6))).jacobian_condition[0])


def limits_text(model: StewartModel) -> str:
    """The limits that bound a pose at rest, in words."""
    lim = model.limits
    angles = [f'{name} {math.degrees(value):g} deg' for name, value in
              (('U-joint angles', lim.u_joint_max_angle),
               ('spherical joint angles', lim.spherical_joint_max_angle)) if value is not None]
    return (f'leg lengths in [{lim.length_min:g}, {lim.length_max:g}] m; joint-angle limits: '
            + (', '.join(angles) if angles else 'none set'))


def default_extent(ranges: Sequence[Range], axes: tuple[int, int]) -> tuple[float, ...]:
    """MARGIN times the farthest end of the ranges of ``axes``, either side of
    home (the reach of the search if home is not reachable); angles up to 180 deg.
    """
    out = []
    for k in axes:
        ends = ranges[k].intervals[0] if ranges[k].intervals else None
        far = MARGIN * max(abs(e.value) for e in ends) if ends else LINE_REACH[k]
        far = min(far, 180.0) if k in ANGLES else far
        out += [-far, far]
    return tuple(out)


#: The options of :func:`survey` (``flight-sim-dynamics workspace``).
OPTIONS = (
    Option('extent', 'extent of the surge-heave map, m (default: '
           f'{MARGIN:g} x the ranges through home)', flag='range', nargs=4,
           metavar=('SURGE_MIN', 'SURGE_MAX', 'HEAVE_MIN', 'HEAVE_MAX'), check=check_extent),
    Option('at', 'the pose of the surge-heave map, m and degrees (default '
           + ' '.join(f'{v:g}' for v in DEFAULT_AT) + ')', nargs=4,
           metavar=('SWAY', 'ROLL', 'PITCH', 'YAW'), check=check_finite),
    Option('yaws', 'yaw angles of the roll-pitch maps at home, one map each (default '
           + ' '.join(f'{v:g}' for v in DEFAULT_YAWS) + ')', nargs='+', metavar='DEG',
           check=angles_check(6)),
    Option('orientation_extent', 'extent of the roll-pitch maps, degrees (default: '
           f'{MARGIN:g} x the ranges through home)', flag='orientation_range', nargs=4,
           metavar=('ROLL_MIN', 'ROLL_MAX', 'PITCH_MIN', 'PITCH_MAX'), check=check_extent))


def survey(model: StewartModel, *, resolution: int, extent: Sequence[float] | None = None,
           at: Sequence[float] = DEFAULT_AT, yaws: Sequence[float] = DEFAULT_YAWS,
           orientation_extent: Sequence[float] | None = None) -> Survey:
    """The ranges through home of each coordinate, the surge-heave map at
    ``at`` over ``extent`` and the roll-pitch map of each yaw in ``yaws`` over
    ``orientation_extent`` (:func:`surge_heave_map`, :func:`roll_pitch_map`;
    extents by default :func:`default_extent`).
    """
    ranges = []
    for k, name in enumerate(COORDINATES):
        ends = line_range(model, k)
        ranges.append(Range(name, 'deg' if k in ANGLES else 'm',
                            () if ends is None else (ends,), through=ends is not None))
    extent = default_extent(ranges, (0, 2)) if extent is None else extent
    orientation_extent = (default_extent(ranges, (3, 4)) if orientation_extent is None
                          else orientation_extent)
    planes = (surge_heave_map(model, at, extent, resolution),) + tuple(
        roll_pitch_map(model, yaw, orientation_extent, resolution) for yaw in yaws)
    return Survey(
        title=f'Workspace of {model.name} at rest',
        notes=(f'Reachable at rest: solvable and {limits_text(model)}; condition of the '
               f'actuator Jacobian J at home {home_condition(model):.3g}.',),
        sets=('reachable',), condition_label='condition of the actuator Jacobian J',
        condition_name='condition of J',
        max_condition=model.limits.max_jacobian_condition,
        near_singular_rule=f'condition of J > {model.limits.max_jacobian_condition:g}',
        ranges=tuple(ranges),
        planes=planes)
