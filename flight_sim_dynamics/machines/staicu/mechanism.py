"""The mechanism as points to draw (RViz markers, ``animate``): the joint
centres and the plate of one pose, by name, from the solver's own positions
(eq. 5-8, docs/design/mechanism.md "Points"), in the REP-103 simulator base
frame: ``X = x0 - x0G``, ``Y = -z0``, ``Z = y0 - h_G``.
"""
from __future__ import annotations

from ...core.vectors import add, sub
from .kinematics import Geometric
from .model import Model

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


def mechanism_points(model: Model, g: Geometric) -> dict[str, Point3]:
    """Every point drawn (:data:`JOINTS`, ``G``, ``A3_right``, ``A3_left``) of the
    positions ``g`` of eq. (5)-(8), in the base frame.
    """
    geom = model.geometry
    x0, y0 = geom.d2 + geom.d3 + geom.d4, geom.h_G     # the base's origin: G, central
    paper = {'A1': geom.A1, 'A3': g.A3, 'B1': geom.B1, 'B4': g.B4, 'C1': geom.C1, 'C4': g.C4,
             'D1': geom.D1, 'D2': g.D2, 'E1': geom.E1, 'E2': g.E2, 'G': g.G}
    # plate corners at the A3 end: A3 +/- (b/2) t, with (b/2) t = B4 - G
    paper['A3_right'] = add(g.A3, sub(g.B4, g.G))
    paper['A3_left'] = add(g.A3, sub(g.C4, g.G))
    return {name: (float(p[0]) - x0, 0.0 - float(p[2]), float(p[1]) - y0)
            for name, p in paper.items()}
