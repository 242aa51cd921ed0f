"""What the package's managed nodes (``dynamics_node``, ``motion_cueing``) share
about parameters: their declaration from :class:`~..core.parameter_spec.ParamSpec`
(descriptors with ranges, start-up values checked, :meth:`GuardedParameters._declare_specs`)
and the guard around rclpy's parameter and lifecycle services
(:class:`GuardedParameters`): every request answered, none fatal (rclpy 7.1.6
dies on a value of unknown type and on a transition the state lacks), a set
request bounded, typed, checked and applied as one change, a failed
SetParameters sorted out parameter by parameter, every refused set counted
once whatever refused it (:meth:`GuardedParameters._count_refused`), the
parameter services taken on a thread of their own
(:class:`.service_thread.ServiceThread`).
"""
from __future__ import annotations

import sys
from typing import Any, Callable, Iterator, Mapping, Sequence

from rcl_interfaces.msg import (FloatingPointRange, IntegerRange, ParameterDescriptor,
                                ParameterType, SetParametersResult)
from rcl_interfaces.srv import (DescribeParameters, GetParameters, GetParameterTypes,
                                ListParameters, SetParameters, SetParametersAtomically)
from rclpy.exceptions import ParameterException
from rclpy.parameter import Parameter

from ..config import parameters as prm
from ..config.files import ROS_PARAMETERS
from .service_thread import ServiceThread

# bounds of one parameter set request (the node's only thread validates it)
MAX_PARAMETERS_PER_REQUEST = 256
MAX_NAMES_PER_REQUEST = 4096         # of a get, describe, types or list request
PARAMETER_SERVICES = (DescribeParameters, GetParameters, GetParameterTypes, ListParameters,
                      SetParameters, SetParametersAtomically)
MAX_VALIDATIONS_PER_REQUEST = 12  # model validations, ~1.5 ms each
MAX_STRING_LENGTH = 4096
_KNOWN_TYPES = frozenset(t.value for t in Parameter.Type) - {ParameterType.PARAMETER_NOT_SET}
_COERCIONS = {(Parameter.Type.DOUBLE, Parameter.Type.INTEGER),
              (Parameter.Type.DOUBLE_ARRAY, Parameter.Type.INTEGER_ARRAY)}
_KIND_TYPES = {kind: Parameter.Type[kind.upper()]
               for kind in ('double', 'double_array', 'integer', 'string', 'bool')}
_NOT_DECIDED = ('not applied: the parameters of this request conflict with each other, and '
                f'finding which ones fail needs more than {MAX_VALIDATIONS_PER_REQUEST} '
                'validations of the model; send fewer parameters per request')


def descriptor_for(spec: prm.ParamSpec, read_only: bool = False) -> ParameterDescriptor:
    text = spec.full_description
    if spec.exclusive_minimum and spec.minimum is not None:
        text += f' (must be > {spec.minimum:g})'
    if spec.kind == 'double_array' and spec.minimum is not None and spec.maximum is not None:
        # a descriptor's floating_point_range bounds a double only: an array's in words
        text += (f" (each number in {'(' if spec.exclusive_minimum else '['}"
                 f'{spec.minimum:g}, {spec.maximum:g}])')
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
    if spec.choices or spec.length:
        d.additional_constraints = ('one of: ' + ', '.join(spec.choices) if spec.choices
                                    else f'{spec.length} numbers')
    return d


def plain(value: Any) -> Any:
    return value if isinstance(value, (bool, int, float, str)) else list(value)


def typed(param: Parameter, declared: Parameter.Type) -> tuple[Parameter, str | None]:
    """An integer (array) given for a double (array) converted, with a note."""
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
    if spec.kind == 'double':
        value = float(value)
    elif spec.kind == 'double_array':
        value = [float(v) for v in value]
    return Parameter(spec.name, _KIND_TYPES[spec.kind], value)


class GuardedParameters:
    """Mixin of a managed node (before ``LifecycleNode`` in its bases) whose
    parameters are ``self._specs`` (name -> ParamSpec, set before
    :meth:`_guard_services` serves a request). The node calls
    :meth:`_guard_services` in its constructor, registers its own on-set
    callback (which validates the whole set) and calls
    :meth:`_stop_serving_apart` in ``destroy_node``.
    """

    _apart: ServiceThread | None = None      # the parameter services' own thread
    _specs: Mapping[str, prm.ParamSpec] = {}
    #: a set request of the parameter services is being handled (it counts its refusals)
    _handling_request = False
    #: the log line's start for a refused set
    REJECTED = 'parameter change rejected, nothing changed'

    def _read_only_reason(self, name: str) -> str | None:
        """Why the parameter ``name`` is refused before anything else (None: it
        is not); a node's hook for a read-only parameter with a reason of its own.
        """
        return None

    def _count_refused(self, count: int) -> None:
        """A node's hook: ``count`` parameter sets were refused. Every refusal
        comes here once, whatever refused it: the request's bounds, a type, a
        bound, a read-only or undeclared name, rclpy's descriptor checks, the
        node's on-set callback (the whole model), a failing request. A set is
        one parameter of a SetParameters request (``ros2 param set`` sends one)
        or one SetParametersAtomically request.
        """

    def _refused_by_callback(self) -> None:
        """The node's on-set callback refused a set: counted here unless a
        request of the parameter services is being handled (which counts its
        outcome once: a SetParameters sorted out calls the callback again for
        each half it tries).
        """
        if not self._handling_request:
            self._count_refused(1)

    def _given_parameters(self) -> dict[str, Parameter]:
        """The start-up values (overrides, all declared by rclpy), undeclared
        again to be declared with their specs (:meth:`_declare_specs`).
        """
        names = set(self.list_parameters([], 0).names) - ROS_PARAMETERS
        given = {name: self.get_parameter(name) for name in names}
        for name in names:
            self.undeclare_parameter(name)
        return given

    def _declare_specs(self, specs: Sequence[prm.ParamSpec], defaults: Mapping[str, Any],
                       given: Mapping[str, Parameter],
                       read_only: Callable[[str], bool] = lambda name: False
                       ) -> dict[str, str]:
        """Declare ``specs`` at their ``given`` values, else ``defaults`` (a name
        with neither is not declared), with their descriptors; a given value the
        spec refuses keeps the default and is returned (name -> reason).
        """
        refused: dict[str, str] = {}
        declarations = []
        for spec in specs:
            value = defaults.get(spec.name)
            if spec.name in given:
                param, _ = typed(given[spec.name], _KIND_TYPES[spec.kind])
                reason = self._check(param, spec)
                if reason is None:
                    value = param.value
                else:
                    refused[spec.name] = reason
            if value is None:       # optional, neither given nor packaged
                continue
            declarations.append((spec.name, _declared(spec, value).value,
                                 descriptor_for(spec, read_only=read_only(spec.name))))
        self.declare_parameters('', declarations, ignore_override=True)
        return refused

    @staticmethod
    def _check(param: Parameter, spec: prm.ParamSpec) -> str | None:
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

    def _guard_services(self) -> None:
        """Every service (parameters, lifecycle): a failing request is answered as
        a failure, never fatal (rclpy 7.1.6 dies on a value of unknown type and
        on a transition the state lacks); SetParameters gets :meth:`_set_request`.
        """
        own = {SetParameters: lambda req, resp: self._set_request(req, resp, False),
               SetParametersAtomically: lambda req, resp: self._set_request(req, resp, True)}
        for service in self.services:
            service.callback = self._guarded(service.srv_name,
                                             own.get(service.srv_type, service.callback))

    def serve_parameters_apart(self, executor: Any) -> None:
        """The parameter services taken on a thread of their own (decoding a
        request of 100,000 parameters takes seconds), each request then handled
        on ``executor``; call before ``executor.add_node(self)``.
        """
        services = [s for s in self._services if s.srv_type in PARAMETER_SERVICES]
        self._apart = ServiceThread(self.context, services, executor, self._request_problem,
                                    self._refusal, self.get_logger())

    @property
    def services(self) -> Iterator[Any]:
        """What an executor takes: not the services taken apart."""
        apart = self._apart.services if self._apart is not None else frozenset()
        return (s for s in self._services if s not in apart)

    def _stop_serving_apart(self) -> None:
        """End the parameter services' thread (before the node is destroyed)."""
        if self._apart is not None:
            self._apart.stop()

    def _guarded(self, name: str, handler: Callable[[Any, Any], Any]) -> Callable[[Any, Any], Any]:
        def guarded(request: Any, response: Any) -> Any:
            try:
                return handler(request, response)
            except Exception as exc:  # noqa: BLE001 - answered as a failure, never fatal
                self.get_logger().warn(f'{name}: request refused: {type(exc).__name__}: {exc}',
                                       throttle_duration_sec=2.0)
                return self._refusal(request, type(response)(), f'refused: {exc}')
        return guarded

    def _parse(self, msg: Any) -> tuple[Parameter | None, str | None, str | None]:
        value = msg.value
        if value.type not in _KNOWN_TYPES:
            return None, None, f"parameter '{msg.name}': unknown value type {value.type}"
        if len(value.string_value) > MAX_STRING_LENGTH:
            return None, None, (f"parameter '{msg.name}': string of {len(value.string_value)} "
                                f'characters, more than {MAX_STRING_LENGTH}')
        special = self._read_only_reason(msg.name)
        if special is not None:
            return None, None, special
        if not msg.name or not self.has_parameter(msg.name):
            # rclpy creates a parameter named '' and loses undeclared names in its reason
            return None, None, f'parameter {msg.name!r} is not declared: refused'
        if self.describe_parameter(msg.name).read_only:
            # refused on its own, so the rest of a dump loads back in one change
            return None, None, f'parameter {msg.name!r} is read-only: refused'
        param = Parameter.from_parameter_msg(msg)
        spec = self._specs.get(param.name)
        if spec is None:            # rclpy's to answer (qos_overrides: read-only; unknown)
            return param, None, None
        param, note = typed(param, _KIND_TYPES[spec.kind])
        return param, note, self._check(param, spec)

    def _apply(self, params: list[Parameter]) -> SetParametersResult:
        try:
            return self.set_parameters_atomically(params)
        except ParameterException as exc:
            return _failed(str(exc))

    @staticmethod
    def _request_problem(request: Any) -> str | None:
        """Why a parameter request is refused whole before the node reads it: more
        than :data:`MAX_PARAMETERS_PER_REQUEST` parameters or
        :data:`MAX_NAMES_PER_REQUEST` names or prefixes (None: it is not).
        """
        for field, limit in (('parameters', MAX_PARAMETERS_PER_REQUEST),
                             ('names', MAX_NAMES_PER_REQUEST),
                             ('prefixes', MAX_NAMES_PER_REQUEST)):
            count = len(getattr(request, field, ()))
            if count > limit:
                return f'{count} {field} in one request, more than {limit}: refused whole'
        return None

    def _refusal(self, request: Any, response: Any, reason: str) -> Any:
        """``response`` refusing ``request`` whole: a failed result per parameter
        (the reason in the first), each counted (:meth:`_count_refused`); a
        query's lists left empty.
        """
        if isinstance(response, SetParametersAtomically.Response):
            response.result = _failed(reason)
            self._count_refused(1)
        elif isinstance(response, SetParameters.Response) and request.parameters:
            response.results = [_failed(reason)] + [_failed('refused whole')] * (
                len(request.parameters) - 1)
            self._count_refused(len(request.parameters))
        return response

    def _set_request(self, request: Any, response: Any, atomic: bool) -> Any:
        """Applied as one change; a failed SetParameters is sorted out. Its
        refused sets are counted once, from its answer (:meth:`_count_refused`).
        """
        problem = self._request_problem(request)
        if problem is not None:
            return self._refusal(request, response, problem)
        self._handling_request = True
        try:
            response = self._answer_set(request, response, atomic)
        finally:
            self._handling_request = False
        results = [response.result] if atomic else list(response.results)
        refused = sum(not r.successful for r in results)
        if refused:
            self._count_refused(refused)
        return response

    def _answer_set(self, request: Any, response: Any, atomic: bool) -> Any:
        """``response`` to a set request within bounds: each parameter parsed and
        checked on its own, then the whole applied (the on-set callback).
        """
        msgs = list(request.parameters)
        parsed = [self._parse(m) for m in msgs]
        params = [p for p, _, _ in parsed]
        notes = [n for _, n, _ in parsed]
        problems = [r for _, _, r in parsed]
        problem = next(filter(None, problems), None)
        if problem:     # refused before the on-set callback, which logs the others
            self.get_logger().warn(f'{self.REJECTED}: {problem}')
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
        """Which parameters of a failed SetParameters fail: halves applied in
        order, a failing half halved again (rclpy's one-at-a-time outcome), at
        most :data:`MAX_VALIDATIONS_PER_REQUEST` tries.
        """
        results: list[SetParametersResult | None] = [_failed(p) if p else None
                                                     for p in problems]
        budget = [MAX_VALIDATIONS_PER_REQUEST]

        def resolve(chunk: list[int], known_failed: bool) -> bool:
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


__all__ = ['GuardedParameters', 'descriptor_for', 'plain', 'typed']
