"""The node's setpoint intake, without rclpy: :class:`SetpointIntake` checks each
message, joins and orders the setpoints, estimates what is missing, solves
(the machine's ``solve``) and returns the answers and log lines due. A
rejected setpoint leaves no trace (docs/node.md, "Stamps"). What a machine
takes of the messages: :class:`.messages.PoseMap`. SI units; stamps in integer ns.
"""
from __future__ import annotations

import math
import time
from typing import Any, Callable, NamedTuple, Sequence

import flight_sim_dynamics as fsd

from ..config.parameters import NodeConfig
from ..core.estimator import DerivativeEstimator, Vec
from ..core.euler import EulerSingularity
from ..core.machine import Machine
from ..core.status import Status
from ..machines.api import machine_of
from .diagnostics import CycleStats, LogThrottle, limit_report
from .join import RESTART_CONFIRMATIONS, Rejected, Setpoint, StampSynchroniser
from .messages import (ACCEL, BAD_SETPOINT, ERROR, INACTIVE, INFO, NON_FINITE_OUTPUT,
                       PLATFORM, POSE, QUIET_REASONS, SOLVER_ERROR, TWIST, UNREACHABLE, WARMING_UP,
                       WARN, Motion, SetpointError, check_not_future, fmt_stamp,
                       platform_setpoints, pose_input, pose_map, rate_input)

JOIN_WINDOW = 1.0                  # s after the first message: partial setpoints are joining
STALE_WINDOW = 2.0                 # s after an activation: setpoints stamped before it are stale


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

    # -- a setpoint's path: receive -> checks -> join -> estimate -> solve -> answer -> assess
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

    # -- rejections, internal errors and log lines (throttled)
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

    def _flush(self) -> Outcome:
        out = (self._answers[:], self._lines)
        self._answers.clear()
        self._lines = []
        return out

    # -- activation, reset and parameters
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

    def reset(self, reason: str | None = None) -> Outcome:
        """Forget pending setpoints and history; drops counted under ``reason``."""
        for _ in range(self.sync.pending if reason else 0):
            self.reject(reason, 'pending setpoint dropped: the node was deactivated')
        self.sync.reset()
        self.estimator.reset()
        self._answered = None
        return self._flush()

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

    def _new_estimator(self, config: NodeConfig) -> DerivativeEstimator:
        # warming up: never estimates an acceleration from a rest it assumed
        return DerivativeEstimator(config.estimator_method, config.estimator_max_gap,
                                   warm_up=True, angles=self.poses.angles)
