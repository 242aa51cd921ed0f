"""One solution as a MarkerArray (eqs. 5-8), one marker per part updated in
place; legs coloured by |force| / max_force (red beyond a limit, magenta near
singular); without positions the last pose in grey. No rclpy here.
"""
from __future__ import annotations

import math
from typing import Sequence

from builtin_interfaces.msg import Time
from geometry_msgs.msg import Point
from std_msgs.msg import ColorRGBA, Header
from visualization_msgs.msg import Marker, MarkerArray

from ..core.status import SEVERITY, Status
from ..core.vectors import backend
from ..machines.staicu.kinematics import inverse_geometry
from ..machines.staicu.mechanism import JOINTS, PLATE, SEGMENTS, mechanism_points
from ..machines.staicu.model import LEG_NAMES, Model
from ..machines.staicu.solver import Solution

_SCALAR = backend(False)

NAMESPACES = LEG_NAMES + ('rod', 'platform', 'crank_d', 'crank_e', 'joints', 'status')

WIDTH = {'leg_a': 0.04, 'leg_b': 0.04, 'leg_c': 0.04, 'rod': 0.05, 'crank_d': 0.03,
         'crank_e': 0.03}
JOINT_DIAMETER = 0.07
TEXT_HEIGHT = 0.08
TEXT_ABOVE = 0.35          # m above G
MAX_TEXT = 120             # characters of the status text

RED = (1.0, 0.0, 0.0, 1.0)
MAGENTA = (1.0, 0.0, 1.0, 1.0)
GREY = (0.5, 0.5, 0.5, 0.4)
PART_COLOURS = {'rod': (0.25, 0.35, 0.8, 1.0), 'platform': (0.6, 0.65, 0.75, 0.8),
                'crank_d': (0.1, 0.6, 0.6, 1.0), 'crank_e': (0.1, 0.6, 0.6, 1.0),
                'joints': (0.15, 0.15, 0.15, 1.0), 'status': (1.0, 1.0, 1.0, 1.0)}


def force_colour(fraction: float) -> tuple[float, float, float, float]:
    """Green (0) -> yellow (0.5) -> red (1), clipped; NaN: red."""
    r = 1.0 if fraction != fraction else min(max(fraction, 0.0), 1.0)
    if r <= 0.5:
        return (2.0 * r, 1.0, 0.0, 1.0)
    return (1.0, 2.0 * (1.0 - r), 0.0, 1.0)


def _set_colour(c: ColorRGBA, rgba: Sequence[float]) -> None:
    c.r, c.g, c.b, c.a = rgba


def _set_point(p: Point, xyz: Sequence[float]) -> None:
    p.x, p.y, p.z = xyz


def _over_limits(sol: Solution, leg: int) -> bool:
    lim = sol.model.limits
    stroke = float(sol.stroke[leg])
    return not (lim.stroke_min <= stroke <= lim.stroke_max
                and abs(float(sol.rate[leg])) <= lim.max_speed
                and abs(float(sol.force[leg])) <= lim.max_force)


class MarkerBuilder:
    """One MarkerArray, rewritten in place by :meth:`update`."""

    def __init__(self, model: Model, frame_id: str) -> None:
        self.header = Header(stamp=Time(), frame_id=frame_id)
        self.array = MarkerArray()
        self.markers: dict[str, Marker] = {}
        kinds = {'platform': Marker.TRIANGLE_LIST, 'joints': Marker.SPHERE_LIST,
                 'status': Marker.TEXT_VIEW_FACING}
        sizes = {'platform': len(PLATE), 'joints': len(JOINTS), 'status': 0}
        for ns in NAMESPACES:
            m = Marker(ns=ns, id=0, type=kinds.get(ns, Marker.LINE_LIST), action=Marker.ADD)
            m.header = self.header        # shared: one stamp to write
            m.pose.orientation.w = 1.0
            m.points = [Point() for _ in range(sizes.get(ns, 2))]
            if ns in WIDTH:
                m.scale.x = WIDTH[ns]
            elif ns == 'joints':
                m.scale.x = m.scale.y = m.scale.z = JOINT_DIAMETER
            elif ns == 'status':
                m.scale.z = TEXT_HEIGHT
            else:
                m.scale.x = m.scale.y = m.scale.z = 1.0
            self.markers[ns] = m
        self.array.markers = [self.markers[ns] for ns in NAMESPACES]
        self._last = mechanism_points(model, inverse_geometry(model, (0.0, 0.0, 0.0), _SCALAR))
        self._draw(self._last)
        self._colour_void()
        self.markers['status'].text = 'no solution yet'

    @property
    def frame_id(self) -> str:
        return self.header.frame_id

    @frame_id.setter
    def frame_id(self, value: str) -> None:
        self.header.frame_id = value

    def update(self, sol: Solution, sec: int, nanosec: int) -> MarkerArray:
        """The markers of one solution (not a batch): publish before the next update."""
        stamp = self.header.stamp
        stamp.sec, stamp.nanosec = int(sec), int(nanosec)
        status = sol.status
        if isinstance(status, Status):
            severity = SEVERITY[status]
        else:
            raise ValueError('MarkerBuilder.update takes one solution of fsd.solve, '
                             'not a batch')
        pts = None
        if severity < SEVERITY[Status.UNREACHABLE]:
            g = sol.geometric
            if g is not None:
                pts = mechanism_points(sol.model, g)
                if not all(math.isfinite(v) for p in pts.values() for v in p):
                    pts = None
        if pts is None:                          # unreachable, invalid input
            self._draw(self._last)
            self._colour_void()
        else:
            self._last = pts
            self._draw(pts)
            self._colour(sol, status)
        text = str(status) if not sol.detail else f'{status}: {sol.detail}'
        self.markers['status'].text = (text if len(text) <= MAX_TEXT
                                       else text[:MAX_TEXT - 3] + '...')
        return self.array

    def clear(self) -> MarkerArray:
        """One DELETEALL marker (a new array)."""
        m = Marker(action=Marker.DELETEALL)
        m.header = Header(stamp=self.header.stamp, frame_id=self.header.frame_id)
        return MarkerArray(markers=[m])

    def _draw(self, pts: dict) -> None:
        for ns, (a, b) in SEGMENTS.items():
            p = self.markers[ns].points
            _set_point(p[0], pts[a])
            _set_point(p[1], pts[b])
        for p, name in zip(self.markers['platform'].points, PLATE):
            _set_point(p, pts[name])
        for p, name in zip(self.markers['joints'].points, JOINTS):
            _set_point(p, pts[name])
        g = pts['G']
        _set_point(self.markers['status'].pose.position, (g[0], g[1], g[2] + TEXT_ABOVE))

    def _colour(self, sol: Solution, status: Status) -> None:
        for ns, rgba in PART_COLOURS.items():
            _set_colour(self.markers[ns].color, rgba)
        max_force = sol.model.limits.max_force
        for leg, ns in enumerate(LEG_NAMES):
            if status is Status.NEAR_SINGULAR:
                rgba = MAGENTA
            elif _over_limits(sol, leg):
                rgba = RED
            else:
                rgba = force_colour(abs(float(sol.force[leg])) / max_force)
            _set_colour(self.markers[ns].color, rgba)

    def _colour_void(self) -> None:
        for ns in NAMESPACES:
            _set_colour(self.markers[ns].color,
                        PART_COLOURS['status'] if ns == 'status' else GREY)
