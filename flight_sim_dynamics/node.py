"""The ROS 2 node: pose/twist/accel setpoints in, leg lengths, rates and forces out.

A thin adapter around :func:`flight_sim_dynamics.solve`. Every complete
setpoint (pose, twist and acceleration with the same header stamp) is turned
into one solve and one ``actuator_states`` message stamped like the setpoint.
Nothing a planner sends can take the node down: every rejection is counted in
``/diagnostics`` and logged (throttled), and nothing non-finite is published.

Run it::

    dynamics_node --ros-args --params-file config/flight_sim_dynamics.yaml
    python -m flight_sim_dynamics.node            # packaged defaults
    flight-sim-dynamics node --ros-args -r __ns:=/sim

Topics (relative: a namespace or remap moves them), QoS and parameters are
described in docs/node.md. The plain-Python parts (quaternion conversion,
synchroniser, estimators, limit checks) are in :mod:`.setpoints`.
"""
from __future__ import annotations

import argparse
import array
import math
import sys
import time
from dataclasses import dataclass
from typing import Any, Sequence

import numpy as np
import rclpy
import rclpy.task
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from geometry_msgs.msg import AccelStamped, PoseStamped, TwistStamped
from rcl_interfaces.msg import (FloatingPointRange, IntegerRange, ParameterDescriptor,
                                SetParametersResult)
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import JointState

import flight_sim_dynamics as fsd

from . import parameters as prm
from .model import JOINT_NAMES, LEG_NAMES, Model
from .status import Status
from .setpoints import (ACCEL, ERROR, NON_FINITE_OUTPUT, POSE, SOLVER_ERROR, TWIST,
                        UNREACHABLE, WARN, CycleStats, DerivativeEstimator, LogThrottle,
                        NodeConfig, PoseInput, RateInput, Rejected, Setpoint, SetpointError,
                        StampSynchroniser, check_acceleration, check_limits, pose_input,
                        rate_input, unfollowable)

MODEL_NAMES = frozenset(spec.name for spec in prm.MODEL_PARAMETERS)
NODE_NAMES = frozenset(spec.name for spec in prm.NODE_PARAMETERS)
#: Parameters ROS itself declares on every node; not ours to check.
ROS_PARAMETERS = frozenset({'use_sim_time', 'start_type_description_service'})

DIAGNOSTIC_NAME = 'flight_sim_dynamics: inverse dynamics'
HARDWARE_ID = 'flight_sim_dynamics'


# ----------------------------------------------------------------------------
# The one place where the node calls the solver
# ----------------------------------------------------------------------------
def solve_setpoint(model: Model, q: Sequence[float], qd: Sequence[float],
                   qdd: Sequence[float]) -> tuple[Any | None, str, str]:
    """Solve one setpoint. Returns ``(solution, '', '')``, or ``(None, reason,
    message)`` when there is nothing to publish: reason ``unreachable`` (the
    solver's status unreachable or invalid_input) or ``solver_error``. Never
    raises."""
    try:
        sol = fsd.solve(model, q, qd, qdd)
    except Exception as exc:  # noqa: BLE001 - a malformed call: never escape a callback
        return None, SOLVER_ERROR, f'{type(exc).__name__}: {exc}'
    if sol.status is Status.UNREACHABLE:
        return None, UNREACHABLE, f'unreachable pose: {sol.detail}'
    if sol.status is Status.INVALID_INPUT:
        return None, SOLVER_ERROR, f'invalid input: {sol.detail}'
    return sol, '', ''


# ----------------------------------------------------------------------------
# Parameters <-> ROS
# ----------------------------------------------------------------------------
def descriptor_for(spec: prm.ParamSpec) -> ParameterDescriptor:
    """The ParameterDescriptor of one parameter of the schema: description
    with unit, range where there is one; doubles are dynamically typed so
    that an integer (``mass: 2``) is accepted as it is by
    :func:`parameters.validate`. Our on-set callback does the type check."""
    text = spec.full_description
    if spec.exclusive_minimum and spec.minimum is not None:
        text += f' (must be > {spec.minimum:g})'
    if spec.choices:
        text += f" (one of: {', '.join(spec.choices)})"
    if spec.length:
        text += f' ({spec.length} numbers)'
    d = ParameterDescriptor(description=text, read_only=False)
    if spec.kind == 'double':
        d.dynamic_typing = True
        if spec.minimum is not None or spec.maximum is not None:
            big = sys.float_info.max
            d.floating_point_range = [FloatingPointRange(
                from_value=float(spec.minimum if spec.minimum is not None else -big),
                to_value=float(spec.maximum if spec.maximum is not None else big),
                step=0.0)]
    elif spec.kind == 'double_array':
        d.dynamic_typing = True     # [0, 0, 1] in YAML is an integer array
        d.additional_constraints = f'{spec.length} numbers'
    elif spec.kind == 'integer':
        if spec.minimum is not None or spec.maximum is not None:
            d.integer_range = [IntegerRange(
                from_value=int(spec.minimum if spec.minimum is not None else -2 ** 63),
                to_value=int(spec.maximum if spec.maximum is not None else 2 ** 63 - 1),
                step=1)]
    if spec.choices:
        d.additional_constraints = 'one of: ' + ', '.join(spec.choices)
    return d


def plain(value: Any) -> Any:
    """A parameter value as plain Python (arrays become lists)."""
    if isinstance(value, (array.array, np.ndarray, tuple)):
        return list(value)
    return value


def ros_value(spec: prm.ParamSpec, value: Any) -> Any:
    """A default value as rclpy wants it for declaration."""
    if spec.kind == 'double_array':
        return [float(v) for v in value]
    if spec.kind == 'double':
        return float(value)
    return value


def make_qos(config: NodeConfig) -> QoSProfile:
    """QoS of setpoints and outputs: KEEP_LAST ``qos.depth``, ``qos.reliability``,
    VOLATILE (a late joiner must not get stale setpoints or forces)."""
    return QoSProfile(
        history=HistoryPolicy.KEEP_LAST, depth=config.qos_depth,
        reliability=(ReliabilityPolicy.RELIABLE if config.qos_reliability == 'reliable'
                     else ReliabilityPolicy.BEST_EFFORT),
        durability=DurabilityPolicy.VOLATILE)


@dataclass(frozen=True)
class Runtime:
    """What a cycle needs from the parameters: swapped as one reference."""

    model: Model
    config: NodeConfig


# ----------------------------------------------------------------------------
# The node
# ----------------------------------------------------------------------------
class DynamicsNode(Node):
    """Inverse dynamics of the flight simulator as a ROS 2 node."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__(prm.NODE_NAME, **kwargs)
        self._declare_parameters()
        values = self._parameter_values()
        # Invalid startup parameters raise ParameterError: main() reports it and exits.
        model = prm.model_from_values({k: values[k] for k in MODEL_NAMES}, require_all=True)
        config = NodeConfig.from_values({k: values[k] for k in NODE_NAMES})
        self._runtime = Runtime(model, config)
        self._staged: Runtime | None = None
        self._last_solution: Any = None

        self._stats = CycleStats()
        self._throttle = LogThrottle(config.log_throttle)
        self._sync: StampSynchroniser[PoseInput, RateInput] = StampSynchroniser(
            config.sync_wait, config.sync_max_pending)
        self._estimator = DerivativeEstimator(config.estimator, config.estimator_max_gap)

        # Reused output messages (no per-cycle message allocation).
        self._actuator_msg = JointState()
        self._actuator_msg.name = list(LEG_NAMES)
        self._actuator_msg.header.frame_id = config.frame_id
        self._joint_msg = JointState()
        self._joint_msg.name = list(JOINT_NAMES)
        self._joint_msg.header.frame_id = config.joint_states_frame_id
        self._diag_msg = DiagnosticArray()
        self._diag_status = DiagnosticStatus(name=DIAGNOSTIC_NAME, hardware_id=HARDWARE_ID)
        self._diag_msg.status = [self._diag_status]

        self._io: list[Any] = []
        self._io_dirty = False
        self._create_io(config)
        # /diagnostics: the standard topic, default QoS (reliable, depth 10).
        self._diag_pub = self.create_publisher(DiagnosticArray, '/diagnostics', 10)
        self._diag_timer = self.create_timer(config.diagnostics_period, self._on_diagnostics_timer)
        self._poll_timer = self.create_timer(self._poll_period(config), self._on_poll_timer)

        self.add_on_set_parameters_callback(self._on_set_parameters)
        self.add_post_set_parameters_callback(self._on_parameters_set)
        self.get_logger().info(
            f'ready: {len(prm.SPECS)} parameters, beta0 = {model.central.beta0:.6f} rad, '
            f'QoS {config.qos_reliability} depth {config.qos_depth}; '
            f'subscribing {self._topic("pose_setpoint")}, {self._topic("twist_setpoint")}, '
            f'{self._topic("accel_setpoint")}; publishing {self._topic("actuator_states")}, '
            f'{self._topic("joint_states")}, /diagnostics')

    # -- set-up ----------------------------------------------------------------
    def _topic(self, name: str) -> str:
        try:
            return self.resolve_topic_name(name)
        except Exception:  # noqa: BLE001 - informational only
            return name

    def _declare_parameters(self) -> None:
        defaults = packaged_defaults()
        self.declare_parameters('', [
            (spec.name, ros_value(spec, defaults[spec.name]), descriptor_for(spec))
            for spec in prm.ALL_PARAMETERS])
        overrides = getattr(self, '_parameter_overrides', {})   # rclpy: the --ros-args values
        unknown = sorted(set(overrides) - set(prm.SPECS) - ROS_PARAMETERS)
        if unknown:
            self.get_logger().warn('ignoring unknown parameters (typo?): ' + ', '.join(unknown))

    def _parameter_values(self) -> dict[str, Any]:
        return {name: plain(self.get_parameter(name).value) for name in prm.SPECS}

    @staticmethod
    def _poll_period(config: NodeConfig) -> float:
        return min(max(config.sync_wait / 2.0, 0.001), 0.05)

    def _create_io(self, config: NodeConfig) -> None:
        """(Re)create setpoint subscriptions and output publishers with the QoS
        of the parameters."""
        for entity in self._io:
            if hasattr(entity, 'publish'):
                self.destroy_publisher(entity)
            else:
                self.destroy_subscription(entity)
        qos = make_qos(config)
        self._actuator_pub = self.create_publisher(JointState, 'actuator_states', qos)
        self._joint_pub = self.create_publisher(JointState, 'joint_states', qos)
        self._io = [
            self._actuator_pub, self._joint_pub,
            self.create_subscription(PoseStamped, 'pose_setpoint', self._on_pose, qos),
            self.create_subscription(TwistStamped, 'twist_setpoint', self._on_twist, qos),
            self.create_subscription(AccelStamped, 'accel_setpoint', self._on_accel, qos),
        ]

    # -- subscription callbacks --------------------------------------------------
    def _on_pose(self, msg: PoseStamped) -> None:
        self._guard(self._handle_pose, msg)

    def _on_twist(self, msg: TwistStamped) -> None:
        self._guard(self._handle_rates, TWIST, msg, msg.twist)

    def _on_accel(self, msg: AccelStamped) -> None:
        self._guard(self._handle_rates, ACCEL, msg, msg.accel)

    def _guard(self, func: Any, *args: Any) -> None:
        """Run a callback body; nothing escapes (an escaped exception would stop
        the executor, i.e. the node)."""
        try:
            func(*args)
        except Exception as exc:  # noqa: BLE001
            self._internal_error(exc)

    def _internal_error(self, exc: BaseException) -> None:
        try:
            self._reject(SOLVER_ERROR, f'internal error: {type(exc).__name__}: {exc}')
        except Exception:  # noqa: BLE001 - even reporting failed: stay up
            pass

    def _handle_pose(self, msg: PoseStamped) -> None:
        now = time.monotonic()
        stamp = msg.header.stamp
        stamp_ns = stamp.sec * 1_000_000_000 + stamp.nanosec
        self._stats.received[POSE] += 1
        p, o = msg.pose.position, msg.pose.orientation
        try:
            pose = pose_input(p.x, p.y, p.z, o.x, o.y, o.z, o.w,
                              self._runtime.config.quaternion_tolerance)
        except SetpointError as exc:
            self._sync.discard(stamp_ns, POSE)
            self._reject(exc.reason, f'pose rejected: {exc}')
            return
        self._dispatch(*self._sync.add(POSE, stamp_ns, pose, now, stamp))

    def _handle_rates(self, kind: str, msg: Any, body: Any) -> None:
        now = time.monotonic()
        stamp_ns = msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec
        self._stats.received[kind] += 1
        lin, ang = body.linear, body.angular
        try:
            rates = rate_input(lin.x, lin.y, lin.z, ang.x, ang.y, ang.z, kind)
            if kind == ACCEL:
                config = self._runtime.config
                check_acceleration(rates.q, config.max_linear_acceleration,
                                   config.max_angular_acceleration)
        except SetpointError as exc:
            self._sync.discard(stamp_ns, kind)
            self._reject(exc.reason, f'{kind} rejected: {exc}')
            return
        self._dispatch(*self._sync.add(kind, stamp_ns, rates, now))

    def _on_poll_timer(self) -> None:
        """Release setpoints whose bounded wait expired; apply QoS changes."""
        try:
            if self._io_dirty:
                self._io_dirty = False
                self._create_io(self._runtime.config)
                self.get_logger().info('QoS changed: setpoint subscriptions and output '
                                       'publishers re-created')
            if self._sync.pending:
                self._dispatch(*self._sync.poll(time.monotonic()))
        except Exception as exc:  # noqa: BLE001
            self._internal_error(exc)

    def _dispatch(self, released: list[Setpoint], rejected: list[Rejected]) -> None:
        for item in rejected:
            self._reject(item.reason, item.message)
        for setpoint in released:
            self._guard(self._process, setpoint)    # one failure must not skip the others

    # -- one cycle -----------------------------------------------------------------
    def _process(self, sp: Setpoint) -> None:
        """Estimate what is missing, check, solve, publish: one setpoint."""
        runtime = self._runtime            # read once: a parameter change applies next cycle
        config = runtime.config
        pose: PoseInput = sp.pose
        stats = self._stats
        qd, qdd = self._estimator.update(sp.stamp_ns * 1e-9, pose.q,
                                         sp.twist.q if sp.twist is not None else None,
                                         sp.accel.q if sp.accel is not None else None)
        if sp.twist is None:
            stats.estimated_twist += 1
        if sp.accel is None:
            stats.estimated_accel += 1
            try:
                check_acceleration(qdd, config.max_linear_acceleration,
                                   config.max_angular_acceleration, 'estimated acceleration')
            except SetpointError as exc:
                self._reject(exc.reason, f'setpoint rejected: {exc}')
                return

        t0 = time.perf_counter()
        sol, reason, message = solve_setpoint(runtime.model, pose.q, qd, qdd)
        elapsed = time.perf_counter() - t0
        if sol is None:
            self._reject(reason, f'setpoint rejected: {message}')
            return
        length, rate, force = sol.length, sol.rate, sol.force
        joints, joint_rates = sol.joints, sol.joint_rates
        # sum() is finite iff every element is (one reduction per array)
        if not math.isfinite(float(length.sum() + rate.sum() + force.sum()
                                   + joints.sum() + joint_rates.sum())):
            self._reject(NON_FINITE_OUTPUT, 'solver returned a non-finite value (not published)')
            return

        ignored = unfollowable(pose, sp.twist, sp.accel, -sol.beta,
                               config.position_tolerance, config.angle_tolerance)
        if ignored:
            for component in ignored:
                stats.ignored[component] += 1
            text = 'motion the mechanism cannot follow, ignored: ' + ', '.join(ignored)
            stats.note(WARN, 'ignored ' + '/'.join(ignored))
            self._log(WARN, 'ignored', text)

        if sol.status is Status.NEAR_SINGULAR:
            stats.near_singular += 1
            stats.note(WARN, 'near singular')
            self._log(WARN, 'near_singular', f'near singular: {sol.detail}')
        limits = check_limits(sol.stroke, rate, force, runtime.model.limits,
                              config.warn_fraction)
        if limits.exceeded:
            stats.limit_exceeded += 1
            stats.note(ERROR, 'limit exceeded')
            self._log(ERROR, 'limit', 'actuator limit exceeded (published anyway): '
                      + ', '.join(limits.exceeded))
        elif limits.near:
            stats.near_limit += 1
            stats.note(WARN, 'near an actuator limit')

        # array('d') is taken as is by the message setters (no per-element checks)
        out = self._actuator_msg
        out.header.stamp = sp.header
        out.position = array.array('d', length.tobytes())
        out.velocity = array.array('d', rate.tobytes())
        out.effort = array.array('d', force.tobytes())
        joint_msg = self._joint_msg
        joint_msg.header.stamp = sp.header
        joint_msg.position = array.array('d', joints.tobytes())
        joint_msg.velocity = array.array('d', joint_rates.tobytes())
        self._actuator_pub.publish(out)
        self._joint_pub.publish(joint_msg)
        stats.solved(elapsed, sol.kinematic_condition, sol.jacobian_condition,
                     (out.effort[0], out.effort[1], out.effort[2]))
        self._last_solution = sol

    # -- rejection and logging -------------------------------------------------
    def _reject(self, reason: str, message: str) -> None:
        self._stats.reject(reason, message)
        self._log_rejection(reason, message)

    def _log_rejection(self, reason: str, message: str) -> None:
        self._log(ERROR if reason in (UNREACHABLE, SOLVER_ERROR) else WARN, reason, message)

    def _log(self, level: int, key: str, message: str) -> None:
        skipped = self._throttle(key, time.monotonic())
        if skipped is None:
            return
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
        and the running model is untouched."""
        try:
            ours = [p for p in params if p.name in prm.SPECS]
            if not ours:
                return SetParametersResult(successful=True)
            values = self._parameter_values()
            for p in ours:
                values[p.name] = plain(p.value)
            runtime = self._runtime
            model = runtime.model
            if any(p.name in MODEL_NAMES for p in ours):
                model = prm.model_from_values({k: values[k] for k in MODEL_NAMES},
                                              require_all=True)
            config = NodeConfig.from_values({k: values[k] for k in NODE_NAMES})
            self._staged = Runtime(model, config)
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
        if (new.estimator, new.estimator_max_gap) != (old.estimator, old.estimator_max_gap):
            self._estimator = DerivativeEstimator(new.estimator, new.estimator_max_gap)
        self._sync.wait = new.sync_wait
        self._sync.max_pending = new.sync_max_pending
        self._throttle.period = new.log_throttle
        self._actuator_msg.header.frame_id = new.frame_id
        self._joint_msg.header.frame_id = new.joint_states_frame_id
        if new.diagnostics_period != old.diagnostics_period:
            self._diag_timer.timer_period_ns = int(new.diagnostics_period * 1e9)
        if self._poll_period(new) != self._poll_period(old):
            self._poll_timer.timer_period_ns = int(self._poll_period(new) * 1e9)
        if (new.qos_depth, new.qos_reliability) != (old.qos_depth, old.qos_reliability):
            self._io_dirty = True       # re-created from the poll timer, not inside a service
        self.get_logger().info('parameters changed: ' + ', '.join(p.name for p in params))


def packaged_defaults() -> dict[str, Any]:
    """Declared defaults: the packaged YAML (so `dynamics_node` with no params
    file runs the packaged configuration), falling back to the schema."""
    try:
        return prm.validate(prm.read_params_file(prm.default_params_path()), require_all=False)
    except (prm.ParameterError, FileNotFoundError):
        return prm.defaults()


# ----------------------------------------------------------------------------
# Entry point
# ----------------------------------------------------------------------------
EXECUTORS = ('events', 'single')
DEFAULT_EXECUTOR = 'events'


def make_executor(name: str, context: Any = None) -> Any:
    """``events``: rclpy.experimental.EventsExecutor; ``single``:
    SingleThreadedExecutor."""
    if name == 'events':
        from rclpy.experimental import EventsExecutor
        return EventsExecutor(context=context)
    return SingleThreadedExecutor(context=context)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog='dynamics_node',
        description='ROS 2 node of flight_sim_dynamics: subscribes pose_setpoint, '
                    'twist_setpoint, accel_setpoint; publishes actuator_states, joint_states '
                    'and /diagnostics. ROS arguments go after --ros-args, e.g. '
                    '--ros-args --params-file config/flight_sim_dynamics.yaml '
                    '-r __ns:=/sim -p limits.max_force:=500.0',
        epilog='See docs/node.md for topics, parameters and QoS.')
    parser.add_argument('--executor', choices=EXECUTORS, default=DEFAULT_EXECUTOR,
                        help=f'rclpy executor (default: {DEFAULT_EXECUTOR})')
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run the node until Ctrl-C / SIGTERM. ``argv``: arguments after the
    program name (None: sys.argv[1:]), ROS arguments after ``--ros-args``."""
    argv = list(sys.argv[1:] if argv is None else argv)
    own = rclpy.utilities.remove_ros_args(['dynamics_node', *argv])[1:]
    args = build_parser().parse_args(own)
    rclpy.init(args=['dynamics_node', *argv])
    node = None
    executor = None
    try:
        try:
            node = DynamicsNode()
        except prm.ParameterError as exc:
            rclpy.logging.get_logger(prm.NODE_NAME).fatal(f'invalid parameters: {exc}')
            return 2
        executor = make_executor(args.executor)
        executor.add_node(node)
        spin(executor)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown()
    return 0


def spin(executor: Any, context: Any = None) -> None:
    """Spin until the context shuts down (Ctrl-C, SIGTERM).

    Always with a timeout: rclpy 7.1.6's EventsExecutor busy-loops at 100 % CPU
    in ``spin()`` (and hangs in ``spin_until_future_complete`` without a
    timeout), and does not return on SIGINT; with a timeout it idles and the
    shutdown is noticed within ``timeout_sec``."""
    never = rclpy.task.Future()
    while rclpy.ok(context=context):
        executor.spin_until_future_complete(never, timeout_sec=0.5)


if __name__ == '__main__':
    sys.exit(main())
