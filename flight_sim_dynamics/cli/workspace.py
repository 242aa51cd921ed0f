"""The workspace map: ``flight-sim-dynamics workspace [-o map.png]``.

For a few roll angles this samples the (surge, heave) plane on a grid with
:func:`flight_sim_dynamics.solve_batch` (at rest: the map is about geometry,
not motion) and draws, one panel per roll angle,

* the reachable region, coloured by the exact condition number cond(Q) of the
  connectivity matrix (``sol.cond``, SVD; log scale), or by the cheap
  ``kinematic_condition`` with ``--color-by kinematic``;
* the unreachable regions, hatched and coloured by their cause: crank D
  cannot reach the rod (loop D), crank E cannot reach the rod line (loop E),
  and the slider E2 would leave the rod between A3 and G ('E2 on rod': a pose
  that needs E2 off the rod is ``unreachable``, like one where a loop cannot
  close), plus degenerate legs if any;
* the boundary of the reachable set, thick where loop D or E stops closing
  (a crank tangent to its circle: Q is singular there) and thin where E2
  reaches A3 or G (not a singularity);
* the stroke-limit contours of the three legs (stroke ==
  ``limits.stroke_min`` / ``limits.stroke_max``), with the reachable part
  outside the stroke limits dimmed;
* the singular curves: the contour of the kinematic condition (blocks of Q)
  at ``limits.max_kinematic_condition`` (it hugs the loop D / E boundary),
  the curve det(dL/dq) = 0 where the actuator Jacobian is singular (its
  condition blows up there; a contour of the condition at a threshold would
  fall apart into specks on a grid, the sign change of the determinant does
  not), and the cells whose status is ``near_singular``;
* the central configuration and the paper's three motions (eq. 6).

A second row zooms onto the region around the central configuration where
the actuators can actually go (``--zoom``; ``--no-zoom`` leaves it out).

It prints a summary: per roll angle, the reachable surge range at heave 0 and
heave range at surge 0 (all intervals, the one through the central
configuration first) and the same within the stroke limits, each end with the
constraint that ends it (located by bisection to ~1e-12 m); the areas of the
reachable region and of its part within the stroke limits (row by row with
each crossing located by bisection); and how the paper's motions fare.
``--markdown FILE`` writes the same as a markdown page next to the figure.

Roll enters legs B and C only, so the reachable set (loops D and E, slider
E2) is the same for every roll angle, and roll -r gives the same map as +r
with legs B and C exchanged. No rclpy needed.
"""
from __future__ import annotations

import argparse
import io
import math
import os
import shlex
import sys
import time
from dataclasses import dataclass
from typing import Callable, Sequence

import numpy as np

import flight_sim_dynamics as fsd

from ..core.model import Model
from ..core.trajectories import PAPER_EXAMPLES, paper_example, sample_times

#: Default view: the whole reachable set with margin (surge min, max, heave min, max; m).
DEFAULT_RANGE = (-3.0, 1.2, -3.7, 1.5)
#: Default zoom: the part the actuators can reach around the central configuration.
DEFAULT_ZOOM = (-0.8, 1.0, -0.8, 1.0)
#: Default roll angles, degrees (negative ones mirror these: legs B and C exchanged).
DEFAULT_ROLLS = (0.0, 15.0, 30.0, 45.0)
DEFAULT_RESOLUTION = 201

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


# ----------------------------------------------------------------------------
# Sampling
# ----------------------------------------------------------------------------
def at_rest(model: Model, q: np.ndarray) -> fsd.Solution:
    """solve_batch of the poses q (N, 3) at rest."""
    return fsd.solve_batch(model, q, np.zeros_like(q), np.zeros_like(q))


def categorise(sol: fsd.Solution) -> np.ndarray:
    """Category code of each sample of a batch solve (REACHABLE, LOOP_D, ...)."""
    cat = np.full(len(sol.status), REACHABLE, dtype=np.int8)
    for i, (status, detail) in enumerate(zip(sol.status, sol.detail)):
        if status == fsd.Status.UNREACHABLE:
            loop = detail.split(':', 1)[0].removeprefix('loop ')
            cat[i] = _LOOP_CATEGORY.get(loop, DEGENERATE)
        elif status == fsd.Status.INVALID_INPUT:
            cat[i] = INVALID
    return cat


def within_strokes(model: Model, sol: fsd.Solution, cat: np.ndarray) -> np.ndarray:
    """Reachable and every stroke within [stroke_min, stroke_max]."""
    lim = model.limits
    s = np.asarray(sol.stroke)
    return (cat == REACHABLE) & ((s >= lim.stroke_min) & (s <= lim.stroke_max)).all(axis=1)


def failure_cause(model: Model, sol: fsd.Solution, cat: np.ndarray, i: int) -> str:
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
    """One roll angle sampled on a grid of cell centres (ny rows of heave, nx
    columns of surge)."""

    roll_deg: float
    surge: np.ndarray            # (nx,) m
    heave: np.ndarray            # (ny,) m
    category: np.ndarray         # (ny, nx) int8
    within: np.ndarray           # (ny, nx) reachable and strokes within limits
    stroke: np.ndarray           # (ny, nx, 3) m (NaN where unreachable)
    kinematic_condition: np.ndarray   # (ny, nx) (NaN where unreachable)
    jacobian_condition: np.ndarray    # (ny, nx)
    colour: np.ndarray           # (ny, nx) cond(Q) or kinematic condition (NaN unreachable)
    near_singular: np.ndarray    # (ny, nx) status near_singular
    jacobian_det: np.ndarray     # (ny, nx) det(dL/dq): 0 on the actuator-Jacobian singularity


def cell_centres(lo: float, hi: float, n: int) -> np.ndarray:
    return lo + (np.arange(n) + 0.5) * ((hi - lo) / n)


def sample_map(model: Model, roll_deg: float, extent: Sequence[float], resolution: int,
               exact_cond: bool = True) -> RollMap:
    """Solve the grid of ``resolution`` x ``resolution`` cell centres of
    ``extent`` (surge min, max, heave min, max) at roll ``roll_deg``."""
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
    jac = np.where(ok, sol.jacobian_condition, nan)
    if exact_cond:
        colour = np.full(S.size, nan)
        idx = np.flatnonzero(ok)
        if idx.size:
            colour[idx] = at_rest(model, q[idx]).cond
    else:
        colour = kin
    stroke = np.where(ok[:, None], sol.stroke, nan)
    near = np.array([s == fsd.Status.NEAR_SINGULAR for s in sol.status])
    return RollMap(roll_deg=roll_deg, surge=surge, heave=heave, category=cat.reshape(shape),
                   within=within_strokes(model, sol, cat).reshape(shape),
                   stroke=stroke.reshape(shape + (3,)), kinematic_condition=kin.reshape(shape),
                   jacobian_condition=jac.reshape(shape), colour=colour.reshape(shape),
                   near_singular=near.reshape(shape),
                   jacobian_det=np.where(ok, np.linalg.det(sol.jacobian), nan).reshape(shape))


# ----------------------------------------------------------------------------
# Intervals along lines and areas, with the crossings located by bisection
# ----------------------------------------------------------------------------
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

    def contains(self, x: float) -> bool:
        return self.lo <= x <= self.hi

    def text(self, digits: int = 3) -> str:
        return (f'[{self.lo:+.{digits}f} ({self.lo_cause}), '
                f'{self.hi:+.{digits}f} ({self.hi_cause})]')


def classify(model: Model, q: np.ndarray) -> tuple[np.ndarray, Callable[[int], str]]:
    """One solve of the poses q (N, 3): (N, 2) booleans (reachable, within the
    stroke limits) and a function naming what sample i violates."""
    sol = at_rest(model, q)
    cat = categorise(sol)
    inside = np.column_stack([cat == REACHABLE, within_strokes(model, sol, cat)])
    return inside, lambda i: failure_cause(model, sol, cat, i)


def bisect(model: Model, kind: np.ndarray, q_in: np.ndarray, q_out: np.ndarray,
           iterations: int) -> tuple[np.ndarray, np.ndarray, list[str]]:
    """Halve each segment q_in (inside) - q_out (outside) of the set ``kind``
    (0 or 1, see KINDS) ``iterations`` times, all segments in one solve per
    step; returns the final inside and outside ends and what the pose at each
    outside end violates."""
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
    """Samples of one set (``kind``) along rows: ``inside`` (rows, n) at the
    coordinates ``xs`` (n,) of axis ``axis`` of the pose; ``base`` (rows, 3)
    holds the other coordinates of each row. Runs reaching the first or last
    sample end at ``lo_edge`` / ``hi_edge``."""

    kind: int
    xs: np.ndarray
    inside: np.ndarray
    axis: int
    base: np.ndarray
    lo_edge: float
    hi_edge: float


def row_intervals(model: Model, jobs: Sequence[RowJob], iterations: int
                  ) -> list[list[list[Interval]]]:
    """The inside intervals of every row of every job (job -> row -> intervals).
    Each crossing between two neighbouring samples is located by bisection,
    all crossings of all jobs together."""
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
        return next((iv for iv in self.intervals[which] if iv.contains(0.0)), None)


def line_ranges(model: Model, roll_deg: float, extent: Sequence[float], samples: int = 4001,
                iterations: int = 50) -> tuple[LineRanges, LineRanges]:
    """Reachable and within-stroke intervals of surge at heave 0 and of heave at
    surge 0, within ``extent`` (surge min, max, heave min, max), at roll
    ``roll_deg``; ends located to ~1e-12 m."""
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
    """Areas (m^2) of the reachable set and of its part within the stroke
    limits: midpoint rule over the heave rows of the map, each row's length
    exact to ~1e-9 m (crossings by bisection)."""
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


# ----------------------------------------------------------------------------
# The paper's motions
# ----------------------------------------------------------------------------
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
    from collections import Counter

    t = sample_times(rate_hz)
    out = []
    for name in PAPER_EXAMPLES:
        q, qd, qdd = paper_example(name, t)
        sol = fsd.solve_batch(model, q, qd, qdd)
        counts = Counter(str(s) for s in sol.status)
        out.append(MotionReport(
            name=name, statuses=dict(sorted(counts.items())),
            stroke_min=sol.stroke.min(axis=0), stroke_max=sol.stroke.max(axis=0),
            max_kinematic_condition=float(np.max(sol.kinematic_condition)),
            max_jacobian_condition=float(np.max(sol.jacobian_condition)),
            max_cond=float(np.max(sol.cond)), end_pose=q[-1]))
    return out


def general_pose_at_roll(roll_deg: float) -> tuple[float, float] | None:
    """Where the paper's general motion is when its roll passes ``roll_deg``
    (surge, heave; None if it never does): all three coordinates follow the
    same (1 - cos) profile, so the fraction of the way is roll / roll_end."""
    x, y, phi = PAPER_EXAMPLES['general']
    end = 2.0 * math.degrees(phi)
    frac = roll_deg / end if end else math.nan
    if not 0.0 <= frac <= 1.0 + 1e-12:
        return None
    return 2.0 * x * frac, 2.0 * y * frac


# ----------------------------------------------------------------------------
# Results and text
# ----------------------------------------------------------------------------
@dataclass
class RollResult:
    roll_deg: float
    surge_line: LineRanges
    heave_line: LineRanges
    areas: Areas
    overview: RollMap
    zoom: RollMap | None


def _intervals_text(line: LineRanges, which: str, digits: int = 3) -> str:
    ivs = line.intervals[which]
    if not ivs:
        return 'none'
    centre = line.through_centre(which)
    ordered = ([centre] if centre else []) + [iv for iv in ivs if iv is not centre]
    parts = [iv.text(digits) for iv in ordered]
    if centre is None:
        return 'not through 0: ' + '; '.join(parts)
    return parts[0] + ('' if len(parts) == 1 else '; also ' + '; '.join(parts[1:]))


def _fmt_statuses(counts: dict[str, int]) -> str:
    total = sum(counts.values())
    if set(counts) == {'ok'}:
        return f'all {total} ok'
    return ', '.join(f'{n} {s}' for s, n in counts.items()) + f' (of {total})'


def _outside_cause(model: Model, rm: RollMap) -> np.ndarray:
    """Per grid cell, what keeps it out of the within-stroke region: a category
    name, the most violated stroke limit ('stroke A min', ...), or '' if inside."""
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
    """'stroke A min', or 'stroke B, C max' when several legs tie (6 flags:
    A, B, C below the minimum, then above the maximum)."""
    parts = []
    for offset, bound in ((0, 'min'), (3, 'max')):
        legs = [leg for j, leg in enumerate(LEGS) if tied[offset + j]]
        if legs:
            parts.append(f"stroke {', '.join(legs)} {bound}")
    return '; '.join(parts)


def boundary_shares(model: Model, rm: RollMap, which: str) -> dict[str, float]:
    """Share of the boundary of the reachable set (which = KINDS[0]) or of the
    within-stroke region (KINDS[1]) that each constraint makes (grid estimate:
    lengths of the cell edges between an inside and an outside cell, named by
    the outside cell's cause)."""
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


def _shares_text(shares: dict[str, float]) -> str:
    return ', '.join(f'{name} {100 * share:.0f} %' for name, share in shares.items()
                     if share >= 0.005) or 'none'


def findings(results: Sequence[RollResult], motions: Sequence[MotionReport], model: Model
             ) -> list[str]:
    """A few sentences on what bounds the workspace, from the computed figures."""
    out = []
    reach = [r.areas.reachable for r in results]
    if max(reach) - min(reach) <= 1e-9 * max(reach):
        r0 = results[0]
        out.append(f'The reachable set is the same at every roll angle ({reach[0]:.3f} m^2 of '
                   '(surge, heave); roll moves legs B and C only). Its boundary (share of the '
                   'length, grid estimate): '
                   f'{_shares_text(boundary_shares(model, r0.overview, KINDS[0]))}.')
    else:
        out.append('The reachable area depends on roll: '
                   + ', '.join(f'{r.areas.reachable:.3f} m^2 at {r.roll_deg:+g} deg'
                               for r in results) + '.')
    out.append('Within the stroke limits: '
               + ', '.join(f'{r.areas.within:.3f} m^2 at {r.roll_deg:+g} deg' for r in results)
               + '.')
    for r in results:
        rm = r.zoom if r.zoom is not None else r.overview
        out.append(f'At roll {r.roll_deg:+g} deg the region within the stroke limits is bounded '
                   f'by {_shares_text(boundary_shares(model, rm, KINDS[1]))} (share of its '
                   'boundary in the ' + ('zoomed' if r.zoom is not None else 'overview')
                   + ' panel).')
    shares = []
    for r in results:
        rm = r.zoom if r.zoom is not None else r.overview
        n = int(rm.within.sum())
        near = int((rm.within & rm.near_singular).sum())
        shares.append(f'{100 * near / n:.1f} % at {r.roll_deg:+g} deg' if n else
                      f'- at {r.roll_deg:+g} deg')
    out.append('Status near_singular (at rest) within the stroke limits, share of the cells: '
               + ', '.join(shares) + '.')
    bad = [m.name for m in motions if set(m.statuses) != {'ok'}]
    out.append("The paper's three motions are " + ('ok at every sample.' if not bad else
                                                   'not all ok: ' + ', '.join(bad) + '.'))
    return out


def summary_lines(results: Sequence[RollResult], motions: Sequence[MotionReport],
                  model: Model) -> list[str]:
    lim = model.limits
    lines = [f'Stroke limits [{lim.stroke_min:g}, {lim.stroke_max:g}] m; near-singular '
             f'thresholds: kinematic condition {lim.max_kinematic_condition:g}, actuator '
             f'Jacobian condition {lim.max_jacobian_condition:g}. Intervals in m; each end '
             'names the constraint just beyond it; the interval through the central '
             'configuration comes first.', '']
    for r in results:
        lines.append(f'roll {r.roll_deg:+g} deg:')
        for line in (r.surge_line, r.heave_line):
            lines.append(f'  reachable {line.name}: {_intervals_text(line, "reachable")}')
            lines.append(f'    within stroke limits: '
                         f'{_intervals_text(line, "within stroke limits")}')
        clip = ' (clipped by the edge of --range: widen it)' if r.areas.clipped else ''
        lines.append(f'  area: reachable {r.areas.reachable:.3f} m^2{clip}, within stroke limits '
                     f'{r.areas.within:.3f} m^2')
    lines.append('')
    lines.append("The paper's motions (eq. 6, 100 Hz, with their rates and accelerations):")
    for m in motions:
        lines.append(f'  {m.name}: {_fmt_statuses(m.statuses)}; end pose surge '
                     f'{m.end_pose[0]:.3f} m, heave {m.end_pose[1]:.3f} m, roll '
                     f'{math.degrees(m.end_pose[2]):.1f} deg; strokes '
                     + ', '.join(f'{leg} [{lo:+.3f}, {hi:+.3f}]' for leg, lo, hi in
                                 zip(LEGS, m.stroke_min, m.stroke_max))
                     + f' m; max cond(Q) {m.max_cond:.3g}, kinematic condition '
                     f'{m.max_kinematic_condition:.3g}, Jacobian condition '
                     f'{m.max_jacobian_condition:.3g}')
    lines += ['', 'What bounds it:'] + ['  ' + f for f in findings(results, motions, model)]
    return lines


def command_line(argv: Sequence[str] | None) -> str:
    return 'flight-sim-dynamics workspace' + ''.join(' ' + shlex.quote(a) for a in (argv or []))


def markdown(results: Sequence[RollResult], motions: Sequence[MotionReport], model: Model,
             args: argparse.Namespace, image: str | None, md_path: str) -> str:
    lim = model.limits
    out = io.StringIO()
    w = out.write
    w('# Workspace of the flight simulator\n\n')
    w(f'Generated by `{args.command_line}` (grid of {args.resolution} x {args.resolution} '
      'cell centres per panel; interval ends and areas refined by bisection). Do not edit '
      'by hand: rerun the command.\n\n')
    if image:
        rel = os.path.relpath(os.path.abspath(image), os.path.dirname(os.path.abspath(md_path)))
        w(f'![reachable (surge, heave) region per roll angle, coloured by the condition '
          f'number]({rel})\n\n')
    colour = ('the exact condition number cond(Q) of the connectivity matrix Q (SVD)'
              if args.color_by == 'cond' else
              "the kinematic condition (the largest condition number of Q's pivot blocks)")
    w(f'Each panel is one roll angle (the platform at rest); the top row shows the whole '
      'reachable set, the bottom row (if any) zooms onto the central configuration (+). '
      f'Colour: {colour}, log scale; the reachable part outside the stroke limits is dimmed. '
      'Hatched: unreachable, by cause (loop D: crank D cannot reach the rod; loop E: crank E '
      'cannot reach the rod line; E2 off the rod: the slider E2 would leave the rod between '
      'A3 and G, which the solver reports as `unreachable` with `loop E2 on rod`, like a loop '
      'that cannot close). Lines: the boundary of the reachable set, thick where loop D or E '
      'stops closing (a crank tangent to its circle: Q is singular there, so these are '
      'singular curves too) and thin where E2 reaches A3 or G (not singular); the stroke '
      f'limits of legs A, B, C ({lim.stroke_min:g} m dashed, {lim.stroke_max:g} m solid); '
      'the kinematic condition (blocks of Q) at its near-singular threshold '
      f'({lim.max_kinematic_condition:g}, dotted); the singular curve of the actuator '
      'Jacobian, det(dL/dq) = 0 (dash-dotted), inside the reachable set. Red cells: status '
      '`near_singular` (kinematic condition above '
      f'{lim.max_kinematic_condition:g} or actuator-Jacobian condition above '
      f'{lim.max_jacobian_condition:g}). Roll enters legs B and C only, so the reachable set '
      'is the same at every roll angle, and roll -r gives the same map as +r with legs B and '
      'C exchanged.\n\n')
    w('## What bounds the workspace\n\n')
    for sentence in findings(results, motions, model):
        w(f'- {sentence}\n')
    w('\n## Reachable ranges\n\n')
    w('Intervals in m along the two axes through the central configuration; each end names '
      'the constraint just beyond it (`loop D`, `loop E`, `E2 off rod`, `stroke X min/max`, '
      '`edge of --range`). The interval through the central configuration comes first; '
      '"also" lists the other pieces of the same line. Areas in m^2.\n\n')
    w('| roll | reachable surge at heave 0 | within stroke limits | reachable heave at surge 0 '
      '| within stroke limits | reachable area | area within stroke limits |\n')
    w('| ---: | :--- | :--- | :--- | :--- | ---: | ---: |\n')
    for r in results:
        cells = [f'{r.roll_deg:+g} deg']
        for line in (r.surge_line, r.heave_line):
            cells.append(_intervals_text(line, 'reachable'))
            cells.append(_intervals_text(line, 'within stroke limits'))
        clip = ' (clipped)' if r.areas.clipped else ''
        cells += [f'{r.areas.reachable:.3f}{clip}', f'{r.areas.within:.3f}']
        w('| ' + ' | '.join(cells) + ' |\n')
    w('\n## The paper\'s motions\n\n')
    w('Solved at 100 Hz with their rates and accelerations (eq. 6). The general motion follows '
      'the rectilinear path in (surge, heave) while rolling; the star in a panel marks where '
      'it is when its roll equals the panel\'s.\n\n')
    w('| motion | status | end pose (surge m, heave m, roll deg) | strokes A, B, C (m) '
      '| max cond(Q) | max kinematic condition | max Jacobian condition |\n')
    w('| :--- | :--- | :--- | :--- | ---: | ---: | ---: |\n')
    for m in motions:
        strokes = '; '.join(f'{leg} {lo:+.3f} .. {hi:+.3f}' for leg, lo, hi in
                            zip(LEGS, m.stroke_min, m.stroke_max))
        w(f'| {m.name} | {_fmt_statuses(m.statuses)} | {m.end_pose[0]:.3f}, '
          f'{m.end_pose[1]:.3f}, {math.degrees(m.end_pose[2]):.1f} | {strokes} | '
          f'{m.max_cond:.3g} | {m.max_kinematic_condition:.3g} | '
          f'{m.max_jacobian_condition:.3g} |\n')
    return out.getvalue()


# ----------------------------------------------------------------------------
# Figure
# ----------------------------------------------------------------------------
_CAUSE_STYLE = {LOOP_D: dict(color='0.86', hatch='//', label='unreachable: loop D cannot close'),
                LOOP_E: dict(color='0.62', hatch='\\\\', label='unreachable: loop E cannot close'),
                E2_OFF_ROD: dict(color='#f4c58f', hatch='xx',
                                 label='unreachable: slider E2 off the rod (outside A3-G)'),
                DEGENERATE: dict(color='0.3', hatch='', label='unreachable: degenerate leg'),
                INVALID: dict(color='k', hatch='', label='invalid')}
#: Legs A, B, C: colour, line width (B drawn wide under a narrow C: they coincide at roll 0).
_LEG_STYLE = (('#d62728', 1.6), ('#ff7f0e', 3.2), ('#e377c2', 1.3))
_KIN_COLOUR, _JAC_COLOUR, _NEAR_COLOUR = '#17becf', '#ffffff', '#ff0000'
_PATHS = {'vertical': dict(color='#00ff00', linewidth=2.4),
          'rectilinear': dict(color='#1f77ff', linewidth=2.4, linestyle=(0, (3, 1.5)))}
_STAR = dict(marker='*', markersize=13, color='#ffff00', markeredgecolor='k', linestyle='')


def _halo(width: float = 2.8):
    import matplotlib.patheffects as pe

    return [pe.withStroke(linewidth=width, foreground='k')]


def _draw_panel(ax, rm: RollMap, model: Model, norm, cmap, extent, show_paths: bool):
    lim = model.limits
    S, H = np.meshgrid(rm.surge, rm.heave)
    reach = rm.category == REACHABLE
    for code, style in _CAUSE_STYLE.items():
        mask = rm.category == code
        if mask.any():
            ax.contourf(S, H, mask.astype(float), levels=[0.5, 1.5], colors=[style['color']],
                        hatches=[style['hatch']])
    mesh = ax.pcolormesh(S, H, np.ma.masked_invalid(np.where(reach, rm.colour, np.nan)),
                         norm=norm, cmap=cmap, shading='nearest', rasterized=True)
    dim = np.ma.masked_where(~(reach & ~rm.within), np.ones(S.shape))
    ax.pcolormesh(S, H, dim, cmap='Greys', vmin=0.0, vmax=10.0, alpha=0.5, shading='nearest',
                  rasterized=True)
    near = np.ma.masked_where(~rm.near_singular, np.ones(S.shape))
    ax.pcolormesh(S, H, near, cmap='Reds', vmin=0.0, vmax=1.0, alpha=0.8, shading='nearest',
                  rasterized=True)
    # Boundary of the reachable set: where loop D or E stops closing (a crank
    # tangent to its circle: Q singular) drawn apart from where E2 reaches A3 or G.
    singular_side = np.isin(rm.category, (LOOP_D, LOOP_E))
    for other, width in ((singular_side, 2.2), (rm.category == E2_OFF_ROD, 1.0)):
        f = np.where(reach, 0.0, np.where(other, 1.0, np.nan))
        if other.any():
            ax.contour(S, H, f, levels=[0.5], colors='k', linewidths=width)
    for j, (colour, width) in enumerate(_LEG_STYLE):
        for level, style in ((lim.stroke_min, '--'), (lim.stroke_max, '-')):
            ax.contour(S, H, rm.stroke[:, :, j], levels=[level], colors=colour,
                       linewidths=width, linestyles=style)
    with np.errstate(divide='ignore', invalid='ignore'):
        logk = np.log10(np.clip(rm.kinematic_condition, 1e-300, 1e300))
    cs = ax.contour(S, H, logk, levels=[math.log10(lim.max_kinematic_condition)],
                    colors=_KIN_COLOUR, linewidths=1.4, linestyles=':')
    cs.set(path_effects=_halo())
    if np.nanmin(rm.jacobian_det) < 0.0 < np.nanmax(rm.jacobian_det):
        cs = ax.contour(S, H, rm.jacobian_det, levels=[0.0], colors=_JAC_COLOUR,
                        linewidths=1.3, linestyles='-.')
        cs.set(path_effects=_halo())
    ax.plot([0], [0], marker='+', color='k', markersize=11, markeredgewidth=2.4, zorder=6)
    ax.plot([0], [0], marker='+', color='w', markersize=9, markeredgewidth=1.0, zorder=7)
    if show_paths:
        for name, style in _PATHS.items():
            q, _, _ = paper_example(name, sample_times(20.0))
            ax.plot(q[:, 0], q[:, 1], zorder=5, path_effects=_halo(), **style)
    gp = general_pose_at_roll(rm.roll_deg)
    if gp is not None and rm.roll_deg > 0:
        ax.plot([gp[0]], [gp[1]], zorder=8, **_STAR)
    ax.set_xlim(extent[0], extent[1])
    ax.set_ylim(extent[2], extent[3])
    ax.set_aspect('equal')
    ax.grid(True, alpha=0.25, color='0.3', linewidth=0.6)
    return mesh


def _legend_handles(model: Model, categories: set[int]):
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    lim = model.limits
    h = [Patch(facecolor=_CAUSE_STYLE[c]['color'], hatch=_CAUSE_STYLE[c]['hatch'],
               edgecolor='0.35', label=_CAUSE_STYLE[c]['label'])
         for c in sorted(categories) if c != REACHABLE]
    h.append(Patch(facecolor='0.82', edgecolor='0.35',
                   label='reachable, outside the stroke limits (dimmed)'))
    h.append(Line2D([], [], color='k', linewidth=2.2,
                    label='reachable boundary at loop D / E (crank tangent: Q singular)'))
    h.append(Line2D([], [], color='k', linewidth=1.0,
                    label='reachable boundary where E2 reaches A3 or G'))
    for j, leg in enumerate(LEGS):
        colour, width = _LEG_STYLE[j]
        h.append(Line2D([], [], color=colour, linestyle='--', linewidth=width,
                        label=f'stroke {leg} = {lim.stroke_min:g} m (min)'))
        h.append(Line2D([], [], color=colour, linestyle='-', linewidth=width,
                        label=f'stroke {leg} = {lim.stroke_max:g} m (max)'))
    h.append(Line2D([], [], color=_KIN_COLOUR, linestyle=':', linewidth=1.4,
                    path_effects=_halo(),
                    label=f'kinematic condition (blocks of Q) = {lim.max_kinematic_condition:g}'))
    h.append(Line2D([], [], color=_JAC_COLOUR, linestyle='-.', linewidth=1.3,
                    path_effects=_halo(),
                    label='actuator Jacobian singular: det(dL/dq) = 0'))
    h.append(Patch(facecolor=_NEAR_COLOUR, alpha=0.8,
                   label=f'near_singular: kinematic or actuator-Jacobian condition > '
                         f'{max(lim.max_kinematic_condition, lim.max_jacobian_condition):g}'
                   if lim.max_kinematic_condition == lim.max_jacobian_condition else
                   f'near_singular: kinematic condition > {lim.max_kinematic_condition:g} or '
                   f'Jacobian condition > {lim.max_jacobian_condition:g}'))
    h.append(Line2D([], [], color='k', marker='+', linestyle='', markersize=10,
                    markeredgewidth=2, label='central configuration (0, 0)'))
    h.append(Line2D([], [], path_effects=_halo(), label="paper's vertical motion (roll 0)",
                    **_PATHS['vertical']))
    h.append(Line2D([], [], path_effects=_halo(),
                    label="paper's rectilinear motion (roll 0); the general one follows it",
                    **_PATHS['rectilinear']))
    h.append(Line2D([], [], label="paper's general motion when its roll is the panel's",
                    **_STAR))
    return h


def plot(results: Sequence[RollResult], model: Model, path: str, args: argparse.Namespace
         ) -> None:
    import matplotlib
    from matplotlib.colors import LogNorm
    from matplotlib.figure import Figure

    from .csv_io import atomic_output
    from .plotting import output_format

    fmt = output_format(path)
    ncol = len(results)
    maps = [[r.overview for r in results]] + ([[r.zoom for r in results]]
                                              if results[0].zoom is not None else [])
    extents = [args.range, args.zoom][:len(maps)]
    col_w = 3.5
    heights = [col_w * (e[3] - e[2]) / (e[1] - e[0]) for e in extents]
    fig = Figure(figsize=(col_w * ncol + 1.4, sum(heights) + 2.3), dpi=args.dpi,
                 layout='compressed')
    axes = fig.subplots(len(maps), ncol, squeeze=False,
                        gridspec_kw=dict(height_ratios=heights))
    values = np.concatenate([rm.colour[np.isfinite(rm.colour) & (rm.colour > 0)].ravel()
                             for row in maps for rm in row])
    lo = max(1.0, float(values.min())) if values.size else 1.0
    norm = LogNorm(vmin=lo, vmax=max(10.0 * lo, 1e3))
    cmap = matplotlib.colormaps['viridis']
    mesh = None
    categories: set[int] = set()
    for i, (row, extent) in enumerate(zip(maps, extents)):
        for k, rm in enumerate(row):
            ax = axes[i, k]
            mesh = _draw_panel(ax, rm, model, norm, cmap, extent, show_paths=rm.roll_deg == 0)
            categories |= set(np.unique(rm.category).tolist())
            ax.set_title(f'roll {rm.roll_deg:+g} deg' + (' (zoom)' if i else ''),
                         fontsize='medium')
            ax.set_xlabel('surge (m)')
            if k == 0:
                ax.set_ylabel('heave (m)')
    label = ('cond(Q), exact (SVD)' if args.color_by == 'cond' else
             'kinematic condition (blocks of Q)') + ', log scale'
    fig.colorbar(mesh, ax=axes, label=label, extend='max', shrink=0.5, pad=0.01)
    fig.legend(handles=_legend_handles(model, categories), loc='outside lower center',
               ncol=3, fontsize=8, frameon=False)
    fig.suptitle('Workspace of the flight simulator: reachable (surge, heave) of G per roll '
                 'angle, at rest', fontsize='large')
    with atomic_output(path) as f:
        fig.savefig(f, format=fmt, dpi=args.dpi)


# ----------------------------------------------------------------------------
# Command line
# ----------------------------------------------------------------------------
def configure(p: argparse.ArgumentParser) -> None:
    p.add_argument('-o', '--output', default='workspace.png', metavar='IMAGE',
                   help='figure to write; the format follows the extension (default '
                        'workspace.png)')
    p.add_argument('--rolls', type=float, nargs='+', default=list(DEFAULT_ROLLS),
                   metavar='DEG', help='roll angles in degrees, one panel each (default '
                   + ' '.join(f'{r:g}' for r in DEFAULT_ROLLS)
                   + '; -r mirrors +r with legs B and C exchanged)')
    p.add_argument('--resolution', type=int, default=DEFAULT_RESOLUTION, metavar='N',
                   help=f'grid points per axis of each panel (default {DEFAULT_RESOLUTION})')
    p.add_argument('--range', type=float, nargs=4, default=list(DEFAULT_RANGE),
                   metavar=('SURGE_MIN', 'SURGE_MAX', 'HEAVE_MIN', 'HEAVE_MAX'),
                   help='extent of the overview panels, m (default '
                   + ' '.join(f'{v:g}' for v in DEFAULT_RANGE)
                   + ': the whole reachable set with margin); also the extent of the '
                     'reported intervals and areas')
    p.add_argument('--zoom', type=float, nargs=4, default=list(DEFAULT_ZOOM),
                   metavar=('SURGE_MIN', 'SURGE_MAX', 'HEAVE_MIN', 'HEAVE_MAX'),
                   help='extent of the zoomed panels, m (default '
                   + ' '.join(f'{v:g}' for v in DEFAULT_ZOOM) + ')')
    p.add_argument('--no-zoom', action='store_true', help='leave out the zoomed row')
    p.add_argument('--color-by', choices=('cond', 'kinematic'), default='cond',
                   help='colour: exact cond(Q) by SVD (default) or the cheap kinematic '
                        'condition (blocks of Q)')
    p.add_argument('--markdown', metavar='MD', default=None,
                   help='also write the summary as a markdown page (e.g. docs/workspace.md) '
                        'that shows the figure')
    p.add_argument('--params', metavar='YAML', default=None,
                   help='parameter file (default: the packaged parameters)')
    p.add_argument('--dpi', type=int, default=100, help='resolution of raster images '
                   '(default 100)')


def _check(args: argparse.Namespace) -> None:
    from .plotting import output_format

    output_format(args.output)
    if not 20 <= args.resolution <= 2000:
        raise ValueError(f'--resolution must be between 20 and 2000, got {args.resolution}')
    if not 1 <= len(args.rolls) <= 8:
        raise ValueError('--rolls takes 1 to 8 angles')
    if not all(math.isfinite(r) and abs(r) <= 180.0 for r in args.rolls):
        raise ValueError('--rolls must be finite angles in [-180, 180] degrees')
    for name in ('range', 'zoom'):
        e = getattr(args, name)
        if not (all(math.isfinite(v) for v in e) and e[0] < e[1] and e[2] < e[3]):
            raise ValueError(f'--{name} needs SURGE_MIN < SURGE_MAX and HEAVE_MIN < HEAVE_MAX '
                             f'(finite, m), got {" ".join(f"{v:g}" for v in e)}')
    if not 1 <= args.dpi <= 1200:
        raise ValueError(f'--dpi must be between 1 and 1200, got {args.dpi}')
    if args.markdown is not None and not args.markdown.endswith('.md'):
        raise ValueError(f'--markdown {args.markdown}: give a .md file')
    for path in (args.output, args.markdown):     # fail before the computation, not after
        if path is not None and not os.path.isdir(os.path.dirname(os.path.abspath(path))):
            raise ValueError(f"{path}: cannot write: directory '{os.path.dirname(path)}' does "
                             'not exist')


def compute(model: Model, args: argparse.Namespace,
            progress: Callable[[str], None] = lambda s: None) -> list[RollResult]:
    """Sample every roll angle: maps, line intervals, areas."""
    exact = args.color_by == 'cond'
    ext = args.range
    results = []
    for roll in args.rolls:
        progress(f'roll {roll:+g} deg')
        overview = sample_map(model, roll, ext, args.resolution, exact)
        zoom = None if args.no_zoom else sample_map(model, roll, args.zoom, args.resolution,
                                                    exact)
        surge_line, heave_line = line_ranges(model, roll, ext)
        results.append(RollResult(roll_deg=roll, surge_line=surge_line, heave_line=heave_line,
                                  areas=areas(model, overview, ext), overview=overview,
                                  zoom=zoom))
    return results


def run(args: argparse.Namespace) -> int:
    """The ``workspace`` subcommand: figure, summary on stdout, optional markdown."""
    t0 = time.perf_counter()
    _check(args)
    if not hasattr(args, 'command_line'):
        args.command_line = command_line(_argv_of(args))
    try:
        model = fsd.load_model(args.params)
    except fsd.ParameterError as exc:
        raise ValueError(f"--params {args.params or '(packaged defaults)'}: {exc}") from None

    def progress(msg: str) -> None:
        print(f'[workspace] {msg}', file=sys.stderr, flush=True)

    results = compute(model, args, progress)
    motions = paper_motions(model)
    progress(f'plotting {args.output}')
    plot(results, model, args.output, args)
    print('\n'.join(summary_lines(results, motions, model)))
    if args.markdown:
        from .csv_io import atomic_output

        text = markdown(results, motions, model, args, args.output, args.markdown)
        with atomic_output(args.markdown) as f:
            f.write(text.encode())
    progress(f'wrote {args.output}' + (f' and {args.markdown}' if args.markdown else '')
             + f' in {time.perf_counter() - t0:.1f} s')
    return 0


def _argv_of(args: argparse.Namespace) -> list[str]:
    """The options of a run, as a command line (for the markdown page)."""
    out = []
    if args.output != 'workspace.png':
        out += ['-o', args.output]
    if list(args.rolls) != list(DEFAULT_ROLLS):
        out += ['--rolls'] + [f'{r:g}' for r in args.rolls]
    if args.resolution != DEFAULT_RESOLUTION:
        out += ['--resolution', str(args.resolution)]
    if list(args.range) != list(DEFAULT_RANGE):
        out += ['--range'] + [f'{v:g}' for v in args.range]
    if args.no_zoom:
        out.append('--no-zoom')
    elif list(args.zoom) != list(DEFAULT_ZOOM):
        out += ['--zoom'] + [f'{v:g}' for v in args.zoom]
    if args.color_by != 'cond':
        out += ['--color-by', args.color_by]
    if args.markdown:
        out += ['--markdown', args.markdown]
    if args.params:
        out += ['--params', args.params]
    if args.dpi != 100:
        out += ['--dpi', str(args.dpi)]
    return out


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog='flight-sim-dynamics workspace',
        description='Map the reachable (surge, heave) region for several roll angles, '
                    'coloured by cond(Q), with the stroke limits, singular curves and the '
                    'poses where the slider E2 would leave the rod.')
    configure(p)
    return p


def main(argv: Sequence[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    return run(build_parser().parse_args(argv))
