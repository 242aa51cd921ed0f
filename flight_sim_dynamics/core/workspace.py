"""What a machine's workspace survey gives the command line
(``Machine.workspace(model, resolution=..., **options) -> Survey``): ranges of a
coordinate along a line with what ends them, maps of two coordinates at rest
(a cause code per cell, the condition figure over the reachable cells), the
curves and paths to draw over a map, and checks of named motions. Numbers are
numpy; the words (titles, causes) are the machine's; the drawing and the text
are the command line's (``flight-sim-dynamics workspace``), written once for
every machine.

A map has up to two nested sets: *reachable* (the pose can be taken: no cause,
or a cause with ``Cause.reachable``) and *within limits* (no cause at all).
A machine whose reachable poses are exactly those within its limits gives no
cause with ``reachable`` set, and names one set only (:attr:`Survey.sets`).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Callable, Mapping, Sequence

import numpy as np


@dataclass(frozen=True)
class Option:
    """A keyword of a machine's survey function, given on the command line as
    ``--<name with dashes>`` (or ``--<flag>``): ``nargs`` numbers (``'+'``: one or more; 0: a flag)
    of ``type``, or one of ``choices``; ``check(value)`` raises ValueError for a
    bad value (before any computation). Not given: the survey's default.
    """

    name: str
    help: str
    flag: str = ''           # the option's name if not the keyword's ('range' for extent)
    nargs: int | str | None = None
    type: type = float
    metavar: str | tuple[str, ...] | None = None
    choices: tuple[str, ...] = ()
    check: Callable[[Any], None] | None = None


@dataclass(frozen=True)
class Cause:
    """What keeps a cell out of a set: its words (``text``: boundary shares,
    range ends), the entry of the figure's legend it belongs to (``kind``),
    whether the pose is still reachable (beyond a limit only: coloured, dimmed)
    and whether the boundary there is a singularity (drawn thick).
    """

    text: str
    kind: str
    reachable: bool = False
    singular: bool = False


#: Cause code 0 of every map: inside every set.
INSIDE = Cause('', '')


@dataclass(frozen=True)
class End:
    """One end of an interval: where (in the range's unit) and what is just beyond it."""

    value: float
    cause: str


@dataclass(frozen=True)
class Range:
    """The intervals of one coordinate along a line through a pose, in one of
    the survey's sets; the one through the pose first (none through it:
    ``through`` False); no interval: none found.
    """

    name: str                          # e.g. 'surge', 'heave at surge 0'
    unit: str                          # 'm' or 'deg'
    intervals: tuple[tuple[End, End], ...]
    group: str = ''                    # e.g. 'roll +0 deg'
    which: int = 0                     # the set measured (Survey.sets index)
    through: bool = True


@dataclass(frozen=True)
class Curve:
    """A level line of ``field`` (ny, nx) at ``level`` drawn over a map, labelled
    for the legend (curves sharing a label share a colour); ``wide`` for a curve
    that another may cover.
    """

    label: str
    field: np.ndarray
    level: float
    line: str = 'solid'      # 'solid', 'dashed', 'dotted' or 'dashdot'
    wide: bool = False


@dataclass(frozen=True)
class Path:
    """A motion's pose drawn over a map (x, y in the map's units): a line, or a
    marker when it is one point.
    """

    label: str
    x: np.ndarray
    y: np.ndarray


@dataclass
class PlaneMap:
    """Two coordinates on a grid of cell centres (ny rows of y, nx of x), the
    others fixed; display units (m, deg).
    """

    title: str
    names: tuple[str, str]
    units: tuple[str, str]
    x: np.ndarray                    # (nx,)
    y: np.ndarray                    # (ny,)
    cause: np.ndarray                # (ny, nx) int, index into causes (0: inside)
    causes: tuple[Cause, ...]        # code -> Cause; causes[0] is INSIDE
    condition: np.ndarray            # (ny, nx) the condition figure, NaN where unreachable
    near_singular: np.ndarray        # (ny, nx) bool: the status near_singular
    row: int = 0                     # the figure's row of panels
    report: tuple[int, ...] = (0,)   # the sets (Survey.sets indices) reported
    # Areas of sets measured more finely than by counting cells (set index -> m^2
    # or deg^2); a set reported without one is counted on the grid.
    areas: Mapping[int, float] = field(default_factory=dict)
    clipped: bool = False            # the reachable set reaches the map's edge
    curves: tuple[Curve, ...] = ()
    paths: tuple[Path, ...] = ()

    def inside(self, which: int) -> np.ndarray:
        """The cells of set ``which``: 0 reachable, 1 within limits."""
        if which == 0:
            reachable = np.array([c is INSIDE or c.reachable for c in self.causes])
            return reachable[self.cause]
        return self.cause == 0

    @property
    def cell_area(self) -> float:
        return float((self.x[1] - self.x[0]) * (self.y[1] - self.y[0]))

    def area(self, which: int) -> float:
        """The area of set ``which``: measured (``areas``) or counted on the grid."""
        if which in self.areas:
            return float(self.areas[which])
        return float(self.inside(which).sum()) * self.cell_area

    def near_singular_share(self, which: int) -> float:
        """The share of the cells of set ``which`` that are near_singular (NaN: none)."""
        inside = self.inside(which)
        n = int(inside.sum())
        return float((inside & self.near_singular).sum()) / n if n else float('nan')

    def boundary_shares(self, which: int) -> dict[str, float]:
        """Share of the boundary of set ``which`` made by each cause (grid
        estimate: cell edges between a cell inside and one outside, by the
        latter's cause; the edge of the map where the set touches it),
        largest first.
        """
        inside = self.inside(which)
        text = np.array([c.text for c in self.causes], dtype=object)[self.cause]
        dx, dy = self.x[1] - self.x[0], self.y[1] - self.y[0]
        total: dict[str, float] = {}
        for ia, ib, ca, cb, length in ((inside[:, :-1], inside[:, 1:], text[:, :-1],
                                        text[:, 1:], dy),
                                       (inside[:-1], inside[1:], text[:-1], text[1:], dx)):
            for c in np.concatenate([cb[ia & ~ib], ca[ib & ~ia]]):
                total[c] = total.get(c, 0.0) + length
        edge = (inside[0].sum() + inside[-1].sum()) * dx + (inside[:, 0].sum()
                                                             + inside[:, -1].sum()) * dy
        if edge:
            total['edge of the map'] = float(edge)
        s = sum(total.values())
        return {k: v / s for k, v in sorted(total.items(), key=lambda kv: -kv[1])} if s else {}


@dataclass(frozen=True)
class Quantity:
    """A named number of a check: a value or an interval (``value`` of two), in ``unit``."""

    label: str
    value: float | np.ndarray
    unit: str = ''


@dataclass(frozen=True)
class Check:
    """A named motion solved with its rates and accelerations: the count of
    each status and figures of it.
    """

    name: str
    statuses: Mapping[str, int]
    figures: tuple[Quantity, ...] = ()


@dataclass(frozen=True)
class Survey:
    """What ``workspace`` shows of a machine."""

    title: str                       # 'Workspace of ...'
    notes: tuple[str, ...]           # what bounds a pose, thresholds: sentences
    sets: tuple[str, ...]            # the names of set 0 (reachable) and set 1 if any
    condition_label: str             # what the colour is, in words
    condition_name: str              # ... in short (a table's column)
    max_condition: float             # the colour's scale ends at 10x this
    near_singular_rule: str          # when a pose is near_singular, in words
    ranges: tuple[Range, ...]
    planes: tuple[PlaneMap, ...]
    checks: tuple[Check, ...] = ()
    checks_title: str = ''
    caption: str = ''                # how to read the figure


def cell_centres(lo: float, hi: float, n: int) -> np.ndarray:
    """``n`` cell centres spanning [lo, hi]."""
    return lo + (np.arange(n) + 0.5) * ((hi - lo) / n)


def check_extent(extent: Sequence[float]) -> None:
    """ValueError unless ``extent`` is x min < x max, y min < y max, finite."""
    if not (len(extent) == 4 and all(np.isfinite(v) for v in extent)
            and extent[0] < extent[1] and extent[2] < extent[3]):
        raise ValueError('needs MIN < MAX twice (finite), got '
                         + ' '.join(f'{v:g}' for v in extent))


def angles_check(most: int) -> Callable[[Sequence[float]], None]:
    """A check of 1 to ``most`` finite angles in [-180, 180] degrees."""
    def check(values: Sequence[float]) -> None:
        if not (1 <= len(values) <= most and all(np.isfinite(v) and abs(v) <= 180.0
                                                 for v in values)):
            raise ValueError(f'takes 1 to {most} finite angles in [-180, 180] degrees')
    return check


def check_finite(values: Sequence[float]) -> None:
    """ValueError unless every value is finite."""
    if not all(np.isfinite(v) for v in values):
        raise ValueError('needs finite numbers, got ' + ' '.join(f'{v:g}' for v in values))


def bisect_segments(inside: Callable[[np.ndarray], np.ndarray], q_in: np.ndarray,
                    q_out: np.ndarray, iterations: int) -> tuple[np.ndarray, np.ndarray]:
    """Each segment from ``q_in[i]`` (inside a set) to ``q_out[i]`` (outside it)
    halved ``iterations`` times, all segments at once: the final ends.
    ``inside(Q) -> (N,) bools`` tells the poses ``Q`` (N, dof) inside the set.
    """
    q_in, q_out = np.array(q_in, dtype=float), np.array(q_out, dtype=float)
    if len(q_in):
        for _ in range(iterations):
            mid = 0.5 * (q_in + q_out)
            ok = np.asarray(inside(mid), dtype=bool)
            q_in[ok] = mid[ok]
            q_out[~ok] = mid[~ok]
    return q_in, q_out
