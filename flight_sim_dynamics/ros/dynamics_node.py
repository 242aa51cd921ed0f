"""The ROS 2 node (:class:`DynamicsNode`; its executable is :mod:`.node`):
pose/twist/accel setpoints in, leg lengths, rates and forces out.

Every complete setpoint (pose, twist and acceleration with one header stamp
on ``pose_setpoint``, ``twist_setpoint``, ``accel_setpoint``; or one point of
a trajectory_msgs/JointTrajectory over surge, heave, roll on
``platform_setpoint``) becomes one solve and one ``actuator_states`` and
``joint_states`` message stamped like it. The rules are rclpy-free
(:class:`.setpoints.SetpointIntake`); this module subscribes, publishes, logs
and owns the clocks, the parameters and the lifecycle.

A managed node: ``configure`` validates the parameters, builds the model and
creates the endpoints (a failure leaves it unconfigured, the reason logged);
``activate`` starts answering; while inactive, setpoints count as
``inactive``; ``cleanup`` and ``shutdown`` release the endpoints.

Nothing a client sends takes the node down: rclpy's parameter and lifecycle
services are kept, each behind a guard (a request rclpy 7.1.6 would die on is
refused with a reason), and every rejected setpoint is counted in
/diagnostics and logged (throttled). Topics, QoS, parameters: docs/node.md.
"""
from __future__ import annotations

import math
import sys
import time
from typing import Any, Callable

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from geometry_msgs.msg import AccelStamped, PoseStamped, TwistStamped
from lifecycle_msgs.srv import ChangeState, GetAvailableStates, GetAvailableTransitions, GetState
from rcl_interfaces.msg import (FloatingPointRange, IntegerRange, ParameterDescriptor,
                                ParameterType, SetParametersResult)
from rcl_interfaces.srv import (DescribeParameters, GetParameters, GetParameterTypes,
                                ListParameters, SetParameters, SetParametersAtomically)
from rclpy.clock import Clock, ClockType
from rclpy.exceptions import ParameterException
from rclpy.lifecycle import LifecycleNode, LifecycleState, TransitionCallbackReturn
from rclpy.parameter import Parameter
from rclpy.qos import (DurabilityPolicy, HistoryPolicy, QoSPolicyKind, QoSProfile,
                       ReliabilityPolicy)
from rclpy.qos_overriding_options import InvalidQosOverridesError, QoSOverridingOptions
from rclpy.serialization import deserialize_message
from rclpy.task import Future
from sensor_msgs.msg import JointState
from trajectory_msgs.msg import JointTrajectory
from visualization_msgs.msg import MarkerArray

from ..config import parameters as prm
from ..core.model import JOINT_NAMES, LEG_NAMES
from ..core.solver import solve
from .markers import MarkerBuilder
from .setpoints import (ACCEL, BAD_SETPOINT, ERROR, INACTIVE, LEVEL_NAMES, PLATFORM, POSE,
                        TWIST, WARN, Outcome, Runtime, SetpointError, SetpointIntake,
                        diagnostic_name)

SUCCESS, FAILURE = TransitionCallbackReturn.SUCCESS, TransitionCallbackReturn.FAILURE
#: Seconds one reading of the clock serves the future-stamp check (a bound of
#: input.max_future, ~1 s, is 200 times coarser; a reading costs ~2 us).
LATEST_STAMP_REUSE = 0.005
#: Bytes a valid trajectory point takes at most (3 positions, velocities and
#: accelerations, time_from_start, padding), and a platform_setpoint's bytes
#: besides its points: a larger message is refused before it is decoded.
MAX_POINT_BYTES = 128
MAX_MESSAGE_OVERHEAD = 65536
#: Parameters in one set request; more is refused whole (the node has 75).
MAX_PARAMETERS_PER_REQUEST = 256
#: Model validations one SetParameters request may cost to find which of its
#: values conflict (each ~1.5 ms of the node's only thread).
MAX_VALIDATIONS_PER_REQUEST = 12
#: Characters of one string value in a set request.
MAX_STRING_LENGTH = 4096
#: Parameters ROS itself declares on every node; not ours to check.
ROS_PARAMETERS = prm.ROS_PARAMETERS
#: The policies a start-up ``qos_overrides.*`` parameter may set.
QOS_POLICIES = (QoSPolicyKind.HISTORY, QoSPolicyKind.DEPTH, QoSPolicyKind.RELIABILITY)
_KNOWN_TYPES = frozenset(t.value for t in Parameter.Type) - {ParameterType.PARAMETER_NOT_SET}
#: The exact conversions to a declared type: integer to double, element-wise.
_COERCIONS = {(Parameter.Type.DOUBLE, Parameter.Type.INTEGER),
              (Parameter.Type.DOUBLE_ARRAY, Parameter.Type.INTEGER_ARRAY)}
_KIND_TYPES = {'double': Parameter.Type.DOUBLE, 'double_array': Parameter.Type.DOUBLE_ARRAY,
               'integer': Parameter.Type.INTEGER, 'string': Parameter.Type.STRING,
               'bool': Parameter.Type.BOOL}
_NOT_DECIDED = ('not applied: the parameters of this request conflict with each other, and '
                f'finding which ones fail needs more than {MAX_VALIDATIONS_PER_REQUEST} '
                'validations of the model; send fewer parameters per request')


def default_qos(depth: int = 1000) -> QoSProfile:
    """Setpoints and outputs: reliable, KEEP_LAST 1000 (1 s at 1 kHz: absorbs a
    stall), VOLATILE (a late joiner must not get stale setpoints or forces).
    """
    return QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=depth,
                      reliability=ReliabilityPolicy.RELIABLE,
                      durability=DurabilityPolicy.VOLATILE)


def check_qos(qos: QoSProfile) -> SetParametersResult:
    """Refuse overrides that cannot work: KEEP_LAST with depth < 1, or a
    reliability other than reliable / best_effort.
    """
    if qos.history == HistoryPolicy.KEEP_LAST and qos.depth < 1:
        return _failed(f'depth must be >= 1 with keep_last, got {qos.depth}')
    if qos.reliability not in (ReliabilityPolicy.RELIABLE, ReliabilityPolicy.BEST_EFFORT):
        return _failed('reliability must be reliable or best_effort, got '
                       f'{qos.reliability.name.lower()}')
    return SetParametersResult(successful=True)


def descriptor_for(spec: prm.ParamSpec, read_only: bool = False) -> ParameterDescriptor:
    """The ParameterDescriptor of one parameter of the schema: description with
    unit, type, range.
    """
    text = spec.full_description
    if spec.exclusive_minimum and spec.minimum is not None:
        text += f' (must be > {spec.minimum:g})'
    if spec.choices:
        text += f" (one of: {', '.join(spec.choices)})"
    d = ParameterDescriptor(description=text, read_only=read_only,
                            type=_KIND_TYPES[spec.kind].value)
    low, high = spec.minimum, spec.maximum
    if spec.kind == 'double' and (low is not None or high is not None):
        d.floating_point_range = [FloatingPointRange(
            from_value=float(-sys.float_info.max if low is None else low),
            to_value=float(sys.float_info.max if high is None else high))]
    elif spec.kind == 'integer' and (low is not None or high is not None):
        d.integer_range = [IntegerRange(from_value=int(-2 ** 63 if low is None else low),
                                        to_value=int(2 ** 63 - 1 if high is None else high),
                                        step=1)]
    if spec.length:
        d.additional_constraints = f'{spec.length} numbers'
    if spec.choices:
        d.additional_constraints = 'one of: ' + ', '.join(spec.choices)
    return d


def plain(value: Any) -> Any:
    """A parameter value as plain Python (arrays become lists)."""
    return value if isinstance(value, (bool, int, float, str)) else list(value)


def typed(param: Parameter, declared: Parameter.Type) -> tuple[Parameter, str | None]:
    """``param`` in the ``declared`` type when it is an integer (array) for a
    double (array): the one exact conversion, and a note saying so.
    """
    if (declared, param.type_) not in _COERCIONS:
        return param, None
    value = (float(param.value) if declared == Parameter.Type.DOUBLE
             else [float(v) for v in param.value])
    return (Parameter(param.name, declared, value),
            f"parameter '{param.name}': {_type_name(param.type_)} {plain(param.value)} set as "
            f'{_type_name(declared)} {value}')


def _type_name(type_: Parameter.Type) -> str:
    return type_.name.lower().replace('_', ' ')


def _failed(reason: str) -> SetParametersResult:
    return SetParametersResult(successful=False, reason=reason)


def _declared(spec: prm.ParamSpec, value: Any) -> Parameter:
    """``value`` of a schema parameter as a Parameter of its declared type."""
    if spec.kind == 'double':
        value = float(value)
    elif spec.kind == 'double_array':
        value = [float(v) for v in value]
    return Parameter(spec.name, _KIND_TYPES[spec.kind], value)


class _Refused(ValueError):
    """A start-up value the schema refused, not set since."""


class DynamicsNode(LifecycleNode):
    """Inverse dynamics of the flight simulator as a managed ROS 2 node (module
    docstring); ``kwargs`` go to rclpy's Node. Starts unconfigured: :meth:`start`
    (or a lifecycle manager) configures and activates it. :attr:`failure`: why
    the last configure failed; :attr:`finalized`: done once shut down.
    """

    def __init__(self, **kwargs: Any) -> None:
        # every --ros-args parameter is declared first, so that the ones that
        # are not ours (typos) can be told apart with public API only
        super().__init__(prm.NODE_NAME, automatically_declare_parameters_from_overrides=True,
                         **kwargs)
        self.failure: str | None = None
        self.finalized = Future()
        self._runtime: Runtime | None = None     # None: unconfigured
        self._staged: Runtime | None = None      # validated by the on-set callback
        self._intake: SetpointIntake | None = None
        self._active = False
        self._starting = False
        self._unknown_reported = False
        self._latest: int | None = None          # _latest_stamp(), reused until _latest_until
        self._latest_until = 0.0
        self._endpoints: list[Any] = []
        self._actuator_pub = self._joint_pub = self._markers_pub = self._diag_pub = None
        self._diag_timer = self._poll_timer = self._markers_timer = None
        self._markers: MarkerBuilder | None = None
        self._actuator_msg = JointState(name=list(LEG_NAMES))
        self._joint_msg = JointState(name=list(JOINT_NAMES))
        self._diag_name = diagnostic_name(self.get_fully_qualified_name())
        # timers on the steady clock: they keep ticking with use_sim_time and no /clock
        self._steady = Clock(clock_type=ClockType.STEADY_TIME)
        self._given, self._refused = self._declare_parameters()
        self._guard_services()
        self.add_on_set_parameters_callback(self._on_set_parameters)
        self.add_post_set_parameters_callback(self._on_parameters_set)

    # -- parameters ----------------------------------------------------------------
    def _declare_parameters(self) -> tuple[set[str], dict[str, str]]:
        """Declare the schema's parameters with their descriptors, at the given
        value (command line, params file) or the packaged default. A given value
        the schema refuses (``-p bodies.platform.mass:=-1.0``) does not end a
        managed node: the parameter keeps its default, and every configure
        fails with the reason until the parameter is set. Returns the names
        given and the refused ones with their reasons.
        """
        names = set(self.list_parameters([], 0).names) - ROS_PARAMETERS
        given = {name: self.get_parameter(name) for name in names}
        for name in names:
            # re-declared below (ours), by the endpoints (qos_overrides.*) or not at all
            self.undeclare_parameter(name)
        try:
            defaults = prm.validate(prm.read_params_file(prm.default_params_path()),
                                    require_all=False)
        except (prm.ParameterError, FileNotFoundError):
            defaults = prm.defaults()
        refused: dict[str, str] = {}
        declarations = []
        for spec in prm.ALL_PARAMETERS:
            value = defaults[spec.name]
            if spec.name in given:
                param, _ = typed(given[spec.name], _KIND_TYPES[spec.kind])
                reason = self._check(param, spec)
                if reason is None:
                    value = param.value
                else:
                    refused[spec.name] = reason
            declarations.append((spec.name, _declared(spec, value).value, descriptor_for(spec)))
        self.declare_parameters('', declarations, ignore_override=True)
        return names, refused

    @staticmethod
    def _check(param: Parameter, spec: prm.ParamSpec) -> str | None:
        """What is wrong with one value of a schema parameter on its own (type,
        range: microseconds), naming the declared type; None if nothing.
        """
        declared = _KIND_TYPES[spec.kind]
        try:
            prm.check_value(spec, plain(param.value))
            detail = None
        except prm.ParameterError as exc:
            detail = str(exc)
        if param.type_ == declared:
            return detail
        reason = (f"parameter '{param.name}' is a {_type_name(declared)}, got a "
                  f'{_type_name(param.type_)}: refused, the parameter keeps its type and value')
        return f'{detail} ({reason})' if detail else reason

    def _values(self) -> dict[str, Any]:
        return {name: plain(self.get_parameter(name).value) for name in prm.SPECS}

    def _runtime_of(self, values: dict[str, Any], changed: Any = prm.SPECS) -> Runtime:
        """Validate ``values`` and build the runtime (the model only when a
        model parameter is among ``changed``); raises ParameterError.
        """
        model = self._runtime.model if self._runtime is not None else None
        if model is None or any(prm.SPECS[n] in prm.MODEL_PARAMETERS for n in changed):
            model = prm.model_from_values({s.name: values[s.name] for s in prm.MODEL_PARAMETERS})
        return Runtime(model, prm.NodeConfig.from_values(
            {s.name: values[s.name] for s in prm.NODE_PARAMETERS}))

    def _on_set_parameters(self, params: list[Parameter]) -> SetParametersResult:
        """The one validating callback: the whole parameter set as it would be
        after the change. Accepted: the new runtime is staged, committed by
        :meth:`_on_parameters_set`; refused: the reason, the model unchanged.
        """
        ours = [p for p in params if p.name in prm.SPECS]
        if not ours:
            return SetParametersResult(successful=True)
        self._staged = None
        try:
            if self._runtime is None:   # unconfigured: each on its own; configure checks all
                reason = next(filter(None, (self._check(p, prm.SPECS[p.name]) for p in ours)),
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
        if self._intake is not None:
            self._intake.stats.parameter_rejections += 1
        self.get_logger().warn(f'parameter change rejected, model unchanged: {reason}')
        return _failed(reason)

    def _on_parameters_set(self, params: list[Parameter]) -> None:
        """Commit a staged change: one reference, read once per cycle."""
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
                self._markers = MarkerBuilder(staged.model, new.output_frame_id)
            self._markers.frame_id = new.output_frame_id
            if new.output_markers_rate != old.config.output_markers_rate:
                self._markers_rate(new.output_markers_rate)
            self._diag_timer.timer_period_ns = int(new.diagnostics_period * 1e9)
            self._poll_timer.timer_period_ns = int(self._poll_period(new) * 1e9)
            self.get_logger().info('parameters changed: '
                                   + ', '.join(dict.fromkeys(p.name for p in params)))
        except Exception as exc:  # noqa: BLE001
            self._internal_error(exc)

    # -- the guard around rclpy's services -------------------------------------------
    def _guard_services(self) -> None:
        """Put rclpy's parameter and lifecycle services behind a guard: a
        request that fails is answered (success false, empty lists), never
        fatal. In rclpy 7.1.6 the parameter services die on a value of unknown
        type (ValueError out of the executor) and apply a SetParameters request
        one parameter at a time (a big request stalls the node): the set
        services get :meth:`_set_request`. ChangeState raises RCLError for a
        transition the current state does not have.
        """
        own = {SetParameters: lambda req, resp: self._set_request(req, resp, False),
               SetParametersAtomically: lambda req, resp: self._set_request(req, resp, True)}
        for service in self.services:
            if service.srv_type in (DescribeParameters, GetParameters, GetParameterTypes,
                                    ListParameters, SetParameters, SetParametersAtomically,
                                    ChangeState, GetState, GetAvailableStates,
                                    GetAvailableTransitions):
                service.callback = self._guarded(service.srv_name,
                                                 own.get(service.srv_type, service.callback))

    def _guarded(self, name: str, handler: Callable[[Any, Any], Any]) -> Callable[[Any, Any], Any]:
        def guarded(request: Any, response: Any) -> Any:
            try:
                return handler(request, response)
            except Exception as exc:  # noqa: BLE001 - answered as a failure, never fatal
                self.get_logger().warn(f'{name}: request refused: {type(exc).__name__}: {exc}',
                                       throttle_duration_sec=2.0)
                response = type(response)()
                if hasattr(response, 'results'):       # SetParameters: one result each
                    response.results = [_failed(f'refused: {exc}')] * len(request.parameters)
                elif hasattr(response, 'result') and isinstance(response.result,
                                                                SetParametersResult):
                    response.result = _failed(f'refused: {exc}')
                return response
        return guarded

    def _parse(self, msg: Any) -> tuple[Parameter | None, str | None, str | None]:
        """(parameter in its declared type, a note if converted, the reason it
        is refused) of one parameter of a set request.
        """
        value = msg.value
        if value.type not in _KNOWN_TYPES:
            return None, None, f"parameter '{msg.name}': unknown value type {value.type}"
        if len(value.string_value) > MAX_STRING_LENGTH:
            return None, None, (f"parameter '{msg.name}': string of {len(value.string_value)} "
                                f'characters, more than {MAX_STRING_LENGTH}')
        if not msg.name or not self.has_parameter(msg.name):
            # rclpy creates a parameter named '' and loses undeclared names in its reason
            return None, None, f'parameter {msg.name!r} is not declared: refused'
        if self.describe_parameter(msg.name).read_only:
            # refused on its own, so the rest of a dump loads back in one change
            return None, None, f'parameter {msg.name!r} is read-only: refused'
        param = Parameter.from_parameter_msg(msg)
        spec = prm.SPECS.get(param.name)
        if spec is None:            # rclpy's to answer (qos_overrides: read-only; unknown)
            return param, None, None
        param, note = typed(param, _KIND_TYPES[spec.kind])
        return param, note, self._check(param, spec)

    def _apply(self, params: list[Parameter]) -> SetParametersResult:
        try:
            return self.set_parameters_atomically(params)
        except ParameterException as exc:
            return _failed(str(exc))

    def _set_request(self, request: Any, response: Any, atomic: bool) -> Any:
        """A set request: refused whole beyond :data:`MAX_PARAMETERS_PER_REQUEST`,
        typed (:func:`typed`), then applied as one change. A SetParameters
        request that fails as a whole is sorted out (:meth:`_sort_out`).
        """
        msgs = list(request.parameters)
        if len(msgs) > MAX_PARAMETERS_PER_REQUEST:
            result = _failed(f'{len(msgs)} parameters in one request, more than '
                             f'{MAX_PARAMETERS_PER_REQUEST}: refused whole')
        else:
            parsed = [self._parse(m) for m in msgs]
            params = [p for p, _, _ in parsed]
            notes = [n for _, n, _ in parsed]
            problems = [r for _, _, r in parsed]
            problem = next(filter(None, problems), None)
            if problem:     # refused before the on-set callback, which logs the others
                self.get_logger().warn(f'parameter change rejected, model unchanged: {problem}')
            result = _failed(problem) if problem else self._apply(params)
            if result.successful:
                result.reason = '; '.join(filter(None, notes))
            elif not atomic and len(msgs) > 1:
                response.results = self._sort_out(params, notes, problems, problem is None)
                return response
        if atomic:
            response.result = result
        else:
            response.results = [result] * len(msgs)
        return response

    def _sort_out(self, params: list[Parameter | None], notes: list[str | None],
                  problems: list[str | None], tried: bool) -> list[SetParametersResult]:
        """Which parameters of a SetParameters request that failed as a whole
        fail, in order: the request is halved, each half applied as one change
        (a half that holds is kept, one that fails is halved again), so a later
        value of a name overrides an earlier one as in rclpy's one-at-a-time
        rule. At most :data:`MAX_VALIDATIONS_PER_REQUEST` changes are tried;
        the parameters not decided by then fail saying so.
        """
        results: list[SetParametersResult | None] = [_failed(p) if p else None
                                                     for p in problems]
        budget = [MAX_VALIDATIONS_PER_REQUEST]

        def resolve(chunk: list[int], known_failed: bool) -> bool:
            """Decide ``chunk``; True if all of it was applied."""
            if known_failed and len(chunk) > 1:
                result = None
            elif budget[0] > 0:
                budget[0] -= 1
                result = self._apply([params[i] for i in chunk])
            else:
                for i in chunk:
                    results[i] = _failed(_NOT_DECIDED)
                return False
            if result is not None and result.successful:
                for i in chunk:
                    results[i] = SetParametersResult(successful=True, reason=notes[i] or '')
                return True
            if len(chunk) == 1:
                results[chunk[0]] = result
                return False
            half = len(chunk) // 2
            # the whole failed and its first half held: the second half, applied
            # after it, gives the same final state as the whole, so it fails too
            first = resolve(chunk[:half], False)
            return resolve(chunk[half:], first) and first

        todo = [i for i, r in enumerate(results) if r is None]
        if todo:
            resolve(todo, tried and len(todo) == len(results))
        return results

    # -- lifecycle -----------------------------------------------------------------
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

    def on_configure(self, state: LifecycleState) -> TransitionCallbackReturn:
        """Validate the parameters, build the model, create the endpoints; on a
        bad parameter: unconfigured, the reason logged and in :attr:`failure`.
        """
        try:
            if self._refused:
                raise _Refused(next(iter(self._refused.values())))
            self._runtime = self._runtime_of(self._values())
            if self._intake is None:
                self._intake = SetpointIntake(self._runtime)
            else:
                self._intake.reconfigure(self._runtime)
                self._intake.reset()
            self._create_endpoints(self._runtime)
        except Exception as exc:  # noqa: BLE001 - a ParameterError, a geometry the solver refuses
            reason = str(exc) if isinstance(exc, (prm.ParameterError, _Refused)) \
                else f'{type(exc).__name__}: {exc}'
            self._release()
            self.failure = f'invalid parameters: {reason}'
            if not self._starting:
                self.get_logger().error(f'configure failed, still unconfigured: {self.failure}')
            return FAILURE
        self.failure = None
        unknown = sorted(n for n in self._given if not self.has_parameter(n))
        if unknown and not self._unknown_reported:
            self.get_logger().warn('ignoring unknown parameters (typo?): ' + ', '.join(unknown))
        self._unknown_reported = True
        self.get_logger().info(
            f'configured: {len(prm.SPECS)} parameters, beta0 = '
            f'{self._runtime.model.central.beta0:.6f} rad; '
            + ', '.join(f'{e.topic_name} ({e.qos_profile.reliability.name.lower()} '
                        f'{e.qos_profile.history.name.lower()} {e.qos_profile.depth})'
                        for e in self._endpoints) + ', /diagnostics')
        return SUCCESS

    def on_activate(self, state: LifecycleState) -> TransitionCallbackReturn:
        self._intake.reset()                  # nothing from before counts as history
        self._active = True
        self.get_logger().info('active: answering setpoints')
        return super().on_activate(state)     # enables the lifecycle publishers

    def on_deactivate(self, state: LifecycleState) -> TransitionCallbackReturn:
        self._active = False
        self._log(self._intake.reset(INACTIVE))
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
        for timer in filter(None, (self._diag_timer, self._poll_timer, self._markers_timer)):
            self.destroy_timer(timer)
        for pub in filter(None, (self._actuator_pub, self._joint_pub, self._markers_pub)):
            self.destroy_lifecycle_publisher(pub)
        for sub in self._endpoints[2:]:
            self.destroy_subscription(sub)
        if self._diag_pub is not None:
            self.destroy_publisher(self._diag_pub)
        self._endpoints = []
        self._actuator_pub = self._joint_pub = self._markers_pub = self._diag_pub = None
        self._diag_timer = self._poll_timer = self._markers_timer = None
        self._runtime = self._staged = None

    def _create_endpoints(self, runtime: Runtime) -> None:
        """Outputs (lifecycle publishers: silent unless active), setpoint
        subscriptions, /diagnostics, markers and the timers.
        """
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
            # serialized: its size is checked before rclpy decodes it (a million
            # points would take seconds of the node's only thread)
            self._endpoints.append(self.create_subscription(
                JointTrajectory, PLATFORM, self._on_platform, default_qos(), raw=True,
                qos_overriding_options=options))
        except (InvalidQosOverridesError, RuntimeError, AssertionError, TypeError,
                ValueError) as exc:
            # rclpy: an unknown policy name (RuntimeError), a wrong type (assert)
            raise prm.ParameterError(prm.QOS_OVERRIDES + '*', None,
                                     f'invalid QoS override: {exc}') from None
        # /diagnostics: the standard topic, default QoS; it reports while inactive too
        self._diag_pub = self.create_publisher(DiagnosticArray, '/diagnostics', 10)
        self._diag_timer = self.create_timer(config.diagnostics_period, self._on_diagnostics,
                                             clock=self._steady)
        self._poll_timer = self.create_timer(self._poll_period(config), self._on_poll,
                                             clock=self._steady)
        self._markers = MarkerBuilder(runtime.model, config.output_frame_id)
        self._markers_pub = self.create_lifecycle_publisher(MarkerArray, 'markers', 10)
        self._markers_rate(config.output_markers_rate)

    @staticmethod
    def _poll_period(config: prm.NodeConfig) -> float:
        return min(max(config.sync_wait / 2.0, 0.001), 0.05)

    def _latest_stamp(self) -> int | None:
        """The latest stamp accepted now (ns): the clock plus input.max_future;
        None: no check (0, or a sim-time clock before its first /clock).
        """
        mono = time.monotonic()
        if mono >= self._latest_until:
            max_future = self._runtime.config.input_max_future
            now = self.get_clock().now().nanoseconds if max_future else 0
            self._latest = now + int(max_future * 1e9) if now else None
            self._latest_until = mono + LATEST_STAMP_REUSE
        return self._latest

    # -- setpoints in, answers out -------------------------------------------------
    def _on_setpoint(self, kind: str, msg: Any) -> None:
        """One setpoint message: the intake's answers published, its lines
        logged. Nothing escapes a callback (it would stop the executor).
        """
        try:
            # taken after deactivate or cleanup (queued before): counted inactive
            active = self._active and self._runtime is not None
            self._publish(self._intake.receive(kind, msg, time.monotonic(),
                                               self._latest_stamp() if active else None,
                                               active))
        except Exception as exc:  # noqa: BLE001
            self._internal_error(exc)

    def _on_platform(self, data: bytes) -> None:
        """A serialized platform_setpoint: refused undecoded beyond the size of
        ``input.max_points`` points, else decoded by rclpy.
        """
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
        """Release setpoints whose bounded wait expired."""
        try:
            if self._runtime is not None:
                self._publish(self._intake.poll(time.monotonic()))
        except Exception as exc:  # noqa: BLE001
            self._internal_error(exc)

    def _publish(self, outcome: Outcome) -> None:
        answers, lines = outcome
        if not answers:
            self._log(outcome)
            return
        config = self._runtime.config
        actuator, joints = self._actuator_msg, self._joint_msg
        actuator.header.frame_id = config.output_frame_id
        joints.header.frame_id = config.output_joint_states_frame_id
        for answer in answers:
            for msg in (actuator, joints):
                msg.header.stamp.sec, msg.header.stamp.nanosec = answer.header
            actuator.position, actuator.velocity, actuator.effort = \
                answer.length, answer.rate, answer.force
            joints.position, joints.velocity = answer.joints, answer.joint_rates
            self._actuator_pub.publish(actuator)
            self._joint_pub.publish(joints)
        self._log(([], lines))

    def _log(self, outcome: Outcome) -> None:
        # rclpy fixes a severity per call site: one call site per severity
        for level, text in outcome[1]:
            if level >= ERROR:
                self.get_logger().error(text)
            elif level == WARN:
                self.get_logger().warn(text)
            else:
                self.get_logger().info(text)

    def _internal_error(self, exc: Exception) -> None:
        """An error of the node's own: counted and logged; none while shutting
        down (a publish after shutdown is the shutdown's).
        """
        if self._intake is not None and self.context.ok():
            self._log(self._intake.internal_error(exc))

    def _markers_rate(self, rate: float) -> None:
        """(Re)start the markers timer at ``rate`` Hz; 0: stop, and clear the view."""
        if self._markers_timer is not None:
            self.destroy_timer(self._markers_timer)
            self._markers_timer = None
            if not rate:
                self._markers_pub.publish(self._markers.clear())
        if rate:
            self._markers_timer = self.create_timer(1.0 / rate, self._on_markers,
                                                    clock=self._steady)

    def _on_markers(self) -> None:
        """The mechanism at the last answered setpoint, stamped like it; before
        the first one, at home (the central configuration), stamped now.
        """
        try:
            if self._markers_pub is None:
                return
            if self._intake.last_solution is not None:
                sol, header = self._intake.last_solution, self._intake.last_header
            else:
                zero = (0.0, 0.0, 0.0)
                sol = solve(self._runtime.model, zero, zero, zero)
                header = self.get_clock().now().seconds_nanoseconds()
            self._markers_pub.publish(self._markers.update(sol, *header))
        except Exception as exc:  # noqa: BLE001
            self._internal_error(exc)

    def _on_diagnostics(self) -> None:
        try:
            runtime, stats = self._runtime, self._intake.stats
            if runtime is None:         # a tick queued before cleanup
                return
            stats.stamp_check = self._stamp_check(runtime.config.input_max_future)
            last = self._intake.last_solution
            level, message, values = stats.report(time.monotonic(),
                                                  last.cond if last is not None else math.nan)
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
        """How stamps are checked against the clock now (for /diagnostics)."""
        if not max_future:
            return 'off (input.max_future = 0)'
        if not self.get_clock().now().nanoseconds:
            return 'off until the first /clock (use_sim_time)'
        return f'stamps at most {max_future:g} s ahead of the node\'s clock'


__all__ = ['DynamicsNode', 'LEVEL_NAMES', 'default_qos', 'descriptor_for']
