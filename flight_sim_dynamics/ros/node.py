"""The ROS 2 node: pose/twist/accel setpoints in, leg lengths, rates and forces out.

A thin adapter around :func:`flight_sim_dynamics.solve`. Every complete
setpoint (pose, twist and acceleration with the same header stamp on
``pose_setpoint``, ``twist_setpoint``, ``accel_setpoint``; or one point of a
``trajectory_msgs/JointTrajectory`` over surge, heave, roll on
``platform_setpoint``, which carries a whole setpoint in one message) is
turned into one solve and one ``actuator_states`` message stamped like the
setpoint.
Nothing a planner sends can take the node down: every rejection is counted in
``/diagnostics`` and logged (throttled), and nothing non-finite is published.

Run it::

    dynamics_node --ros-args --params-file config/flight_sim_dynamics.yaml
    python -m flight_sim_dynamics.node            # packaged defaults
    flight-sim-dynamics node --ros-args -r __ns:=/sim

Topics (relative: a namespace or remap moves them), QoS and parameters are
described in docs/node.md. The plain-Python parts (quaternion conversion,
synchroniser, estimators, limit checks, reading serialized setpoints) are in
:mod:`.setpoints`.

Per setpoint the node builds no ROS message: the setpoints are taken
serialized and read in place (:class:`.setpoints.StampedReader`,
:class:`.setpoints.TrajectoryReader`), the two
outputs are serialized templates whose stamp and numbers are overwritten
(:class:`JointStateOutput`), and nothing is logged or formatted unless a
(throttled) line is due. docs/node.md, "What a cycle costs", has the figures.
"""
from __future__ import annotations

import argparse
import array
import math
import struct
import sys
import time
from dataclasses import dataclass
from typing import Any, Callable, Sequence

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
from rclpy.serialization import deserialize_message, serialize_message
from sensor_msgs.msg import JointState
from trajectory_msgs.msg import JointTrajectory

import flight_sim_dynamics as fsd

from ..config import parameters as prm
from ..core.model import JOINT_NAMES, LEG_NAMES, Model
from ..core.status import Status
from .setpoints import (ACCEL, BAD_SETPOINT, CDR_BE, CDR_LE, ERROR, NON_FINITE_OUTPUT,
                        PLATFORM, POSE, SOLVER_ERROR, TWIST, UNREACHABLE, WARN, CycleStats,
                        DerivativeEstimator, LogThrottle, NodeConfig, PoseInput, RateInput,
                        Rejected, Setpoint, SetpointError, StampSynchroniser, Trajectory,
                        TrajectoryPoint, check_acceleration, check_limits, platform_setpoints,
                        pose_input, rate_input, read_joint_trajectory, read_pose_stamped,
                        read_twist_stamped, unfollowable)

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


def _pose_fields(msg: PoseStamped) -> tuple[int, int, tuple[float, ...]]:
    """What :data:`.setpoints.read_pose_stamped` reads, from a PoseStamped."""
    p, o = msg.pose.position, msg.pose.orientation
    return (msg.header.stamp.sec, msg.header.stamp.nanosec,
            (p.x, p.y, p.z, o.x, o.y, o.z, o.w))


def _rate_fields(msg: Any) -> tuple[int, int, tuple[float, ...]]:
    """What :data:`.setpoints.read_twist_stamped` reads, from a TwistStamped or
    AccelStamped."""
    body = msg.twist if isinstance(msg, TwistStamped) else msg.accel
    lin, ang = body.linear, body.angular
    return (msg.header.stamp.sec, msg.header.stamp.nanosec,
            (lin.x, lin.y, lin.z, ang.x, ang.y, ang.z))


def _trajectory_fields(msg: JointTrajectory) -> Trajectory:
    """What :data:`.setpoints.read_joint_trajectory` reads, from a JointTrajectory."""
    stamp = msg.header.stamp
    return Trajectory(stamp.sec, stamp.nanosec, tuple(msg.joint_names), tuple(
        TrajectoryPoint(tuple(p.positions), tuple(p.velocities), tuple(p.accelerations),
                        tuple(p.effort), p.time_from_start.sec, p.time_from_start.nanosec)
        for p in msg.points))


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


class JointStateOutput:
    """One output topic's ``sensor_msgs/JointState``, reused every cycle.

    Names and ``header.frame_id`` are fixed; per cycle only the stamp and the
    value arrays change (their lengths never do). So the message is kept
    *serialized*: a template built once by the middleware's own serializer,
    in which :meth:`fill` overwrites the stamp and the doubles in place, and
    which is published as bytes (``Publisher.publish`` takes a serialized
    message). That skips converting the Python message to C and serializing
    it again every cycle: the wire bytes are the same.

    The template is checked once, by deserializing a filled copy; if the
    middleware's encoding is not one this class understands, ``raw`` is
    False and :meth:`fill` returns the message object with its arrays
    replaced instead (the old way: correct, slower).

    ``names``: joint names; ``frame_id``; ``arrays``: how many value arrays
    are filled (3: position, velocity, effort; 2: position, velocity, effort
    left empty).
    """

    FIELDS = ('position', 'velocity', 'effort')

    def __init__(self, names: Sequence[str], frame_id: str, arrays: int = 3) -> None:
        self.msg = JointState()
        self.msg.name = list(names)
        self.msg.header.frame_id = frame_id
        self.size = len(names)
        self.arrays = arrays
        self._fields = self.FIELDS[:arrays]
        self.raw = False
        self._buf = bytearray()
        self._stamp_at = 0
        self._value_at: tuple[int, ...] = ()
        self._stamp_struct = struct.Struct('<iI')
        self._values_struct = struct.Struct(f'<{self.size}d')
        try:
            self.raw = self._build_template()
        except Exception:  # noqa: BLE001 - any surprise: publish the message object
            self.raw = False

    def _build_template(self) -> bool:
        """Serialize the message with recognisable values and find where the
        stamp and each array went; True when a filled copy deserializes back
        exactly."""
        n = self.size
        msg = self.msg
        # distinct, finite, unlikely 8-byte patterns
        marks = [[(1.0 + (i * n + k + 1) * 2.0 ** -30) * 2.0 ** 999 for k in range(n)]
                 for i in range(self.arrays)]
        for name, values in zip(self._fields, marks):
            setattr(msg, name, array.array('d', values))
        msg.header.stamp.sec, msg.header.stamp.nanosec = 0x1A2B3C4D, 0x2B3C4D5E
        data = serialize_message(msg)
        order = {CDR_LE: '<', CDR_BE: '>'}.get(bytes(data[:2]))
        if order is None:
            return False
        stamp_struct = struct.Struct(order + 'iI')
        values_struct = struct.Struct(f'{order}{n}d')

        def only(pattern: bytes) -> int:
            at = data.find(pattern)
            if at < 0 or data.find(pattern, at + 1) >= 0:
                raise ValueError('pattern not found exactly once')
            return at

        self._stamp_at = only(stamp_struct.pack(0x1A2B3C4D, 0x2B3C4D5E))
        self._value_at = tuple(only(values_struct.pack(*values)) for values in marks)
        self._stamp_struct, self._values_struct = stamp_struct, values_struct
        self._buf = bytearray(data)
        # check: a filled copy must read back as the message it stands for
        check = [[(i + 1) * 10.0 + k * 0.5 for k in range(n)] for i in range(self.arrays)]
        back = deserialize_message(self._fill_raw(-7, 999_999_999, check), JointState)
        ok = (list(back.name) == list(msg.name) and back.header.frame_id == msg.header.frame_id
              and (back.header.stamp.sec, back.header.stamp.nanosec) == (-7, 999_999_999)
              and all(list(getattr(back, name)) == values
                      for name, values in zip(self._fields, check))
              and all(len(getattr(back, name)) == 0 for name in self.FIELDS[self.arrays:]))
        for name in self._fields:
            setattr(msg, name, array.array('d', [0.0] * n))
        msg.header.stamp.sec = msg.header.stamp.nanosec = 0
        return ok

    def _fill_raw(self, sec: int, nanosec: int, values: Sequence[Sequence[float]]) -> bytes:
        buf = self._buf
        self._stamp_struct.pack_into(buf, self._stamp_at, sec, nanosec)
        pack = self._values_struct.pack_into
        for at, vals in zip(self._value_at, values):
            pack(buf, at, *vals)
        return bytes(buf)

    def fill(self, sec: int, nanosec: int, *values: Sequence[float]) -> Any:
        """The message for this cycle: stamp ``sec``/``nanosec``, then one
        sequence of ``len(names)`` floats per array. Serialized bytes when
        ``raw``, else the (reused) JointState."""
        if self.raw:
            return self._fill_raw(sec, nanosec, values)
        msg = self.msg
        stamp = msg.header.stamp
        stamp.sec, stamp.nanosec = sec, nanosec
        for name, vals in zip(self._fields, values):
            # array('d') is taken as is by the message setters (no per-element checks)
            setattr(msg, name, array.array('d', vals))
        return msg


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
        self._received = self._stats.received      # counters per message kind
        self._throttle = LogThrottle(config.log_throttle)
        self._sync: StampSynchroniser[PoseInput, RateInput] = StampSynchroniser(
            config.sync_wait, config.sync_max_pending)
        self._estimator = DerivativeEstimator(config.estimator, config.estimator_max_gap)

        # Reused output messages, kept serialized (no per-cycle message allocation
        # or conversion; see JointStateOutput).
        self._actuator_out = JointStateOutput(LEG_NAMES, config.frame_id, 3)
        self._joint_out = JointStateOutput(JOINT_NAMES, config.joint_states_frame_id, 2)
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
            f'{self._topic("accel_setpoint")}, {self._topic("platform_setpoint")}; '
            f'publishing {self._topic("actuator_states")}, '
            f'{self._topic("joint_states")}, /diagnostics')
        if not (self._actuator_out.raw and self._joint_out.raw):
            self.get_logger().info('outputs published as message objects (the middleware '
                                   'writes an encoding the in-place writer does not know)')

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
            # serialized (raw): read by setpoints.StampedReader, no Python message built
            self.create_subscription(PoseStamped, 'pose_setpoint', self._on_pose, qos,
                                     raw=True),
            self.create_subscription(TwistStamped, 'twist_setpoint', self._on_twist, qos,
                                     raw=True),
            self.create_subscription(AccelStamped, 'accel_setpoint', self._on_accel, qos,
                                     raw=True),
            # a whole setpoint per point: read by setpoints.TrajectoryReader
            self.create_subscription(JointTrajectory, 'platform_setpoint',
                                     self._on_platform_setpoint, qos, raw=True),
        ]

    # -- subscription callbacks --------------------------------------------------
    # The setpoints arrive serialized (raw=True): the stamp and the doubles are
    # read straight from the CDR bytes. A sample in an encoding the reader does
    # not know is deserialized the usual way. Nothing escapes a callback (an
    # escaped exception would stop the executor, i.e. the node).
    def _on_pose(self, data: bytes) -> None:
        try:
            now = time.monotonic()
            fields = read_pose_stamped(data)
            if fields is None:
                fields = _pose_fields(deserialize_message(data, PoseStamped))
            sec, nanosec, (px, py, pz, qx, qy, qz, qw) = fields
            stamp_ns = sec * 1_000_000_000 + nanosec
            self._received[POSE] += 1
            try:
                pose = pose_input(px, py, pz, qx, qy, qz, qw,
                                  self._runtime.config.quaternion_tolerance)
            except SetpointError as exc:
                self._sync.discard(stamp_ns, POSE)
                self._reject(exc.reason, f'pose rejected: {exc}')
                return
            released, rejected = self._sync.add(POSE, stamp_ns, pose, now, (sec, nanosec))
            if released or rejected:
                self._dispatch(released, rejected)
        except Exception as exc:  # noqa: BLE001
            self._internal_error(exc)

    def _on_twist(self, data: bytes) -> None:
        self._on_rates(TWIST, TwistStamped, data)

    def _on_accel(self, data: bytes) -> None:
        self._on_rates(ACCEL, AccelStamped, data)

    def _on_rates(self, kind: str, msg_type: Any, data: bytes) -> None:
        try:
            now = time.monotonic()
            fields = read_twist_stamped(data)
            if fields is None:
                fields = _rate_fields(deserialize_message(data, msg_type))
            sec, nanosec, (lx, ly, lz, ax, ay, az) = fields
            stamp_ns = sec * 1_000_000_000 + nanosec
            self._received[kind] += 1
            try:
                rates = rate_input(lx, ly, lz, ax, ay, az, kind)
                if kind == ACCEL:
                    config = self._runtime.config
                    check_acceleration(rates.q, config.max_linear_acceleration,
                                       config.max_angular_acceleration)
            except SetpointError as exc:
                self._sync.discard(stamp_ns, kind)
                self._reject(exc.reason, f'{kind} rejected: {exc}')
                return
            released, rejected = self._sync.add(kind, stamp_ns, rates, now)
            if released or rejected:
                self._dispatch(released, rejected)
        except Exception as exc:  # noqa: BLE001
            self._internal_error(exc)

    def _on_platform_setpoint(self, data: bytes) -> None:
        """Whole setpoints, one per point of a JointTrajectory over surge, heave,
        roll (stamp = header.stamp + time_from_start): checked point by point
        (:func:`.setpoints.platform_setpoints`), ordered with the three-topic
        setpoints by the synchroniser (:meth:`.StampSynchroniser.add_complete`),
        then solved like them."""
        try:
            now = time.monotonic()
            self._received[PLATFORM] += 1
            try:
                fields = read_joint_trajectory(data)
                if fields is None:
                    fields = _trajectory_fields(deserialize_message(data, JointTrajectory))
            except Exception as exc:  # noqa: BLE001 - truncated or inconsistent bytes
                self._reject(BAD_SETPOINT, f'{PLATFORM} rejected: malformed serialized '
                                           f'message: {exc}')
                return
            config = self._runtime.config
            try:
                points = platform_setpoints(fields, config.max_linear_acceleration,
                                            config.max_angular_acceleration)
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
            try:
                self._process(setpoint)
            except Exception as exc:  # noqa: BLE001 - one failure must not skip the others
                self._internal_error(exc)

    # -- one cycle -----------------------------------------------------------------
    def _process(self, sp: Setpoint) -> None:
        """Estimate what is missing, check, solve, publish: one setpoint.

        The outputs go out as soon as the solution is known to be finite; the
        bookkeeping that only feeds the diagnostics (ignored components,
        limits, statistics) comes after."""
        runtime = self._runtime            # read once: a parameter change applies next cycle
        config = runtime.config
        pose: PoseInput = sp.pose
        twist, accel = sp.twist, sp.accel
        stats = self._stats
        qd, qdd = self._estimator.update(sp.stamp_ns * 1e-9, pose.q,
                                         None if twist is None else twist.q,
                                         None if accel is None else accel.q)
        if twist is None:
            stats.estimated_twist += 1
        if accel is None:
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
        # plain floats: cheaper than numpy for 3 and 12 numbers
        length, rate, force = sol.length.tolist(), sol.rate.tolist(), sol.force.tolist()
        joints, joint_rates = sol.joints.tolist(), sol.joint_rates.tolist()
        # a sum is finite iff every term is (inf - inf is nan)
        if not math.isfinite(sum(length) + sum(rate) + sum(force) + sum(joints)
                             + sum(joint_rates)):
            self._reject(NON_FINITE_OUTPUT, 'solver returned a non-finite value (not published)')
            return

        sec, nanosec = sp.header
        self._actuator_pub.publish(self._actuator_out.fill(sec, nanosec, length, rate, force))
        self._joint_pub.publish(self._joint_out.fill(sec, nanosec, joints, joint_rates))

        ignored = unfollowable(pose, twist, accel, -sol.beta,
                               config.position_tolerance, config.angle_tolerance)
        if ignored:
            for component in ignored:
                stats.ignored[component] += 1
            stats.note(WARN, 'ignored ' + '/'.join(ignored))
            self._log(WARN, 'ignored', lambda: 'motion the mechanism cannot follow, ignored: '
                      + ', '.join(ignored))
        if sol.status is Status.NEAR_SINGULAR:
            stats.near_singular += 1
            stats.note(WARN, 'near singular')
            self._log(WARN, 'near_singular', lambda: f'near singular: {sol.detail}')
        limits = check_limits(sol.stroke.tolist(), rate, force, runtime.model.limits,
                              config.warn_fraction)
        if limits.exceeded:
            stats.limit_exceeded += 1
            stats.note(ERROR, 'limit exceeded')
            self._log(ERROR, 'limit', lambda: 'actuator limit exceeded (published anyway): '
                      + ', '.join(limits.exceeded))
        elif limits.near:
            stats.near_limit += 1
            stats.note(WARN, 'near an actuator limit')
        stats.solved(elapsed, sol.kinematic_condition, sol.jacobian_condition,
                     (force[0], force[1], force[2]))
        self._last_solution = sol

    # -- rejection and logging -------------------------------------------------
    def _reject(self, reason: str, message: str) -> None:
        self._stats.reject(reason, message)
        self._log_rejection(reason, message)

    def _log_rejection(self, reason: str, message: str) -> None:
        self._log(ERROR if reason in (UNREACHABLE, SOLVER_ERROR) else WARN, reason, message)

    def _log(self, level: int, key: str, message: str | Callable[[], str]) -> None:
        """Log ``message`` (or what the callable returns: built only when the
        line is not throttled) at most once per ``diagnostics.log_throttle``
        per ``key``."""
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
        if new.frame_id != old.frame_id:
            self._actuator_out = JointStateOutput(LEG_NAMES, new.frame_id, 3)
        if new.joint_states_frame_id != old.joint_states_frame_id:
            self._joint_out = JointStateOutput(JOINT_NAMES, new.joint_states_frame_id, 2)
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
                    'twist_setpoint, accel_setpoint (one setpoint: the three with one stamp) '
                    'and platform_setpoint (trajectory_msgs/JointTrajectory over surge, '
                    'heave, roll: one setpoint per point); publishes actuator_states, '
                    'joint_states and /diagnostics. ROS arguments go after --ros-args, e.g. '
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
