"""Workspace sampling at rest, the numerics of ``flight-sim-dynamics workspace``:
grid maps per roll angle by what ends reachability (:func:`sample_map`), intervals
and areas with bisected crossings (:func:`line_ranges`, :func:`areas`), what makes
the boundary (:func:`boundary_shares`) and the paper's motions (eq. 6).
"""
from __future__ import annotations

import math
from collections import Counter
from dataclasses import dataclass
from typing import Callable, Sequence

import numpy as np

from ...core.status import Status
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


def cell_centres(lo: float, hi: float, n: int) -> np.ndarray:
    return lo + (np.arange(n) + 0.5) * ((hi - lo) / n)


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
    q_in, q_out = np.array(q_in, dtype=float), np.array(q_out, dtype=float)
    if len(q_in) == 0:
        return q_in, q_out, []
    rows = np.arange(len(q_in))
    for _ in range(iterations):
        mid = 0.5 * (q_in + q_out)
        inside = classify(model, mid)[0][rows, kind]
        q_in[inside] = mid[inside]
        q_out[~inside] = mid[~inside]
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


def boundary_shares(model: Model, rm: RollMap, which: str) -> dict[str, float]:
    """Share of the boundary of the set ``which`` made by each constraint (grid
    estimate: cell edges between inside and outside, by the outside's cause).
    """
    inside = rm.category == REACHABLE if which == KINDS[0] else rm.within
    cause = _outside_cause(model, rm)
    if which == KINDS[0]:
        cause = np.where(rm.category == REACHABLE, '', cause)
    ds = rm.surge[1] - rm.surge[0]
    dh = rm.heave[1] - rm.heave[0]
    total: dict[str, float] = {}
    pairs = ((inside[:, :-1], inside[:, 1:], cause[:, :-1], cause[:, 1:], dh),
             (inside[:-1], inside[1:], cause[:-1], cause[1:], ds))
    for ia, ib, ca, cb, length in pairs:
        for c in np.concatenate([cb[ia & ~ib], ca[ib & ~ia]]):
            total[c] = total.get(c, 0.0) + length
    edge = (inside[0].sum() + inside[-1].sum()) * ds + (inside[:, 0].sum()
                                                         + inside[:, -1].sum()) * dh
    if edge:
        total['edge of the panel'] = float(edge)
    s = sum(total.values())
    return {k: v / s for k, v in sorted(total.items(), key=lambda kv: -kv[1])} if s else {}


def sample_roll(model: Model, roll_deg: float, extent: Sequence[float],
                zoom: Sequence[float] | None, resolution: int, exact_cond: bool = True
                ) -> RollResult:
    """One roll angle: the maps of ``extent`` and ``zoom``, intervals and areas."""
    overview = sample_map(model, roll_deg, extent, resolution, exact_cond)
    zoomed = None if zoom is None else sample_map(model, roll_deg, zoom, resolution, exact_cond)
    surge_line, heave_line = line_ranges(model, roll_deg, extent)
    return RollResult(roll_deg=roll_deg, surge_line=surge_line, heave_line=heave_line,
                      areas=areas(model, overview, extent), overview=overview, zoom=zoomed)


def near_singular_share(rm: RollMap) -> float:
    """Share of the within-stroke cells that are near_singular (nan: none within)."""
    n = int(rm.within.sum())
    return float((rm.within & rm.near_singular).sum()) / n if n else math.nan
