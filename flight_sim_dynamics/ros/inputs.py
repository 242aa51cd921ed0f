"""Input checks of the node's setpoints, without ROS.

Everything between "the numbers of a message" and "a setpoint to solve":

* the rejection reasons (diagnostics counters) and :class:`SetpointError`;
* :func:`quaternion_to_rpy` / :func:`rpy_to_quaternion` -- roll, pitch, yaw
  of a quaternion (ZYX, REP-103), with the checks for non-finite, zero and
  non-unit quaternions;
* :func:`pose_input`, :func:`rate_input`, :func:`check_acceleration`,
  :func:`unfollowable` -- the three commanded coordinates (surge, heave,
  roll, the mechanism's q of mechanism.md) and the components the mechanism
  cannot follow;
* :func:`platform_setpoints` -- the points of one ``platform_setpoint``
  (``trajectory_msgs/JointTrajectory`` over :data:`PLATFORM_DOF_NAMES`),
  checked point by point.

Units: SI throughout (m, rad, s); stamps are integer nanoseconds.
"""
from __future__ import annotations

import math
import reprlib
from typing import Any, Iterable, NamedTuple, Sequence

# ----------------------------------------------------------------------------
# Rejection reasons (diagnostics counters). A *rejected* setpoint is not
# solved and nothing is published for it.
# ----------------------------------------------------------------------------
NON_FINITE = 'non_finite'                  # NaN or infinity in a field
BAD_QUATERNION = 'bad_quaternion'          # zero-length or non-unit quaternion
STAMP_REPEATED = 'stamp_repeated'          # stamp equal to the last answered one
STAMP_BACKWARDS = 'stamp_backwards'        # stamp older than the last answered one
FUTURE_STAMP = 'future_stamp'              # stamp beyond input.max_future ahead of the clock
DUPLICATE = 'duplicate'                    # second message of one kind for a pending stamp
NO_POSE = 'no_pose'                        # twist/accel whose pose never arrived
LATE = 'late'                              # twist/accel after its setpoint was answered
OVERFLOW = 'overflow'                      # too many incomplete stamps pending
ABSURD_ACCELERATION = 'absurd_acceleration'  # |acceleration| beyond input.max_*_acceleration
UNREACHABLE = 'unreachable'                # the loops cannot close at this pose
SOLVER_ERROR = 'solver_error'              # any other solver failure
NON_FINITE_OUTPUT = 'non_finite_output'    # the solver returned NaN/inf (never published)
BAD_SETPOINT = 'bad_setpoint'              # a malformed serialized sample, platform_setpoint
#                                            message or point
WARMING_UP = 'warming_up'                  # its estimate needs history the node does not have
INACTIVE = 'inactive'                      # received while the node is not active (lifecycle)
JOINING = 'joining'                        # a stream joined mid-way: its setpoint's other
#                                            messages were published before the node listened

REJECTION_REASONS = (NON_FINITE, BAD_QUATERNION, STAMP_REPEATED, STAMP_BACKWARDS,
                     FUTURE_STAMP, DUPLICATE, NO_POSE, LATE, OVERFLOW, ABSURD_ACCELERATION,
                     UNREACHABLE, SOLVER_ERROR, NON_FINITE_OUTPUT, BAD_SETPOINT, WARMING_UP,
                     INACTIVE, JOINING)

#: Reasons that make the diagnostics level ERROR (the rest of the rejections
#: are stream hygiene problems and make it WARN).
ERROR_REASONS = frozenset({NON_FINITE, BAD_QUATERNION, ABSURD_ACCELERATION,
                           UNREACHABLE, SOLVER_ERROR, NON_FINITE_OUTPUT, BAD_SETPOINT})
#: Setpoints not answered by design, not for a fault: counted, logged at INFO,
#: the diagnostics level stays OK.
QUIET_REASONS = frozenset({WARMING_UP, INACTIVE, JOINING})

# Motion the mechanism cannot follow: reported, ignored, the setpoint is solved.
SWAY = 'sway'
YAW = 'yaw'
PITCH = 'pitch'
UNFOLLOWABLE_COMPONENTS = (SWAY, YAW, PITCH)

Vec3 = tuple[float, float, float]
_NOTHING: tuple[str, ...] = ()


class SetpointError(ValueError):
    """A setpoint message is rejected; ``reason`` is one of REJECTION_REASONS."""

    def __init__(self, reason: str, message: str) -> None:
        self.reason = reason
        super().__init__(message)


# Message kinds (diagnostics counters "received <kind>").
POSE, TWIST, ACCEL = 'pose', 'twist', 'accel'
KINDS = (POSE, TWIST, ACCEL)
#: A whole setpoint in one message (``platform_setpoint``, a JointTrajectory).
PLATFORM = 'platform_setpoint'


def fmt_stamp(stamp_ns: int) -> str:
    """A stamp in nanoseconds as ``sec.nanosec`` for messages."""
    return f'{stamp_ns // 1_000_000_000}.{stamp_ns % 1_000_000_000:09d}'


def check_not_future(stamp_ns: int, latest_ns: int | None) -> None:
    """Raise :class:`SetpointError` (``future_stamp``) for a stamp after
    ``latest_ns`` (the node's clock plus ``input.max_future``; None: no
    check). Such a message is refused before it reaches the synchroniser or
    the estimator, so it leaves no state behind.
    """
    if latest_ns is not None and stamp_ns > latest_ns:
        raise SetpointError(FUTURE_STAMP, f'stamp {fmt_stamp(stamp_ns)} is more than '
                                          'input.max_future ahead of the node\'s clock (latest '
                                          f'accepted {fmt_stamp(latest_ns)})')


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
    built per message, and a tuple is the cheapest immutable record.)
    """

    q: Vec3
    sway: float
    pitch: float
    yaw: float


class RateInput(NamedTuple):
    """A twist or acceleration setpoint: the derivatives of (surge, heave, roll)
    (``q``) and the sway, pitch and yaw components (``sway``, ``pitch``,
    ``yaw``: linear.y, angular.y, angular.z).
    """

    q: Vec3
    sway: float
    pitch: float
    yaw: float


def pose_input(px: float, py: float, pz: float,
               qx: float, qy: float, qz: float, qw: float,
               quaternion_tolerance: float = 1e-3) -> PoseInput:
    """Convert the fields of a geometry_msgs/Pose (REP-103 simulator base,
    origin at G's central position) into a :class:`PoseInput`: surge =
    position.x, heave = position.z, roll = ZYX roll of the orientation.
    """
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
    angular.x).
    """
    # a sum is finite iff every term is (inf - inf is nan), unless it overflows:
    # then the components are checked one by one
    if not math.isfinite(lx + ly + lz + ax + ay + az) and not all(
            math.isfinite(v) for v in (lx, ly, lz, ax, ay, az)):
        raise SetpointError(NON_FINITE, f'{what} has a non-finite component')
    return RateInput((lx, lz, ax), ly, ay, az)


def check_acceleration(qdd: Iterable[float], max_linear: float, max_angular: float,
                       source: str = 'acceleration') -> None:
    """Reject absurd accelerations: |d2 surge|, |d2 heave| > ``max_linear``
    (m/s^2) or |d2 roll| > ``max_angular`` (rad/s^2).
    """
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
# One message per setpoint: trajectory_msgs/JointTrajectory on platform_setpoint
# ----------------------------------------------------------------------------
#: ``joint_names`` of a ``platform_setpoint`` message (trajectory_msgs/
#: JointTrajectory), in any order: they give the order of the numbers of each
#: point. Units m, m, rad (rates per s, accelerations per s^2).
PLATFORM_DOF_NAMES = ('surge', 'heave', 'roll')


class TrajectoryPoint(NamedTuple):
    """The fields of one ``trajectory_msgs/JointTrajectoryPoint``: the four
    number sequences as received (any length) and ``time_from_start``
    (``sec``, ``nanosec``).
    """

    positions: tuple[float, ...]
    velocities: tuple[float, ...]
    accelerations: tuple[float, ...]
    effort: tuple[float, ...]
    sec: int
    nanosec: int


class Trajectory(NamedTuple):
    """The fields of a ``trajectory_msgs/JointTrajectory`` the node uses: the
    header stamp, ``joint_names`` and the points (``header.frame_id`` is not
    checked, as for the other setpoints).
    """

    sec: int
    nanosec: int
    joint_names: tuple[str, ...]
    points: tuple[TrajectoryPoint, ...]


class PlatformPoint(NamedTuple):
    """One setpoint of a ``platform_setpoint`` message, checked, in the
    mechanism's coordinates: ``stamp_ns`` = header.stamp + time_from_start,
    ``header`` = that stamp as (sec, nanosec) for the outputs; ``twist`` /
    ``accel`` None when the point has no velocities / accelerations (they are
    then estimated). Sway, pitch and yaw are 0: the message cannot carry them.
    """

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
    order; raises :class:`SetpointError` (``bad_setpoint``) otherwise.
    """
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
    :func:`platform_setpoints` one by one; None: a sum that overflowed).
    """
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


def platform_setpoints(trajectory: Trajectory, max_linear: float, max_angular: float,
                       latest_ns: int | None = None) -> list[PlatformPoint | SetpointError]:
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
    * ``future_stamp``: a stamp after ``latest_ns`` (:func:`check_not_future`);
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
            check_not_future(stamp_ns, latest_ns)
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
                    f'stamp {fmt_stamp(before)} (points must be in increasing stamp order)')
        except SetpointError as exc:
            out.append(SetpointError(exc.reason, f'point {index} (stamp {fmt_stamp(stamp_ns)})'
                                                 f': {exc}'))
            continue
        out.append(make_point((stamp_ns, header, pose, twist, accel)))
    return out


