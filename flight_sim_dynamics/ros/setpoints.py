"""Setpoint handling for the ROS 2 node, without ROS.

Everything the node does between "a message arrived" and "call the solver"
that is plain Python lives here, so that it can be unit-tested without rclpy:

* :func:`quaternion_to_rpy` -- roll, pitch, yaw of a quaternion (ZYX, REP-103),
  with the checks for non-finite, zero and non-unit quaternions;
* :func:`pose_input`, :func:`rate_input` -- the three commanded coordinates
  (surge, heave, roll) and the components the mechanism cannot follow;
* :class:`StampedReader` -- the stamp and numbers of a serialized (CDR)
  PoseStamped, TwistStamped or AccelStamped, read without building the message;
* :class:`TrajectoryReader`, :func:`platform_setpoints` -- a whole setpoint (or
  several) in one serialized ``trajectory_msgs/JointTrajectory`` over the
  joints :data:`PLATFORM_DOF_NAMES`, read and checked point by point;
* :class:`StampSynchroniser` -- joins pose, twist and acceleration messages
  that carry the same header stamp (exact match, bounded wait), and orders the
  one-message setpoints among them (:meth:`StampSynchroniser.add_complete`);
* :class:`DerivativeEstimator` -- causal finite differences that fill in the
  rates and accelerations a planner does not send;
* :class:`NodeConfig`, :func:`check_limits` -- actuator limits and tolerances;
* :class:`CycleStats`, :class:`LogThrottle` -- diagnostics bookkeeping.

Units: SI throughout (m, rad, s); stamps are integer nanoseconds.
"""
from __future__ import annotations

import math
import reprlib
import struct
from dataclasses import dataclass
from typing import Any, Generic, Iterable, Mapping, NamedTuple, Sequence, TypeVar

from ..core.model import Limits
from ..config.parameters import NODE_PARAMETERS, SPECS, check_value

# ----------------------------------------------------------------------------
# Rejection reasons (diagnostics counters). A *rejected* setpoint is not
# solved and nothing is published for it.
# ----------------------------------------------------------------------------
NON_FINITE = 'non_finite'                  # NaN or infinity in a field
BAD_QUATERNION = 'bad_quaternion'          # zero-length or non-unit quaternion
STAMP_REPEATED = 'stamp_repeated'          # stamp equal to the last answered one
STAMP_BACKWARDS = 'stamp_backwards'        # stamp older than the last answered one
DUPLICATE = 'duplicate'                    # second message of one kind for a pending stamp
NO_POSE = 'no_pose'                        # twist/accel whose pose never arrived
LATE = 'late'                              # twist/accel after its setpoint was answered
OVERFLOW = 'overflow'                      # too many incomplete stamps pending
ABSURD_ACCELERATION = 'absurd_acceleration'  # |acceleration| beyond input.max_*_acceleration
UNREACHABLE = 'unreachable'                # the loops cannot close at this pose
SOLVER_ERROR = 'solver_error'              # any other solver failure
NON_FINITE_OUTPUT = 'non_finite_output'    # the solver returned NaN/inf (never published)
BAD_SETPOINT = 'bad_setpoint'              # a malformed platform_setpoint message or point

REJECTION_REASONS = (NON_FINITE, BAD_QUATERNION, STAMP_REPEATED, STAMP_BACKWARDS,
                     DUPLICATE, NO_POSE, LATE, OVERFLOW, ABSURD_ACCELERATION,
                     UNREACHABLE, SOLVER_ERROR, NON_FINITE_OUTPUT, BAD_SETPOINT)

#: Reasons that make the diagnostics level ERROR (the rest of the rejections
#: are stream hygiene problems and make it WARN).
ERROR_REASONS = frozenset({NON_FINITE, BAD_QUATERNION, ABSURD_ACCELERATION,
                           UNREACHABLE, SOLVER_ERROR, NON_FINITE_OUTPUT, BAD_SETPOINT})

# Motion the mechanism cannot follow: reported, ignored, the setpoint is solved.
SWAY = 'sway'
YAW = 'yaw'
PITCH = 'pitch'
UNFOLLOWABLE_COMPONENTS = (SWAY, YAW, PITCH)

# Diagnostic levels (same numbers as diagnostic_msgs/DiagnosticStatus).
OK, WARN, ERROR = 0, 1, 2
LEVEL_NAMES = {OK: 'OK', WARN: 'WARN', ERROR: 'ERROR'}

Vec3 = tuple[float, float, float]
_NOTHING: tuple[str, ...] = ()


class SetpointError(ValueError):
    """A setpoint message is rejected; ``reason`` is one of REJECTION_REASONS."""

    def __init__(self, reason: str, message: str) -> None:
        self.reason = reason
        super().__init__(message)


# ----------------------------------------------------------------------------
# Conversions
# ----------------------------------------------------------------------------
def wrap_angle(angle: float) -> float:
    """``angle`` wrapped to [-pi, pi)."""
    return (angle + math.pi) % (2.0 * math.pi) - math.pi


def quaternion_to_rpy(x: float, y: float, z: float, w: float,
                      tolerance: float = 1e-3) -> Vec3:
    """Roll, pitch, yaw (rad) of the ZYX (yaw-pitch-roll) decomposition
    ``R = Rz(yaw) Ry(pitch) Rx(roll)`` of a quaternion.

    The quaternion must be finite and of unit length within ``tolerance``
    (``| |q| - 1 | <= tolerance``); it is normalised before use. Raises
    :class:`SetpointError` otherwise. Pitch is in [-pi/2, pi/2]; roll and
    yaw in (-pi, pi]. A quaternion carrying a pitch (such as the platform's
    parasitic pitch) gives the same roll as the roll-only quaternion.
    """
    if not (math.isfinite(x) and math.isfinite(y) and math.isfinite(z) and math.isfinite(w)):
        raise SetpointError(NON_FINITE, f'orientation has a non-finite component '
                                        f'({x!r}, {y!r}, {z!r}, {w!r})')
    norm = math.sqrt(x * x + y * y + z * z + w * w)
    if norm == 0.0:
        raise SetpointError(BAD_QUATERNION, 'orientation quaternion is zero')
    if abs(norm - 1.0) > tolerance:
        raise SetpointError(BAD_QUATERNION, f'orientation quaternion is not a unit '
                                             f'quaternion (|q| = {norm:.6g})')
    if norm != 1.0:
        x, y, z, w = x / norm, y / norm, z / norm, w / norm
    roll = math.atan2(2.0 * (w * x + y * z), 1.0 - 2.0 * (x * x + y * y))
    sin_pitch = max(-1.0, min(1.0, 2.0 * (w * y - z * x)))
    pitch = math.asin(sin_pitch)
    yaw = math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))
    return roll, pitch, yaw


def rpy_to_quaternion(roll: float, pitch: float = 0.0, yaw: float = 0.0
                      ) -> tuple[float, float, float, float]:
    """Quaternion (x, y, z, w) of ``Rz(yaw) Ry(pitch) Rx(roll)``."""
    cr, sr = math.cos(roll / 2), math.sin(roll / 2)
    cp, sp = math.cos(pitch / 2), math.sin(pitch / 2)
    cy, sy = math.cos(yaw / 2), math.sin(yaw / 2)
    return (sr * cp * cy - cr * sp * sy,
            cr * sp * cy + sr * cp * sy,
            cr * cp * sy - sr * sp * cy,
            cr * cp * cy + sr * sp * sy)


class PoseInput(NamedTuple):
    """A pose setpoint in the mechanism's coordinates.

    ``q`` = (surge m, heave m, roll rad); ``sway`` (m), ``pitch`` and ``yaw``
    (rad) are what the message asked for beyond them. (A named tuple: one is
    built per message, and a tuple is the cheapest immutable record.)"""

    q: Vec3
    sway: float
    pitch: float
    yaw: float


class RateInput(NamedTuple):
    """A twist or acceleration setpoint: the derivatives of (surge, heave, roll)
    (``q``) and the sway, pitch and yaw components (``sway``, ``pitch``,
    ``yaw``: linear.y, angular.y, angular.z)."""

    q: Vec3
    sway: float
    pitch: float
    yaw: float


def pose_input(px: float, py: float, pz: float,
               qx: float, qy: float, qz: float, qw: float,
               quaternion_tolerance: float = 1e-3) -> PoseInput:
    """Convert the fields of a geometry_msgs/Pose (REP-103 simulator base,
    origin at G's central position) into a :class:`PoseInput`: surge =
    position.x, heave = position.z, roll = ZYX roll of the orientation."""
    if not (math.isfinite(px + py + pz)
            or (math.isfinite(px) and math.isfinite(py) and math.isfinite(pz))):
        raise SetpointError(NON_FINITE, f'position has a non-finite component '
                                        f'({px!r}, {py!r}, {pz!r})')
    roll, pitch, yaw = quaternion_to_rpy(qx, qy, qz, qw, quaternion_tolerance)
    return PoseInput((px, pz, roll), py, pitch, yaw)


def rate_input(lx: float, ly: float, lz: float, ax: float, ay: float, az: float,
               what: str = 'twist') -> RateInput:
    """Convert the linear/angular fields of a Twist or Accel into a
    :class:`RateInput`: d/dt of (surge, heave, roll) = (linear.x, linear.z,
    angular.x)."""
    # a sum is finite iff every term is (inf - inf is nan), unless it overflows:
    # then the components are checked one by one
    if not math.isfinite(lx + ly + lz + ax + ay + az) and not all(
            math.isfinite(v) for v in (lx, ly, lz, ax, ay, az)):
        raise SetpointError(NON_FINITE, f'{what} has a non-finite component')
    return RateInput((lx, lz, ax), ly, ay, az)


def check_acceleration(qdd: Iterable[float], max_linear: float, max_angular: float,
                       source: str = 'acceleration') -> None:
    """Reject absurd accelerations: |d2 surge|, |d2 heave| > ``max_linear``
    (m/s^2) or |d2 roll| > ``max_angular`` (rad/s^2)."""
    a_surge, a_heave, a_roll = qdd
    if abs(a_surge) > max_linear or abs(a_heave) > max_linear:
        raise SetpointError(ABSURD_ACCELERATION,
                            f'{source} ({a_surge:.4g}, {a_heave:.4g}) m/s^2 exceeds '
                            f'input.max_linear_acceleration = {max_linear:g} m/s^2')
    if abs(a_roll) > max_angular:
        raise SetpointError(ABSURD_ACCELERATION,
                            f'{source} roll {a_roll:.4g} rad/s^2 exceeds '
                            f'input.max_angular_acceleration = {max_angular:g} rad/s^2')


def unfollowable(pose: PoseInput, twist: RateInput | None, accel: RateInput | None,
                 parasitic_pitch: float, position_tolerance: float,
                 angle_tolerance: float) -> tuple[str, ...]:
    """Components of a setpoint the mechanism cannot follow.

    Sway (position.y, twist/accel linear.y) and yaw (orientation yaw,
    angular.z) must be zero within the tolerances; the orientation's pitch
    must be either zero (a roll-only quaternion) or the parasitic pitch
    ``parasitic_pitch`` (REP-103, = -beta) within ``angle_tolerance``. The
    pitch rate and acceleration (angular.y) are the parasitic pitch's own
    derivatives, which the planner cannot choose; they are not checked.
    Rates are compared against the same tolerances per second (per s^2).
    """
    sway = abs(pose.sway) > position_tolerance
    yaw = abs(pose.yaw) > angle_tolerance
    pitch = pose.pitch
    for rates in (twist, accel):
        if rates is not None:
            sway = sway or abs(rates.sway) > position_tolerance
            yaw = yaw or abs(rates.yaw) > angle_tolerance
    if not (sway or yaw) and (abs(pitch) <= angle_tolerance
                              or abs(pitch - parasitic_pitch) <= angle_tolerance):
        return _NOTHING           # the usual case
    found = []
    if sway:
        found.append(SWAY)
    if yaw:
        found.append(YAW)
    if abs(pitch) > angle_tolerance and abs(pitch - parasitic_pitch) > angle_tolerance:
        found.append(PITCH)
    return tuple(found)


# ----------------------------------------------------------------------------
# Serialized setpoint messages
# ----------------------------------------------------------------------------
#: Encapsulation identifiers (first two bytes of a serialized DDS sample) of
#: plain XCDR1, which rmw_fastrtps and rmw_cyclonedds write for ROS messages.
CDR_BE, CDR_LE = b'\x00\x00', b'\x00\x01'


class StampedReader:
    """Read a serialized (CDR) ``geometry_msgs/*Stamped`` message without building
    the Python message: the header stamp and the ``count`` doubles that follow
    the header (PoseStamped: 7 = position x, y, z, orientation x, y, z, w;
    TwistStamped, AccelStamped: 6 = linear x, y, z, angular x, y, z).

    The node subscribes its setpoints serialized (``raw=True``): building the
    nested Python message of each sample costs more than the rest of its
    handling. Layout (XCDR1, plain CDR, either byte order): 4 bytes
    encapsulation, ``int32 sec``, ``uint32 nanosec``, ``uint32`` length of
    ``frame_id`` (its terminating NUL included) and its bytes, then the doubles,
    aligned to 8 bytes from the end of the encapsulation.

    Calling it returns ``(sec, nanosec, doubles)``, or None when the sample is
    in another encoding (the caller then deserializes it the usual way). A
    truncated sample raises ``struct.error``.
    """

    __slots__ = ('count', '_le', '_be')

    def __init__(self, count: int) -> None:
        self.count = count
        self._le = (struct.Struct('<iII'), struct.Struct(f'<{count}d'))
        self._be = (struct.Struct('>iII'), struct.Struct(f'>{count}d'))

    def __call__(self, data: bytes) -> tuple[int, int, tuple[float, ...]] | None:
        if data[0] != 0:
            return None
        encoding = data[1]
        if encoding == 1:
            head, body = self._le
        elif encoding == 0:
            head, body = self._be
        else:
            return None
        sec, nanosec, length = head.unpack_from(data, 4)
        offset = 16 + length               # 4 encapsulation + 12 header bytes + frame_id
        offset += (4 - offset) % 8         # align the doubles (relative to byte 4)
        return sec, nanosec, body.unpack_from(data, offset)


read_pose_stamped = StampedReader(7)
read_twist_stamped = StampedReader(6)        # and AccelStamped: the same layout


# ----------------------------------------------------------------------------
# One message per setpoint: trajectory_msgs/JointTrajectory on platform_setpoint
# ----------------------------------------------------------------------------
#: ``joint_names`` of a ``platform_setpoint`` message (trajectory_msgs/
#: JointTrajectory), in any order: they give the order of the numbers of each
#: point. Units m, m, rad (rates per s, accelerations per s^2).
PLATFORM_DOF_NAMES = ('surge', 'heave', 'roll')


class TrajectoryPoint(NamedTuple):
    """The fields of one ``trajectory_msgs/JointTrajectoryPoint``: the four
    number sequences as received (any length) and ``time_from_start``
    (``sec``, ``nanosec``)."""

    positions: tuple[float, ...]
    velocities: tuple[float, ...]
    accelerations: tuple[float, ...]
    effort: tuple[float, ...]
    sec: int
    nanosec: int


class Trajectory(NamedTuple):
    """The fields of a ``trajectory_msgs/JointTrajectory`` the node uses: the
    header stamp, ``joint_names`` and the points (``header.frame_id`` is not
    checked, as for the other setpoints)."""

    sec: int
    nanosec: int
    joint_names: tuple[str, ...]
    points: tuple[TrajectoryPoint, ...]


#: Fewest bytes of a serialized JointTrajectoryPoint: four sequence counts
#: (empty sequences) and a Duration.
_MIN_POINT_BYTES = 24
_MAX_CACHED_DOUBLES = 8


class _CdrFormats:
    """The struct formats of one byte order (``order``: '<' or '>')."""

    __slots__ = ('order', 'head', 'u32', 'duration', 'doubles')

    def __init__(self, order: str) -> None:
        self.order = order
        self.head = struct.Struct(order + 'iII')           # stamp sec, nanosec, len(frame_id)
        self.u32 = struct.Struct(order + 'I')
        self.duration = struct.Struct(order + 'iI')
        self.doubles = tuple(struct.Struct(f'{order}{n}d')
                             for n in range(_MAX_CACHED_DOUBLES + 1))

    def double_struct(self, n: int) -> struct.Struct:
        return self.doubles[n] if n <= _MAX_CACHED_DOUBLES else struct.Struct(f'{self.order}{n}d')


def _read_doubles(data: bytes, at: int, fmt: _CdrFormats) -> tuple[tuple[float, ...], int]:
    """A ``float64[]`` of a serialized sample at byte ``at``: (values, end)."""
    at += -at & 3
    (n,) = fmt.u32.unpack_from(data, at)
    at += 4
    if not n:
        return (), at                      # no alignment without elements
    at += (4 - at) & 7                     # doubles: 8-aligned relative to byte 4
    end = at + 8 * n
    if end > len(data):
        raise struct.error(f'a sequence of {n} doubles at byte {at} runs past the end '
                           f'({len(data)} bytes)')
    return fmt.double_struct(n).unpack_from(data, at), end


class TrajectoryReader:
    """Read a serialized (CDR) ``trajectory_msgs/JointTrajectory`` without
    building the Python message (the ``platform_setpoint`` input; the same
    reasons as :class:`StampedReader`).

    Layout (XCDR1, plain CDR, either byte order; alignment of every field to
    its size counted from the end of the 4-byte encapsulation):

    * ``std_msgs/Header``: ``int32 sec``, ``uint32 nanosec``, ``frame_id``
      (``uint32`` length including the terminating NUL, then the bytes);
    * ``string[] joint_names``: ``uint32`` count, then each string as above
      (each length aligned to 4);
    * ``JointTrajectoryPoint[] points``: ``uint32`` count, then per point the
      sequences ``positions``, ``velocities``, ``accelerations``, ``effort``
      (``uint32`` count, then the doubles aligned to 8 when there are any)
      and ``time_from_start`` (``int32 sec``, ``uint32 nanosec``).

    Calling it returns a :class:`Trajectory`, or None when the sample is in
    another encoding (the caller then deserializes it the usual way). A
    truncated or inconsistent sample raises ``struct.error`` (never reads
    past the end of ``data``, never loops longer than ``data`` is long).
    Names are decoded as UTF-8 (undecodable bytes replaced: such a name is
    wrong anyway and the rejection shows it). Bytes after the message are
    ignored.

    Cheap in the usual case (one point, the same three names in every
    message): the parsed names are kept with the bytes they came from (count,
    lengths and characters; not the padding, whose bytes are arbitrary), and a
    message whose name bytes match gets the same tuple without parsing.
    """

    __slots__ = ('_le', '_be', '_names', '_names_encoding', '_names_parts', '_names_size')

    def __init__(self) -> None:
        self._le = _CdrFormats('<')
        self._be = _CdrFormats('>')
        self._names: tuple[str, ...] = ()
        self._names_encoding = -1
        self._names_parts: tuple[tuple[int, bytes], ...] = ()
        self._names_size = 0

    def __call__(self, data: bytes) -> Trajectory | None:
        if len(data) < 4:
            raise struct.error(f'{len(data)} bytes: not even an encapsulation header')
        if data[0] != 0:
            return None
        encoding = data[1]
        if encoding == 1:
            fmt = self._le
        elif encoding == 0:
            fmt = self._be
        else:
            return None
        size = len(data)
        sec, nanosec, length = fmt.head.unpack_from(data, 4)
        at = 16 + length                   # 4 encapsulation + 12 header bytes + frame_id
        at += -at & 3                      # 4-aligned (relative to byte 4 = absolute)
        names, at = self._joint_names(data, at, encoding, fmt)
        at += -at & 3
        u32 = fmt.u32.unpack_from
        (count,) = u32(data, at)
        at += 4
        if count > (size - at) // _MIN_POINT_BYTES:
            raise struct.error(f'{count} points cannot fit in the {size - at} bytes left')
        duration = fmt.duration.unpack_from
        make_point = TrajectoryPoint._make       # cheaper than the keyword-capable __new__
        points = []
        for _ in range(count):
            positions, at = _read_doubles(data, at, fmt)
            velocities, at = _read_doubles(data, at, fmt)
            accelerations, at = _read_doubles(data, at, fmt)
            effort, at = _read_doubles(data, at, fmt)
            at += -at & 3
            t_sec, t_nanosec = duration(data, at)
            at += 8
            points.append(make_point((positions, velocities, accelerations, effort,
                                      t_sec, t_nanosec)))
        return Trajectory._make((sec, nanosec, names, tuple(points)))

    def _joint_names(self, data: bytes, at: int, encoding: int, fmt: _CdrFormats
                     ) -> tuple[tuple[str, ...], int]:
        """``joint_names`` starting at byte ``at`` (4-aligned): (names, end)."""
        if encoding == self._names_encoding:
            for offset, chunk in self._names_parts:
                if not data.startswith(chunk, at + offset):
                    break
            else:
                return self._names, at + self._names_size
        size = len(data)
        u32 = fmt.u32.unpack_from
        start = at
        (count,) = u32(data, at)
        at += 4
        if count > (size - at) // 4:
            raise struct.error(f'{count} joint names cannot fit in the {size - at} bytes left')
        names = []
        parts = []
        chunk_at = start                   # the current run of bytes without padding
        for _ in range(count):
            aligned = at + (-at & 3)
            if aligned != at:
                parts.append((chunk_at - start, data[chunk_at:at]))
                chunk_at = aligned
            (n,) = u32(data, aligned)
            at = aligned + 4 + n
            if at > size:
                raise struct.error(f'a string of {n} bytes at byte {aligned + 4} runs past '
                                   f'the end ({size} bytes)')
            raw = data[aligned + 4:at]
            if raw and raw[-1] == 0:
                raw = raw[:-1]
            names.append(raw.decode('utf-8', 'replace'))
        parts.append((chunk_at - start, data[chunk_at:at]))
        result = tuple(names)
        self._names, self._names_encoding = result, encoding
        self._names_parts, self._names_size = tuple(parts), at - start
        return result, at


read_joint_trajectory = TrajectoryReader()


class PlatformPoint(NamedTuple):
    """One setpoint of a ``platform_setpoint`` message, checked, in the
    mechanism's coordinates: ``stamp_ns`` = header.stamp + time_from_start,
    ``header`` = that stamp as (sec, nanosec) for the outputs; ``twist`` /
    ``accel`` None when the point has no velocities / accelerations (they are
    then estimated). Sway, pitch and yaw are 0: the message cannot carry them."""

    stamp_ns: int
    header: tuple[int, int]
    pose: PoseInput
    twist: RateInput | None
    accel: RateInput | None


#: The valid joint-name orders seen so far -> index of surge, heave, roll
#: (at most the 6 permutations of PLATFORM_DOF_NAMES).
_DOF_ORDERS: dict[tuple[str, ...], tuple[int, int, int]] = {}

_INT32_MIN, _INT32_LIMIT = -2 ** 31, 2 ** 31
_SHOWN = reprlib.Repr()
_SHOWN.maxlist = _SHOWN.maxtuple = 6
_SHOWN.maxstring = 40


def _shown(values: Sequence[Any]) -> str:
    """``values`` for a log line (at most 6 items, long strings cut)."""
    return _SHOWN.repr(list(values))


def platform_dof_order(joint_names: Sequence[str]) -> tuple[int, int, int]:
    """Index of surge, heave and roll in a ``platform_setpoint``'s
    ``joint_names``, which must be exactly :data:`PLATFORM_DOF_NAMES` in any
    order; raises :class:`SetpointError` (``bad_setpoint``) otherwise."""
    key = tuple(joint_names)
    order = _DOF_ORDERS.get(key)
    if order is not None:
        return order
    if len(key) != len(PLATFORM_DOF_NAMES) or set(key) != set(PLATFORM_DOF_NAMES):
        raise SetpointError(BAD_SETPOINT, f'joint_names must be {", ".join(PLATFORM_DOF_NAMES)} '
                                          f'(each once, in any order), got {_shown(key)}')
    surge, heave, roll = (key.index(name) for name in PLATFORM_DOF_NAMES)
    order = _DOF_ORDERS[key] = (surge, heave, roll)
    return order


def _point_problem(point: TrajectoryPoint) -> SetpointError | None:
    """What is wrong with the numbers of one point, if anything (the checks of
    :func:`platform_setpoints` one by one; None: a sum that overflowed)."""
    p = point.positions
    if len(p) != 3:
        return SetpointError(BAD_SETPOINT, f'positions must be 3 numbers (in the order of '
                                           f'joint_names), got {len(p)}: {_shown(p)}')
    for name, values in (('velocities', point.velocities),
                         ('accelerations', point.accelerations)):
        if len(values) not in (0, 3):
            return SetpointError(BAD_SETPOINT, f'{name} must be 3 numbers or empty (then '
                                               f'estimated), got {len(values)}: '
                                               f'{_shown(values)}')
    if point.effort:
        return SetpointError(BAD_SETPOINT, "effort must be empty (the forces are this node's "
                                           f'output, on actuator_states), got '
                                           f'{len(point.effort)}: {_shown(point.effort)}')
    for name, values in (('positions', p), ('velocities', point.velocities),
                         ('accelerations', point.accelerations)):
        if not all(math.isfinite(v) for v in values):
            return SetpointError(NON_FINITE, f'{name} has a non-finite number: '
                                             f'{_shown(values)}')
    return None


def platform_setpoints(trajectory: Trajectory, max_linear: float, max_angular: float
                       ) -> list[PlatformPoint | SetpointError]:
    """The setpoints of one ``platform_setpoint`` message, point by point.

    Raises :class:`SetpointError` (``bad_setpoint``) when the message as a
    whole is malformed: ``joint_names`` not exactly :data:`PLATFORM_DOF_NAMES`
    (in any order), or no points. Otherwise returns one item per point, in
    the message's order: a :class:`PlatformPoint`, or the
    :class:`SetpointError` that rejects that point alone:

    * ``bad_setpoint``: ``time_from_start`` < 0; a stamp header.stamp +
      time_from_start outside builtin_interfaces/Time (int32 seconds);
      ``positions`` not 3 numbers; ``velocities`` or ``accelerations`` neither
      3 numbers nor empty (empty: estimated by the node); ``effort`` not empty
      (forces are this node's output);
    * ``non_finite``: a NaN or infinity in a sequence used;
    * ``absurd_acceleration``: received accelerations beyond ``max_linear``
      (surge, heave; m/s^2) or ``max_angular`` (roll; rad/s^2), as
      :func:`check_acceleration`;
    * ``stamp_repeated`` / ``stamp_backwards``: a stamp not later than the
      previous point's in the same message (points must be in increasing
      stamp order; the order against the last answered setpoint is the
      synchroniser's, :meth:`StampSynchroniser.add_complete`).

    The stamp of a point with time_from_start 0 is the header stamp as
    received; others are normalised (0 <= nanosec < 1e9).
    """
    surge, heave, roll = platform_dof_order(trajectory.joint_names)
    points = trajectory.points
    if not points:
        raise SetpointError(BAD_SETPOINT, 'points is empty (each point is one setpoint)')
    sec, nanosec = trajectory.sec, trajectory.nanosec
    base_ns = sec * 1_000_000_000 + nanosec
    out: list[PlatformPoint | SetpointError] = []
    previous: int | None = None
    make_pose, make_rates, make_point = PoseInput._make, RateInput._make, PlatformPoint._make
    for index, point in enumerate(points):
        offset_ns = point.sec * 1_000_000_000 + point.nanosec
        if offset_ns < 0:
            out.append(SetpointError(BAD_SETPOINT, f'point {index}: time_from_start must be '
                                                   f'>= 0, got {offset_ns * 1e-9:.9g} s (sec '
                                                   f'{point.sec}, nanosec {point.nanosec})'))
            continue
        stamp_ns = base_ns + offset_ns
        before, previous = previous, stamp_ns
        try:
            if offset_ns == 0:
                header = (sec, nanosec)
            else:
                stamp_sec, stamp_nanosec = divmod(stamp_ns, 1_000_000_000)
                if not _INT32_MIN <= stamp_sec < _INT32_LIMIT:
                    raise SetpointError(BAD_SETPOINT, f'header.stamp + time_from_start = '
                                                      f'{stamp_sec} s is beyond '
                                                      'builtin_interfaces/Time (int32 seconds)')
                header = (stamp_sec, stamp_nanosec)
            p, v, a = point.positions, point.velocities, point.accelerations
            # the usual case in one test; _point_problem says what is wrong
            if (len(p) != 3 or (v and len(v) != 3) or (a and len(a) != 3) or point.effort
                    or not math.isfinite(p[0] + p[1] + p[2]
                                         + (v[0] + v[1] + v[2] if v else 0.0)
                                         + (a[0] + a[1] + a[2] if a else 0.0))):
                problem = _point_problem(point)
                if problem is not None:
                    raise problem
            # (_make: cheaper than the keyword-capable constructors)
            pose = make_pose(((p[surge], p[heave], p[roll]), 0.0, 0.0, 0.0))
            twist = make_rates(((v[surge], v[heave], v[roll]), 0.0, 0.0, 0.0)) if v else None
            accel = None
            if a:
                accel = make_rates(((a[surge], a[heave], a[roll]), 0.0, 0.0, 0.0))
                check_acceleration(accel.q, max_linear, max_angular)
            if before is not None and stamp_ns <= before:
                raise SetpointError(
                    STAMP_REPEATED if stamp_ns == before else STAMP_BACKWARDS,
                    f'{"repeats" if stamp_ns == before else "precedes"} the previous point\'s '
                    f'stamp {_fmt_stamp(before)} (points must be in increasing stamp order)')
        except SetpointError as exc:
            out.append(SetpointError(exc.reason, f'point {index} (stamp {_fmt_stamp(stamp_ns)})'
                                                 f': {exc}'))
            continue
        out.append(make_point((stamp_ns, header, pose, twist, accel)))
    return out


# ----------------------------------------------------------------------------
# Exact-stamp synchroniser
# ----------------------------------------------------------------------------
P = TypeVar('P')
R = TypeVar('R')

POSE, TWIST, ACCEL = 'pose', 'twist', 'accel'
KINDS = (POSE, TWIST, ACCEL)
#: A whole setpoint in one message (``platform_setpoint``, a JointTrajectory).
PLATFORM = 'platform_setpoint'


@dataclass(slots=True)
class Setpoint(Generic[P, R]):
    """One setpoint: the pose, twist and acceleration carrying ``stamp_ns``.
    ``twist``/``accel`` are None when their stream did not deliver them in
    time (they are then estimated). ``header`` is whatever the caller passed
    with the pose (the node keeps the ROS stamp message there)."""

    stamp_ns: int
    pose: P | None = None
    twist: R | None = None
    accel: R | None = None
    header: Any = None
    first_arrival: float = 0.0


@dataclass(frozen=True, slots=True)
class Rejected:
    """A message the synchroniser dropped: ``reason`` in REJECTION_REASONS."""

    reason: str
    kind: str
    stamp_ns: int
    message: str


class StampSynchroniser(Generic[P, R]):
    """Join pose, twist and acceleration messages with the same header stamp.

    * A setpoint is *complete* when its pose and the message of every
      *expected* optional stream (twist, accel) are there; it is then released
      at once, whatever order the three arrived in.
    * An optional stream is expected for a stamp if it is active and has not
      yet delivered a newer stamp (each topic is in order, so once it has,
      its message for this stamp is lost or was never sent).
    * An optional stream is active until a setpoint waited ``wait`` seconds for
      it in vain; it becomes active again as soon as it delivers a message.
      So a pose-only or pose+twist stream costs one bounded wait at start-up
      and none afterwards, and a full stream is never answered without its
      twist/accel unless one is lost or more than ``wait`` late.
    * Setpoints are released in stamp order: when a setpoint is complete,
      older incomplete ones are released first (with what they have; those
      without a pose are rejected as ``no_pose``).
    * Stamps must increase: a pose whose stamp equals or precedes the last
      released one is rejected (``stamp_repeated`` / ``stamp_backwards``), a
      twist/accel for a released stamp is ``late``. A stamp the caller
      rejected (:meth:`discard`) drops the other messages with that stamp
      silently.
    * At most ``max_pending`` stamps wait at once (the oldest is released or
      rejected as ``overflow``).
    * A setpoint that arrives whole in one message (:meth:`add_complete`)
      follows the same stamp rules against the same last released stamp, and
      releases the older pending setpoints first, so the two inputs can be
      mixed without answering out of order.

    :meth:`add`, :meth:`add_complete` and :meth:`poll` return ``(released,
    rejected)`` lists; the
    caller passes the time ``now`` (monotonic seconds), so the class has no
    clock and no thread of its own: call :meth:`poll` periodically (faster
    than ``wait``).
    """

    def __init__(self, wait: float = 0.05, max_pending: int = 64) -> None:
        self.wait = float(wait)
        self.max_pending = int(max_pending)
        self._pending: dict[int, Setpoint[P, R]] = {}
        self._last_released: int | None = None
        self.active = {TWIST: True, ACCEL: True}
        self._newest: dict[str, int | None] = {TWIST: None, ACCEL: None}
        # stamps the caller rejected -> kinds already seen (insertion-ordered, bounded)
        self._discarded: dict[int, set[str]] = {}

    # -- public --------------------------------------------------------------
    @property
    def last_released(self) -> int | None:
        """Stamp (ns) of the last released setpoint, None before the first."""
        return self._last_released

    @property
    def pending(self) -> int:
        return len(self._pending)

    def reset(self) -> None:
        """Forget pending setpoints and stamp history (streams stay as they are)."""
        self._pending.clear()
        self._last_released = None
        self._discarded.clear()
        self._newest = {TWIST: None, ACCEL: None}

    def discard(self, stamp_ns: int, kind: str) -> None:
        """The caller rejected the ``kind`` message with this stamp: drop the
        pending setpoint and ignore the other kinds' messages with the stamp
        (a second message of a kind already seen is reported as a duplicate)."""
        entry = self._pending.pop(stamp_ns, None)
        seen = self._discarded.setdefault(stamp_ns, set())
        seen.add(kind)
        if entry is not None:
            seen.update(k for k in KINDS if getattr(entry, k) is not None)
        while len(self._discarded) > 4 * max(self.max_pending, 1):
            del self._discarded[next(iter(self._discarded))]

    def add(self, kind: str, stamp_ns: int, data: Any, now: float, header: Any = None
            ) -> tuple[list[Setpoint[P, R]], list[Rejected]]:
        """Add one message of ``kind`` (``pose``, ``twist`` or ``accel``)."""
        released: list[Setpoint[P, R]] = []
        rejected: list[Rejected] = []
        seen = self._discarded.get(stamp_ns)
        if seen is not None:
            if kind in seen:
                rejected.append(Rejected(DUPLICATE, kind, stamp_ns,
                                         f'second {kind} for the rejected stamp '
                                         f'{_fmt_stamp(stamp_ns)} (ignored)'))
            seen.add(kind)
            return released, rejected
        if kind != POSE:
            self.active[kind] = True
            newest = self._newest[kind]
            if newest is None or stamp_ns > newest:
                self._newest[kind] = stamp_ns
        last = self._last_released
        if last is not None and stamp_ns <= last:
            if kind == POSE:
                rejected.append(_not_after_last(kind, stamp_ns, last))
            else:
                rejected.append(Rejected(LATE, kind, stamp_ns,
                                         f'{kind} stamped {_fmt_stamp(stamp_ns)} arrived after '
                                         'its setpoint was answered (or after a newer one)'))
            return released, rejected
        pending = self._pending
        entry = pending.get(stamp_ns)
        if entry is None:
            if len(pending) >= self.max_pending:
                self._evict_oldest(released, rejected)
            entry = Setpoint(stamp_ns, first_arrival=now)
            pending[stamp_ns] = entry
        if getattr(entry, kind) is not None:
            rejected.append(Rejected(DUPLICATE, kind, stamp_ns,
                                     f'second {kind} for stamp {_fmt_stamp(stamp_ns)} (ignored)'))
            return released, rejected
        setattr(entry, kind, data)
        if kind == POSE:
            entry.header = header
        if len(pending) == 1:          # the usual case: only this stamp is pending
            if self._complete(entry):
                del pending[stamp_ns]
                self._release(entry, released, rejected)
            return released, rejected
        newest_complete = None
        complete = self._complete
        for stamp, other in pending.items():
            if (newest_complete is None or stamp > newest_complete) and complete(other):
                newest_complete = stamp
        if newest_complete is not None:
            self._release_through(newest_complete, released, rejected)
        return released, rejected

    def add_complete(self, stamp_ns: int, pose: Any, twist: Any, accel: Any, now: float,
                     header: Any = None, kind: str = PLATFORM
                     ) -> tuple[list[Setpoint[P, R]], list[Rejected]]:
        """Add a whole setpoint that came in one message (``kind``, for the
        messages): pose, twist and acceleration (None: to be estimated).

        It obeys the stamp rules of :meth:`add`: a stamp equal to the last
        released one is ``stamp_repeated``, an older one ``stamp_backwards``.
        A stamp that is pending (some of its three messages are here) or was
        rejected (:meth:`discard`) is a second setpoint for that stamp:
        ``duplicate``, and this one is dropped (the pending one stays). Else
        the pending setpoints with older stamps are released first, in stamp
        order and with what they have (those without a pose are rejected as
        ``no_pose``), exactly as when a newer three-message setpoint
        completes; then this one. The stream state (active, newest stamps) of
        the twist and accel topics is not touched."""
        released: list[Setpoint[P, R]] = []
        rejected: list[Rejected] = []
        last = self._last_released
        if last is not None and stamp_ns <= last:
            rejected.append(_not_after_last(kind, stamp_ns, last))
            return released, rejected
        pending = self._pending
        if stamp_ns in pending or stamp_ns in self._discarded:
            rejected.append(Rejected(DUPLICATE, kind, stamp_ns,
                                     f'{kind} for stamp {_fmt_stamp(stamp_ns)}, for which '
                                     'pose/twist/accel messages came too (ignored)'))
            return released, rejected
        if pending:
            self._release_through(stamp_ns, released, rejected)
        self._release(Setpoint(stamp_ns, pose, twist, accel, header, now), released, rejected)
        return released, rejected

    def poll(self, now: float) -> tuple[list[Setpoint[P, R]], list[Rejected]]:
        """Release or reject the setpoints that waited ``wait`` seconds."""
        released: list[Setpoint[P, R]] = []
        rejected: list[Rejected] = []
        if not self._pending:
            return released, rejected
        expired = [s for s, e in self._pending.items() if now - e.first_arrival >= self.wait]
        if expired:
            newest = max(expired)
            for stamp in sorted(s for s in self._pending if s <= newest):
                entry = self._pending[stamp]
                if entry.pose is not None:
                    for kind in (TWIST, ACCEL):
                        if getattr(entry, kind) is None:
                            self.active[kind] = False
            # newer setpoints that waited for the streams just found silent
            for stamp in self._pending:
                if stamp > newest and self._complete(self._pending[stamp]):
                    newest = stamp
            self._release_through(newest, released, rejected)
        return released, rejected

    # -- internals -----------------------------------------------------------
    def _expected(self, kind: str, stamp_ns: int) -> bool:
        newest = self._newest[kind]
        return self.active[kind] and (newest is None or newest < stamp_ns)

    def _complete(self, entry: Setpoint[P, R]) -> bool:
        if entry.pose is None:
            return False
        if entry.twist is None and self._expected(TWIST, entry.stamp_ns):
            return False
        return entry.accel is not None or not self._expected(ACCEL, entry.stamp_ns)

    def _release_through(self, stamp_ns: int, released: list, rejected: list) -> None:
        for stamp in sorted(s for s in self._pending if s <= stamp_ns):
            entry = self._pending.pop(stamp)
            self._release(entry, released, rejected)

    def _release(self, entry: Setpoint[P, R], released: list, rejected: list) -> None:
        if entry.pose is None:
            kinds = '+'.join(k for k in (TWIST, ACCEL) if getattr(entry, k) is not None)
            rejected.append(Rejected(NO_POSE, kinds, entry.stamp_ns,
                                     f'{kinds} stamped {_fmt_stamp(entry.stamp_ns)} '
                                     'has no pose with the same stamp'))
            return
        self._last_released = entry.stamp_ns
        released.append(entry)

    def _evict_oldest(self, released: list, rejected: list) -> None:
        oldest = min(self._pending)
        entry = self._pending.pop(oldest)
        if entry.pose is None:
            rejected.append(Rejected(OVERFLOW, 'twist/accel', oldest,
                                     f'more than {self.max_pending} incomplete stamps pending; '
                                     f'dropped stamp {_fmt_stamp(oldest)}'))
        else:
            self._release_through(oldest, released, rejected)
            self._release(entry, released, rejected)


def _not_after_last(kind: str, stamp_ns: int, last: int) -> Rejected:
    """The rejection of a setpoint (its pose, or a whole one) whose stamp is
    not later than the last answered ``last``: ``stamp_repeated`` or
    ``stamp_backwards``."""
    repeated = stamp_ns == last
    return Rejected(STAMP_REPEATED if repeated else STAMP_BACKWARDS, kind, stamp_ns,
                    f'{kind} stamp {_fmt_stamp(stamp_ns)} '
                    f'{"repeats" if repeated else "precedes"} the last answered stamp '
                    f'{_fmt_stamp(last)}')


def _fmt_stamp(stamp_ns: int) -> str:
    return f'{stamp_ns // 1_000_000_000}.{stamp_ns % 1_000_000_000:09d}'


# ----------------------------------------------------------------------------
# Estimation of missing rates and accelerations
# ----------------------------------------------------------------------------
ESTIMATORS = ('backward', 'backward2')


def backward_derivative(times: list[float], values: list[Vec3], order: int) -> Vec3:
    """Derivative at ``times[-1]`` from the last samples (causal).

    ``order`` 1: two-point backward difference ``(f_k - f_k-1) / h`` (error
    ``h f''/2``). ``order`` 2: derivative at ``t_k`` of the parabola through
    the last three samples (BDF2, error ``h^2 f'''/3`` on a uniform grid);
    the steps may be unequal. Falls back to order 1 with two samples and to
    zero with one.
    """
    n = len(times)
    if n < 2:
        return (0.0, 0.0, 0.0)
    if order == 1 or n < 3:
        h = times[-1] - times[-2]
        f1, f0 = values[-1], values[-2]
        return ((f1[0] - f0[0]) / h, (f1[1] - f0[1]) / h, (f1[2] - f0[2]) / h)
    h1 = times[-1] - times[-2]
    h2 = times[-2] - times[-3]
    c0 = (2.0 * h1 + h2) / (h1 * (h1 + h2))
    c1 = -(h1 + h2) / (h1 * h2)
    c2 = h1 / (h2 * (h1 + h2))
    f0, f1, f2 = values[-1], values[-2], values[-3]
    return (c0 * f0[0] + c1 * f1[0] + c2 * f2[0],
            c0 * f0[1] + c1 * f1[1] + c2 * f2[1],
            c0 * f0[2] + c1 * f1[2] + c2 * f2[2])


class DerivativeEstimator:
    """Fill in missing rates and accelerations from the stream itself.

    Each :meth:`update` takes the pose of one setpoint (stamp in seconds) and
    the measured twist/acceleration when the planner sent them (None
    otherwise). Missing rates are the backward derivative of the last poses;
    missing accelerations the backward derivative of the last rates (the
    measured ones when they came, else the estimated ones), so a pose-only
    stream gets its accelerations from a second difference of poses.
    Roll is unwrapped across +-pi before differencing.

    The history restarts (rates and accelerations estimated as zero, i.e. the
    motion is assumed to start from rest) on the first setpoint, after a gap
    longer than ``max_gap`` seconds, and on :meth:`reset`.
    """

    def __init__(self, method: str = 'backward2', max_gap: float = 0.5) -> None:
        if method not in ESTIMATORS:
            raise ValueError(f'unknown estimator {method!r}; choose one of {ESTIMATORS}')
        self.order = 1 if method == 'backward' else 2
        self.method = method
        self.max_gap = float(max_gap)
        self._t: list[float] = []
        self._q: list[Vec3] = []
        self._qd: list[Vec3] = []

    def reset(self) -> None:
        self._t.clear()
        self._q.clear()
        self._qd.clear()

    def update(self, t: float, q: Vec3, qd: Vec3 | None, qdd: Vec3 | None
               ) -> tuple[Vec3, Vec3]:
        """Record a setpoint and return its (rates, accelerations): the given
        ones where present, estimates otherwise."""
        if self._t and not (0.0 < t - self._t[-1] <= self.max_gap):
            self.reset()
        if self._q:
            prev = self._q[-1]
            q = (q[0], q[1], prev[2] + wrap_angle(q[2] - prev[2]))
        self._t.append(t)
        self._q.append(q)
        if qd is None:
            qd = backward_derivative(self._t, self._q, self.order)
        self._qd.append(qd)
        if qdd is None:
            qdd = backward_derivative(self._t, self._qd, self.order)
        if len(self._t) > 3:
            del self._t[0], self._q[0], self._qd[0]
        return qd, qdd


# ----------------------------------------------------------------------------
# Node configuration (the node parameters of parameters.NODE_PARAMETERS)
# ----------------------------------------------------------------------------
NODE_PARAMETER_NAMES = tuple(spec.name for spec in NODE_PARAMETERS)


@dataclass(frozen=True)
class NodeConfig:
    """The validated node parameters (see ``NODE_PARAMETERS``)."""

    warn_fraction: float
    max_linear_acceleration: float
    max_angular_acceleration: float
    quaternion_tolerance: float
    position_tolerance: float
    angle_tolerance: float
    sync_wait: float
    sync_max_pending: int
    estimator: str
    estimator_max_gap: float
    qos_depth: int
    qos_reliability: str
    diagnostics_period: float
    log_throttle: float
    frame_id: str
    joint_states_frame_id: str

    _FIELDS = {
        'limits.warn_fraction': 'warn_fraction',
        'input.max_linear_acceleration': 'max_linear_acceleration',
        'input.max_angular_acceleration': 'max_angular_acceleration',
        'input.quaternion_tolerance': 'quaternion_tolerance',
        'input.position_tolerance': 'position_tolerance',
        'input.angle_tolerance': 'angle_tolerance',
        'sync.wait': 'sync_wait',
        'sync.max_pending': 'sync_max_pending',
        'estimator.method': 'estimator',
        'estimator.max_gap': 'estimator_max_gap',
        'qos.depth': 'qos_depth',
        'qos.reliability': 'qos_reliability',
        'diagnostics.period': 'diagnostics_period',
        'diagnostics.log_throttle': 'log_throttle',
        'output.frame_id': 'frame_id',
        'output.joint_states_frame_id': 'joint_states_frame_id',
    }

    @classmethod
    def from_values(cls, values: Mapping[str, Any]) -> 'NodeConfig':
        """Check every node parameter in ``values`` (defaults for the absent
        ones) and the relations between them; raises ParameterError."""
        kwargs = {}
        for name, field in cls._FIELDS.items():
            spec = SPECS[name]
            kwargs[field] = check_value(spec, values[name] if name in values else spec.default)
        return cls(**kwargs)


def _check_fields_match() -> None:
    missing = set(NodeConfig._FIELDS) ^ set(NODE_PARAMETER_NAMES)
    if missing:  # pragma: no cover - a programming error caught at import
        raise AssertionError(f'NodeConfig and NODE_PARAMETERS disagree on {sorted(missing)}')


_check_fields_match()


# ----------------------------------------------------------------------------
# Limits
# ----------------------------------------------------------------------------
class LimitReport(NamedTuple):
    """Outcome of :func:`check_limits`: the level and what caused it.

    ``usage`` is the largest ratio value/limit over stroke, speed and force
    (1.0 = at a limit)."""

    level: int
    exceeded: tuple[str, ...]
    near: tuple[str, ...]
    usage: float


_LIMIT_NAMES = tuple((f'stroke {leg}', f'speed {leg}', f'force {leg}') for leg in 'ABC')


def check_limits(stroke: Sequence[float], rate: Sequence[float], force: Sequence[float],
                 limits: Limits, warn_fraction: float) -> LimitReport:
    """Compare one solution with the actuator limits (``limits.*``, the model's:
    the solver's status says ``limit`` beyond them). Beyond a limit is ERROR,
    within ``warn_fraction`` of it WARN. The solution is still published: the
    numbers are what the commanded motion requires; the status says it is unsafe.

    Usage of a limit: |force| / max_force, |rate| / max_speed and, for the
    stroke, its distance from the middle of [stroke_min, stroke_max] over the
    half-range (1.0 at either end)."""
    mid = 0.5 * (limits.stroke_max + limits.stroke_min)
    half = 0.5 * (limits.stroke_max - limits.stroke_min)
    max_speed, max_force = limits.max_speed, limits.max_force
    s0, s1, s2 = stroke
    r0, r1, r2 = rate
    f0, f1, f2 = force
    # the usual case first: plain arithmetic, no per-leg containers
    usage = max(abs(s0 - mid) / half, abs(s1 - mid) / half, abs(s2 - mid) / half,
                abs(r0) / max_speed, abs(r1) / max_speed, abs(r2) / max_speed,
                abs(f0) / max_force, abs(f1) / max_force, abs(f2) / max_force)
    if usage < warn_fraction:       # the usual case: no strings
        return LimitReport(OK, _NOTHING, _NOTHING, usage)
    usages = [(abs(stroke[i] - mid) / half, abs(rate[i]) / max_speed,
               abs(force[i]) / max_force) for i in range(3)]
    exceeded: list[str] = []
    near: list[str] = []
    for names, values in zip(_LIMIT_NAMES, usages):
        for name, u in zip(names, values):
            if u > 1.0:
                exceeded.append(name)
            elif u >= warn_fraction:
                near.append(name)
    level = ERROR if exceeded else WARN if near else OK
    return LimitReport(level, tuple(exceeded), tuple(near), usage)


# ----------------------------------------------------------------------------
# Diagnostics bookkeeping
# ----------------------------------------------------------------------------
class CycleStats:
    """Counters and per-period statistics for the diagnostics message.

    Totals (received, answered, rejections by reason, ignored components,
    limit events) accumulate from start-up; solve times, condition extremes
    and the worst level are per reporting period and reset by :meth:`report`.
    Per cycle only the solver's cheap condition figures are recorded; the exact
    cond(Q) of the last solution (an SVD) is computed once per report.
    """

    def __init__(self) -> None:
        self.received = {POSE: 0, TWIST: 0, ACCEL: 0, PLATFORM: 0}   # messages
        self.answered = 0
        self.estimated_twist = 0
        self.estimated_accel = 0
        self.rejected = {reason: 0 for reason in REJECTION_REASONS}
        self.ignored = {c: 0 for c in UNFOLLOWABLE_COMPONENTS}
        self.limit_exceeded = 0
        self.near_limit = 0
        self.near_singular = 0
        self.parameter_changes = 0
        self.parameter_rejections = 0
        self.last_message = ''
        self.last_cond = math.nan
        self.last_jacobian_cond = math.nan
        self.last_force: tuple[float, float, float] | None = None
        self._period_reset(None)

    def _period_reset(self, now: float | None) -> None:
        self._times: list[float] = []
        self._cond_max = 0.0
        self._jacobian_cond_max = 0.0
        self._level = OK
        self._messages: list[str] = []
        self._answered_at_start = self.answered
        self._period_start = now

    def note(self, level: int, message: str) -> None:
        """Raise this period's level to ``level`` and remember why."""
        if level > self._level:
            self._level = level
        if level > OK and message not in self._messages and len(self._messages) < 5:
            self._messages.append(message)

    def reject(self, reason: str, message: str) -> None:
        self.rejected[reason] += 1
        self.last_message = message
        self.note(ERROR if reason in ERROR_REASONS else WARN, f'rejected ({reason})')

    def solved(self, seconds: float, cond: float, jacobian_cond: float,
               force: tuple[float, float, float]) -> None:
        """One answered setpoint: solve time, the solver's kinematic condition
        (of Q) and actuator-Jacobian condition, the forces."""
        self.answered += 1
        self._times.append(seconds)
        self.last_cond = cond
        self.last_jacobian_cond = jacobian_cond
        self.last_force = force
        if cond > self._cond_max:
            self._cond_max = cond
        if jacobian_cond > self._jacobian_cond_max:
            self._jacobian_cond_max = jacobian_cond

    def report(self, now: float, exact_cond: float = math.nan
               ) -> tuple[int, str, list[tuple[str, str]]]:
        """(level, message, [(key, value), ...]) for this period; starts a new one.
        ``exact_cond``: cond(Q) of the last solution (SVD), if known."""
        times = sorted(self._times)
        n = len(times)
        period = (now - self._period_start) if self._period_start is not None else math.nan
        rate = (self.answered - self._answered_at_start) / period if period and period > 0 else 0.0
        total_rejected = sum(self.rejected.values())
        if n:
            mean_us = 1e6 * sum(times) / n
            median_us = 1e6 * (times[(n - 1) // 2] + times[n // 2]) / 2.0
            p99_us = 1e6 * times[min(n - 1, int(math.ceil(0.99 * n)) - 1)]
            max_us = 1e6 * times[-1]
        else:
            mean_us = median_us = p99_us = max_us = math.nan
        level = self._level
        if self._messages:
            message = '; '.join(self._messages)
        elif self.answered == 0:
            message = 'waiting for setpoints'
        elif n == 0:
            message = 'idle (no setpoint this period)'
        else:
            message = 'OK'
        values = [
            ('status', LEVEL_NAMES[level]),
            ('rate (Hz)', f'{rate:.1f}'),
            ('setpoints answered', str(self.answered)),
            ('solve time mean (us)', f'{mean_us:.1f}'),
            ('solve time median (us)', f'{median_us:.1f}'),
            ('solve time p99 (us)', f'{p99_us:.1f}'),
            ('solve time max (us)', f'{max_us:.1f}'),
            ('solves this period', str(n)),
            ('cond(Q) last', f'{exact_cond:.4g}'),
            ('kinematic condition last', f'{self.last_cond:.4g}'),
            ('kinematic condition max this period', f'{self._cond_max:.4g}' if n else 'nan'),
            ('Jacobian condition last', f'{self.last_jacobian_cond:.4g}'),
            ('Jacobian condition max this period',
             f'{self._jacobian_cond_max:.4g}' if n else 'nan'),
            ('rejected total', str(total_rejected)),
        ]
        values += [(f'rejected {reason}', str(count)) for reason, count in self.rejected.items()]
        values += [(f'ignored {c}', str(count)) for c, count in self.ignored.items()]
        values += [
            ('limit exceeded', str(self.limit_exceeded)),
            ('near limit', str(self.near_limit)),
            ('near singular', str(self.near_singular)),
            ('received pose', str(self.received[POSE])),
            ('received twist', str(self.received[TWIST])),
            ('received accel', str(self.received[ACCEL])),
            ('received platform_setpoint', str(self.received[PLATFORM])),
            ('estimated twist', str(self.estimated_twist)),
            ('estimated accel', str(self.estimated_accel)),
            ('parameter changes accepted', str(self.parameter_changes)),
            ('parameter changes rejected', str(self.parameter_rejections)),
            ('last rejection', self.last_message),
        ]
        self._period_reset(now)
        return level, message, values


class LogThrottle:
    """At most one log line per ``key`` per ``period`` seconds; counts the
    suppressed ones so the next line can say how many were skipped."""

    def __init__(self, period: float = 1.0) -> None:
        self.period = float(period)
        self._last: dict[str, float] = {}
        self._suppressed: dict[str, int] = {}

    def __call__(self, key: str, now: float) -> int | None:
        """None: do not log now. Else the number suppressed since the last line."""
        last = self._last.get(key)
        if last is not None and now - last < self.period:
            self._suppressed[key] = self._suppressed.get(key, 0) + 1
            return None
        self._last[key] = now
        return self._suppressed.pop(key, 0)
