"""The node's setpoint rules, without rclpy: :class:`SetpointIntake` checks each
message, joins and orders the setpoints, estimates what is missing, solves
(the machine's ``solve``) and returns the answers and log lines due. A
rejected setpoint leaves no trace (docs/node.md, "Stamps"). What a machine
takes of the messages: :class:`PoseMap`. SI units; stamps in integer ns.
"""
from __future__ import annotations

import math
import reprlib
import time
from dataclasses import dataclass
from typing import Any, Callable, NamedTuple, Sequence

import flight_sim_dynamics as fsd

from ..config.parameters import NodeConfig
from ..core.estimator import DerivativeEstimator, Vec, Vec3
from ..core.euler import (EulerSingularity, angular_acceleration, angular_velocity,
                          euler_accelerations, euler_rates)
from ..core.machine import LimitUsage, Machine
from ..core.status import Status
from ..machines.api import machine_of

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
DIAGNOSTIC_TASK = 'inverse dynamics'
RESTART_CONFIRMATIONS = 3          # setpoints in a row far behind: a planner restart
JOIN_WINDOW = 1.0                  # s after the first message: partial setpoints are joining
STALE_WINDOW = 2.0                 # s after an activation: setpoints stamped before it are stale

_SHOWN = reprlib.Repr()
_SHOWN.maxlist = _SHOWN.maxtuple = 6
_SHOWN.maxstring = 40
_INT32_MIN, _INT32_LIMIT = -2 ** 31, 2 ** 31


class SetpointError(ValueError):
    """A setpoint message is rejected; ``reason`` is one of REJECTION_REASONS."""

    def __init__(self, reason: str, message: str) -> None:
        self.reason = reason
        super().__init__(message)


def diagnostic_name(node_fqn: str, task: str = DIAGNOSTIC_TASK) -> str:
    """The node's status name in /diagnostics."""
    return f'{node_fqn}: {task}'


def fmt_stamp(stamp_ns: int) -> str:
    """A stamp in nanoseconds as ``sec.nanosec``."""
    return f'{stamp_ns // 1_000_000_000}.{stamp_ns % 1_000_000_000:09d}'


def check_not_future(stamp_ns: int, latest_ns: int | None) -> None:
    if latest_ns is not None and stamp_ns > latest_ns:
        raise SetpointError(FUTURE_STAMP, f'stamp {fmt_stamp(stamp_ns)} is more than '
                                          'input.max_future ahead of the node\'s clock (latest '
                                          f'accepted {fmt_stamp(latest_ns)})')


# -- message checks: q = (surge, heave, roll) -----------------------------------
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
        self.angles = tuple(i for i, unit in enumerate(self.units) if unit == 'rad')
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
        moves itself (the 3-DOF machine's pitch), a value neither zero nor the
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


# -- joining and ordering the setpoints -------------------------------------------
@dataclass(slots=True)
class Setpoint:
    """The messages with one stamp (twist / accel None: estimated): three
    messages' :data:`Motion` s, or from PLATFORM the machine's q, qd, qdd.
    """

    stamp_ns: int
    pose: Any = None
    twist: Any = None
    accel: Any = None
    header: Any = None
    first_arrival: float = 0.0
    source: str = POSE        # the input that carried it: POSE (three topics) or PLATFORM


class Rejected(NamedTuple):
    reason: str
    kind: str
    stamp_ns: int
    message: str


class RestartRule:
    """A restarted stream told from its stamps, one rule for the node's
    setpoints and the twin's commands: :data:`RESTART_CONFIRMATIONS` stamps in
    a row, in increasing order, each more than ``jump_ns`` before the last
    accepted one. Fewer, or out of order, are stray old messages.
    """

    def __init__(self, jump_ns: int = 0) -> None:
        self.jump_ns = int(jump_ns)
        self._behind: list[int] = []       # the confirmations so far, in a row

    def confirms(self, stamp_ns: int, last_ns: int) -> bool:
        """Whether ``stamp_ns`` (not after ``last_ns``) completes a restart."""
        behind = self._behind
        if last_ns - stamp_ns <= self.jump_ns:
            behind.clear()
            return False
        if behind and stamp_ns <= behind[-1]:
            behind.clear()
        behind.append(stamp_ns)
        if len(behind) < RESTART_CONFIRMATIONS:
            return False
        behind.clear()
        return True

    def clear(self) -> None:
        """A stamp accepted in order: the confirmations start again."""
        self._behind.clear()


class StampSynchroniser:
    """Join pose, twist and accel by exact stamp (bounded wait); release in
    stamp order, once the pose and every active stream are there (a stream
    waited for ``wait`` s in vain is inactive until its next message); older
    incomplete ones first. Setpoints more than ``restart_jump`` s behind are a
    planner restart by :class:`RestartRule` (:meth:`_restarted`: on either
    input); at most ``max_pending`` stamps wait; for ``join_window`` s partial
    setpoints are ``joining``. Methods return (released, rejected); poll faster
    than ``wait``.
    """

    def __init__(self, wait: float = 0.05, max_pending: int = 64,
                 restart_jump: float = 0.0, join_window: float = 0.0) -> None:
        self.wait = float(wait)
        self.join_window = float(join_window)
        self.max_pending = int(max_pending)
        self.restart = RestartRule(round(float(restart_jump) * 1e9))
        self.restarts = 0
        self._heard: dict[str, float] = {}     # input (POSE, PLATFORM) -> its last message's time
        self._pending: dict[int, Setpoint] = {}
        self.last_released: int | None = None
        self._last_source: str | None = None     # the input of last_released
        self.active = {TWIST: True, ACCEL: True}
        self._newest: dict[str, int | None] = {TWIST: None, ACCEL: None}
        self._discarded: dict[int, set[str]] = {}   # rejected stamp -> kinds seen (bounded)
        self._join_until: float | None = None
        self._first_pose: int | None = None
        self._in_join = False
        self._stream_join_until: dict[str, float] = {}   # each twist/accel topic's own window

    @property
    def pending(self) -> int:
        return len(self._pending)

    def reset(self) -> None:
        """Forget pending setpoints and stamp history (streams stay as they are)."""
        self._pending.clear()
        self.last_released = None
        self._discarded.clear()
        self.restart.clear()
        self._newest = {TWIST: None, ACCEL: None}
        self._first_pose = None

    def withdraw(self, setpoint: Setpoint, answered: int | None) -> None:
        """Undo a released setpoint the caller could not answer."""
        self.discard(setpoint.stamp_ns, POSE, setpoint)
        last = self.last_released
        if last is not None and last == setpoint.stamp_ns:
            self.last_released = answered

    def discard(self, stamp_ns: int, kind: str, entry: Setpoint | None = None) -> None:
        """Drop the stamp of a rejected message; its other messages are ignored."""
        pending = self._pending.pop(stamp_ns, None)
        entry = pending if pending is not None else entry
        seen = self._discarded.setdefault(stamp_ns, set())
        seen.add(kind)
        if entry is not None:
            seen.update(k for k in KINDS if getattr(entry, k) is not None)
        while len(self._discarded) > 4 * max(self.max_pending, 1):
            del self._discarded[next(iter(self._discarded))]

    def add(self, kind: str, stamp_ns: int, data: Any, now: float, header: Any = None
            ) -> tuple[list[Setpoint], list[Rejected]]:
        """Add one message of ``kind`` (``pose``, ``twist`` or ``accel``)."""
        released: list[Setpoint] = []
        rejected: list[Rejected] = []
        self._heard[POSE] = now
        joining = self._joining(now)
        stream_joining = kind != POSE and self._stream_joining(kind, now)
        seen = self._discarded.get(stamp_ns)
        if seen is not None:
            if kind in seen:
                rejected.append(Rejected(DUPLICATE, kind, stamp_ns,
                                         f'second {kind} for the rejected stamp '
                                         f'{fmt_stamp(stamp_ns)} (ignored)'))
            seen.add(kind)
            return released, rejected
        last = self.last_released
        if last is not None and stamp_ns <= last:
            if kind != POSE:
                # an old message proves its stream alive; it is not its newest stamp
                if stream_joining and self._newest[kind] is None:
                    rejected.append(_joined(kind, stamp_ns, 'its topic matched after the pose '
                                                            'topic; its setpoint was answered'))
                else:
                    rejected.append(Rejected(LATE, kind, stamp_ns,
                                             f'{kind} stamped {fmt_stamp(stamp_ns)} arrived '
                                             'after its setpoint was answered (or after a '
                                             'newer one)'))
                self.active[kind] = True
                return released, rejected
            if not self._restarted(stamp_ns, last, POSE, now):
                rejected.append(_not_after_last(kind, stamp_ns, last))
                return released, rejected
        pending = self._pending
        first = self._first_pose
        if kind == POSE and first is None:
            self._first_pose = stamp_ns
            if joining:
                self._drop_before_first_pose(stamp_ns, rejected)
        elif joining and first is not None and stamp_ns < first and kind != POSE:
            rejected.append(_joined(kind, stamp_ns, 'stamped before the first pose'))
            return released, rejected
        entry = pending.get(stamp_ns)
        if entry is None:
            if len(pending) >= self.max_pending:
                self._evict_oldest(released, rejected, joining and first is None)
            entry = Setpoint(stamp_ns, first_arrival=now)
            pending[stamp_ns] = entry
        if getattr(entry, kind) is not None:
            rejected.append(Rejected(DUPLICATE, kind, stamp_ns,
                                     f'second {kind} for stamp {fmt_stamp(stamp_ns)} (ignored)'))
            return released, rejected
        setattr(entry, kind, data)
        if kind == POSE:
            entry.header = header
            self._streams_seen(entry)
        elif entry.pose is not None:
            self._streams_seen(entry)
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
                     ) -> tuple[list[Setpoint], list[Rejected]]:
        """A whole setpoint in one message, under the stamp rules of :meth:`add`."""
        released: list[Setpoint] = []
        rejected: list[Rejected] = []
        self._heard[PLATFORM] = now
        last = self.last_released
        if (last is not None and stamp_ns <= last
                and not self._restarted(stamp_ns, last, kind, now)):
            rejected.append(_not_after_last(kind, stamp_ns, last))
            return released, rejected
        pending = self._pending
        if stamp_ns in pending or stamp_ns in self._discarded:
            rejected.append(Rejected(DUPLICATE, kind, stamp_ns,
                                     f'{kind} for stamp {fmt_stamp(stamp_ns)}, for which '
                                     'pose/twist/accel messages came too (ignored)'))
            return released, rejected
        self._joining(now)
        if pending:
            self._release_through(stamp_ns, released, rejected)
        self._release(Setpoint(stamp_ns, pose, twist, accel, header, now, kind), released,
                      rejected)
        return released, rejected

    def poll(self, now: float) -> tuple[list[Setpoint], list[Rejected]]:
        """Release or reject the setpoints that waited ``wait`` seconds."""
        released: list[Setpoint] = []
        rejected: list[Rejected] = []
        if not self._pending:
            return released, rejected
        expired = [s for s, e in self._pending.items() if now - e.first_arrival >= self.wait]
        if expired:
            self._joining(now)
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

    def _joining(self, now: float) -> bool:
        if self._join_until is None:
            self._join_until = now + self.join_window
        self._in_join = now < self._join_until
        return self._in_join

    def _stream_joining(self, kind: str, now: float) -> bool:
        until = self._stream_join_until.setdefault(kind, now + self.join_window)
        return now < until

    def _restarted(self, stamp_ns: int, last: int, source: str, now: float) -> bool:
        """This setpoint (not after ``last``), arrived at ``now`` on ``source``,
        confirms a planner restart (:class:`RestartRule`). On another input
        than the one that carried ``last``, only once that one has been silent
        for ``restart_jump`` s: an input lagging behind a live one is refused,
        so outputs stay in stamp order.
        """
        rule = self.restart
        jump = rule.jump_ns
        if not jump or (source != self._last_source and now - self._heard.get(
                self._last_source, -math.inf) < jump * 1e-9):
            rule.clear()
            return False
        if not rule.confirms(stamp_ns, last):
            return False
        self.reset()
        self.restarts += 1
        return True

    def _streams_seen(self, entry: Setpoint) -> None:
        stamp = entry.stamp_ns
        for kind in (TWIST, ACCEL):
            if getattr(entry, kind) is not None:
                self.active[kind] = True
                newest = self._newest[kind]
                if newest is None or stamp > newest:
                    self._newest[kind] = stamp

    def _expected(self, kind: str, stamp_ns: int) -> bool:
        newest = self._newest[kind]
        return self.active[kind] and (newest is None or newest < stamp_ns)

    def _complete(self, entry: Setpoint) -> bool:
        if entry.pose is None:
            return False
        if entry.twist is None and self._expected(TWIST, entry.stamp_ns):
            return False
        return entry.accel is not None or not self._expected(ACCEL, entry.stamp_ns)

    def _release_through(self, stamp_ns: int, released: list, rejected: list) -> None:
        for stamp in sorted(s for s in self._pending if s <= stamp_ns):
            entry = self._pending.pop(stamp)
            self._release(entry, released, rejected)

    def _release(self, entry: Setpoint, released: list, rejected: list) -> None:
        if entry.pose is None:
            kinds = '+'.join(k for k in (TWIST, ACCEL) if getattr(entry, k) is not None)
            if self._in_join and self._first_pose is None:
                rejected.append(_joined(kinds, entry.stamp_ns, 'no pose yet (its topic has '
                                                               'not matched)'))
                return
            rejected.append(Rejected(NO_POSE, kinds, entry.stamp_ns,
                                     f'{kinds} stamped {fmt_stamp(entry.stamp_ns)} '
                                     'has no pose with the same stamp'))
            return
        self.last_released, self._last_source = entry.stamp_ns, entry.source
        self.restart.clear()
        released.append(entry)

    def _drop_before_first_pose(self, first: int, rejected: list) -> None:
        for stamp in sorted(s for s in self._pending if s < first):
            entry = self._pending.pop(stamp)
            rejected.append(_joined('+'.join(k for k in (TWIST, ACCEL)
                                             if getattr(entry, k) is not None),
                                    stamp, 'stamped before the first pose'))

    def _evict_oldest(self, released: list, rejected: list, joining: bool = False) -> None:
        oldest = min(self._pending)
        entry = self._pending.pop(oldest)
        if entry.pose is None and joining:
            rejected.append(_joined('twist/accel', oldest, 'no pose yet (its topic has not '
                                                           'matched)'))
        elif entry.pose is None:
            rejected.append(Rejected(OVERFLOW, 'twist/accel', oldest,
                                     f'more than {self.max_pending} incomplete stamps pending; '
                                     f'dropped stamp {fmt_stamp(oldest)}'))
        else:
            self._release_through(oldest, released, rejected)
            self._release(entry, released, rejected)


def _joined(kind: str, stamp_ns: int, why: str) -> Rejected:
    return Rejected(JOINING, kind, stamp_ns,
                    f'{kind} stamped {fmt_stamp(stamp_ns)} dropped while joining the running '
                    f'stream ({why})')


def _not_after_last(kind: str, stamp_ns: int, last: int) -> Rejected:
    repeated = stamp_ns == last
    return Rejected(STAMP_REPEATED if repeated else STAMP_BACKWARDS, kind, stamp_ns,
                    f'{kind} stamp {fmt_stamp(stamp_ns)} '
                    f'{"repeats" if repeated else "precedes"} the last answered stamp '
                    f'{fmt_stamp(last)}')


# -- limits, /diagnostics, log throttle -----------------------------------------
class LimitReport(NamedTuple):
    """One answer's level (OK, WARN, ERROR) and the names of the limits it
    exceeds and of those it is near.
    """

    level: int
    exceeded: tuple[str, ...]
    near: tuple[str, ...]


def limit_report(usage: LimitUsage, warn_fraction: float) -> LimitReport:
    """Beyond a limit (a usage above 1: the status ``limit``): ERROR, within
    ``warn_fraction`` of one: WARN (published anyway); each limit by its name
    in the machine's :class:`LimitUsage` (``force C``, ``u_joint 1``).
    """
    exceeded: list[str] = []
    near: list[str] = []
    for name, used in zip(usage.names, usage.usage.tolist()):
        if used > 1.0:
            exceeded.append(name)
        elif used >= warn_fraction:
            near.append(name)
    level = ERROR if exceeded else WARN if near else OK
    return LimitReport(level, tuple(exceeded), tuple(near))


class CycleStats:
    """/diagnostics: counters from start-up, statistics per period."""

    def __init__(self, ignorable: Sequence[str] = (SWAY, YAW, PITCH),
                 kinematic: bool = True) -> None:
        """``ignorable``: the components a machine cannot follow; ``kinematic``:
        its solutions have a kinematic condition (reported with the exact cond(Q)).
        """
        self.received = {POSE: 0, TWIST: 0, ACCEL: 0, PLATFORM: 0}   # messages
        self.rejected = {reason: 0 for reason in REJECTION_REASONS}
        self.ignored = {c: 0 for c in ignorable}
        self.kinematic = kinematic
        self.answered = self.estimated_twist = self.estimated_accel = 0
        self.limit_exceeded = self.near_limit = self.near_singular = 0
        self.parameter_changes = self.parameter_rejections = self.planner_restarts = 0
        self.stamp_check = self.last_message = ''
        self.last_cond = self.last_jacobian_cond = math.nan
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
        if level > self._level:
            self._level = level
        if level > OK and message not in self._messages and len(self._messages) < 5:
            self._messages.append(message)

    def reject(self, reason: str, message: str) -> None:
        self.rejected[reason] += 1
        self.last_message = message
        if reason in QUIET_REASONS:
            return
        self.note(ERROR if reason in ERROR_REASONS else WARN, f'rejected ({reason})')

    def solved(self, seconds: float, cond: float, jacobian_cond: float) -> None:
        self.answered += 1
        self._times.append(seconds)
        self.last_cond = cond
        self.last_jacobian_cond = jacobian_cond
        if cond > self._cond_max:
            self._cond_max = cond
        if jacobian_cond > self._jacobian_cond_max:
            self._jacobian_cond_max = jacobian_cond

    def report(self, now: float, exact_cond: float = math.nan
               ) -> tuple[int, str, list[tuple[str, str]]]:
        """(level, message, [(key, value)]) of this period; starts the next."""
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
        cond_max = self._cond_max if n else math.nan
        jacobian_cond_max = self._jacobian_cond_max if n else math.nan
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
            ('solve time mean (us)', number(mean_us, '.1f')),
            ('solve time median (us)', number(median_us, '.1f')),
            ('solve time p99 (us)', number(p99_us, '.1f')),
            ('solve time max (us)', number(max_us, '.1f')),
            ('solves this period', str(n)),
            *([('cond(Q) last', number(exact_cond, '.4g')),
               ('kinematic condition last', number(self.last_cond, '.4g')),
               ('kinematic condition max this period', number(cond_max, '.4g'))]
              if self.kinematic else []),
            ('Jacobian condition last', number(self.last_jacobian_cond, '.4g')),
            ('Jacobian condition max this period', number(jacobian_cond_max, '.4g')),
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
            ('planner restarts', str(self.planner_restarts)),
            ('stamp check', self.stamp_check),
            ('last rejection', self.last_message),
        ]
        self._period_reset(now)
        return level, message, values


def number(value: float, fmt: str) -> str:
    """Never 'nan' in /diagnostics: a monitor parsing numbers would get NaN."""
    return format(value, fmt) if math.isfinite(value) else 'no samples'


class LogThrottle:
    """At most one log line per key per ``period`` s, counting the suppressed."""

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


def log_at(logger: Any, level: int, text: str) -> None:
    """``text`` on rclpy's ``logger`` at ``level`` (OK: INFO, WARN, ERROR).

    rclpy fixes a severity per call site (a ValueError from the second call
    at another one): one call site per severity, here, for every logging
    whose severity varies.
    """
    if level >= ERROR:
        logger.error(text)
    elif level == WARN:
        logger.warning(text)
    else:
        logger.info(text)


# -- from messages to answers -----------------------------------------------------
class Runtime(NamedTuple):
    """What a cycle reads from the parameters, swapped as one reference."""

    model: Any              # a model of load_model, of any machine
    config: NodeConfig

    @property
    def machine(self) -> Machine:
        return machine_of(self.model)


class Answer(NamedTuple):
    """Stamp, leg lengths, rates and forces, the joint variables and rates."""

    header: tuple[int, int]
    length: list[float]
    rate: list[float]
    force: list[float]
    joints: list[float]
    joint_rates: list[float]


#: The answers to publish (stamp order) and the log lines due (throttled).
Outcome = tuple[list[Answer], list[tuple[int, str]]]


class SetpointIntake:
    """Messages in, :data:`Outcome` s out; an internal error is a ``solver_error``.
    With ``publish``, each answer goes to it as soon as it is solved, before the
    answer's limit checks and statistics (off the round trip), and the
    outcome's answers are empty.
    """

    def __init__(self, runtime: Runtime, publish: Callable[[Answer], None] | None = None) -> None:
        config = runtime.config
        self.runtime = runtime
        machine = runtime.machine
        self.poses = pose_map(machine)
        #: its solutions' exact cond(Q) is reported (a costly field)
        self.reports_cond = 'cond' in machine.costly_fields
        self._kinematic = 'kinematic_condition' in machine.sample_fields
        self.stats = CycleStats(self.poses.ignored, self._kinematic)
        self.throttle = LogThrottle(config.diagnostics_log_throttle)
        self.sync = StampSynchroniser(config.sync_wait, config.sync_max_pending,
                                      config.input_restart_jump, join_window=JOIN_WINDOW)
        self.estimator = self._new_estimator(config)
        self.last_solution: Any = None
        self.last_header: tuple[int, int] = (0, 0)
        self._answered: int | None = None           # stamp of the last answered setpoint
        self._inactive_seen = False                 # a message taken while inactive
        self._stale: tuple[int, float] | None = None   # (activation stamp, until)
        self._answers: list[Answer] = []
        self._lines: list[tuple[int, str]] = []
        self._publish = self._answers.append if publish is None else publish

    def _new_estimator(self, config: NodeConfig) -> DerivativeEstimator:
        # warming up: never estimates an acceleration from a rest it assumed
        return DerivativeEstimator(config.estimator_method, config.estimator_max_gap,
                                   warm_up=True, angles=self.poses.angles)

    def _flush(self) -> Outcome:
        out = (self._answers[:], self._lines)
        self._answers.clear()
        self._lines = []
        return out

    def receive(self, kind: str, msg: Any, now: float, latest_ns: int | None,
                active: bool = True) -> Outcome:
        """One message; ``latest_ns``: the latest stamp accepted now (None: any)."""
        try:
            self.stats.received[kind] += 1
            if not active:
                self._inactive_seen = True
                self.reject(INACTIVE, f'{kind} received while inactive: not answered')
            elif kind == PLATFORM:
                self._platform(msg, now, latest_ns)
            else:
                self._stamped(kind, msg, now, latest_ns)
        except Exception as exc:  # noqa: BLE001 - nothing escapes
            self._internal(exc)
        return self._flush()

    def activate(self, stamp_ns: int, now: float, connected: bool = False) -> None:
        """The node activates at ``stamp_ns`` (its clock; 0: unknown).

        If a stream may have run while it was inactive (a setpoint arrived
        meanwhile, or ``connected``: a planner's publisher is matched), what it
        published then may still arrive: for :data:`STALE_WINDOW` s, setpoints
        stamped before the activation are dropped and counted inactive. (A node
        too busy to take them, or a transport that holds them back, delivers them
        only after the activation: ``connected`` covers that case.)
        """
        self.reset()
        armed = (self._inactive_seen or connected) and stamp_ns > 0
        self._stale = (stamp_ns, now + STALE_WINDOW) if armed else None
        self._inactive_seen = False

    def _published_while_inactive(self, kind: str, stamp_ns: int, now: float) -> bool:
        stale = self._stale
        if stale is None:
            return False
        if now >= stale[1]:
            self._stale = None
            return False
        if stamp_ns >= stale[0]:
            return False
        self.reject(INACTIVE, f'{kind} stamped {fmt_stamp(stamp_ns)}, before the node '
                              'activated: published while inactive, not answered')
        return True

    def _motion(self, kind: str, msg: Any) -> Motion:
        config = self.runtime.config
        if kind == POSE:
            p, o = msg.pose.position, msg.pose.orientation
            return pose_input(p.x, p.y, p.z, o.x, o.y, o.z, o.w,
                              config.input_quaternion_tolerance)
        v = msg.twist if kind == TWIST else msg.accel
        rates = rate_input(v.linear.x, v.linear.y, v.linear.z,
                           v.angular.x, v.angular.y, v.angular.z, kind)
        if kind == ACCEL:   # the components the machine takes, angular ones as received
            self.poses.check_acceleration(self.poses.coordinates(rates),
                                          config.input_max_linear_acceleration,
                                          config.input_max_angular_acceleration)
        return rates

    def _stamped(self, kind: str, msg: Any, now: float, latest_ns: int | None) -> None:
        stamp = msg.header.stamp
        sec, nanosec = stamp.sec, stamp.nanosec
        stamp_ns = sec * 1_000_000_000 + nanosec
        try:
            check_not_future(stamp_ns, latest_ns)
        except SetpointError as exc:     # no state: not even discarded
            self.reject(exc.reason, f'{kind} rejected: {exc}')
            return
        if self._published_while_inactive(kind, stamp_ns, now):
            return
        try:
            item = self._motion(kind, msg)
        except SetpointError as exc:
            self.sync.discard(stamp_ns, kind)
            self.reject(exc.reason, f'{kind} rejected: {exc}')
            return
        self._dispatch(*self.sync.add(kind, stamp_ns, item, now, (sec, nanosec)))

    def _platform(self, msg: Any, now: float, latest_ns: int | None) -> None:
        """``msg``: a JointTrajectory, or the SetpointError that refused it."""
        config = self.runtime.config
        if isinstance(msg, SetpointError):
            self.reject(msg.reason, f'{PLATFORM} rejected: {msg}')
            return
        if len(msg.points) > config.input_max_points:
            self.reject(BAD_SETPOINT, f'{PLATFORM} rejected: {len(msg.points)} points, more '
                                      f'than input.max_points = {config.input_max_points}')
            return
        try:
            points = platform_setpoints(msg, self.poses, config.input_max_linear_acceleration,
                                        config.input_max_angular_acceleration, latest_ns)
        except SetpointError as exc:
            self.reject(exc.reason, f'{PLATFORM} rejected: {exc}')
            return
        for point in points:
            if isinstance(point, SetpointError):
                self.reject(point.reason, f'{PLATFORM} rejected: {point}')
            elif not self._published_while_inactive(PLATFORM, point.stamp_ns, now):
                self._dispatch(*self.sync.add_complete(point.stamp_ns, point.pose, point.twist,
                                                       point.accel, now, point.header))

    def poll(self, now: float) -> Outcome:
        try:
            if self.sync.pending:
                self._dispatch(*self.sync.poll(now))
        except Exception as exc:  # noqa: BLE001
            self._internal(exc)
        return self._flush()

    def _dispatch(self, released: list[Setpoint], rejected: list[Rejected]) -> None:
        if self.sync.restarts != self.stats.planner_restarts:
            # stamps far back, sustained: the estimator's history goes too
            self.stats.planner_restarts = self.sync.restarts
            self.estimator.reset()
            self._answered = None
            self._lines.append((WARN, f'planner restart: {RESTART_CONFIRMATIONS} setpoints in '
                                'a row stamped more than input.restart_jump = '
                                f'{self.runtime.config.input_restart_jump:g} s before the last '
                                'answered one; stamp and estimator history reset'))
        for item in rejected:
            self.reject(item.reason, item.message)
        for setpoint in released:
            try:
                self._process(setpoint)
            except Exception as exc:  # noqa: BLE001 - one failure must not skip the others
                self._internal(exc)

    def _process(self, sp: Setpoint) -> None:
        """Estimate, solve, check; not answered: no trace (warming up: its pose
        is history the next estimates need).
        """
        runtime = self.runtime            # read once: a parameter change applies next cycle
        try:
            q, qd, qdd = self._rates(sp, runtime.config)
            t0 = time.perf_counter()
            sol = _solve(runtime.model, q, qd, qdd)
            elapsed = time.perf_counter() - t0
            answer = Answer(sp.header, sol.length.tolist(), sol.rate.tolist(),
                            sol.force.tolist(), sol.joints.ravel().tolist(),
                            sol.joint_rates.ravel().tolist())
            if not math.isfinite(sum(map(sum, answer[1:]))):
                raise SetpointError(NON_FINITE_OUTPUT, 'solver returned a non-finite value '
                                                       '(not published)')
        except SetpointError as exc:
            if exc.reason == WARMING_UP:
                self.estimator.commit()
            else:
                self.sync.withdraw(sp, self._answered)
            self.reject(exc.reason, f'setpoint rejected: {exc}')
            return
        self._answered = sp.stamp_ns
        self.estimator.commit()
        self._publish(answer)
        self.last_solution, self.last_header = sol, sp.header
        self._assess(sol, sp, runtime, elapsed)

    def _rates(self, sp: Setpoint, config: NodeConfig) -> tuple[Vec, Vec, Vec]:
        """q, qd, qdd of a setpoint: given (converted, :class:`PoseMap`) or estimated."""
        twist, accel, t = sp.twist, sp.accel, sp.stamp_ns * 1e-9
        if sp.source == PLATFORM:       # the machine's coordinates already
            q = sp.pose
            qd, qdd = self.estimator.estimate(t, q, twist, accel)
        else:
            poses = self.poses
            q = poses.coordinates(sp.pose)
            try:
                given = None if twist is None else poses.rates(q, twist)
                if accel is None:
                    qd, qdd = self.estimator.estimate(t, q, given, None)
                else:       # the rates, given or estimated, convert the angular acceleration
                    qd, _ = self.estimator.estimate(t, q, given, accel)
                    qdd = poses.accelerations(q, qd, accel)
            except EulerSingularity as exc:
                raise SetpointError(BAD_SETPOINT, str(exc)) from None
        if twist is None:
            self.stats.estimated_twist += 1
        if qdd is None:
            raise SetpointError(WARMING_UP, 'not answered: its acceleration would be estimated '
                                            'from a rate the node assumed (the first setpoint '
                                            'of a stream is taken at rest); the next ones are')
        if accel is None:
            self.stats.estimated_accel += 1
            self.poses.check_acceleration(qdd, config.input_max_linear_acceleration,
                                          config.input_max_angular_acceleration,
                                          'estimated acceleration')
        return q, qd, qdd

    def _assess(self, sol: Any, sp: Setpoint, runtime: Runtime, seconds: float) -> None:
        config, stats = runtime.config, self.stats
        ignored = () if sp.source == PLATFORM else self.poses.unfollowable(
            sp.pose, sp.twist, sp.accel, sol, config.input_position_tolerance,
            config.input_angle_tolerance)
        if ignored:
            for component in ignored:
                stats.ignored[component] += 1
            stats.note(WARN, 'ignored ' + '/'.join(ignored))
            self.log(WARN, 'ignored', lambda: 'motion the mechanism cannot follow, ignored: '
                     + ', '.join(ignored))
        if sol.status is Status.NEAR_SINGULAR:
            stats.near_singular += 1
            stats.note(WARN, 'near singular')
            self.log(WARN, 'near_singular', lambda: f'near singular: {sol.detail}')
        # the machine's own rule, the one of its status limit (joint angles too)
        limits = limit_report(runtime.machine.limit_usage(runtime.model, sol),
                              config.limits_warn_fraction)
        if limits.exceeded:
            stats.limit_exceeded += 1
            stats.note(ERROR, 'limit exceeded')
            self.log(ERROR, 'limit', lambda: 'limit exceeded (published anyway): '
                     + ', '.join(limits.exceeded))
        elif limits.near:
            stats.near_limit += 1
            stats.note(WARN, 'near a limit')
        stats.solved(seconds, sol.kinematic_condition if self._kinematic else math.nan,
                     float(sol.jacobian_condition))

    def reconfigure(self, runtime: Runtime) -> None:
        old, new = self.runtime.config, runtime.config
        self.runtime = runtime
        if (new.estimator_method, new.estimator_max_gap) != (old.estimator_method,
                                                             old.estimator_max_gap):
            self.estimator = self._new_estimator(new)
        self.sync.wait = new.sync_wait
        self.sync.max_pending = new.sync_max_pending
        self.sync.restart.jump_ns = round(new.input_restart_jump * 1e9)
        self.throttle.period = new.diagnostics_log_throttle

    def reset(self, reason: str | None = None) -> Outcome:
        """Forget pending setpoints and history; drops counted under ``reason``."""
        for _ in range(self.sync.pending if reason else 0):
            self.reject(reason, 'pending setpoint dropped: the node was deactivated')
        self.sync.reset()
        self.estimator.reset()
        self._answered = None
        return self._flush()

    def reject(self, reason: str, message: str) -> None:
        self.stats.reject(reason, message)
        level = (ERROR if reason in (UNREACHABLE, SOLVER_ERROR)
                 else INFO if reason in QUIET_REASONS else WARN)
        self.log(level, reason, message)

    def internal_error(self, exc: BaseException) -> Outcome:
        """A failure outside the intake's own calls (the node's): counted, and
        the outcome with its log line.
        """
        self._internal(exc)
        return self._flush()

    def _internal(self, exc: BaseException) -> None:
        """A failure: a ``solver_error``, its line queued with the others."""
        try:
            self.reject(SOLVER_ERROR, f'internal error: {type(exc).__name__}: {exc}')
        except Exception:  # noqa: BLE001 - even reporting failed: stay up
            pass

    def log(self, level: int, key: str, message: str | Callable[[], str]) -> None:
        """Throttled per ``key``; a callable message is built only when due."""
        skipped = self.throttle(key, time.monotonic())
        if skipped is None:
            return
        text = message if isinstance(message, str) else message()
        if skipped:
            text += f' ({skipped} more since the last such message)'
        self._lines.append((level, text))


def _solve(model: Any, q: Sequence[float], qd: Sequence[float], qdd: Sequence[float]) -> Any:
    try:
        sol = fsd.solve(model, q, qd, qdd)
    except Exception as exc:  # noqa: BLE001 - a malformed call: never escape
        raise SetpointError(SOLVER_ERROR, f'{type(exc).__name__}: {exc}') from None
    if sol.status is Status.UNREACHABLE:
        raise SetpointError(UNREACHABLE, f'unreachable pose: {sol.detail}')
    if sol.status is Status.INVALID_INPUT:     # finite numbers whose results overflow
        raise SetpointError(BAD_SETPOINT, f'input too large: {sol.detail}')
    return sol
