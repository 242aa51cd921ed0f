"""The twin node ``platform_sim``: the machine without the machine.

Subscribes ``actuator_commands`` (sensor_msgs/JointState in the layout
``dynamics_node`` publishes on ``actuator_states``: position = leg length
reference, velocity = rate reference, effort = feed-forward force), so one
remap (``-r actuator_commands:=actuator_states``) connects the two nodes.
Runs the actuator servos and the plant in real time
(:class:`..core.twin.TwinStepper`: RK4 at ``rate``, the last command held)
and publishes the simulated state in the setpoints' frame: ``platform_pose``
(PoseStamped), ``platform_twist`` (TwistStamped), ``measured_actuator_states``
(JointState: measured lengths, rates, delivered forces) and /diagnostics.

The loop is a timer at ``tick_rate`` on the steady clock: each tick makes the
steps due since the first command (sub-stepping at ``rate``) and publishes.
A command first brings the plant up to its arrival time, then replaces the
held one, so the zero-order hold is exact to a step whatever the tick rate.
Before the first command the platform is held at rest at ``initial``.

Nothing a publisher sends can take the node down: a bad command is rejected,
counted by reason and logged (throttled) (:mod:`.twin_intake`); when the
plant leaves the workspace or nears a singularity the twin stops, holds its
last state at rest and says so in /diagnostics (ERROR); nothing non-finite
is published. Parameters are read-only (set at start-up). docs/twin_node.md.
"""
from __future__ import annotations

import math
import time
from typing import Any

from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PoseStamped, TwistStamped
from rclpy.clock import Clock, ClockType
from rclpy.node import Node
from sensor_msgs.msg import JointState

from ..config.schema import SIM_NODE_NAME, SIM_PARAMETERS
from ..core.model import LEG_NAMES
from . import wire
from .descriptors import descriptor_for, plain, ros_value
from .diagnostics import ERROR, DiagnosticsOutput, LogThrottle, diagnostic_name
from .inputs import SetpointError, rpy_to_quaternion
from .node_parameters import ROS_PARAMETERS
from .qos import default_qos
from .twin_intake import SIM_TASK, CommandStats, check_command, sim_config

#: Parameters ROS itself declares on every node; not ours to check.
#: Seconds between two log lines of one rejection reason.
LOG_THROTTLE = 2.0


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
        descriptors = []
        for spec in SIM_PARAMETERS:
            descriptor = descriptor_for(spec)
            descriptor.read_only = True
            descriptors.append((spec.name, ros_value(spec, spec.default), descriptor))
        self.declare_parameters('', descriptors)
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
        self._measured = wire.JointStateOutput(LEG_NAMES, frame_id, 3)
        self._pose_pub = self.create_publisher(PoseStamped, 'platform_pose', default_qos())
        self._twist_pub = self.create_publisher(TwistStamped, 'platform_twist', default_qos())
        self._measured_pub = self.create_publisher(JointState, 'measured_actuator_states',
                                                   default_qos())
        self._command_sub = self.create_subscription(JointState, 'actuator_commands',
                                                     self._on_command, default_qos())
        self._diag_pub = self.create_publisher(DiagnosticArray, '/diagnostics', 10)
        self._diag = DiagnosticsOutput(diagnostic_name(self.get_fully_qualified_name(), SIM_TASK),
                                       SIM_NODE_NAME)
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
        self._measured_pub.publish(self._measured.fill(sec, nanosec, length, rate, force))

    def _on_diagnostics(self) -> None:
        try:
            level, message, values = self.stats.report(
                time.monotonic(), self.twin, self._started_at is not None, self._rate)
            if level == ERROR and self._throttle('stopped', time.monotonic()) is not None:
                self.get_logger().error(message)
            self._diag_pub.publish(self._diag.fill(level, message, values,
                                                   self.get_clock().now().to_msg()))
        except Exception as exc:  # noqa: BLE001
            self._internal_error(exc)
