"""The mechanism as points to draw: the joint centres and the plate of one
pose, by name, for any viewer (the RViz markers of ``ros/markers.py``, the
``animate`` command of the command line). Drawing rules are written here
once, so every view shows the same machine: the solver's own positions.

Positions are those of the inverse geometric problem (paper eq. 5-8, the
points of docs/design/mechanism.md, "Points"): a :class:`~.kinematics.Geometric`
(``sol.geometric`` of a solve, or :func:`~.kinematics.inverse_geometry` of a
pose), the very positions the solver's joint variables (eq. 13) and leg
lengths come from; the constant points are the model's (eq. 8,
:class:`~.model.Geometry`). They are given in the paper's axes with the
origin at A1; :func:`mechanism_points` returns them in the REP-103 simulator
base frame (mechanism.md, "Frames"; origin at G's central position
``(d2 + d3 + d4, h_G, 0)``): ``X = x0 - x0G``, ``Y = -z0``, ``Z = y0 - h_G``.
"""
from __future__ import annotations

from .kinematics import Geometric
from .model import Geometry, Model
from .vectors import add, sub

Point3 = tuple[float, float, float]

#: The joint centres, in this order (mechanism.md, "Points").
JOINTS = ('A1', 'A3', 'B1', 'B4', 'C1', 'C4', 'D1', 'D2', 'E1', 'E2')

#: The line parts: part -> (first point, second point). Legs A, B, C
#: (joint centre to joint centre: their lengths are L_A, L_B, L_C), the rod
#: A3G (length h), cranks D (l5) and E (l6, E2 the slider on the rod).
SEGMENTS = {'leg_a': ('A1', 'A3'), 'leg_b': ('B1', 'B4'), 'leg_c': ('C1', 'C4'),
            'rod': ('A3', 'G'), 'crank_d': ('D1', 'D2'), 'crank_e': ('E1', 'E2')}

#: The plate's outline: ``h`` along ``l`` by ``b`` along ``t``, from A3 to G
#: (corners A3 -/+ (b/2) t, C4, B4), going round.
PLATE_OUTLINE = ('A3_right', 'B4', 'C4', 'A3_left')

#: The plate as triangles (both windings: seen from above and below).
PLATE = ('A3_right', 'B4', 'C4', 'A3_right', 'C4', 'A3_left',
         'A3_right', 'C4', 'B4', 'A3_right', 'A3_left', 'C4')


def base_origin(geom: Geometry) -> Point3:
    """G at the central configuration, paper axes: the simulator base's origin."""
    return (geom.d2 + geom.d3 + geom.d4, geom.h_G, 0.0)


def mechanism_points(model: Model, g: Geometric) -> dict[str, Point3]:
    """Every point drawn, by name (:data:`JOINTS`, ``G``, and the plate's
    corners ``A3_right``, ``A3_left``), in the REP-103 simulator base frame
    (module docstring) from the positions ``g`` of eq. (5)-(8) of one pose.
    """
    geom = model.geometry
    x0, y0, _ = base_origin(geom)
    paper = {'A1': geom.A1, 'A3': g.A3, 'B1': geom.B1, 'B4': g.B4, 'C1': geom.C1, 'C4': g.C4,
             'D1': geom.D1, 'D2': g.D2, 'E1': geom.E1, 'E2': g.E2, 'G': g.G}
    # plate corners at the A3 end: A3 +/- (b/2) t, with (b/2) t = B4 - G
    paper['A3_right'] = add(g.A3, sub(g.B4, g.G))
    paper['A3_left'] = add(g.A3, sub(g.C4, g.G))
    return {name: (float(p[0]) - x0, 0.0 - float(p[2]), float(p[1]) - y0)
            for name, p in paper.items()}
