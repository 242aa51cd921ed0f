"""The mechanism as points to draw (RViz markers, ``animate``): the joint
centres and the plate of one pose, by name, from the solver's own positions
(eq. 5-8, docs/design/mechanism.md "Points"), in the REP-103 simulator base
frame: ``X = x0 - x0G``, ``Y = -z0``, ``Z = y0 - h_G``; :func:`drawing`: the
machine's :class:`~flight_sim_dynamics.core.drawing.Drawing`.
"""
from __future__ import annotations

from typing import Sequence

from ...core.drawing import Drawing, PartStyle, Point3, View
from ...core.vectors import add, backend, sub
from .kinematics import Geometric, inverse_geometry
from .model import Model

_SCALAR = backend(False)

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


#: How animate draws the parts: legs A, B, C in their leg's colour (C dashed:
#: in the side view it lies on B at zero roll), the rod and the cranks.
STYLES = {'leg_a': PartStyle(), 'leg_b': PartStyle(), 'leg_c': PartStyle(linestyle='--'),
          'rod': PartStyle('#3f59cc', 3.5), 'crank_d': PartStyle('#1a9999', 2.2),
          'crank_e': PartStyle('#1a9999', 2.2)}


def pose_points(model: Model, q: Sequence[float]) -> dict[str, Point3]:
    """:func:`mechanism_points` of pose q = (surge, heave, roll) (eq. 5-8);
    UnreachablePoseError (a ValueError) if a loop cannot close.
    """
    return mechanism_points(model, inverse_geometry(model, tuple(float(v) for v in q), _SCALAR))


def drawing(model: Model) -> Drawing:
    """The 3-DOF machine as drawn: side and front views, the plate."""
    return Drawing(
        points=lambda q: pose_points(model, q), joints=JOINTS, segments=SEGMENTS,
        legs=(('leg_a',), ('leg_b',), ('leg_c',)), leg_names=('A', 'B', 'C'),
        plates={'platform': PLATE_OUTLINE}, styles=STYLES,
        legend=(('rod A3G', 'rod'), ('cranks D, E', 'crank_d')),
        views=(View('side view (from the right)', 0, 'X, m (forward)'),
               View('front view', 1, "Y, m (the machine's left)")),
        plate_colours={'platform': '#9aa6bf'}, home='the central configuration')
