"""The ROS 2 node (the :class:`DynamicsNode`; its executable is :mod:`.node`):
pose/twist/accel setpoints in, leg lengths, rates and forces out.

A thin adapter around :func:`flight_sim_dynamics.solve`. Every complete
setpoint (pose, twist and acceleration with the same header stamp on
``pose_setpoint``, ``twist_setpoint``, ``accel_setpoint``; or one point of a
``trajectory_msgs/JointTrajectory`` over surge, heave, roll on
``platform_setpoint``, which carries a whole setpoint in one message) is
turned into one solve and one ``actuator_states`` message stamped like the
setpoint.
Nothing a planner sends can take the node down: every rejection is counted in
``/diagnostics`` and logged (throttled), and nothing non-finite is published.

A managed node: ``configure`` validates the parameters, builds the model and
creates the endpoints (a failure leaves it unconfigured, the reason logged);
``activate`` starts answering; while inactive, setpoints count as
``inactive``; ``cleanup`` and ``shutdown`` release the endpoints.

Topics, QoS, parameters, lifecycle: docs/node.md. The rules are rclpy-free:
:mod:`.intake` (from a message to an answer), :mod:`.node_config`,
:mod:`.descriptors`; :mod:`.wire` reads and writes the serialized samples.
"""
from __future__ import annotations

import math
import sys
import time
from typing import Any, Callable, Sequence

from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import AccelStamped, PoseStamped, TwistStamped
from rcl_interfaces.msg import SetParametersResult
from rclpy.clock import Clock, ClockType
from rclpy.lifecycle import LifecycleNode, LifecycleState, TransitionCallbackReturn
from rclpy.lifecycle.publisher import LifecyclePublisher
from rclpy.parameter import Parameter
from rclpy.publisher import Publisher
from rclpy.task import Future
from rclpy.qos_overriding_options import InvalidQosOverridesError, QoSOverridingOptions
from sensor_msgs.msg import JointState
from trajectory_msgs.msg import JointTrajectory
from visualization_msgs.msg import MarkerArray

from ..config import parameters as prm
from ..core.model import JOINT_NAMES, LEG_NAMES
from . import wire
from .cycle import Runtime, runtime_from_values
from .descriptors import plain
from .diagnostics import ERROR, WARN, DiagnosticsOutput, diagnostic_name
from .inputs import ACCEL, BAD_SETPOINT, INACTIVE, PLATFORM, POSE, TWIST, SetpointError
from .intake import SetpointIntake
from .markers import MarkerBuilder
from .node_config import NodeConfig
from .node_parameters import NodeParameters
from .parameter_service import ParameterServices
from .qos import QOS_POLICIES, check_qos, default_qos, describe_qos
from .synchroniser import Setpoint

SUCCESS, FAILURE = TransitionCallbackReturn.SUCCESS, TransitionCallbackReturn.FAILURE
#: Seconds one reading of the clock serves the future-stamp check (a bound of
#: input.max_future, ~1 s, is 200 times coarser).
LATEST_STAMP_REUSE = 0.005
#: Prefix of rclpy's QoS override parameters.
QOS_OVERRIDES = prm.QOS_OVERRIDES



# ----------------------------------------------------------------------------
# The node
# ----------------------------------------------------------------------------
class DynamicsNode(LifecycleNode):
    """Inverse dynamics of the flight simulator as a managed ROS 2 node.

    ``fast_wire`` False: setpoints and outputs go through rclpy's
    (de)serialisation only, not :mod:`.wire`'s CDR path (the A/B benchmark,
    benchmarks/bench_callbacks.py); ``kwargs`` go to rclpy's Node. Starts
    unconfigured: :meth:`start` (or a lifecycle manager) configures and
    activates it. :attr:`failure`: why the last configure failed;
    :attr:`finalized`: done when the node was shut down.
    """

    def __init__(self, *, fast_wire: bool = True, **kwargs: Any) -> None:
        # Every --ros-args parameter is declared first, so that the ones that
        # are not ours (typos) can be told apart with public API only.
        super().__init__(prm.NODE_NAME, automatically_declare_parameters_from_overrides=True,
                         start_parameter_services=False, **kwargs)
        # rclpy's parameter services can be killed by one request (issue 12 #1)
        ParameterServices(self, NodeParameters.precheck)
        # The one rule for parameter files (config.parameters.read_params): an
        # unknown name in a --params-file is a ParameterError (main() exits 2).
        prm.check_params_files([*sys.argv, *(kwargs.get('cli_args') or ())],
                               self.get_fully_qualified_name())
        self._params = NodeParameters(self)
        self._fast = fast_wire
        self._runtime: Runtime | None = None     # None: unconfigured
        self._staged: Runtime | None = None
        self._intake: SetpointIntake | None = None
        self._endpoints: list[Any] = []
        self._timers: list[Any] = []
        self._active = False
        self._unknown_reported = False
        self._starting = False
        self.failure: str | None = None
        self.finalized = Future()
        self._latest: int | None = None     # _latest_stamp(), reused until _latest_until
        self._latest_until = 0.0
        # Timers on the steady clock: they keep ticking with use_sim_time and no /clock.
        self._steady = Clock(clock_type=ClockType.STEADY_TIME)
        self._diag = DiagnosticsOutput(diagnostic_name(self.get_fully_qualified_name()))
        self.add_on_set_parameters_callback(self._on_set_parameters)
        self.add_post_set_parameters_callback(self._on_parameters_set)

    def start(self) -> bool:
        """configure, then activate (``autostart``); False (and :attr:`failure`)
        when configure failed.
        """
        self._starting = True       # a failure is the caller's one error: line, not a log
        try:
            if self.trigger_configure() != SUCCESS:
                return False
        finally:
            self._starting = False
        return self.trigger_activate() == SUCCESS

    # -- lifecycle ---------------------------------------------------------------
    def on_configure(self, state: LifecycleState) -> TransitionCallbackReturn:
        """Validate the parameters, build the model and create the endpoints;
        on a bad parameter: unconfigured, the reason logged and in
        :attr:`failure`.
        """
        try:
            problem = self._params.startup_problem()
            if problem is not None:
                raise problem
            runtime = runtime_from_values(self._params.values())
            self._runtime = runtime
            if self._intake is None:
                self._intake = SetpointIntake(runtime, self._publish, self._emit,
                                              self._latest_stamp, self.context.ok)
                self._stats = self._intake.stats
                self._received = self._stats.received      # counters per message kind
            else:
                self._intake.reconfigure(runtime)
                self._intake.reset()
            self._create_endpoints(runtime)
        except Exception as exc:  # noqa: BLE001 - a ParameterError, a geometry the solver refuses
            reason = str(exc) if isinstance(exc, prm.ParameterError) \
                else f'{type(exc).__name__}: {exc}'
            self._release()
            self.failure = f'invalid parameters: {reason}'
            if not self._starting:
                self.get_logger().error(f'configure failed, still unconfigured: {self.failure}')
            return FAILURE
        self.failure = None
        if not self._unknown_reported and self._params.unknown:
            self.get_logger().warn('ignoring unknown parameters (typo?): '
                                   + ', '.join(self._params.unknown))
        self._unknown_reported = True
        model = runtime.model
        self.get_logger().info(
            f'configured: {len(prm.SPECS)} parameters, beta0 = {model.central.beta0:.6f} rad; '
            + ', '.join(f'{e.topic_name} ({describe_qos(e.qos_profile)})'
                        for e in self._endpoints) + ', /diagnostics')
        return SUCCESS

    def on_activate(self, state: LifecycleState) -> TransitionCallbackReturn:
        self._intake.reset()                  # nothing from before counts as history
        self._active = True
        self.get_logger().info('active: answering setpoints')
        return super().on_activate(state)     # enables the lifecycle publishers

    def on_deactivate(self, state: LifecycleState) -> TransitionCallbackReturn:
        self._active = False
        dropped = self._intake.reset()
        for _ in range(dropped):
            self._intake.reject(INACTIVE, 'pending setpoint dropped: the node was deactivated')
        self.get_logger().info('inactive: setpoints are counted as inactive, not answered')
        return super().on_deactivate(state)

    def on_cleanup(self, state: LifecycleState) -> TransitionCallbackReturn:
        self._release()
        self.get_logger().info('unconfigured: endpoints released')
        return SUCCESS

    def on_shutdown(self, state: LifecycleState) -> TransitionCallbackReturn:
        self._release()
        if not self.finalized.done():
            self.finalized.set_result(True)
        return SUCCESS

    def on_error(self, state: LifecycleState) -> TransitionCallbackReturn:
        self._release()
        return SUCCESS

    def _release(self) -> None:
        """Destroy what configure created: back to unconfigured."""
        self._active = False
        for timer in filter(None, [*self._timers, getattr(self, '_markers_timer', None)]):
            self.destroy_timer(timer)
        for entity in filter(None, [*self._endpoints, getattr(self, '_markers_pub', None),
                                    getattr(self, '_diag_pub', None)]):
            (self.destroy_lifecycle_publisher if isinstance(entity, LifecyclePublisher) else
             self.destroy_publisher if isinstance(entity, Publisher) else
             self.destroy_subscription)(entity)
        self._endpoints, self._timers = [], []
        self._markers_pub = self._diag_pub = self._markers_timer = None
        self._runtime = self._staged = None

    # -- set-up ----------------------------------------------------------------
    def _create_endpoints(self, runtime: Runtime) -> None:
        """Outputs (lifecycle publishers: silent unless active), setpoint
        subscriptions (serialized: read by :mod:`.wire`), /diagnostics and
        the timers. QoS: :func:`default_qos` and its start-up overrides.
        """
        config = runtime.config
        # Reused output messages, kept serialized (see wire.JointStateOutput).
        self._actuator_out = wire.JointStateOutput(LEG_NAMES, config.output_frame_id, 3,
                                                   self._fast)
        self._joint_out = wire.JointStateOutput(JOINT_NAMES, config.output_joint_states_frame_id,
                                                2, self._fast)
        self._diag.status.hardware_id = config.diagnostics_hardware_id
        options = QoSOverridingOptions(QOS_POLICIES, callback=check_qos)
        try:
            self._actuator_pub = self.create_lifecycle_publisher(
                JointState, 'actuator_states', default_qos(), qos_overriding_options=options)
            self._endpoints.append(self._actuator_pub)
            self._joint_pub = self.create_lifecycle_publisher(
                JointState, 'joint_states', default_qos(), qos_overriding_options=options)
            self._endpoints.append(self._joint_pub)
            for msg_type, topic, callback in (
                    (PoseStamped, 'pose_setpoint', self._on_pose),
                    (TwistStamped, 'twist_setpoint', self._on_twist),
                    (AccelStamped, 'accel_setpoint', self._on_accel),
                    (JointTrajectory, 'platform_setpoint', self._on_platform_setpoint)):
                self._endpoints.append(self.create_subscription(
                    msg_type, topic, callback, default_qos(), raw=True,
                    qos_overriding_options=options))
        except (InvalidQosOverridesError, RuntimeError, AssertionError, TypeError,
                ValueError) as exc:
            # rclpy: an unknown policy name (RuntimeError), a wrong type (assert)
            raise prm.ParameterError(QOS_OVERRIDES + '*', None,
                                     f'invalid QoS override: {exc}') from None
        # /diagnostics: the standard topic, default QoS (reliable, depth 10); it
        # reports while inactive too.
        self._diag_pub = self.create_publisher(DiagnosticArray, '/diagnostics', 10)
        self._diag_timer = self.create_timer(config.diagnostics_period,
                                             self._on_diagnostics_timer, clock=self._steady)
        self._poll_timer = self.create_timer(self._poll_period(config), self._on_poll_timer,
                                             clock=self._steady)
        self._timers += [self._diag_timer, self._poll_timer]
        # The mechanism for RViz / Foxglove (ros/markers.py), output.markers_rate Hz.
        self._markers = MarkerBuilder(runtime.model, config.output_frame_id)
        self._markers_pub = self.create_lifecycle_publisher(MarkerArray, 'markers', 10)
        self._markers_timer = None
        self._markers_rate(config.output_markers_rate)
        if not (self._actuator_out.raw and self._joint_out.raw):
            self.get_logger().info('outputs published as message objects (the middleware '
                                   'writes an encoding the in-place writer does not know, or '
                                   'fast_wire is off)')

    def _latest_stamp(self) -> int | None:
        """The latest stamp accepted now (ns): the node's clock plus
        ``input.max_future``; None when there is no check (0, or a sim-time
        clock before its first /clock message).
        """
        # Reading the ROS clock costs ~2 us: once per LATEST_STAMP_REUSE s is
        # precise enough for a bound of ~1 s (and costs nothing per message).
        mono = time.monotonic()
        if mono < self._latest_until:
            return self._latest
        max_future = self._runtime.config.input_max_future
        now = self.get_clock().now().nanoseconds if max_future else 0
        self._latest = now + int(max_future * 1e9) if now else None
        self._latest_until = mono + LATEST_STAMP_REUSE
        return self._latest

    def _stamp_check(self) -> str:
        """How stamps are checked against the clock now (for /diagnostics)."""
        max_future = self._runtime.config.input_max_future
        if not max_future:
            return 'off (input.max_future = 0)'
        if not self.get_clock().now().nanoseconds:
            return 'off until the first /clock (use_sim_time)'
        return f'stamps at most {max_future:g} s ahead of the node\'s clock'


    @staticmethod
    def _poll_period(config: NodeConfig) -> float:
        return min(max(config.sync_wait / 2.0, 0.001), 0.05)

    # -- subscription callbacks --------------------------------------------------
    # The setpoints arrive serialized (raw=True) and are read by wire.read_*.
    # Nothing escapes a callback (an escaped exception would stop the
    # executor, i.e. the node).
    def _read(self, kind: str, reader: Callable[[bytes, bool], tuple[Any, bool]],
              data: bytes) -> Any:
        """The fields of one serialized sample, or None when it is malformed:
        bad input (``bad_setpoint``), not an internal error. A sample rclpy had
        to deserialize is counted (``wire fallbacks``) and logged once.
        """
        self._received[kind] += 1
        if not self._active:            # inactive: counted, never answered later
            self._intake.reject(INACTIVE, f'{kind} received while inactive: not answered')
            return None
        try:
            fields, fallback = reader(data, self._fast)
        except SetpointError as exc:    # refused before it was decoded (too many points)
            self._intake.reject(exc.reason, f'{kind} rejected: {exc}')
            return None
        except Exception as exc:  # noqa: BLE001 - truncated or inconsistent bytes
            self._intake.reject(BAD_SETPOINT,
                                f'{kind} rejected: malformed serialized message: {exc}')
            return None
        if fallback:
            self._wire_fallback(kind)
        return fields

    def _wire_fallback(self, what: str) -> None:
        self._stats.wire_fallbacks += 1
        if self._stats.wire_fallbacks == 1:
            self.get_logger().info(f'a {what} sample went through rclpy\'s (de)serialisation, '
                                   'not the CDR fast path (counted in /diagnostics as "wire '
                                   'fallbacks"; logged once)')

    def _on_pose(self, data: bytes) -> None:
        self._on_stamped(POSE, wire.read_pose, self._intake.check_pose, data)

    def _on_twist(self, data: bytes) -> None:
        self._on_stamped(TWIST, wire.read_twist, self._intake.check_twist, data)

    def _on_accel(self, data: bytes) -> None:
        self._on_stamped(ACCEL, wire.read_accel, self._intake.check_accel, data)

    def _on_stamped(self, kind: str, reader: Callable[[bytes, bool], tuple[Any, bool]],
                    check: Callable[[Sequence[float]], Any], data: bytes) -> None:
        """One pose, twist or accel message: read, then the intake's."""
        try:
            now = time.monotonic()
            fields = self._read(kind, reader, data)
            if fields is not None:
                self._intake.stamped(kind, fields, check, now)
        except Exception as exc:  # noqa: BLE001
            self._intake.internal_error(exc)

    def _on_platform_setpoint(self, data: bytes) -> None:
        """A JointTrajectory of whole setpoints: read (at most
        ``input.max_points`` points, else refused undecoded), then the
        intake's (:meth:`.SetpointIntake.platform`).
        """
        try:
            now = time.monotonic()
            max_points = self._runtime.config.input_max_points
            fields = self._read(PLATFORM, lambda raw, fast: wire.read_trajectory(
                raw, fast, max_points), data)
            if fields is not None:
                self._intake.platform(fields, now)
        except Exception as exc:  # noqa: BLE001
            self._intake.internal_error(exc)

    def _guard(self, func: Any, *args: Any) -> None:
        """Run a callback body; nothing escapes."""
        try:
            func(*args)
        except Exception as exc:  # noqa: BLE001
            if self._intake is not None:
                self._intake.internal_error(exc)

    def _on_poll_timer(self) -> None:
        """Release setpoints whose bounded wait expired."""
        self._intake.poll(time.monotonic())

    # -- outputs ---------------------------------------------------------------------
    def _markers_rate(self, rate: float) -> None:
        """(Re)start the markers timer at ``rate`` Hz; 0: stop, and clear the view."""
        if self._markers_timer is not None:
            self.destroy_timer(self._markers_timer)
            self._markers_timer = None
            if not rate:
                self._markers_pub.publish(self._markers.clear())
        if rate:
            self._markers_timer = self.create_timer(1.0 / rate, self._on_markers_timer,
                                                    clock=self._steady)

    def _on_markers_timer(self) -> None:
        """The mechanism at the last answered setpoint, stamped like it."""
        try:
            sol = self._intake.last_solution
            if sol is not None:
                sec, nanosec = self._intake.last_header
                self._markers_pub.publish(self._markers.update(sol, sec, nanosec))
        except Exception as exc:  # noqa: BLE001
            self._intake.internal_error(exc)


    def _publish(self, sp: Setpoint, length: list[float], rate: list[float],
                 force: list[float], joints: list[float], joint_rates: list[float]) -> None:
        """The answer to one setpoint, stamped like it: actuator_states and
        joint_states (reused serialized messages, :class:`.wire.JointStateOutput`).
        """
        sec, nanosec = sp.header
        actuator_out, joint_out = self._actuator_out, self._joint_out
        self._actuator_pub.publish(actuator_out.fill(sec, nanosec, length, rate, force))
        self._joint_pub.publish(joint_out.fill(sec, nanosec, joints, joint_rates))
        if not (actuator_out.raw and joint_out.raw):
            self._stats.wire_fallbacks += (not actuator_out.raw) + (not joint_out.raw)

    def _emit(self, level: int, message: str) -> None:
        """One log line of the intake (already throttled)."""
        # rclpy fixes a severity per call site: one call site per severity.
        if level >= ERROR:
            self.get_logger().error(message)
        elif level == WARN:
            self.get_logger().warn(message)
        else:
            self.get_logger().info(message)

    # -- diagnostics -------------------------------------------------------------
    def _on_diagnostics_timer(self) -> None:
        try:
            last = self._intake.last_solution
            self._stats.stamp_check = self._stamp_check()
            exact_cond = last.cond if last is not None else math.nan   # one SVD per report
            level, message, values = self._stats.report(time.monotonic(), exact_cond)
            values.insert(1, ('scene', self._runtime.model.scene))
            values.insert(1, ('lifecycle state', 'active' if self._active else 'inactive'))
            self._diag_pub.publish(self._diag.fill(level, message, values,
                                                   self.get_clock().now().to_msg()))
        except Exception as exc:  # noqa: BLE001
            self._intake.internal_error(exc)

    # -- parameters --------------------------------------------------------------
    def _on_set_parameters(self, params: list[Parameter]) -> SetParametersResult:
        """Validate the whole parameter set as it would be after the change.
        Accepted: the new model/config is staged and swapped in by
        :meth:`_on_parameters_set`. Rejected: the reason goes back to the caller
        and the running model is untouched.
        """
        try:
            ours = [p for p in params if p.name in prm.SPECS]
            if not ours:
                return SetParametersResult(successful=True)
            if self._runtime is None:       # unconfigured: each on its own; configure checks all
                reason = next(filter(None, map(NodeParameters.precheck, ours)), None)
                return self._refused(reason) if reason else SetParametersResult(successful=True)
            values = self._params.values()
            for p in ours:
                values[p.name] = plain(p.value)
            self._staged = runtime_from_values(values, self._runtime, [p.name for p in ours])
            return SetParametersResult(successful=True)
        except prm.ParameterError as exc:
            reason = str(exc)
        except Exception as exc:  # noqa: BLE001 - e.g. a geometry the solver chokes on
            reason = f'{type(exc).__name__}: {exc}'
        return self._refused(reason)

    def _refused(self, reason: str) -> SetParametersResult:
        self._staged = None
        if self._intake is not None:
            self._stats.parameter_rejections += 1
        self.get_logger().warn(f'parameter change rejected, model unchanged: {reason}')
        return SetParametersResult(successful=False, reason=reason)

    def _on_parameters_set(self, params: list[Parameter]) -> None:
        """Commit a staged change: one reference assignment, read once per cycle."""
        self._guard(self._commit, params)

    def _commit(self, params: list[Parameter]) -> None:
        self._params.set([p.name for p in params])
        staged, self._staged = self._staged, None
        if staged is None:
            return
        old, old_model = self._runtime.config, self._runtime.model
        self._runtime = staged
        self._intake.reconfigure(staged)
        new = staged.config
        self._stats.parameter_changes += 1
        self._diag.status.hardware_id = new.diagnostics_hardware_id
        if new.output_frame_id != old.output_frame_id:
            self._actuator_out = wire.JointStateOutput(LEG_NAMES, new.output_frame_id, 3,
                                                       self._fast)
        if staged.model is not old_model:
            self._markers = MarkerBuilder(staged.model, new.output_frame_id)
        self._markers.frame_id = new.output_frame_id
        if new.output_markers_rate != old.output_markers_rate:
            self._markers_rate(new.output_markers_rate)
        if new.output_joint_states_frame_id != old.output_joint_states_frame_id:
            self._joint_out = wire.JointStateOutput(
                JOINT_NAMES, new.output_joint_states_frame_id, 2, self._fast)
        if new.diagnostics_period != old.diagnostics_period:
            self._diag_timer.timer_period_ns = int(new.diagnostics_period * 1e9)
        if self._poll_period(new) != self._poll_period(old):
            self._poll_timer.timer_period_ns = int(self._poll_period(new) * 1e9)
        self.get_logger().info('parameters changed: '
                               + ', '.join(dict.fromkeys(p.name for p in params)))
