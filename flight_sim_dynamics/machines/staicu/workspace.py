"""Workspace sampling at rest, the numerics of ``flight-sim-dynamics workspace``:
grid maps per roll angle by what ends reachability (:func:`sample_map`), intervals
and areas with bisected crossings (:func:`line_ranges`, :func:`areas`), the
causes that make the boundary, and the paper's motions (eq. 6); :func:`survey`
gives them in the shape every machine's survey has
(:class:`~flight_sim_dynamics.core.workspace.Survey`).
"""
from __future__ import annotations

import math
from collections import Counter
from dataclasses import dataclass
from typing import Callable, Sequence

import numpy as np

from ...core.status import Status
from ...core.workspace import (INSIDE, Cause, Check, Curve, End, Option, Path, PlaneMap,
                               Quantity, Range, Survey, angles_check, bisect_segments,
                               cell_centres, check_extent)
from .model import Model
from .solver import Solution, solve_batch
from .trajectories import PAPER_EXAMPLES, paper_example, sample_times

#: Default view: the whole reachable set with margin (surge min, max, heave min, max; m).
DEFAULT_RANGE = (-3.0, 1.2, -3.7, 1.5)
#: Default zoom: the part the actuators can reach around the central configuration.
DEFAULT_ZOOM = (-0.8, 1.0, -0.8, 1.0)

# Category codes of a grid sample (what ends reachability there).
REACHABLE, LOOP_D, LOOP_E, E2_OFF_ROD, DEGENERATE, INVALID = range(6)
#: solve_batch detail prefix ('loop <X>') -> category.
_LOOP_CATEGORY = {'D': LOOP_D, 'E': LOOP_E, 'E2 on rod': E2_OFF_ROD,
                  'A': DEGENERATE, 'B': DEGENERATE, 'C': DEGENERATE}
#: Short names of the constraints that end an interval.
SHORT_CAUSE = {LOOP_D: 'loop D', LOOP_E: 'loop E', E2_OFF_ROD: 'E2 off rod',
               DEGENERATE: 'degenerate leg', INVALID: 'invalid'}
LEGS = 'ABC'
EDGE = 'edge of --range'


def at_rest(model: Model, q: np.ndarray) -> Solution:
    """solve_batch of the poses q (N, 3) at rest."""
    return solve_batch(model, q, np.zeros_like(q), np.zeros_like(q))


def categorise(sol: Solution) -> np.ndarray:
    """Category code of each sample of a batch solve (REACHABLE, LOOP_D, ...)."""
    cat = np.full(len(sol.status), REACHABLE, dtype=np.int8)
    for i, (status, detail) in enumerate(zip(sol.status, sol.detail)):
        if status == Status.UNREACHABLE:
            loop = detail.split(':', 1)[0].removeprefix('loop ')
            cat[i] = _LOOP_CATEGORY.get(loop, DEGENERATE)
        elif status == Status.INVALID_INPUT:
            cat[i] = INVALID
    return cat


def within_strokes(model: Model, sol: Solution, cat: np.ndarray) -> np.ndarray:
    """Reachable and every stroke within [stroke_min, stroke_max]."""
    lim = model.limits
    s = np.asarray(sol.stroke)
    return (cat == REACHABLE) & ((s >= lim.stroke_min) & (s <= lim.stroke_max)).all(axis=1)


def failure_cause(model: Model, sol: Solution, cat: np.ndarray, i: int) -> str:
    """What a sample violates: a loop, or the stroke limits of which legs."""
    if cat[i] != REACHABLE:
        return SHORT_CAUSE[int(cat[i])]
    lim = model.limits
    out = []
    for j, leg in enumerate(LEGS):
        if sol.stroke[i, j] < lim.stroke_min:
            out.append(f'stroke {leg} min')
        elif sol.stroke[i, j] > lim.stroke_max:
            out.append(f'stroke {leg} max')
    return ', '.join(out) or 'nothing'


@dataclass
class RollMap:
    """One roll angle on a grid of cell centres (ny rows of heave, nx of surge)."""

    roll_deg: float
    surge: np.ndarray            # (nx,) m
    heave: np.ndarray            # (ny,) m
    category: np.ndarray         # (ny, nx) int8
    within: np.ndarray           # (ny, nx) reachable and strokes within limits
    stroke: np.ndarray           # (ny, nx, 3) m (NaN where unreachable)
    kinematic_condition: np.ndarray   # (ny, nx) (NaN where unreachable)
    colour: np.ndarray           # (ny, nx) cond(Q) or kinematic condition (NaN unreachable)
    near_singular: np.ndarray    # (ny, nx) status near_singular
    jacobian_det: np.ndarray     # (ny, nx) det(dL/dq): 0 on the actuator-Jacobian singularity


def sample_map(model: Model, roll_deg: float, extent: Sequence[float], resolution: int,
               exact_cond: bool = True) -> RollMap:
    """Solve the ``resolution``-square grid of cell centres of ``extent``."""
    surge = cell_centres(extent[0], extent[1], resolution)
    heave = cell_centres(extent[2], extent[3], resolution)
    S, H = np.meshgrid(surge, heave)
    q = np.column_stack([S.ravel(), H.ravel(), np.full(S.size, math.radians(roll_deg))])
    sol = at_rest(model, q)
    cat = categorise(sol)
    ok = cat == REACHABLE
    shape = S.shape
    nan = np.nan
    kin = np.where(ok, sol.kinematic_condition, nan)
    if exact_cond:
        colour = np.full(S.size, nan)
        idx = np.flatnonzero(ok)
        if idx.size:
            colour[idx] = at_rest(model, q[idx]).cond
    else:
        colour = kin
    stroke = np.where(ok[:, None], sol.stroke, nan)
    near = np.array([s == Status.NEAR_SINGULAR for s in sol.status])
    return RollMap(roll_deg=roll_deg, surge=surge, heave=heave, category=cat.reshape(shape),
                   within=within_strokes(model, sol, cat).reshape(shape),
                   stroke=stroke.reshape(shape + (3,)), kinematic_condition=kin.reshape(shape),
                   colour=colour.reshape(shape),
                   near_singular=near.reshape(shape),
                   jacobian_det=np.where(ok, np.linalg.det(sol.jacobian), nan).reshape(shape))


#: The two sets measured: index 0 = reachable, 1 = reachable and within the stroke limits.
KINDS = ('reachable', 'within stroke limits')


@dataclass(frozen=True)
class Interval:
    lo: float
    hi: float
    lo_cause: str       # what ends it below (just outside lo)
    hi_cause: str       # ... and above

    @property
    def length(self) -> float:
        return self.hi - self.lo

    def text(self) -> str:
        return f'[{self.lo:+.3f} ({self.lo_cause}), {self.hi:+.3f} ({self.hi_cause})]'


def classify(model: Model, q: np.ndarray) -> tuple[np.ndarray, Callable[[int], str]]:
    """(N, 2) booleans (reachable, within strokes) of the poses q and a
    function naming what sample i violates.
    """
    sol = at_rest(model, q)
    cat = categorise(sol)
    inside = np.column_stack([cat == REACHABLE, within_strokes(model, sol, cat)])
    return inside, lambda i: failure_cause(model, sol, cat, i)


def bisect(model: Model, kind: np.ndarray, q_in: np.ndarray, q_out: np.ndarray,
           iterations: int) -> tuple[np.ndarray, np.ndarray, list[str]]:
    """Bisect each segment q_in (inside) - q_out of the set ``kind`` (KINDS index):
    the final ends and what each outside end violates.
    """
    if len(q_in) == 0:
        return np.array(q_in, dtype=float), np.array(q_out, dtype=float), []
    rows = np.arange(len(q_in))
    q_in, q_out = bisect_segments(lambda q: classify(model, q)[0][rows, kind], q_in, q_out,
                                  iterations)
    _, cause = classify(model, q_out)
    return q_in, q_out, [cause(i) for i in range(len(q_out))]


@dataclass
class RowJob:
    """Samples ``inside`` (rows, n) of the set ``kind`` at ``xs`` along pose
    axis ``axis``, the other coordinates in ``base`` (rows, 3).
    """

    kind: int
    xs: np.ndarray
    inside: np.ndarray
    axis: int
    base: np.ndarray
    lo_edge: float
    hi_edge: float


def row_intervals(model: Model, jobs: Sequence[RowJob], iterations: int
                  ) -> list[list[list[Interval]]]:
    """The inside intervals (job -> row -> intervals), all crossings bisected together."""
    segs = []       # (job index, row of each crossing, enters?, q_in, q_out)
    for j, job in enumerate(jobs):
        inside, xs = job.inside, job.xs
        r_idx, c_idx = np.nonzero(inside[:, :-1] != inside[:, 1:])
        enters = ~inside[r_idx, c_idx]          # outside -> inside going up in x
        q_in = job.base[r_idx].copy()
        q_out = job.base[r_idx].copy()
        q_in[:, job.axis] = np.where(enters, xs[c_idx + 1], xs[c_idx])
        q_out[:, job.axis] = np.where(enters, xs[c_idx], xs[c_idx + 1])
        segs.append((j, r_idx, enters, q_in, q_out))
    q_in = np.concatenate([s[3] for s in segs]) if segs else np.zeros((0, 3))
    q_out = np.concatenate([s[4] for s in segs]) if segs else np.zeros((0, 3))
    kind = np.concatenate([np.full(len(s[1]), jobs[s[0]].kind) for s in segs]).astype(int) \
        if segs else np.zeros(0, dtype=int)
    qi, _, causes = bisect(model, kind, q_in, q_out, iterations)
    out = []
    k = 0
    for j, r_idx, enters, _, _ in segs:
        job = jobs[j]
        per_row: list[list[tuple[float, bool, str]]] = [[] for _ in range(len(job.inside))]
        for m in range(len(r_idx)):
            per_row[r_idx[m]].append((float(qi[k, job.axis]), bool(enters[m]), causes[k]))
            k += 1
        rows = []
        for r, crossings in enumerate(per_row):
            ivs = []
            start = (job.lo_edge, EDGE) if job.inside[r, 0] else None
            for x, enter, cause in sorted(crossings):
                if enter:
                    start = (x, cause)
                elif start is not None:
                    ivs.append(Interval(start[0], x, start[1], cause))
                    start = None
            if start is not None:
                ivs.append(Interval(start[0], job.hi_edge, start[1], EDGE))
            rows.append(ivs)
        out.append(rows)
    return out


@dataclass
class LineRanges:
    """Intervals along one line through the central configuration."""

    name: str           # 'surge at heave 0' / 'heave at surge 0'
    intervals: dict[str, list[Interval]]   # KINDS -> intervals

    def through_centre(self, which: str) -> Interval | None:
        return next((iv for iv in self.intervals[which] if iv.lo <= 0.0 <= iv.hi), None)


def line_ranges(model: Model, roll_deg: float, extent: Sequence[float], samples: int = 4001,
                iterations: int = 50) -> tuple[LineRanges, LineRanges]:
    """Intervals of surge at heave 0 and of heave at surge 0 within ``extent``
    (ends to ~1e-12 m).
    """
    roll = math.radians(roll_deg)
    jobs = []
    for axis, lo, hi in ((0, extent[0], extent[1]), (1, extent[2], extent[3])):
        xs = np.linspace(lo, hi, samples)
        q = np.zeros((samples, 3))
        q[:, axis] = xs
        q[:, 2] = roll
        inside = classify(model, q)[0]
        base = np.array([[0.0, 0.0, roll]])
        for kind in (0, 1):
            jobs.append(RowJob(kind, xs, inside[None, :, kind], axis, base, lo, hi))
    res = row_intervals(model, jobs, iterations)
    return (LineRanges('surge at heave 0', {KINDS[0]: res[0][0], KINDS[1]: res[1][0]}),
            LineRanges('heave at surge 0', {KINDS[0]: res[2][0], KINDS[1]: res[3][0]}))


@dataclass
class Areas:
    reachable: float
    within: float
    clipped: bool       # the reachable set touches the edge of the sampled range


def areas(model: Model, rm: RollMap, extent: Sequence[float], iterations: int = 24) -> Areas:
    """Areas (m^2) of both sets: midpoint rule over the heave rows, each row's
    length by bisection.
    """
    dh = (extent[3] - extent[2]) / len(rm.heave)
    base = np.column_stack([np.zeros(len(rm.heave)), rm.heave,
                            np.full(len(rm.heave), math.radians(rm.roll_deg))])
    jobs = [RowJob(0, rm.surge, rm.category == REACHABLE, 0, base, extent[0], extent[1]),
            RowJob(1, rm.surge, rm.within, 0, base, extent[0], extent[1])]
    reach_rows, within_rows = row_intervals(model, jobs, iterations)
    reach = rm.category == REACHABLE
    clipped = bool(reach[0].any() or reach[-1].any() or reach[:, 0].any() or reach[:, -1].any())
    return Areas(reachable=dh * sum(iv.length for row in reach_rows for iv in row),
                 within=dh * sum(iv.length for row in within_rows for iv in row),
                 clipped=clipped)


@dataclass
class MotionReport:
    name: str
    statuses: dict[str, int]
    stroke_min: np.ndarray     # (3,) per leg, m
    stroke_max: np.ndarray
    max_kinematic_condition: float
    max_jacobian_condition: float
    max_cond: float
    end_pose: np.ndarray       # (3,) surge m, heave m, roll rad at t = 3 s


def paper_motions(model: Model, rate_hz: float = 100.0) -> list[MotionReport]:
    """Solve the paper's three motions (with their rates and accelerations)."""
    t = sample_times(rate_hz)
    out = []
    for name in PAPER_EXAMPLES:
        q, qd, qdd = paper_example(name, t)
        sol = solve_batch(model, q, qd, qdd)
        counts = Counter(str(s) for s in sol.status)
        out.append(MotionReport(
            name=name, statuses=dict(sorted(counts.items())),
            stroke_min=sol.stroke.min(axis=0), stroke_max=sol.stroke.max(axis=0),
            max_kinematic_condition=float(np.max(sol.kinematic_condition)),
            max_jacobian_condition=float(np.max(sol.jacobian_condition)),
            max_cond=float(np.max(sol.cond)), end_pose=q[-1]))
    return out


def general_pose_at_roll(roll_deg: float) -> tuple[float, float] | None:
    """(surge, heave) of the general motion when its roll is ``roll_deg`` (None:
    never); its coordinates share one profile (eq. 6).
    """
    x, y, phi = PAPER_EXAMPLES['general']
    end = 2.0 * math.degrees(phi)
    frac = roll_deg / end if end else math.nan
    if not 0.0 <= frac <= 1.0 + 1e-12:
        return None
    return 2.0 * x * frac, 2.0 * y * frac


@dataclass
class RollResult:
    roll_deg: float
    surge_line: LineRanges
    heave_line: LineRanges
    areas: Areas
    overview: RollMap
    zoom: RollMap | None


def _outside_cause(model: Model, rm: RollMap) -> np.ndarray:
    """Per cell, what keeps it out of the within-stroke region ('' inside)."""
    lim = model.limits
    names = np.array([''] + [SHORT_CAUSE[c] for c in range(1, INVALID + 1)], dtype=object)
    out = names[rm.category]
    with np.errstate(invalid='ignore'):
        below = lim.stroke_min - rm.stroke          # > 0: below the minimum
        above = rm.stroke - lim.stroke_max
    excess = np.nan_to_num(np.concatenate([below, above], axis=-1), nan=-np.inf)  # (ny, nx, 6)
    stroke_out = (rm.category == REACHABLE) & ~rm.within
    worst = excess[stroke_out]
    tied = worst >= worst.max(axis=1, keepdims=True) - 1e-9   # B and C tie at roll 0
    out[stroke_out] = [_limits_label(row) for row in tied]
    return out


def _limits_label(tied: np.ndarray) -> str:
    """'stroke A min', or 'stroke B, C max' for tied legs (flags A, B, C min, then max)."""
    parts = []
    for offset, bound in ((0, 'min'), (3, 'max')):
        legs = [leg for j, leg in enumerate(LEGS) if tied[offset + j]]
        if legs:
            parts.append(f"stroke {', '.join(legs)} {bound}")
    return '; '.join(parts)


def sample_roll(model: Model, roll_deg: float, extent: Sequence[float],
                zoom: Sequence[float] | None, resolution: int, exact_cond: bool = True
                ) -> RollResult:
    """One roll angle: the maps of ``extent`` and ``zoom``, intervals and areas."""
    overview = sample_map(model, roll_deg, extent, resolution, exact_cond)
    zoomed = None if zoom is None else sample_map(model, roll_deg, zoom, resolution, exact_cond)
    surge_line, heave_line = line_ranges(model, roll_deg, extent)
    return RollResult(roll_deg=roll_deg, surge_line=surge_line, heave_line=heave_line,
                      areas=areas(model, overview, extent), overview=overview, zoom=zoomed)


#: Default roll angles, degrees (negative ones mirror these: legs B and C exchanged).
DEFAULT_ROLLS = (0.0, 15.0, 30.0, 45.0)
#: The legend's words of each category (its cause kind) and whether a boundary
#: there is singular (a crank tangent: Q singular).
_KIND = {LOOP_D: ('unreachable: loop D cannot close (crank D cannot reach the rod), outside '
                  'and in the enclosed disk', True),
         LOOP_E: ('unreachable: loop E cannot close', True),
         E2_OFF_ROD: ('unreachable: slider E2 off the rod (outside A3-G)', False),
         DEGENERATE: ('unreachable: degenerate leg', False),
         INVALID: ('invalid', False)}
BEYOND_STROKES = 'reachable, outside the stroke limits (dimmed)'


def _fmt(values: Sequence[float]) -> str:
    return ' '.join(f'{v:g}' for v in values)


def _check_rolls(rolls: Sequence[float]) -> None:
    if not 1 <= len(rolls) <= 8:
        raise ValueError('takes 1 to 8 angles')
    angles_check(8)(rolls)


#: The options of :func:`survey` (``flight-sim-dynamics workspace``).
OPTIONS = (
    Option('rolls', 'roll angles in degrees, one panel each (default '
           f'{_fmt(DEFAULT_ROLLS)})', nargs='+', metavar='DEG', check=_check_rolls),
    Option('extent', 'extent of the overview panels, intervals and areas, m (default '
           f'{_fmt(DEFAULT_RANGE)})', flag='range', nargs=4,
           metavar=('SURGE_MIN', 'SURGE_MAX', 'HEAVE_MIN', 'HEAVE_MAX'), check=check_extent),
    Option('zoom', f'extent of the zoomed panels, m (default {_fmt(DEFAULT_ZOOM)})', nargs=4,
           metavar=('SURGE_MIN', 'SURGE_MAX', 'HEAVE_MIN', 'HEAVE_MAX'), check=check_extent),
    Option('no_zoom', 'leave out the zoomed row', nargs=0),
    Option('color_by', 'colour: exact cond(Q) (default) or the kinematic condition',
           type=str, choices=('cond', 'kinematic')))


def _causes(model: Model, rm: RollMap) -> tuple[np.ndarray, tuple[Cause, ...]]:
    """Per cell the code of what keeps it out of the within-stroke region, and the causes."""
    words = _outside_cause(model, rm)
    causes = [INSIDE] + [Cause(SHORT_CAUSE[c], _KIND[c][0], singular=_KIND[c][1])
                         for c in range(1, INVALID + 1)]
    code = np.where(rm.category == REACHABLE, 0, rm.category).astype(np.int16)
    beyond = (rm.category == REACHABLE) & ~rm.within
    for text in sorted(set(words[beyond].tolist())):
        code[beyond & (words == text)] = len(causes)
        causes.append(Cause(text, BEYOND_STROKES, reachable=True))
    return code, tuple(causes)


def _curves(model: Model, rm: RollMap) -> tuple[Curve, ...]:
    """Stroke limits per leg, the kinematic condition's threshold, det(dL/dq) = 0."""
    lim = model.limits
    curves = []
    for j, leg in enumerate(LEGS):
        label = f'stroke {leg} = {lim.stroke_min:g} m (dashed), {lim.stroke_max:g} m'
        curves += [Curve(label, rm.stroke[:, :, j], lim.stroke_min, 'dashed', wide=leg == 'B'),
                   Curve(label, rm.stroke[:, :, j], lim.stroke_max, 'solid', wide=leg == 'B')]
    with np.errstate(divide='ignore', invalid='ignore'):
        logk = np.log10(np.clip(rm.kinematic_condition, 1e-300, 1e300))
    curves.append(Curve(f'kinematic condition (blocks of Q) = {lim.max_kinematic_condition:g}',
                        logk, math.log10(lim.max_kinematic_condition), 'dotted'))
    if np.nanmin(rm.jacobian_det) < 0.0 < np.nanmax(rm.jacobian_det):
        curves.append(Curve('actuator Jacobian singular: det(dL/dq) = 0', rm.jacobian_det, 0.0,
                            'dashdot'))
    return tuple(curves)


def _paths(roll_deg: float) -> tuple[Path, ...]:
    """The paper's vertical and rectilinear motions at roll 0; the general one's
    pose at the panel's roll (a star).
    """
    paths = []
    if roll_deg == 0.0:
        for name, label in (('vertical', "the paper's vertical motion"),
                            ('rectilinear', "the paper's rectilinear motion (= general at "
                                            'roll 0)')):
            q, _, _ = paper_example(name, sample_times(20.0))
            paths.append(Path(label, q[:, 0], q[:, 1]))
    gp = general_pose_at_roll(roll_deg)
    if gp is not None and roll_deg > 0:
        paths.append(Path("the paper's general motion at the panel's roll",
                          np.array([gp[0]]), np.array([gp[1]])))
    return tuple(paths)


def _plane(model: Model, rm: RollMap, zoomed: bool, report: tuple[int, ...],
           area: Areas | None) -> PlaneMap:
    code, causes = _causes(model, rm)
    return PlaneMap(
        title=f'roll {rm.roll_deg:+g} deg' + (' (zoom)' if zoomed else ''),
        names=('surge', 'heave'), units=('m', 'm'), x=rm.surge, y=rm.heave, cause=code,
        causes=causes, condition=rm.colour, near_singular=rm.near_singular, row=int(zoomed),
        report=report, areas={} if area is None else {0: area.reachable, 1: area.within},
        clipped=bool(area is not None and area.clipped), curves=_curves(model, rm),
        paths=_paths(rm.roll_deg))


def _ranges(line: LineRanges, group: str) -> tuple[Range, ...]:
    out = []
    for which, kind in enumerate(KINDS):
        centre = line.through_centre(kind)
        ivs = ([centre] if centre else []) + [iv for iv in line.intervals[kind]
                                              if iv is not centre]
        out.append(Range(line.name, 'm', tuple((End(iv.lo, iv.lo_cause), End(iv.hi, iv.hi_cause))
                                               for iv in ivs), group, which,
                         through=centre is not None))
    return tuple(out)


def _check(m: MotionReport) -> Check:
    figures = [Quantity('end surge', float(m.end_pose[0]), 'm'),
               Quantity('end heave', float(m.end_pose[1]), 'm'),
               Quantity('end roll', math.degrees(float(m.end_pose[2])), 'deg')]
    figures += [Quantity(f'stroke {leg}', np.array([lo, hi]), 'm')
                for leg, lo, hi in zip(LEGS, m.stroke_min, m.stroke_max)]
    figures += [Quantity('max cond(Q)', m.max_cond),
                Quantity('max kinematic condition', m.max_kinematic_condition),
                Quantity('max Jacobian condition', m.max_jacobian_condition)]
    return Check(m.name, m.statuses, tuple(figures))


def survey(model: Model, *, resolution: int, rolls: Sequence[float] = DEFAULT_ROLLS,
           extent: Sequence[float] = DEFAULT_RANGE, zoom: Sequence[float] = DEFAULT_ZOOM,
           no_zoom: bool = False, color_by: str = 'cond') -> Survey:
    """Per roll angle the (surge, heave) panel of ``extent`` (reachable set,
    refined areas) and, unless ``no_zoom``, of ``zoom`` (within the stroke
    limits); the ranges of surge and heave through the central configuration;
    the paper's three motions (eq. 6). Colour: cond(Q) (``color_by='cond'``)
    or the kinematic condition.
    """
    if color_by not in ('cond', 'kinematic'):
        raise ValueError(f"color_by is 'cond' or 'kinematic', got {color_by!r}")
    lim = model.limits
    planes, ranges = [], []
    for roll in rolls:
        r = sample_roll(model, roll, extent, None if no_zoom else zoom, resolution,
                        color_by == 'cond')
        group = f'roll {roll:+g} deg'
        ranges += _ranges(r.surge_line, group) + _ranges(r.heave_line, group)
        planes.append(_plane(model, r.overview, False, (0,) if r.zoom else (0, 1), r.areas))
        if r.zoom is not None:
            planes.append(_plane(model, r.zoom, True, (1,), None))
    planes.sort(key=lambda p: p.row)
    colour = 'cond(Q) (SVD)' if color_by == 'cond' else 'the kinematic condition'
    caption = (f'One panel per roll angle, at rest; the bottom row (if any) zooms onto the '
               f'central configuration (+). Colour: {colour}, log scale; dimmed: outside the '
               f'stroke limits ({lim.stroke_min:g} m dashed, {lim.stroke_max:g} m solid); '
               'hatched: unreachable, by cause. Roll enters legs B and C only: the reachable '
               'set is the same at every roll angle.')
    return Survey(
        title='Workspace of the flight simulator: reachable (surge, heave) of G per roll '
              'angle, at rest',
        notes=(f'Stroke limits [{lim.stroke_min:g}, {lim.stroke_max:g}] m; near-singular '
               f'thresholds: kinematic condition {lim.max_kinematic_condition:g}, actuator '
               f'Jacobian condition {lim.max_jacobian_condition:g}.',),
        sets=KINDS,
        condition_label=('cond(Q), exact (SVD)' if color_by == 'cond'
                         else 'kinematic condition (blocks of Q)'),
        condition_name='cond(Q)' if color_by == 'cond' else 'kinematic condition',
        max_condition=lim.max_kinematic_condition,
        near_singular_rule=(f'kinematic condition > {lim.max_kinematic_condition:g} or '
                            f'Jacobian condition > {lim.max_jacobian_condition:g}'),
        ranges=tuple(ranges), planes=tuple(planes),
        checks=tuple(_check(m) for m in paper_motions(model)),
        checks_title="The paper's motions (eq. 6, 100 Hz, with their rates and accelerations)",
        caption=caption)
