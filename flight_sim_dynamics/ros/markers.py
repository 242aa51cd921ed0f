"""Any machine's drawing (:attr:`Machine.drawing`, core/drawing.py) as one
MarkerArray, one marker per part updated in place: each line part, each plate,
the joints and a status text, in the setpoints' frame (origin at the
platform's home position, :attr:`Drawing.origin`: where the poses put it).
Legs coloured by |force| / max_force (red beyond a limit of the leg by the
machine's limit rule, :attr:`Machine.limit_usage`; magenta near singular); a
pose without a drawing redraws the last one grey. No rclpy here (the node
publishes it: ros/marker_publisher.py).
"""
from __future__ import annotations

import math
from typing import Any, NamedTuple, Sequence

from builtin_interfaces.msg import Time
from geometry_msgs.msg import Point
from std_msgs.msg import ColorRGBA, Header
from visualization_msgs.msg import Marker, MarkerArray

from ..core.machine import Machine
from ..core.status import SEVERITY, Status

# sizes as fractions of the machine's size (the diagonal of its home drawing's
# bounding box, about 3.4 m for both packaged machines)
WIDTH_PER_STYLE = 0.0133 / 3.45    # a line part's width per unit of PartStyle.width
JOINT_DIAMETER = 0.02
TEXT_HEIGHT = 0.023
TEXT_ABOVE = 0.1                   # above the highest point drawn
MAX_TEXT = 120                     # characters of the status text

RED = (1.0, 0.0, 0.0, 1.0)
MAGENTA = (1.0, 0.0, 1.0, 1.0)
GREY = (0.5, 0.5, 0.5, 0.4)
WHITE = (1.0, 1.0, 1.0, 1.0)
JOINT_COLOUR = (0.15, 0.15, 0.15, 1.0)
PLATE_ALPHA = 0.8
JOINTS, STATUS = 'joints', 'status'


class Snapshot(NamedTuple):
    """What the markers draw of one solution, plain numbers (picklable)."""

    pose: tuple[float, ...]        # q, the machine's coordinates
    stroke: tuple[float, ...]      # per leg, m
    rate: tuple[float, ...]        # per leg, m/s
    force: tuple[float, ...]       # per leg, N
    over: tuple[bool, ...]         # per leg: some limit of it exceeded
    status: Status
    detail: str


def snapshot(machine: Machine, model: Any, sol: Any) -> Snapshot:
    """The :class:`Snapshot` of one solution of ``machine.solve`` on ``model``
    (a leg is over when the machine's limit usage of any of its limits, the
    status rule's, is above 1); ValueError for a batch.
    """
    if not isinstance(sol.status, Status):
        raise ValueError('markers take one solution of solve, not a batch')
    usage = machine.limit_usage(model, sol)
    # a usage's name ends with its leg's label in upper case ('force C', 'u_joint 1')
    over = {name.rsplit(' ', 1)[-1] for name, used in zip(usage.names, usage.usage.tolist())
            if used > 1.0}
    return Snapshot(tuple(float(v) for v in sol.pose), tuple(sol.stroke.tolist()),
                    tuple(sol.rate.tolist()), tuple(sol.force.tolist()),
                    tuple(label.upper() in over for label in machine.leg_labels),
                    sol.status, str(sol.detail))


def force_colour(fraction: float) -> tuple[float, float, float, float]:
    """Green (0) -> yellow (0.5) -> red (1), clipped; NaN: red."""
    r = 1.0 if fraction != fraction else min(max(fraction, 0.0), 1.0)
    if r <= 0.5:
        return (2.0 * r, 1.0, 0.0, 1.0)
    return (1.0, 2.0 * (1.0 - r), 0.0, 1.0)


def hex_colour(text: str, alpha: float = 1.0) -> tuple[float, float, float, float]:
    """'#rrggbb' as RGBA in [0, 1]."""
    return (int(text[1:3], 16) / 255, int(text[3:5], 16) / 255, int(text[5:7], 16) / 255, alpha)


def triangles(corners: Sequence[str]) -> tuple[str, ...]:
    """A plate through ``corners`` (going round) as a triangle fan from the first,
    in both windings (seen from either side).
    """
    fan = [(corners[0], a, b) for a, b in zip(corners[1:-1], corners[2:])]
    return tuple(p for tri in fan for p in tri) + tuple(p for a, b, c in fan for p in (a, c, b))


def _set_colour(c: ColorRGBA, rgba: Sequence[float]) -> None:
    c.r, c.g, c.b, c.a = rgba


def _set_point(p: Point, xyz: Sequence[float]) -> None:
    p.x, p.y, p.z = xyz


class MarkerBuilder:
    """One MarkerArray of ``machine``'s ``model``, rewritten in place by
    :meth:`update`: namespaces = the drawing's line parts, its plates,
    ``joints``, ``status``; id 0 each.
    """

    def __init__(self, machine: Machine, model: Any, frame_id: str) -> None:
        drawing = machine.drawing(model)
        self.machine, self.model = machine, model
        self.drawing = drawing
        self.limits = machine.actuator_limits(model)
        zero = (0.0,) * machine.dof
        self.home = snapshot(machine, model, machine.solve(model, zero, zero, zero))
        self._last = drawing.points(zero)
        low = [min(p[k] for p in self._last.values()) for k in range(3)]
        high = [max(p[k] for p in self._last.values()) for k in range(3)]
        self.size = math.dist(low, high)
        self.plates = {name: triangles(corners) for name, corners in drawing.plates.items()}
        self.namespaces = (*drawing.segments, *drawing.plates, JOINTS, STATUS)
        self.colours: dict[str, tuple[float, float, float, float]] = {JOINTS: JOINT_COLOUR,
                                                                      STATUS: WHITE}
        self.header = Header(stamp=Time(), frame_id=frame_id)
        self.markers: dict[str, Marker] = {}
        for ns in self.namespaces:
            m = Marker(ns=ns, id=0, action=Marker.ADD)
            m.header = self.header        # shared: one stamp to write
            m.pose.orientation.w = 1.0
            if ns in drawing.segments:
                m.type, n = Marker.LINE_LIST, 2
                style = drawing.styles[ns]
                m.scale.x = style.width * WIDTH_PER_STYLE * self.size
                if style.colour is not None:
                    self.colours[ns] = hex_colour(style.colour)
            elif ns in self.plates:
                m.type, n = Marker.TRIANGLE_LIST, len(self.plates[ns])
                m.scale.x = m.scale.y = m.scale.z = 1.0
                self.colours[ns] = hex_colour(drawing.plate_colours[ns], PLATE_ALPHA)
            elif ns == JOINTS:
                m.type, n = Marker.SPHERE_LIST, len(drawing.joints)
                m.scale.x = m.scale.y = m.scale.z = JOINT_DIAMETER * self.size
            else:
                m.type, n = Marker.TEXT_VIEW_FACING, 0
                m.scale.z = TEXT_HEIGHT * self.size
            m.points = [Point() for _ in range(n)]
            self.markers[ns] = m
        self.array = MarkerArray(markers=[self.markers[ns] for ns in self.namespaces])
        self._draw(self._last)
        self._colour_void()
        self.markers[STATUS].text = 'no solution yet'

    @property
    def frame_id(self) -> str:
        return self.header.frame_id

    @frame_id.setter
    def frame_id(self, value: str) -> None:
        self.header.frame_id = value

    def update(self, snap: Snapshot, sec: int, nanosec: int) -> MarkerArray:
        """The markers of one solution, stamped (sec, nanosec); the same array
        at every call: publish (or serialize) it before the next.
        """
        stamp = self.header.stamp
        stamp.sec, stamp.nanosec = int(sec), int(nanosec)
        pts = None
        if SEVERITY[snap.status] < SEVERITY[Status.UNREACHABLE]:
            try:
                pts = self.drawing.points(snap.pose)
            except ValueError:                   # a pose the drawing cannot show
                pts = None
            if pts is not None and not all(math.isfinite(v) for p in pts.values() for v in p):
                pts = None
        if pts is None:                          # unreachable, invalid input
            self._draw(self._last)
            self._colour_void()
        else:
            self._last = pts
            self._draw(pts)
            self._colour(snap)
        text = str(snap.status) if not snap.detail else f'{snap.status}: {snap.detail}'
        self.markers[STATUS].text = (text if len(text) <= MAX_TEXT
                                     else text[:MAX_TEXT - 3] + '...')
        return self.array

    def clear(self) -> MarkerArray:
        """One DELETEALL marker (a new array)."""
        return clear_array(self.header.frame_id, self.header.stamp.sec, self.header.stamp.nanosec)

    def _draw(self, pts: dict) -> None:
        ox, oy, oz = self.drawing.origin       # the drawing's frame -> the setpoints'
        pts = {name: (x - ox, y - oy, z - oz) for name, (x, y, z) in pts.items()}
        for ns, (a, b) in self.drawing.segments.items():
            p = self.markers[ns].points
            _set_point(p[0], pts[a])
            _set_point(p[1], pts[b])
        for ns, corners in self.plates.items():
            for p, name in zip(self.markers[ns].points, corners):
                _set_point(p, pts[name])
        for p, name in zip(self.markers[JOINTS].points, self.drawing.joints):
            _set_point(p, pts[name])
        n = len(pts)
        top = max(p[2] for p in pts.values())
        _set_point(self.markers[STATUS].pose.position,
                   (sum(p[0] for p in pts.values()) / n, sum(p[1] for p in pts.values()) / n,
                    top + TEXT_ABOVE * self.size))

    def _colour(self, snap: Snapshot) -> None:
        for ns, rgba in self.colours.items():
            _set_colour(self.markers[ns].color, rgba)
        max_force = self.limits.max_force
        for leg, parts in enumerate(self.drawing.legs):
            if snap.status is Status.NEAR_SINGULAR:
                rgba = MAGENTA
            elif snap.over[leg]:
                rgba = RED
            else:
                rgba = force_colour(abs(snap.force[leg]) / max_force)
            for ns in parts:
                _set_colour(self.markers[ns].color, rgba)

    def _colour_void(self) -> None:
        for ns in self.namespaces:
            _set_colour(self.markers[ns].color, WHITE if ns == STATUS else GREY)


def clear_array(frame_id: str, sec: int = 0, nanosec: int = 0) -> MarkerArray:
    """One DELETEALL marker: a viewer removes every marker of the topic."""
    m = Marker(action=Marker.DELETEALL)
    m.header = Header(stamp=Time(sec=int(sec), nanosec=int(nanosec)), frame_id=frame_id)
    return MarkerArray(markers=[m])
