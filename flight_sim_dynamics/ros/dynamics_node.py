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

Topics, QoS and parameters: docs/node.md. The rclpy-free parts are modules
of their own (:mod:`.inputs`, :mod:`.synchroniser`, :mod:`.estimator`,
:mod:`.cycle`, :mod:`.diagnostics`, :mod:`.node_config`, :mod:`.descriptors`);
:mod:`.wire` reads and writes the serialized samples. QoS: :func:`default_qos`
with rclpy's read-only start-up overrides; endpoints are never re-created.
"""
from __future__ import annotations

import math
import sys
import time
from typing import Any, Callable, Sequence

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from geometry_msgs.msg import AccelStamped, PoseStamped, TwistStamped
from rcl_interfaces.msg import SetParametersResult
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import (DurabilityPolicy, HistoryPolicy, QoSPolicyKind, QoSProfile,
                       ReliabilityPolicy)
from rclpy.qos_overriding_options import InvalidQosOverridesError, QoSOverridingOptions
from sensor_msgs.msg import JointState
from trajectory_msgs.msg import JointTrajectory

from ..config import parameters as prm
from ..core.model import JOINT_NAMES, LEG_NAMES
from . import wire
from .cycle import (Runtime, assess, outputs_of, rates_of, runtime_from_values,
                    solve_setpoint)
from .descriptors import descriptor_for, packaged_defaults, plain, ros_value
from .diagnostics import ERROR, WARN, CycleStats, LogThrottle
from .estimator import DerivativeEstimator
from .inputs import (ACCEL, BAD_SETPOINT, PLATFORM, POSE, SOLVER_ERROR, TWIST, UNREACHABLE,
                     PoseInput, RateInput, SetpointError, check_acceleration,
                     platform_setpoints, pose_input, rate_input)
from .node_config import NodeConfig
from .parameter_service import ParameterServices
from .synchroniser import Rejected, Setpoint, StampSynchroniser

#: Parameters ROS itself declares on every node; not ours to check.
ROS_PARAMETERS = frozenset({'use_sim_time', 'start_type_description_service'})
#: Prefix of rclpy's QoS override parameters.
QOS_OVERRIDES = prm.QOS_OVERRIDES

DIAGNOSTIC_NAME = 'flight_sim_dynamics: inverse dynamics'
HARDWARE_ID = 'flight_sim_dynamics'


def default_qos() -> QoSProfile:
    """QoS of setpoints and outputs before overrides: reliable, KEEP_LAST 1000
    (1 s at 1 kHz: absorbs a stall of the node or the planner), VOLATILE (a
    late joiner must not get stale setpoints or forces; not overridable). A
    new profile per endpoint: rclpy writes the overrides into it.
    """
    return QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1000,
                      reliability=ReliabilityPolicy.RELIABLE,
                      durability=DurabilityPolicy.VOLATILE)


def describe_qos(qos: QoSProfile) -> str:
    """``reliable keep_last 1000`` (for the start-up log)."""
    return f'{qos.reliability.name.lower()} {qos.history.name.lower()} {qos.depth}'


#: The policies a start-up ``qos_overrides.*`` parameter may set.
QOS_POLICIES = (QoSPolicyKind.HISTORY, QoSPolicyKind.DEPTH, QoSPolicyKind.RELIABILITY)


def check_qos(qos: QoSProfile) -> SetParametersResult:
    """Reject overrides that cannot work: KEEP_LAST with depth < 1, or a
    reliability other than reliable / best_effort (system_default would make
    the node's behaviour depend on the middleware's configuration).
    """
    if qos.history == HistoryPolicy.KEEP_LAST and qos.depth < 1:
        return SetParametersResult(successful=False,
                                   reason=f'depth must be >= 1 with keep_last, got {qos.depth}')
    if qos.reliability not in (ReliabilityPolicy.RELIABLE, ReliabilityPolicy.BEST_EFFORT):
        return SetParametersResult(successful=False, reason='reliability must be reliable or '
                                   f'best_effort, got {qos.reliability.name.lower()}')
    return SetParametersResult(successful=True)


# ----------------------------------------------------------------------------
# The node
# ----------------------------------------------------------------------------
class DynamicsNode(Node):
    """Inverse dynamics of the flight simulator as a ROS 2 node.

    ``fast_wire`` False: setpoints and outputs go through rclpy's
    (de)serialisation only, not :mod:`.wire`'s CDR path (the A/B benchmark,
    scripts/bench_callbacks.py); ``kwargs`` go to rclpy's Node.
    """

    def __init__(self, *, fast_wire: bool = True, **kwargs: Any) -> None:
        # Every --ros-args parameter is declared first, so that the ones that
        # are not ours (typos) can be told apart with public API only.
        super().__init__(prm.NODE_NAME, automatically_declare_parameters_from_overrides=True,
                         start_parameter_services=False, **kwargs)
        # rclpy's parameter services can be killed by one request (issue 12 #1)
        ParameterServices(self)
        # The one rule for parameter files (config.parameters.read_params): an
        # unknown name in a --params-file is a ParameterError (main() exits 2).
        prm.check_params_files([*sys.argv, *(kwargs.get('cli_args') or ())],
                               self.get_fully_qualified_name())
        given = self._declare_parameters()
        values = self._parameter_values()
        # Invalid startup parameters raise ParameterError: main() reports it and exits.
        self._runtime = runtime_from_values(values)
        model, config = self._runtime.model, self._runtime.config
        self._staged: Runtime | None = None
        self._last_solution: Any = None
        self._fast = fast_wire

        self._stats = CycleStats()
        self._received = self._stats.received      # counters per message kind
        self._throttle = LogThrottle(config.diagnostics_log_throttle)
        self._sync: StampSynchroniser[PoseInput, RateInput] = StampSynchroniser(
            config.sync_wait, config.sync_max_pending)
        self._estimator = DerivativeEstimator(config.estimator_method,
                                              config.estimator_max_gap)

        # Reused output messages, kept serialized (see wire.JointStateOutput).
        self._actuator_out = wire.JointStateOutput(LEG_NAMES, config.output_frame_id, 3,
                                                   fast_wire)
        self._joint_out = wire.JointStateOutput(JOINT_NAMES, config.output_joint_states_frame_id,
                                                2, fast_wire)
        self._diag_msg = DiagnosticArray()
        self._diag_status = DiagnosticStatus(name=DIAGNOSTIC_NAME, hardware_id=HARDWARE_ID)
        self._diag_msg.status = [self._diag_status]

        self._create_endpoints()
        unknown = sorted(name for name in given if not self.has_parameter(name))
        if unknown:
            self.get_logger().warn('ignoring unknown parameters (typo?): ' + ', '.join(unknown))
        # /diagnostics: the standard topic, default QoS (reliable, depth 10).
        self._diag_pub = self.create_publisher(DiagnosticArray, '/diagnostics', 10)
        self._diag_timer = self.create_timer(config.diagnostics_period,
                                             self._on_diagnostics_timer)
        self._poll_timer = self.create_timer(self._poll_period(config), self._on_poll_timer)

        self.add_on_set_parameters_callback(self._on_set_parameters)
        self.add_post_set_parameters_callback(self._on_parameters_set)
        self.get_logger().info(
            f'ready: {len(prm.SPECS)} parameters, beta0 = {model.central.beta0:.6f} rad; '
            + ', '.join(f'{e.topic_name} ({describe_qos(e.qos_profile)})'
                        for e in self._endpoints) + ', /diagnostics')
        if not (self._actuator_out.raw and self._joint_out.raw):
            self.get_logger().info('outputs published as message objects (the middleware '
                                   'writes an encoding the in-place writer does not know, or '
                                   'fast_wire is off)')

    # -- set-up ----------------------------------------------------------------
    def _declare_parameters(self) -> set[str]:
        """Declare every parameter of the schema with its descriptor (the
        --ros-args value if given, else the packaged default). Returns the
        names given on the command line or in params files.
        """
        given = set(self.list_parameters([], 0).names) - ROS_PARAMETERS
        for name in given:
            # re-declared below with our descriptors (ours), by the endpoints
            # (qos_overrides.*) or not at all (unknown: reported)
            self.undeclare_parameter(name)
        defaults = packaged_defaults()
        self.declare_parameters('', [
            (spec.name, ros_value(spec, defaults[spec.name]), descriptor_for(spec))
            for spec in prm.ALL_PARAMETERS])
        return given

    def _parameter_values(self) -> dict[str, Any]:
        return {name: plain(self.get_parameter(name).value) for name in prm.SPECS}

    @staticmethod
    def _poll_period(config: NodeConfig) -> float:
        return min(max(config.sync_wait / 2.0, 0.001), 0.05)

    def _create_endpoints(self) -> None:
        """Setpoint subscriptions (serialized: read by :mod:`.wire`) and output
        publishers, each with :func:`default_qos` and its start-up overrides.
        """
        options = QoSOverridingOptions(QOS_POLICIES, callback=check_qos)
        try:
            self._actuator_pub = self.create_publisher(
                JointState, 'actuator_states', default_qos(), qos_overriding_options=options)
            self._joint_pub = self.create_publisher(
                JointState, 'joint_states', default_qos(), qos_overriding_options=options)
            self._endpoints = [self._actuator_pub, self._joint_pub] + [
                self.create_subscription(msg_type, topic, callback, default_qos(), raw=True,
                                         qos_overriding_options=options)
                for msg_type, topic, callback in (
                    (PoseStamped, 'pose_setpoint', self._on_pose),
                    (TwistStamped, 'twist_setpoint', self._on_twist),
                    (AccelStamped, 'accel_setpoint', self._on_accel),
                    (JointTrajectory, 'platform_setpoint', self._on_platform_setpoint))]
        except (InvalidQosOverridesError, RuntimeError, AssertionError, TypeError,
                ValueError) as exc:
            # rclpy: an unknown policy name (RuntimeError), a wrong type (assert)
            raise prm.ParameterError(QOS_OVERRIDES + '*', None,
                                     f'invalid QoS override: {exc}') from None

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
        try:
            fields, fallback = reader(data, self._fast)
        except Exception as exc:  # noqa: BLE001 - truncated or inconsistent bytes
            self._reject(BAD_SETPOINT, f'{kind} rejected: malformed serialized message: {exc}')
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
        self._on_message(POSE, wire.read_pose, self._pose_of, data)

    def _on_twist(self, data: bytes) -> None:
        self._on_message(TWIST, wire.read_twist, self._twist_of, data)

    def _on_accel(self, data: bytes) -> None:
        self._on_message(ACCEL, wire.read_accel, self._accel_of, data)

    def _pose_of(self, values: Sequence[float]) -> PoseInput:
        return pose_input(*values, self._runtime.config.input_quaternion_tolerance)

    @staticmethod
    def _twist_of(values: Sequence[float]) -> RateInput:
        return rate_input(*values, TWIST)

    def _accel_of(self, values: Sequence[float]) -> RateInput:
        rates = rate_input(*values, ACCEL)
        config = self._runtime.config
        check_acceleration(rates.q, config.input_max_linear_acceleration,
                           config.input_max_angular_acceleration)
        return rates

    def _on_message(self, kind: str, reader: Callable[[bytes, bool], tuple[Any, bool]],
                    check: Callable[[Sequence[float]], Any], data: bytes) -> None:
        """One pose, twist or accel message: read, checked (``check``: raises
        SetpointError), handed to the synchroniser.
        """
        try:
            now = time.monotonic()
            fields = self._read(kind, reader, data)
            if fields is None:
                return
            sec, nanosec, values = fields
            stamp_ns = sec * 1_000_000_000 + nanosec
            try:
                item = check(values)
            except SetpointError as exc:
                self._sync.discard(stamp_ns, kind)
                self._reject(exc.reason, f'{kind} rejected: {exc}')
                return
            released, rejected = self._sync.add(kind, stamp_ns, item, now, (sec, nanosec))
            if released or rejected:
                self._dispatch(released, rejected)
        except Exception as exc:  # noqa: BLE001
            self._internal_error(exc)

    def _on_platform_setpoint(self, data: bytes) -> None:
        """Whole setpoints, one per point of a JointTrajectory over surge, heave,
        roll (stamp = header.stamp + time_from_start): checked point by point
        (:func:`.inputs.platform_setpoints`), ordered with the three-topic
        setpoints by the synchroniser (:meth:`.StampSynchroniser.add_complete`),
        then solved like them.
        """
        try:
            now = time.monotonic()
            fields = self._read(PLATFORM, wire.read_trajectory, data)
            if fields is None:
                return
            config = self._runtime.config
            try:
                points = platform_setpoints(fields, config.input_max_linear_acceleration,
                                            config.input_max_angular_acceleration)
            except SetpointError as exc:
                self._reject(exc.reason, f'{PLATFORM} rejected: {exc}')
                return
            add_complete = self._sync.add_complete
            for point in points:
                if isinstance(point, SetpointError):
                    self._reject(point.reason, f'{PLATFORM} rejected: {point}')
                    continue
                released, rejected = add_complete(point.stamp_ns, point.pose, point.twist,
                                                  point.accel, now, point.header)
                self._dispatch(released, rejected)
        except Exception as exc:  # noqa: BLE001
            self._internal_error(exc)

    def _guard(self, func: Any, *args: Any) -> None:
        """Run a callback body; nothing escapes."""
        try:
            func(*args)
        except Exception as exc:  # noqa: BLE001
            self._internal_error(exc)

    def _internal_error(self, exc: BaseException) -> None:
        try:
            self._reject(SOLVER_ERROR, f'internal error: {type(exc).__name__}: {exc}')
        except Exception:  # noqa: BLE001 - even reporting failed: stay up
            pass

    def _on_poll_timer(self) -> None:
        """Release setpoints whose bounded wait expired."""
        try:
            if self._sync.pending:
                self._dispatch(*self._sync.poll(time.monotonic()))
        except Exception as exc:  # noqa: BLE001
            self._internal_error(exc)

    def _dispatch(self, released: list[Setpoint], rejected: list[Rejected]) -> None:
        for item in rejected:
            self._reject(item.reason, item.message)
        for setpoint in released:
            try:
                self._process(setpoint)
            except Exception as exc:  # noqa: BLE001 - one failure must not skip the others
                self._internal_error(exc)

    # -- one cycle -----------------------------------------------------------------
    def _process(self, sp: Setpoint) -> None:
        """Estimate what is missing, check, solve, publish: one setpoint
        (:mod:`.cycle`). The outputs go out as soon as the solution is known
        to be finite; the bookkeeping for the diagnostics comes after.
        """
        runtime = self._runtime            # read once: a parameter change applies next cycle
        stats = self._stats
        try:
            qd, qdd = rates_of(sp, runtime.config, self._estimator, stats)
            t0 = time.perf_counter()
            sol = solve_setpoint(runtime.model, sp.pose.q, qd, qdd)
            elapsed = time.perf_counter() - t0
        except SetpointError as exc:
            self._reject(exc.reason, f'setpoint rejected: {exc}')
            return
        try:
            length, rate, force, joints, joint_rates = outputs_of(sol)
        except SetpointError as exc:
            self._reject(exc.reason, str(exc))
            return
        sec, nanosec = sp.header
        actuator_out, joint_out = self._actuator_out, self._joint_out
        self._actuator_pub.publish(actuator_out.fill(sec, nanosec, length, rate, force))
        self._joint_pub.publish(joint_out.fill(sec, nanosec, joints, joint_rates))
        if not (actuator_out.raw and joint_out.raw):
            stats.wire_fallbacks += (not actuator_out.raw) + (not joint_out.raw)
        for level, key, message in assess(sol, sp, runtime, stats, elapsed, rate, force):
            self._log(level, key, message)
        self._last_solution = sol

    # -- rejection and logging -------------------------------------------------
    def _reject(self, reason: str, message: str) -> None:
        self._stats.reject(reason, message)
        self._log(ERROR if reason in (UNREACHABLE, SOLVER_ERROR) else WARN, reason, message)

    def _log(self, level: int, key: str, message: str | Callable[[], str]) -> None:
        """Log ``message`` (or what the callable returns: built only when the
        line is not throttled) at most once per ``diagnostics.log_throttle``
        per ``key``.
        """
        skipped = self._throttle(key, time.monotonic())
        if skipped is None:
            return
        if not isinstance(message, str):
            message = message()
        if skipped:
            message += f' ({skipped} more since the last such message)'
        # rclpy fixes a severity per call site: one call site per severity.
        if level >= ERROR:
            self.get_logger().error(message)
        else:
            self.get_logger().warn(message)

    # -- diagnostics -------------------------------------------------------------
    def _on_diagnostics_timer(self) -> None:
        try:
            last = self._last_solution
            exact_cond = last.cond if last is not None else math.nan   # one SVD per report
            level, message, values = self._stats.report(time.monotonic(), exact_cond)
            values.insert(1, ('scene', self._runtime.model.scene))
            status = self._diag_status
            status.level = bytes([level])
            status.message = message
            status.values = [KeyValue(key=k, value=v) for k, v in values]
            self._diag_msg.header.stamp = self.get_clock().now().to_msg()
            self._diag_pub.publish(self._diag_msg)
        except Exception as exc:  # noqa: BLE001
            self._internal_error(exc)

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
            values = self._parameter_values()
            for p in ours:
                values[p.name] = plain(p.value)
            self._staged = runtime_from_values(values, self._runtime, [p.name for p in ours])
            return SetParametersResult(successful=True)
        except prm.ParameterError as exc:
            reason = str(exc)
        except Exception as exc:  # noqa: BLE001 - e.g. a geometry the solver chokes on
            reason = f'{type(exc).__name__}: {exc}'
        self._staged = None
        self._stats.parameter_rejections += 1
        self.get_logger().warn(f'parameter change rejected, model unchanged: {reason}')
        return SetParametersResult(successful=False, reason=reason)

    def _on_parameters_set(self, params: list[Parameter]) -> None:
        """Commit a staged change: one reference assignment, read once per cycle."""
        self._guard(self._commit, params)

    def _commit(self, params: list[Parameter]) -> None:
        staged, self._staged = self._staged, None
        if staged is None:
            return
        old = self._runtime.config
        self._runtime = staged
        new = staged.config
        self._stats.parameter_changes += 1
        if (new.estimator_method, new.estimator_max_gap) != (old.estimator_method,
                                                             old.estimator_max_gap):
            self._estimator = DerivativeEstimator(new.estimator_method, new.estimator_max_gap)
        self._sync.wait = new.sync_wait
        self._sync.max_pending = new.sync_max_pending
        self._throttle.period = new.diagnostics_log_throttle
        if new.output_frame_id != old.output_frame_id:
            self._actuator_out = wire.JointStateOutput(LEG_NAMES, new.output_frame_id, 3,
                                                       self._fast)
        if new.output_joint_states_frame_id != old.output_joint_states_frame_id:
            self._joint_out = wire.JointStateOutput(
                JOINT_NAMES, new.output_joint_states_frame_id, 2, self._fast)
        if new.diagnostics_period != old.diagnostics_period:
            self._diag_timer.timer_period_ns = int(new.diagnostics_period * 1e9)
        if self._poll_period(new) != self._poll_period(old):
            self._poll_timer.timer_period_ns = int(self._poll_period(new) * 1e9)
        self.get_logger().info('parameters changed: ' + ', '.join(p.name for p in params))
