"""The managed node :class:`DynamicsNode`: each setpoint becomes one
``actuator_states`` and one ``joint_states`` stamped like it (rules:
:class:`.intake.SetpointIntake`). Nothing a client sends takes it down.
Topics, QoS, parameters: docs/node.md.
"""
from __future__ import annotations

import math
import time
import warnings
from typing import Any

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from geometry_msgs.msg import AccelStamped, PoseStamped, TwistStamped
from rcl_interfaces.msg import SetParametersResult
from rclpy.clock import Clock, ClockType
from rclpy.lifecycle import LifecycleState, TransitionCallbackReturn
from rclpy.parameter import Parameter
from rclpy.qos import (DurabilityPolicy, HistoryPolicy, QoSPolicyKind, QoSProfile,
                       ReliabilityPolicy)
from rclpy.qos_overriding_options import InvalidQosOverridesError, QoSOverridingOptions
from rclpy.serialization import deserialize_message
from sensor_msgs.msg import JointState
from trajectory_msgs.msg import JointTrajectory

from ..config import parameters as prm
from ..config.files import QOS_OVERRIDES
from ..config.machine_files import ignored_message, ignored_values
from ..config.node_schema import MACHINE, NodeSchema, node_schema
from ..config.cueing import SPECS as CUEING_SPECS
from .marker_publisher import MarkerPublisher
from .managed_node import ManagedNode
from .parameter_guard import (MAX_NAMES_PER_REQUEST, MAX_PARAMETERS_PER_REQUEST,
                              MAX_VALIDATIONS_PER_REQUEST, _failed, plain)
from .process import end_spins, stop_requested
from .diagnostics import diagnostic_name, log_at
from .intake import Answer, Outcome, Runtime, SetpointIntake
from .messages import (ACCEL, BAD_SETPOINT, INACTIVE, LEVEL_NAMES, PLATFORM, POSE, TWIST,
                       SetpointError)

LATEST_STAMP_REUSE = 0.005       # s one clock reading serves the future-stamp check
# bytes of a valid trajectory point at most, and of the rest of a
# platform_setpoint: a larger message is refused undecoded
MAX_POINT_BYTES = 128
MAX_MESSAGE_OVERHEAD = 65536
MAX_DROPPED_AT_ACTIVATION = 100_000  # queued messages per keep-all subscription
# rclpy warns of a zero QoS depth before check_qos refuses it with the reason
warnings.filterwarnings('ignore', 'A zero depth', UserWarning)
QOS_POLICIES = (QoSPolicyKind.HISTORY, QoSPolicyKind.DEPTH, QoSPolicyKind.RELIABILITY)


def default_qos(depth: int = 1000) -> QoSProfile:
    """Reliable, KEEP_LAST 1000 (1 s at 1 kHz), VOLATILE (nothing stale)."""
    return QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=depth,
                      reliability=ReliabilityPolicy.RELIABLE,
                      durability=DurabilityPolicy.VOLATILE)


def check_qos(qos: QoSProfile) -> SetParametersResult:
    if qos.history == HistoryPolicy.KEEP_LAST and qos.depth < 1:
        return _failed(f'depth must be >= 1 with keep_last, got {qos.depth}')
    if qos.reliability not in (ReliabilityPolicy.RELIABLE, ReliabilityPolicy.BEST_EFFORT):
        return _failed('reliability must be reliable or best_effort, got '
                       f'{qos.reliability.name.lower()}')
    return SetParametersResult(successful=True)


class DynamicsNode(ManagedNode):
    """Starts unconfigured; :meth:`start` (or a lifecycle manager) configures
    and activates it. :attr:`failure`: why configure failed.
    """

    REJECTED = 'parameter change rejected, model unchanged'

    def __init__(self, **kwargs: Any) -> None:
        super().__init__(prm.NODE_NAME, **kwargs)
        self._runtime: Runtime | None = None     # None: unconfigured
        self._staged: Runtime | None = None      # validated by the on-set callback
        self._intake: SetpointIntake | None = None
        self._refused_unconfigured = 0           # parameter sets refused before the intake
        self._active = False
        self._unknown_reported = False
        self._latest: int | None = None
        self._latest_until = 0.0
        self._endpoints: list[Any] = []
        self._actuator_pub = self._joint_pub = self._diag_pub = None
        self._diag_timer = self._poll_timer = None
        self._markers: MarkerPublisher | None = None
        self._answered_since = False             # an answer out since the last markers offer
        self._diag_name = diagnostic_name(self.get_fully_qualified_name())
        # timers on the steady clock: they tick with use_sim_time and no /clock
        self._steady = Clock(clock_type=ClockType.STEADY_TIME)
        self._schema: NodeSchema = node_schema()
        self._given, self._refused = self._declare_parameters()
        self._specs = self._schema.specs
        self._model_names = frozenset(s.name for s in self._schema.model_specs)
        machine = self._schema.machine
        self._actuator_msg = JointState(name=list(machine.legs))
        self._joint_msg = JointState(name=list(machine.joints))
        self._guard_services()
        self.add_on_set_parameters_callback(self._on_set_parameters)
        self.add_post_set_parameters_callback(self._on_parameters_set)

    @property
    def machine_name(self) -> str | None:
        """The ``machine`` parameter it was started with (None: the default machine's)."""
        return self.get_parameter(MACHINE).value if self.has_parameter(MACHINE) else None

    # -- parameters ----------------------------------------------------------------
    def _declare_parameters(self) -> tuple[set[str], dict[str, str]]:
        """Declare the schema of the machine the given ``machine`` names (none:
        the default machine) at the given values, else the defaults (a name with
        neither is not declared). A refused given value keeps the default and
        fails every configure until set; ``machine`` is read-only.
        """
        given = self._given_parameters()
        if MACHINE in given:
            self._schema = node_schema(plain(given[MACHINE].value))
        refused = self._declare_specs(list(self._schema.specs.values()), self._schema.defaults,
                                      given, lambda name: name == MACHINE)
        return set(given), refused

    def _values(self) -> dict[str, Any]:
        return {name: plain(self.get_parameter(name).value) for name in self._specs
                if self.has_parameter(name)}

    def _runtime_of(self, values: dict[str, Any], changed: Any = None) -> Runtime:
        """The model is rebuilt only when a model parameter changed."""
        model = self._runtime.model if self._runtime is not None else None
        if model is None or changed is None or not self._model_names.isdisjoint(changed):
            model = self._schema.model(values, changed)
        return Runtime(model, prm.NodeConfig.from_values(
            {s.name: values[s.name] for s in prm.NODE_PARAMETERS}))

    def _on_set_parameters(self, params: list[Parameter]) -> SetParametersResult:
        """Validate the whole set as it would be; stage the runtime for the commit."""
        ours = [p for p in params if p.name in self._specs]
        if not ours:
            return SetParametersResult(successful=True)
        self._staged = None
        try:
            if self._runtime is None:   # unconfigured: each on its own; configure checks all
                reason = next(filter(None, (self._check(p, self._specs[p.name]) for p in ours)),
                              None)
                return _failed(reason) if reason else SetParametersResult(successful=True)
            values = self._values()
            values.update((p.name, plain(p.value)) for p in ours)
            self._staged = self._runtime_of(values, [p.name for p in ours])
            return SetParametersResult(successful=True)
        except prm.ParameterError as exc:
            reason = str(exc)
        except Exception as exc:  # noqa: BLE001 - e.g. a geometry the solver chokes on
            reason = f'{type(exc).__name__}: {exc}'
        self._refused_by_callback()
        self.get_logger().warn(f'parameter change rejected, model unchanged: {reason}')
        return _failed(reason)

    def _count_refused(self, count: int) -> None:
        """Every refused parameter set (:meth:`GuardedParameters._count_refused`),
        into /diagnostics' ``parameter changes rejected``; those refused before
        the first configure are kept until its counters exist.
        """
        if self._intake is None:
            self._refused_unconfigured += count
        else:
            self._intake.stats.parameter_rejections += count

    def _on_parameters_set(self, params: list[Parameter]) -> None:
        try:
            for p in params:
                self._refused.pop(p.name, None)
            staged, self._staged = self._staged, None
            if staged is None or self._runtime is None:
                return
            old = self._runtime
            self._runtime = staged
            self._intake.reconfigure(staged)
            self._intake.stats.parameter_changes += 1
            new = staged.config
            if staged.model is not old.model:
                self._markers.set_model(staged.model)
            self._markers.set_frame(new.output_frame_id)
            self._markers.set_rate(new.output_markers_rate)
            self._diag_timer.timer_period_ns = int(new.diagnostics_period * 1e9)
            self._poll_timer.timer_period_ns = int(self._poll_period(new) * 1e9)
            self.get_logger().info('parameters changed: '
                                   + ', '.join(dict.fromkeys(p.name for p in params)))
        except Exception as exc:  # noqa: BLE001
            self._internal_error(exc)

    def _read_only_reason(self, name: str) -> str | None:
        if name != MACHINE:
            return None
        return (f"parameter 'machine' is read-only: refused; this node serves the "
                f'{self._schema.machine.title} its start-up parameters name; another machine '
                'needs another node started with its parameter file')

    def destroy_node(self) -> None:
        self._stop_serving_apart()
        if self._markers is not None:        # its renderer process ends with it
            self._markers.close()
        super().destroy_node()


    # -- lifecycle (ManagedNode: start, configure's failure, cleanup, shutdown) ---
    def _configure(self) -> None:
        self._runtime = self._runtime_of(self._values())
        if self._intake is None:
            self._intake = SetpointIntake(self._runtime, self._publish_answer)
            self._intake.stats.parameter_rejections += self._refused_unconfigured
            self._refused_unconfigured = 0
        else:
            self._intake.reconfigure(self._runtime)
            self._intake.reset()
        self._create_endpoints(self._runtime)

    def _configured(self) -> None:
        # the cueing group of a shared params file is motion_cueing's (checked by the loaders)
        unknown = sorted(n for n in self._given
                         if not self.has_parameter(n) and n not in CUEING_SPECS)
        if unknown and not self._unknown_reported:
            self.get_logger().warn('ignoring unknown parameters (typo?): ' + ', '.join(unknown))
        if not self._unknown_reported:      # values given for an effect the scene leaves out
            values, model = self._values(), self._runtime.model
            ignored = ignored_values({n: values[n] for n in self._given if n in values},
                                     self._schema.defaults, model)
            if ignored:
                self.get_logger().warn(ignored_message(ignored, model.scene))
        self._unknown_reported = True
        self.get_logger().info(
            f'configured: {self._schema.machine.title}, {len(self._values())} parameters; '
            + ', '.join(f'{e.topic_name} ({e.qos_profile.reliability.name.lower()} '
                        f'{e.qos_profile.history.name.lower()} {e.qos_profile.depth})'
                        for e in self._endpoints) + ', /diagnostics')

    def on_activate(self, state: LifecycleState) -> TransitionCallbackReturn:
        self._drop_queued()
        # nothing from before counts as history; stragglers of a stream that ran
        # meanwhile are dropped by their stamps
        # a planner matched while the node sat inactive may have streamed meanwhile
        connected = not self.activating_at_start and any(
            self.count_publishers(sub.topic_name) for sub in self._endpoints[2:])
        self._intake.activate(self.get_clock().now().nanoseconds, time.monotonic(), connected)
        self._active = True
        self.get_logger().info('active: answering setpoints')
        return super().on_activate(state)     # enables the lifecycle publishers

    def _drop_queued(self) -> None:
        """Setpoints still queued at activation were published while inactive
        (a busy node, or an executor that serves the request first): taken now
        and counted inactive, not answered late. The executor's events for them
        then take nothing.
        """
        for sub in self._endpoints[2:]:
            qos = sub.qos_profile       # at most a queue's worth: a fast stream never ends
            with sub.handle:
                for _ in range(qos.depth if qos.history == HistoryPolicy.KEEP_LAST
                               else MAX_DROPPED_AT_ACTIVATION):
                    taken = sub.handle.take_message(sub.msg_type, sub.raw)
                    if taken is None:
                        break
                    sub.callback(taken[0])

    def on_deactivate(self, state: LifecycleState) -> TransitionCallbackReturn:
        self._active = False
        self._markers.clear()
        self._log(self._intake.reset(INACTIVE))
        self.get_logger().info('inactive: setpoints are counted as inactive, not answered')
        return super().on_deactivate(state)

    def _release(self) -> None:
        self._active = False
        for timer in filter(None, (self._diag_timer, self._poll_timer)):
            self.destroy_timer(timer)
        for pub in filter(None, (self._actuator_pub, self._joint_pub)):
            self.destroy_lifecycle_publisher(pub)
        if self._markers is not None:
            self._markers.close()
        for sub in self._endpoints[2:]:
            self.destroy_subscription(sub)
        if self._diag_pub is not None:
            self.destroy_publisher(self._diag_pub)
        self._endpoints = []
        self._actuator_pub = self._joint_pub = self._diag_pub = None
        self._diag_timer = self._poll_timer = None
        self._markers = None
        self._runtime = self._staged = None

    def _create_endpoints(self, runtime: Runtime) -> None:
        config = runtime.config
        options = QoSOverridingOptions(QOS_POLICIES, callback=check_qos)
        try:
            self._actuator_pub = self.create_lifecycle_publisher(
                JointState, 'actuator_states', default_qos(), qos_overriding_options=options)
            self._joint_pub = self.create_lifecycle_publisher(
                JointState, 'joint_states', default_qos(), qos_overriding_options=options)
            self._endpoints = [self._actuator_pub, self._joint_pub]
            for msg_type, kind in ((PoseStamped, POSE), (TwistStamped, TWIST),
                                   (AccelStamped, ACCEL)):
                self._endpoints.append(self.create_subscription(
                    msg_type, f'{kind}_setpoint', lambda msg, kind=kind: self._on_setpoint(
                        kind, msg), default_qos(), qos_overriding_options=options))
            # serialized: the size is checked before decoding (a million points
            # would take seconds of the node's only thread)
            self._endpoints.append(self.create_subscription(
                JointTrajectory, PLATFORM, self._on_platform, default_qos(), raw=True,
                qos_overriding_options=options))
        except (InvalidQosOverridesError, RuntimeError, AssertionError, TypeError,
                ValueError) as exc:
            raise prm.ParameterError(QOS_OVERRIDES + '*', None,
                                     f'invalid QoS override: {exc}') from None
        # reports while inactive too
        self._diag_pub = self.create_publisher(DiagnosticArray, '/diagnostics', 10)
        self._diag_timer = self.create_timer(config.diagnostics_period, self._on_diagnostics,
                                             clock=self._steady)
        self._poll_timer = self.create_timer(self._poll_period(config), self._on_poll,
                                             clock=self._steady)
        self._markers = MarkerPublisher(self, self._schema.machine, runtime.model,
                                        config.output_frame_id, config.output_markers_rate)

    @staticmethod
    def _poll_period(config: prm.NodeConfig) -> float:
        return min(max(config.sync_wait / 2.0, 0.001), 0.05)

    def _latest_stamp(self) -> int | None:
        """Clock + input.max_future (ns); None: no check (0, or no /clock yet)."""
        mono = time.monotonic()
        if mono >= self._latest_until:
            max_future = self._runtime.config.input_max_future
            now = self.get_clock().now().nanoseconds if max_future else 0
            self._latest = now + int(max_future * 1e9) if now else None
            self._latest_until = mono + LATEST_STAMP_REUSE
        return self._latest

    # -- setpoints in, answers out -------------------------------------------------
    def _on_setpoint(self, kind: str, msg: Any) -> None:
        # nothing escapes a callback (it would stop the executor)
        if stop_requested():    # stopping: the spin returns after this callback
            end_spins()
            return
        try:
            # taken after deactivate or cleanup (queued before): counted inactive
            active = self._active and self._runtime is not None
            self._publish(self._intake.receive(kind, msg, time.monotonic(),
                                               self._latest_stamp() if active else None,
                                               active))
        except Exception as exc:  # noqa: BLE001
            self._internal_error(exc)

    def _on_platform(self, data: bytes) -> None:
        if stop_requested():
            end_spins()
            return
        try:
            if self._runtime is None or not self._active:
                self._on_setpoint(PLATFORM, None)       # counted inactive, not decoded
                return
            max_points = self._runtime.config.input_max_points
            if len(data) > MAX_MESSAGE_OVERHEAD + max_points * MAX_POINT_BYTES:
                msg = SetpointError(BAD_SETPOINT, f'{len(data)} bytes: more than a message of '
                                    f'input.max_points = {max_points} points can take (not '
                                    'decoded)')
            else:
                try:
                    msg = deserialize_message(data, JointTrajectory)
                except Exception as exc:  # noqa: BLE001 - truncated or inconsistent bytes
                    msg = SetpointError(BAD_SETPOINT, f'malformed serialized message: {exc}')
            self._on_setpoint(PLATFORM, msg)
        except Exception as exc:  # noqa: BLE001
            self._internal_error(exc)

    def _on_poll(self) -> None:
        try:
            if self._runtime is not None:
                self._publish(self._intake.poll(time.monotonic()))
        except Exception as exc:  # noqa: BLE001
            self._internal_error(exc)

    def _publish_answer(self, answer: Answer) -> None:
        """One answer out, as soon as it is solved: the intake checks it and
        counts it afterwards, off the round trip.
        """
        config = self._runtime.config
        actuator, joints = self._actuator_msg, self._joint_msg
        actuator.header.frame_id = config.output_frame_id
        joints.header.frame_id = config.output_joint_states_frame_id
        for msg in (actuator, joints):
            msg.header.stamp.sec, msg.header.stamp.nanosec = answer.header
        actuator.position, actuator.velocity, actuator.effort = \
            answer.length, answer.rate, answer.force
        joints.position, joints.velocity = answer.joints, answer.joint_rates
        try:
            self._actuator_pub.publish(actuator)
            self._joint_pub.publish(joints)
        except Exception:
            if self.context.ok():
                raise           # the intake's internal error
            return              # shutting down: the shutdown's failure
        self._answered_since = True

    def _publish(self, outcome: Outcome) -> None:
        """After the intake: the markers of the last answer, the log lines."""
        if self._answered_since:
            self._answered_since = False
            self._markers.offer(self._intake.last_header, self._intake.last_solution)
        self._log(outcome)

    def _log(self, outcome: Outcome) -> None:
        for level, text in outcome[1]:
            log_at(self.get_logger(), level, text)

    def _internal_error(self, exc: Exception) -> None:
        # not while shutting down: a failed publish then is the shutdown's
        if self._intake is not None and self.context.ok():
            self._log(self._intake.internal_error(exc))

    def _on_diagnostics(self) -> None:
        try:
            runtime, stats = self._runtime, self._intake.stats
            if runtime is None:         # a tick queued before cleanup
                return
            stats.stamp_check = self._stamp_check(runtime.config.input_max_future)
            last = self._intake.last_solution
            exact = last.cond if last is not None and self._intake.reports_cond else math.nan
            level, message, values = stats.report(time.monotonic(), exact)
            values[1:1] = [('lifecycle state', 'active' if self._active else 'inactive'),
                           ('scene', runtime.model.scene)]
            msg = DiagnosticArray(status=[DiagnosticStatus(
                level=bytes([level]), name=self._diag_name, message=message,
                hardware_id=runtime.config.diagnostics_hardware_id,
                values=[KeyValue(key=k, value=v) for k, v in values])])
            msg.header.stamp = self.get_clock().now().to_msg()
            self._diag_pub.publish(msg)
        except Exception as exc:  # noqa: BLE001
            self._internal_error(exc)

    def _stamp_check(self, max_future: float) -> str:
        if not max_future:
            return 'off (input.max_future = 0)'
        if not self.get_clock().now().nanoseconds:
            return 'off until the first /clock (use_sim_time)'
        return f'stamps at most {max_future:g} s ahead of the node\'s clock'


# the bounds of a parameter request, for the tests and benchmarks
__all__ = ['DynamicsNode', 'LEVEL_NAMES', 'MAX_NAMES_PER_REQUEST', 'MAX_PARAMETERS_PER_REQUEST',
           'MAX_VALIDATIONS_PER_REQUEST', 'default_qos']
