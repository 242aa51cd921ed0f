"""The hexapod as points to draw (``animate``, RViz markers): the base joints
``B1..B6``, the platform joints ``P1..P6`` of a pose (S1), (S4) and on each leg
the point ``S1..S6`` where the rod leaves the cylinder, in the base frame.

Each leg is drawn as two parts: the cylinder from B_i along u_i, as long as the
shortest leg (``limits.length_min``: the rod fully retracted), and the rod from
there to P_i, whose length ``L_i - length_min`` is how far the actuator is
extended (shorter than that, the leg is all cylinder). The base and the
platform are the polygons through their joints, going round.
"""
from __future__ import annotations

from typing import Sequence

import numpy as np

from ...core.drawing import Drawing, PartStyle, Point3, View
from .kinematics import leg_positions, rotation
from .model import StewartModel

LEGS = range(1, 7)
#: The joint centres, in this order.
JOINTS = tuple(f'B{i}' for i in LEGS) + tuple(f'P{i}' for i in LEGS)
#: The line parts: per leg its cylinder (B_i to S_i) and its rod (S_i to P_i).
SEGMENTS = {name: ends for i in LEGS for name, ends in
            ((f'cylinder_{i}', (f'B{i}', f'S{i}')), (f'rod_{i}', (f'S{i}', f'P{i}')))}
STYLES = {name: PartStyle(width=5.0 if name.startswith('cylinder') else 2.0)
          for name in SEGMENTS}


def going_round(points: np.ndarray) -> tuple[int, ...]:
    """Indices of ``points`` (6, 3) in the order of their azimuth about their
    centroid in the xy plane: a polygon through them does not cross itself.
    """
    d = points[:, :2] - points[:, :2].mean(axis=0)
    return tuple(int(k) for k in np.argsort(np.arctan2(d[:, 1], d[:, 0]), kind='stable'))


def hexapod_points(model: StewartModel, q: np.ndarray) -> dict[str, np.ndarray]:
    """Every point of :data:`JOINTS` and ``S1..S6`` of the poses q (N, 6), each
    (N, 3), base frame: B_i fixed, P_i = p + R p_i (S1), (S4), S_i = B_i +
    min(length_min, L_i) u_i.
    """
    q = np.atleast_2d(np.asarray(q, dtype=float))
    legs = leg_positions(model, model.home + q[:, :3], rotation(q))
    cylinder = np.minimum(model.limits.length_min, legs.L)[..., None] * legs.u
    split = model.base_joints + cylinder
    out = {f'B{i}': np.broadcast_to(model.base_joints[i - 1], (len(q), 3)) for i in LEGS}
    out.update({f'P{i}': legs.P[:, i - 1] for i in LEGS})
    out.update({f'S{i}': split[:, i - 1] for i in LEGS})
    return out


def pose_points(model: StewartModel, q: Sequence[float]) -> dict[str, Point3]:
    """:func:`hexapod_points` of one pose (six numbers); ValueError if it has
    no drawing (not finite, or a leg of zero length).
    """
    q = np.asarray(q, dtype=float).reshape(1, 6)
    points = hexapod_points(model, q)
    if not all(np.isfinite(p).all() for p in points.values()):
        raise ValueError(f'no drawing of pose {q[0].tolist()}: not finite, or a leg of '
                         'zero length')
    return {name: (float(p[0, 0]), float(p[0, 1]), float(p[0, 2])) for name, p in points.items()}


def drawing(model: StewartModel) -> Drawing:
    """The hexapod as drawn: a 3-D view and a side view, base and platform plates."""
    base = tuple(f'B{k + 1}' for k in going_round(model.base_joints))
    platform = tuple(f'P{k + 1}' for k in going_round(model.platform_joints))
    return Drawing(
        points=lambda q: pose_points(model, q), joints=JOINTS, segments=SEGMENTS,
        legs=tuple((f'cylinder_{i}', f'rod_{i}') for i in LEGS),
        leg_names=tuple(str(i) for i in LEGS), plates={'base': base, 'platform': platform},
        styles=STYLES, legend=(('cylinders', 'cylinder_1'), ('rods', 'rod_1')),
        views=(View('3-D view', None), View('side view (from the right)', 0, 'X, m (forward)')),
        plate_colours={'base': '#c8c8c8', 'platform': '#9aa6bf'}, home='home',
        origin=tuple(float(v) for v in model.home))
