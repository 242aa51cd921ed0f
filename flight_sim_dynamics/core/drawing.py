"""What a viewer draws of a machine (``animate``, RViz markers), one shape for
every machine: named points of a pose in the base frame (REP-103: x forward,
y left, z up; m), the line parts between them, the flat plates through them,
and which parts make each actuated leg. A machine gives it for a model
(:attr:`flight_sim_dynamics.core.machine.Machine.drawing`).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Mapping, Sequence

Point3 = tuple[float, float, float]


@dataclass(frozen=True)
class PartStyle:
    """How a line part looks; ``colour`` None: its leg's colour."""

    colour: str | None = None
    width: float = 3.0
    linestyle: str = '-'


@dataclass(frozen=True)
class View:
    """One view of ``animate``: a projection on (``axis``, z), ``axis`` 0 (x)
    or 1 (y), or ``axis`` None for a 3-D view.
    """

    title: str
    axis: int | None
    label: str = ''


@dataclass(frozen=True)
class Drawing:
    """One machine's model as drawn; :attr:`points` of a pose q (``len(q)`` =
    the machine's dof) raises ValueError for a pose it cannot draw.
    """

    points: Callable[[Sequence[float]], dict[str, Point3]]   # q -> every point, base frame
    joints: tuple[str, ...]                     # the points drawn as joint centres
    segments: Mapping[str, tuple[str, str]]     # line part -> (first point, second point)
    legs: tuple[tuple[str, ...], ...]           # per leg (order of forces): its line parts
    leg_names: tuple[str, ...]                  # per leg: the short name a view shows ('A', '1')
    plates: Mapping[str, tuple[str, ...]]       # flat part -> its corners, going round
    styles: Mapping[str, PartStyle]             # line part -> its look
    legend: tuple[tuple[str, str], ...]         # (label, part) of the parts a legend names
    views: tuple[View, ...]                     # animate's views
    plate_colours: Mapping[str, str]            # flat part -> its colour
    home: str = 'home'                          # what q = 0 is called ('the central ...')
    #: the platform's home position in the drawing's frame: the origin of the
    #: setpoints' frame (docs/node.md "Frame"), where the RViz markers put theirs
    origin: Point3 = (0.0, 0.0, 0.0)

    def leg_of(self, part: str) -> int | None:
        """The leg (index) a line part belongs to, None for the others."""
        return next((k for k, parts in enumerate(self.legs) if part in parts), None)
