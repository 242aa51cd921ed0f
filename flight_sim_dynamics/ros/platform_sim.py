"""The twin node ``platform_sim``: the machine without the machine.

Subscribes ``actuator_commands`` (JointState in the layout of the dynamics
node's ``actuator_states``: leg length and rate references, feed-forward
forces; ``-r actuator_commands:=actuator_states`` connects the two), runs
servos and plant in real time (:class:`..core.twin.TwinStepper`: RK4 at
``rate``, the last command held; a timer at ``tick_rate`` makes the steps due,
a command first brings the plant up to its arrival) and publishes
``platform_pose``, ``platform_twist``, ``measured_actuator_states`` and
/diagnostics. A bad command is rejected, counted and logged (throttled); a
plant that leaves the workspace stops at rest with an ERROR status; nothing
non-finite is published. Parameters are read-only. docs/twin_node.md.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Any, Mapping, Sequence

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from geometry_msgs.msg import PoseStamped, TwistStamped
from rclpy.clock import Clock, ClockType
from rclpy.node import Node
from sensor_msgs.msg import JointState

from ..config import parameters as prm
from ..config.schema import SIM_NODE_NAME, SIM_PARAMETERS
from ..core.model import LEG_NAMES, Model
from ..core.simulation import Servo
from ..core.twin import TwinStepper
from .dynamics_node import ROS_PARAMETERS, _declared, default_qos, descriptor_for, plain
from .setpoints import (ERROR, LEVEL_NAMES, NON_FINITE, OK, STAMP_BACKWARDS, STAMP_REPEATED,
                        WARN, LogThrottle, SetpointError, Vec3, diagnostic_name, number,
                        rpy_to_quaternion)

#: Seconds between two log lines of one rejection reason.
LOG_THROTTLE = 2.0
BAD_NAMES = 'bad_names'          # names that are not the three legs, once each
BAD_SIZE = 'bad_size'            # an array of another size than 3 (or 0: velocity, effort)
#: Why a command is rejected, in the order /diagnostics lists them.
COMMAND_REASONS = (BAD_NAMES, BAD_SIZE, NON_FINITE, STAMP_REPEATED, STAMP_BACKWARDS)
#: Commands in a row stamped before the last accepted one that are a restart
#: of the stream (a planner restarted with its clock): accepted from then on.
RESTART_AFTER = 3
#: The status name of the twin in /diagnostics (``<node>: <task>``).
SIM_TASK = 'platform simulation'
SIM_SPECS: Mapping[str, prm.ParamSpec] = {spec.name: spec for spec in SIM_PARAMETERS}


@dataclass(frozen=True)
class SimConfig:
    """The twin's validated parameters, the plant and its servos."""

    values: Mapping[str, Any]
    plant: Model
    servo: Servo

    @property
    def step(self) -> float:
        return 1.0 / self.values['rate']

    def stepper(self) -> TwinStepper:
        return TwinStepper(self.plant, self.servo, self.step, self.values['initial'])


def sim_config(values: Mapping[str, Any]) -> SimConfig:
    """Check every twin parameter (dotted names, defaults for the absent ones)
    and build the plant (:func:`..config.parameters.load_model`) and its
    servos; raises ParameterError (also for a plant scene without inertia or
    a start pose the plant cannot take).
    """
    checked = {name: prm.check_value(spec, values.get(name, spec.default))
               for name, spec in SIM_SPECS.items()}
    try:
        plant = prm.load_model(checked['plant.params_file'] or None,
                               checked['plant.scene'] or None)
    except prm.SceneError as exc:
        raise prm.ParameterError('plant.scene', checked['plant.scene'], str(exc)) from None
    except (OSError, ValueError) as exc:
        raise prm.ParameterError('plant.params_file', checked['plant.params_file'],
                                 str(exc)) from None
    if checked['tick_rate'] > checked['rate']:
        raise prm.ParameterError('tick_rate', checked['tick_rate'],
                                 f"must not exceed rate ({checked['rate']:g} Hz): a tick "
                                 'makes whole steps')
    try:
        servo = Servo.for_bandwidth(plant, checked['servo.bandwidth'], checked['servo.damping'])
        config = SimConfig(checked, plant, servo)
        twin = config.stepper()
    except ValueError as exc:           # a scene without inertia
        raise prm.ParameterError('plant.scene', checked['plant.scene'], str(exc)) from None
    if not twin.running:
        raise prm.ParameterError('initial', checked['initial'],
                                 f'the plant cannot start there: {twin.outcome}: {twin.detail}')
    return config


def check_command(names: Sequence[str], position: Sequence[float],
                  velocity: Sequence[float], effort: Sequence[float]
                  ) -> tuple[Vec3, Vec3, Vec3]:
    """(length, rate, force) of a command, legs A, B, C; raises
    :class:`SetpointError` with the reason (:data:`COMMAND_REASONS`; the
    stamp is checked by :meth:`CommandStats.stamp`).
    """
    if len(names) != 3 or sorted(names) != sorted(LEG_NAMES):
        raise SetpointError(BAD_NAMES, f'names must be {", ".join(LEG_NAMES)} once each, '
                                       f'got {list(names)!r:.200}')
    if len(position) != 3:
        raise SetpointError(BAD_SIZE, f'position must have 3 values, got {len(position)}')
    for what, values in (('velocity', velocity), ('effort', effort)):
        if len(values) not in (0, 3):
            raise SetpointError(BAD_SIZE, f'{what} must have 3 values or none, '
                                          f'got {len(values)}')
    order = [names.index(leg) for leg in LEG_NAMES]
    out = []
    for what, values in (('position', position), ('velocity', velocity), ('effort', effort)):
        if not values:
            out.append((0.0, 0.0, 0.0))
            continue
        picked = (float(values[order[0]]), float(values[order[1]]), float(values[order[2]]))
        if not all(math.isfinite(v) for v in picked):
            raise SetpointError(NON_FINITE, f'{what} has a non-finite value {picked!r}')
        out.append(picked)
    return out[0], out[1], out[2]


class CommandStats:
    """Counters of the commands, stamp order, and the real-time figures of
    the loop (per diagnostics period: ticks, their work time, simulated time).
    """

    def __init__(self) -> None:
        self.received = 0
        self.accepted = 0
        self.rejected = {reason: 0 for reason in COMMAND_REASONS}
        self.restarts = 0
        self.last_rejection = ''
        self.last_stamp: int | None = None
        self._behind = 0
        self.overruns = 0                    # ticks late or with dropped steps, total
        self.dropped_steps = 0
        self.non_finite_outputs = 0          # states not published (never seen: a guard)
        self._period_reset(None, 0.0)

    def _period_reset(self, now: float | None, sim_time: float) -> None:
        self._start, self._sim_start = now, sim_time
        self._work: list[float] = []
        self._rejected_at_start = sum(self.rejected.values())
        self._overruns_at_start = self.overruns

    def stamp(self, stamp_ns: int) -> None:
        """Accept a command's stamp, or raise SetpointError (repeated, or
        before the last accepted one; :data:`RESTART_AFTER` in a row are a
        restart, accepted).
        """
        last = self.last_stamp
        if last is not None and stamp_ns <= last:
            self._behind += 1
            if self._behind < RESTART_AFTER:
                if stamp_ns == last:
                    raise SetpointError(STAMP_REPEATED, f'stamp {stamp_ns} ns repeated')
                raise SetpointError(STAMP_BACKWARDS, f'stamp {stamp_ns} ns before the last '
                                                     f'accepted one ({last} ns)')
            self.restarts += 1
        self._behind = 0
        self.last_stamp = stamp_ns

    def reject(self, reason: str, message: str) -> None:
        self.rejected[reason] += 1
        self.last_rejection = f'{reason}: {message}'

    def tick(self, work: float, period: float, dropped: int) -> None:
        """One tick of the loop: its work time (s) against its period; steps
        it had to drop.
        """
        self._work.append(work)
        if dropped or work > period:
            self.overruns += 1
            self.dropped_steps += dropped

    def report(self, now: float, twin: TwinStepper, started: bool, rate: float
               ) -> tuple[int, str, list[tuple[str, str]]]:
        """(level, message, [(key, value), ...]) for this period; starts a new
        one. ERROR once the plant stopped; WARN for rejections, overruns or a
        plant beyond an actuator limit this period.
        """
        wall = now - self._start if self._start is not None else math.nan
        simulated = twin.time - self._sim_start
        factor = simulated / wall if started and wall > 0 else math.nan
        work = sorted(self._work)
        n = len(work)
        rejected = sum(self.rejected.values()) - self._rejected_at_start
        overruns = self.overruns - self._overruns_at_start
        problems = []
        level = OK
        if not twin.running:
            level, problems = ERROR, [f'stopped: {twin.outcome}: {twin.detail}']
        else:
            if rejected:
                problems.append(f'{rejected} commands rejected')
            if overruns:
                problems.append(f'{overruns} overruns')
            if str(twin.status) != 'ok':
                problems.append(f'plant {twin.status}: {twin.status_detail}')
            level = WARN if problems else OK
        message = ('; '.join(problems) if problems
                   else 'waiting for commands' if not started else 'OK')
        values = [
            ('status', LEVEL_NAMES[level]),
            ('plant', twin.plant.scene),
            ('outcome', str(twin.outcome) if twin.running else f'{twin.outcome}: {twin.detail}'),
            ('plant status', str(twin.status)),
            ('rate (Hz)', f'{rate:g}'),
            ('real-time factor', number(factor, '.4f')),
            ('simulated time (s)', f'{twin.time:.3f}'),
            ('steps', str(twin.steps)),
            ('tick work mean (us)', number(1e6 * sum(work) / n if n else math.nan, '.1f')),
            ('tick work max (us)', number(1e6 * work[-1] if n else math.nan, '.1f')),
            ('ticks this period', str(n)),
            ('overruns', str(self.overruns)),
            ('overruns this period', str(overruns)),
            ('steps dropped', str(self.dropped_steps)),
            ('commands received', str(self.received)),
            ('commands accepted', str(self.accepted)),
            ('rejected total', str(sum(self.rejected.values()))),
        ]
        values += [(f'rejected {reason}', str(count)) for reason, count in self.rejected.items()]
        values += [('stream restarts', str(self.restarts)),
                   ('non-finite states not published', str(self.non_finite_outputs)),
                   ('last rejection', self.last_rejection)]
        self._period_reset(now, twin.time)
        return level, message, values


class PlatformSim(Node):
    """The digital twin as a ROS 2 node (module docstring); ``kwargs`` go to
    rclpy's Node. Invalid start-up parameters raise ParameterError.
    """

    def __init__(self, **kwargs: Any) -> None:
        super().__init__(SIM_NODE_NAME, automatically_declare_parameters_from_overrides=True,
                         **kwargs)
        given = set(self.list_parameters([], 0).names) - ROS_PARAMETERS
        for name in given:
            self.undeclare_parameter(name)      # re-declared below with our descriptors
        self.declare_parameters('', [(spec.name, _declared(spec, spec.default).value,
                                      descriptor_for(spec, read_only=True))
                                     for spec in SIM_PARAMETERS])
        unknown = sorted(name for name in given if not self.has_parameter(name))
        if unknown:
            self.get_logger().warn('ignoring unknown parameters (typo?): ' + ', '.join(unknown))
        self.config = sim_config({spec.name: plain(self.get_parameter(spec.name).value)
                                  for spec in SIM_PARAMETERS})
        values = self.config.values
        self.twin = self.config.stepper()
        self.stats = CommandStats()
        self._rate = values['rate']
        self._tick_period = 1.0 / values['tick_rate']
        self._max_steps = max(1, int(values['max_catch_up'] * self._rate))
        self._started_at: float | None = None    # monotonic time of the first command
        self._stamp0 = 0                         # ROS time (ns) of simulated time 0
        self._dropped = 0                        # steps dropped after stalls
        self._throttle = LogThrottle(LOG_THROTTLE)

        frame_id = values['frame_id']
        self._pose = PoseStamped()
        self._pose.header.frame_id = frame_id
        self._twist = TwistStamped()
        self._twist.header.frame_id = frame_id
        self._measured = JointState(name=list(LEG_NAMES))
        self._measured.header.frame_id = frame_id
        self._pose_pub = self.create_publisher(PoseStamped, 'platform_pose', default_qos())
        self._twist_pub = self.create_publisher(TwistStamped, 'platform_twist', default_qos())
        self._measured_pub = self.create_publisher(JointState, 'measured_actuator_states',
                                                   default_qos())
        self._command_sub = self.create_subscription(JointState, 'actuator_commands',
                                                     self._on_command, default_qos())
        self._diag_pub = self.create_publisher(DiagnosticArray, '/diagnostics', 10)
        self._diag_name = diagnostic_name(self.get_fully_qualified_name(), SIM_TASK)
        # Timers on the steady clock: they keep ticking with use_sim_time and no /clock.
        steady = Clock(clock_type=ClockType.STEADY_TIME)
        self._tick_timer = self.create_timer(self._tick_period, self._on_tick, clock=steady)
        self._diag_timer = self.create_timer(values['diagnostics.period'],
                                             self._on_diagnostics, clock=steady)
        self.get_logger().info(
            f"ready: plant scene {self.config.plant.scene}, RK4 at {self._rate:g} Hz, "
            f"ticks at {values['tick_rate']:g} Hz, servo {values['servo.bandwidth']:g} Hz "
            f"(kp {', '.join(f'{k:.4g}' for k in self.config.servo.kp)} N/m); waiting for "
            'actuator_commands')

    # -- the loop -------------------------------------------------------------------------
    def _catch_up(self, now: float) -> int:
        """Make the steps due at ``now`` (monotonic s); returns the steps
        dropped (more than ``max_catch_up`` due after a stall).
        """
        if self._started_at is None or not self.twin.running:
            return 0
        due = int((now - self._started_at) * self._rate) - self.twin.steps - self._dropped
        dropped = 0
        if due > self._max_steps:
            dropped = due - self._max_steps
            self._dropped += dropped
            due = self._max_steps
        if due > 0:
            self.twin.advance(due)
        return dropped

    def _on_tick(self) -> None:
        try:
            start = time.monotonic()
            dropped = self._catch_up(start)
            self._publish()
            if self._started_at is not None:
                self.stats.tick(time.monotonic() - start, self._tick_period, dropped)
        except Exception as exc:  # noqa: BLE001 - nothing escapes a callback
            self._internal_error(exc)

    def _on_command(self, msg: JointState) -> None:
        """One command: checked, then held from its arrival on."""
        stats = self.stats
        try:
            now = time.monotonic()
            stats.received += 1
            stamp = msg.header.stamp
            try:
                length, rate, force = check_command(msg.name, msg.position, msg.velocity,
                                                    msg.effort)
                stats.stamp(stamp.sec * 1_000_000_000 + stamp.nanosec)
            except SetpointError as exc:
                stats.reject(exc.reason, str(exc))
                self._log_rejection(exc.reason, str(exc), now)
                return
            if self._started_at is None:
                self._started_at = now
                self._stamp0 = self.get_clock().now().nanoseconds
                self.get_logger().info('first command: the simulation runs')
            else:
                dropped = self._catch_up(now)     # the old command up to now
                if dropped:
                    stats.tick(0.0, self._tick_period, dropped)
            self.twin.command(length, rate, force)
            stats.accepted += 1
        except Exception as exc:  # noqa: BLE001
            self._internal_error(exc)

    def _log_rejection(self, reason: str, message: str, now: float) -> None:
        skipped = self._throttle(reason, now)
        if skipped is not None:
            more = f' ({skipped} more since the last line)' if skipped else ''
            self.get_logger().warn(f'command rejected ({reason}): {message}{more}')

    def _internal_error(self, exc: Exception) -> None:
        skipped = self._throttle('internal', time.monotonic())
        if skipped is not None:
            self.get_logger().error(f'internal error (the node carries on): '
                                    f'{type(exc).__name__}: {exc}')

    # -- outputs ---------------------------------------------------------------------------
    def _stamp_ns(self) -> int:
        """Simulated time on the ROS clock (the wall clock's now before the
        first command and once stopped).
        """
        if self._started_at is None or not self.twin.running:
            return self.get_clock().now().nanoseconds
        return self._stamp0 + round((self.twin.steps + self._dropped) * 1e9 / self._rate)

    def _publish(self) -> None:
        twin = self.twin
        q, qd = twin.q.tolist(), twin.qd.tolist()
        length, rate, force = twin.length.tolist(), twin.rate.tolist(), twin.force.tolist()
        if not math.isfinite(sum(q) + sum(qd) + sum(length) + sum(rate) + sum(force)):
            self.stats.non_finite_outputs += 1      # a guard: the stepper never gives NaN
            return
        sec, nanosec = divmod(self._stamp_ns(), 1_000_000_000)
        pose = self._pose
        pose.header.stamp.sec, pose.header.stamp.nanosec = sec, nanosec
        p, o = pose.pose.position, pose.pose.orientation
        p.x, p.y, p.z = q[0], 0.0, q[1]
        o.x, o.y, o.z, o.w = rpy_to_quaternion(q[2])
        self._pose_pub.publish(pose)
        twist = self._twist
        twist.header.stamp.sec, twist.header.stamp.nanosec = sec, nanosec
        twist.twist.linear.x, twist.twist.linear.z, twist.twist.angular.x = qd
        self._twist_pub.publish(twist)
        measured = self._measured
        measured.header.stamp = pose.header.stamp
        measured.position, measured.velocity, measured.effort = length, rate, force
        self._measured_pub.publish(measured)

    def _on_diagnostics(self) -> None:
        try:
            level, message, values = self.stats.report(
                time.monotonic(), self.twin, self._started_at is not None, self._rate)
            if level == ERROR and self._throttle('stopped', time.monotonic()) is not None:
                self.get_logger().error(message)
            msg = DiagnosticArray(status=[DiagnosticStatus(
                level=bytes([level]), name=self._diag_name, message=message,
                hardware_id=SIM_NODE_NAME, values=[KeyValue(key=k, value=v) for k, v in values])])
            msg.header.stamp = self.get_clock().now().to_msg()
            self._diag_pub.publish(msg)
        except Exception as exc:  # noqa: BLE001
            self._internal_error(exc)
