"""The setpoint messages' rules, without rclpy: the rejection reasons, the
message kinds and the diagnostic levels the ROS adapter shares; the checks
and conversions of a message (:func:`pose_input`, :func:`rate_input`,
:func:`platform_setpoints`, a refusal a :class:`SetpointError`); what a
machine takes of the messages (:class:`PoseMap`). SI units; stamps in integer ns.
"""
from __future__ import annotations

import math
import reprlib
from typing import Any, NamedTuple, Sequence

from ..core.estimator import Vec, Vec3
from ..core.euler import angular_acceleration, angular_velocity, euler_accelerations, euler_rates
from ..core.machine import Machine

# Rejection reasons (diagnostics counters): nothing is published for them.
NON_FINITE = 'non_finite'                  # NaN or infinity in a field
BAD_QUATERNION = 'bad_quaternion'          # zero-length or non-unit quaternion
STAMP_REPEATED = 'stamp_repeated'          # stamp equal to the last answered one
STAMP_BACKWARDS = 'stamp_backwards'        # stamp older than the last answered one
FUTURE_STAMP = 'future_stamp'              # beyond input.max_future ahead of the clock
DUPLICATE = 'duplicate'                    # second message of one kind for a stamp
NO_POSE = 'no_pose'                        # twist/accel whose pose never arrived
LATE = 'late'                              # twist/accel after its setpoint was answered
OVERFLOW = 'overflow'                      # too many incomplete stamps pending
ABSURD_ACCELERATION = 'absurd_acceleration'  # beyond input.max_*_acceleration
UNREACHABLE = 'unreachable'                # the loops cannot close at this pose
SOLVER_ERROR = 'solver_error'              # any other solver failure, internal errors
NON_FINITE_OUTPUT = 'non_finite_output'    # the solver returned NaN/inf (never published)
BAD_SETPOINT = 'bad_setpoint'              # a malformed message or point, or one too large
WARMING_UP = 'warming_up'                  # its estimate needs history the node lacks
INACTIVE = 'inactive'                      # received while the node is not active
JOINING = 'joining'                        # a stream joined mid-way
REJECTION_REASONS = (NON_FINITE, BAD_QUATERNION, STAMP_REPEATED, STAMP_BACKWARDS,
                     FUTURE_STAMP, DUPLICATE, NO_POSE, LATE, OVERFLOW, ABSURD_ACCELERATION,
                     UNREACHABLE, SOLVER_ERROR, NON_FINITE_OUTPUT, BAD_SETPOINT, WARMING_UP,
                     INACTIVE, JOINING)
ERROR_REASONS = frozenset({NON_FINITE, BAD_QUATERNION, ABSURD_ACCELERATION,
                           UNREACHABLE, SOLVER_ERROR, NON_FINITE_OUTPUT, BAD_SETPOINT})
# not answered by design: counted, logged at INFO, the level stays OK
QUIET_REASONS = frozenset({WARMING_UP, INACTIVE, JOINING})

#: The six components of a pose setpoint (position x, y, z; the orientation's
#: ZYX angles), of which a machine's coordinates are some; the others are
#: motion it cannot follow: reported, ignored, the setpoint is solved.
COMPONENTS = ('surge', 'sway', 'heave', 'roll', 'pitch', 'yaw')
SWAY, YAW, PITCH = 'sway', 'yaw', 'pitch'

POSE, TWIST, ACCEL = 'pose', 'twist', 'accel'
KINDS = (POSE, TWIST, ACCEL)
PLATFORM = 'platform_setpoint'

# diagnostic_msgs/DiagnosticStatus levels; INFO: log lines only
OK, WARN, ERROR = 0, 1, 2
INFO = OK
LEVEL_NAMES = {OK: 'OK', WARN: 'WARN', ERROR: 'ERROR'}

_SHOWN = reprlib.Repr()
_SHOWN.maxlist = _SHOWN.maxtuple = 6
_SHOWN.maxstring = 40
_INT32_MIN, _INT32_LIMIT = -2 ** 31, 2 ** 31


class SetpointError(ValueError):
    """A setpoint message is rejected; ``reason`` is one of REJECTION_REASONS."""

    def __init__(self, reason: str, message: str) -> None:
        self.reason = reason
        super().__init__(message)


def fmt_stamp(stamp_ns: int) -> str:
    """A stamp in nanoseconds as ``sec.nanosec``."""
    return f'{stamp_ns // 1_000_000_000}.{stamp_ns % 1_000_000_000:09d}'


def check_not_future(stamp_ns: int, latest_ns: int | None) -> None:
    if latest_ns is not None and stamp_ns > latest_ns:
        raise SetpointError(FUTURE_STAMP, f'stamp {fmt_stamp(stamp_ns)} is more than '
                                          'input.max_future ahead of the node\'s clock (latest '
                                          f'accepted {fmt_stamp(latest_ns)})')


# -- message checks: q = the machine's coordinates ------------------------------
def quaternion_to_rpy(x: float, y: float, z: float, w: float,
                      tolerance: float = 1e-3) -> Vec3:
    """Roll, pitch, yaw of ``Rz(yaw) Ry(pitch) Rx(roll)`` (REP-103) of a finite
    quaternion of unit length within ``tolerance`` (else SetpointError).
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
    pitch = math.asin(max(-1.0, min(1.0, 2.0 * (w * y - z * x))))
    yaw = math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))
    return roll, pitch, yaw


def rpy_to_quaternion(roll: float, pitch: float = 0.0, yaw: float = 0.0
                      ) -> tuple[float, float, float, float]:
    """Quaternion (x, y, z, w) of ``Rz(yaw) Ry(pitch) Rx(roll)``."""
    cr, sr = math.cos(roll / 2), math.sin(roll / 2)
    cp, sp = math.cos(pitch / 2), math.sin(pitch / 2)
    cy, sy = math.cos(yaw / 2), math.sin(yaw / 2)
    return (sr * cp * cy - cr * sp * sy, cr * sp * cy + sr * cp * sy,
            cr * cp * sy - sr * sp * cy, cr * cp * cy + sr * sp * sy)


#: A message's six numbers: a pose's surge, sway, heave, roll, pitch, yaw
#: (:data:`COMPONENTS`), or a twist's or acceleration's linear x, y, z and angular x, y, z.
Motion = tuple[float, float, float, float, float, float]


def pose_input(px: float, py: float, pz: float, qx: float, qy: float, qz: float, qw: float,
               quaternion_tolerance: float = 1e-3) -> Motion:
    """Position x, y, z and the ZYX roll, pitch, yaw of the orientation (REP-103)."""
    if not math.isfinite(px + py + pz) and not all(map(math.isfinite, (px, py, pz))):
        raise SetpointError(NON_FINITE, f'position has a non-finite component '
                                        f'({px!r}, {py!r}, {pz!r})')
    return (px, py, pz, *quaternion_to_rpy(qx, qy, qz, qw, quaternion_tolerance))


def rate_input(lx: float, ly: float, lz: float, ax: float, ay: float, az: float,
               what: str = 'twist') -> Motion:
    """The six numbers of a twist or acceleration, finite."""
    # a sum is finite iff every term is, unless it overflows (then one by one)
    if not math.isfinite(lx + ly + lz + ax + ay + az) and not all(
            map(math.isfinite, (lx, ly, lz, ax, ay, az))):
        raise SetpointError(NON_FINITE, f'{what} has a non-finite component')
    return (lx, ly, lz, ax, ay, az)


def check_acceleration(qdd: Sequence[float], names: Sequence[str], units: Sequence[str],
                       max_linear: float, max_angular: float,
                       source: str = 'acceleration') -> None:
    """Accelerations of coordinates ``names`` (``units`` m or rad) within the bounds."""
    linear = [v for v, unit in zip(qdd, units) if unit != 'rad']
    if any(abs(v) > max_linear for v in linear):
        raise SetpointError(ABSURD_ACCELERATION,
                            f'{source} ({", ".join(f"{v:.4g}" for v in linear)}) m/s^2 exceeds '
                            f'input.max_linear_acceleration = {max_linear:g} m/s^2')
    for v, name, unit in zip(qdd, names, units):
        if unit == 'rad' and abs(v) > max_angular:
            raise SetpointError(ABSURD_ACCELERATION,
                                f'{source} {name} {v:.4g} rad/s^2 exceeds '
                                f'input.max_angular_acceleration = {max_angular:g} rad/s^2')


class PoseMap:
    """What a machine takes of the setpoint messages (docs/node.md): its
    coordinates (some of :data:`COMPONENTS`, in its order); a twist's and an
    acceleration's linear part as the rates of surge, sway, heave, their
    angular part (the platform's angular velocity and acceleration in the base
    frame) as Euler-angle rates (S2)/(S3) at the angles the machine follows
    (zero for the others); the other components reported as motion it cannot
    follow, except where the machine itself moves them (``Machine.parasitic``).
    """

    def __init__(self, machine: Machine) -> None:
        names = machine.coordinates
        unknown = [c for c in names if c not in COMPONENTS]
        if unknown:
            raise ValueError(f'the node takes the coordinates {", ".join(COMPONENTS)}; '
                             f'{machine.name} has {", ".join(unknown)}')
        self.names, self.units = names, machine.units
        self.index = tuple(COMPONENTS.index(c) for c in names)
        self.parasitic = dict(machine.parasitic)
        others = [c for c in COMPONENTS if c not in names]
        #: reported when beyond the tolerances, those the machine moves last
        self.ignored = tuple([c for c in others if c not in self.parasitic]
                             + [c for c in others if c in self.parasitic])
        self._checks = tuple((c, COMPONENTS.index(c), COMPONENTS.index(c) < 3,
                              self.parasitic.get(c)) for c in self.ignored)
        # the Euler angles followed: their positions in q (None: held at zero);
        # pitch and yaw held: E is the identity, the angular part taken as it is
        self._euler = tuple(names.index(c) if c in names else None
                            for c in COMPONENTS[3:])
        self._identity = self._euler[1] is None and self._euler[2] is None
        #: the coordinates unwrapped across +-pi by the estimator (the angles)
        self.angles = machine.angles
        self._linear = tuple(i for i, unit in enumerate(self.units) if unit != 'rad')

    def coordinates(self, msg: Motion) -> Vec:
        """The machine's components of a message, in its order."""
        return tuple([msg[i] for i in self.index])

    def _angles(self, q: Vec) -> tuple[float, float, float]:
        return tuple([0.0 if i is None else q[i] for i in self._euler])

    def rates(self, q: Vec, twist: Motion) -> Vec:
        """The rates (qd) of a twist at the pose q: linear as given, angular as Euler rates (S2)."""
        if self._identity:
            return tuple([twist[i] for i in self.index])
        euler = euler_rates(self._angles(q), twist[3:])
        return tuple([twist[i] if i < 3 else euler[i - 3] for i in self.index])

    def accelerations(self, q: Vec, qd: Vec, accel: Motion) -> Vec:
        """The accelerations (qdd) of an acceleration at the pose q and rates qd (S3)."""
        if self._identity:
            return tuple([accel[i] for i in self.index])
        euler = euler_accelerations(self._angles(q), self._angles(qd), accel[3:])
        return tuple([accel[i] if i < 3 else euler[i - 3] for i in self.index])

    # -- the other way: the machine's motion as the messages carry it (the twin, the planner)
    def message(self, values: Sequence[float]) -> Motion:
        """The six numbers of a pose (:data:`COMPONENTS`) of the machine's
        coordinates ``values``; zero for the components it lacks.
        """
        out = [0.0] * 6
        for i, v in zip(self.index, values):
            out[i] = float(v)
        return tuple(out)

    def twist(self, q: Sequence[float], qd: Sequence[float]) -> Motion:
        """The six numbers of a twist of the rates qd at the pose q: linear the
        rates of surge, sway, heave, angular the base-frame angular velocity (S2).
        """
        pose, rates = self.message(q), self.message(qd)
        return (*rates[:3], *angular_velocity(pose[3:], rates[3:]))

    def accel(self, q: Sequence[float], qd: Sequence[float], qdd: Sequence[float]) -> Motion:
        """The six numbers of an acceleration of qdd at the pose q and rates qd (S3)."""
        pose, rates, accelerations = self.message(q), self.message(qd), self.message(qdd)
        return (*accelerations[:3],
                *angular_acceleration(pose[3:], rates[3:], accelerations[3:]))

    def check_acceleration(self, qdd: Sequence[float], max_linear: float, max_angular: float,
                           source: str = 'acceleration') -> None:
        """:func:`check_acceleration` of the machine's coordinates."""
        for i in self._linear:
            if abs(qdd[i]) > max_linear:
                break
        else:
            for i in self.angles:
                if abs(qdd[i]) > max_angular:
                    break
            else:
                return
        check_acceleration(qdd, self.names, self.units, max_linear, max_angular, source)

    def unfollowable(self, pose: Motion, twist: Motion | None, accel: Motion | None,
                     solution: Any, position_tolerance: float,
                     angle_tolerance: float) -> tuple[str, ...]:
        """The components beyond the machine's coordinates that the setpoint
        gives beyond the tolerances: a value or a rate, or for one the machine
        moves itself (:attr:`Machine.parasitic`), a value neither zero nor the
        machine's (its rates are not the planner's to choose).
        """
        out = []
        for name, i, linear, own in self._checks:
            tolerance = position_tolerance if linear else angle_tolerance
            value = pose[i]
            if own is not None:
                bad = abs(value) > tolerance and abs(value - own(solution)) > tolerance
            else:
                bad = (abs(value) > tolerance
                       or (twist is not None and abs(twist[i]) > tolerance)
                       or (accel is not None and abs(accel[i]) > tolerance))
            if bad:
                out.append(name)
        return tuple(out)


_MAPS: dict[str, PoseMap] = {}


def pose_map(machine: Machine) -> PoseMap:
    """The :class:`PoseMap` of ``machine``, made once."""
    found = _MAPS.get(machine.name)
    if found is None:
        found = _MAPS[machine.name] = PoseMap(machine)
    return found


class PlatformPoint(NamedTuple):
    """One checked trajectory point, in the machine's coordinates (q, qd, qdd);
    twist / accel None: estimated.
    """

    stamp_ns: int
    header: tuple[int, int]
    pose: Vec
    twist: Vec | None
    accel: Vec | None


def platform_dof_order(joint_names: Sequence[str], coordinates: Sequence[str]
                       ) -> tuple[int, ...]:
    """Index of each of ``coordinates`` in ``joint_names`` (any order)."""
    key = list(joint_names)
    if len(key) != len(coordinates) or set(key) != set(coordinates):
        raise SetpointError(BAD_SETPOINT, f'joint_names must be {", ".join(coordinates)} '
                                          f'(each once, in any order), got {_SHOWN.repr(key)}')
    return tuple(key.index(name) for name in coordinates)


def _point_problem(p: Sequence[float], v: Sequence[float], a: Sequence[float],
                   e: Sequence[float], n: int) -> SetpointError | None:
    if len(p) != n:
        return SetpointError(BAD_SETPOINT, f'positions must be {n} numbers (in the order of '
                                           f'joint_names), got {len(p)}: {_SHOWN.repr(list(p))}')
    for name, values in (('velocities', v), ('accelerations', a)):
        if len(values) not in (0, n):
            return SetpointError(BAD_SETPOINT, f'{name} must be {n} numbers or empty (then '
                                               f'estimated), got {len(values)}: '
                                               f'{_SHOWN.repr(list(values))}')
    if len(e):
        return SetpointError(BAD_SETPOINT, "effort must be empty (the forces are this node's "
                                           f'output), got {len(e)}: {_SHOWN.repr(list(e))}')
    for name, values in (('positions', p), ('velocities', v), ('accelerations', a)):
        if not all(map(math.isfinite, values)):
            return SetpointError(NON_FINITE, f'{name} has a non-finite number: '
                                             f'{_SHOWN.repr(list(values))}')
    return None


def platform_setpoints(msg: Any, poses: PoseMap, max_linear: float, max_angular: float,
                       latest_ns: int | None = None) -> list[PlatformPoint | SetpointError]:
    """A PlatformPoint or SetpointError per point (stamp: header.stamp +
    time_from_start, increasing; joint_names: the coordinates of ``poses``'
    machine); bad joint_names or no points: raised.
    """
    order = platform_dof_order(msg.joint_names, poses.names)
    n = len(order)
    if not msg.points:
        raise SetpointError(BAD_SETPOINT, 'points is empty (each point is one setpoint)')
    sec, nanosec = msg.header.stamp.sec, msg.header.stamp.nanosec
    base_ns = sec * 1_000_000_000 + nanosec
    out: list[PlatformPoint | SetpointError] = []
    previous: int | None = None
    for index, point in enumerate(msg.points):
        t = point.time_from_start
        offset_ns = t.sec * 1_000_000_000 + t.nanosec
        if offset_ns < 0:
            out.append(SetpointError(BAD_SETPOINT, f'point {index}: time_from_start must be '
                                                   f'>= 0, got {offset_ns * 1e-9:.9g} s (sec '
                                                   f'{t.sec}, nanosec {t.nanosec})'))
            continue
        stamp_ns = base_ns + offset_ns
        before, previous = previous, stamp_ns
        try:
            check_not_future(stamp_ns, latest_ns)
            header = (sec, nanosec) if offset_ns == 0 else divmod(stamp_ns, 1_000_000_000)
            if not _INT32_MIN <= header[0] < _INT32_LIMIT:
                raise SetpointError(BAD_SETPOINT, f'header.stamp + time_from_start = '
                                                  f'{header[0]} s is beyond '
                                                  'builtin_interfaces/Time (int32 seconds)')
            p, v, a = point.positions, point.velocities, point.accelerations
            problem = _point_problem(p, v, a, point.effort, n)
            if problem is not None:
                raise problem
            pose = tuple([p[i] for i in order])
            twist = tuple([v[i] for i in order]) if len(v) else None
            accel = tuple([a[i] for i in order]) if len(a) else None
            if accel is not None:
                poses.check_acceleration(accel, max_linear, max_angular)
            if before is not None and stamp_ns <= before:
                raise SetpointError(
                    STAMP_REPEATED if stamp_ns == before else STAMP_BACKWARDS,
                    f'{"repeats" if stamp_ns == before else "precedes"} the previous point\'s '
                    f'stamp {fmt_stamp(before)} (points must be in increasing stamp order)')
        except SetpointError as exc:
            out.append(SetpointError(exc.reason, f'point {index} (stamp {fmt_stamp(stamp_ns)})'
                                                 f': {exc}'))
            continue
        out.append(PlatformPoint(stamp_ns, tuple(header), pose, twist, accel))
    return out
