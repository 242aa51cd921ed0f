"""The node's six parameter services, written on rclpy's public Node API.

rclpy's own ``ParameterService`` (7.1.6) converts every request value with
``Parameter.from_parameter_msg``, which raises ``ValueError`` for an unknown
``ParameterValue.type`` (e.g. 99): the exception leaves the executor and
ends the node (issue 12 #1). It also applies a SetParameters request one
parameter at a time, each a full validation of the model (a request of
thousands of copies stalled the node for minutes, issue 12 #4). These
services answer the same messages the same way, except that

* a value of an unknown type gets a failed result naming it, never an
  exception;
* a request over :data:`MAX_PARAMETERS_PER_REQUEST` parameters (or with a
  string over :data:`MAX_STRING_LENGTH` characters) is refused as a whole,
  before any of it is applied;
* a SetParameters request is tried as one atomic change first (one
  validation); if that fails, the parameters the node's ``precheck`` finds
  wrong on their own (type, range: microseconds each) are failed and the
  rest is tried again as one change; only if that fails too (parameters
  that conflict with each other) is the request split in halves, in order,
  to say which ones fail, with at most :data:`MAX_VALIDATIONS_PER_REQUEST`
  validations (measured with ``python -m benchmarks.param_requests``);
* a value is kept in the type its parameter was declared with (issue 15 #2):
  an integer (array) for a double (array) is converted to the same float(s)
  and the result says so; any other type is refused with the parameter's
  declared type in the reason, before the node sees it (rclpy's own check
  would refuse it too, but our on-set callback must never see it).
"""
from __future__ import annotations

from typing import Any, Callable

from rcl_interfaces.msg import ListParametersResult, ParameterType, SetParametersResult
from rcl_interfaces.srv import (DescribeParameters, GetParameters, GetParameterTypes,
                                ListParameters, SetParameters, SetParametersAtomically)
from rclpy.exceptions import (ParameterException, ParameterNotDeclaredException,
                              ParameterUninitializedException)
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import qos_profile_parameters

#: Parameters in one set request; more is refused whole (the node has 75).
MAX_PARAMETERS_PER_REQUEST = 256
#: Model validations one SetParameters request may cost when its parameters
#: conflict with each other (each ~1.5 ms of the node's only thread).
MAX_VALIDATIONS_PER_REQUEST = 12
#: Characters of one string value in a set request.
MAX_STRING_LENGTH = 4096
_NOT_DECIDED = (f'not applied: the parameters of this request conflict with each other, and '
                f'finding which ones fail needs more than {MAX_VALIDATIONS_PER_REQUEST} '
                f'validations of the model; send fewer parameters per request')
_KNOWN_TYPES = frozenset(t.value for t in Parameter.Type)


def _problem(msg: Any) -> str | None:
    """Why a ParameterValue message cannot be a parameter value, or None."""
    value = msg.value
    if value.type not in _KNOWN_TYPES or value.type == ParameterType.PARAMETER_NOT_SET:
        return f"parameter '{msg.name}': unknown value type {value.type}"
    if len(value.string_value) > MAX_STRING_LENGTH:
        return (f"parameter '{msg.name}': string of {len(value.string_value)} characters, "
                f'more than {MAX_STRING_LENGTH}')
    return None


def _failed(reason: str) -> SetParametersResult:
    return SetParametersResult(successful=False, reason=reason)


def _succeeded(note: str | None = None) -> SetParametersResult:
    return SetParametersResult(successful=True, reason=note or '')


def _type_name(type_: Parameter.Type) -> str:
    return type_.name.lower().replace('_', ' ')


#: The exact conversions to a declared type: integer to double, element-wise.
_COERCIONS = {(Parameter.Type.DOUBLE, Parameter.Type.INTEGER),
              (Parameter.Type.DOUBLE_ARRAY, Parameter.Type.INTEGER_ARRAY)}


class ParameterServices:
    """``describe/get/get_types/list/set/set_atomically_parameters`` of ``node``
    (created with ``start_parameter_services=False``).
    """

    def __init__(self, node: Node,
                 precheck: Callable[[Parameter], str | None] | None = None) -> None:
        self._node = node
        self._precheck = precheck
        name = node.get_name()
        for kind, suffix, callback in (
                (DescribeParameters, 'describe_parameters', self._describe),
                (GetParameters, 'get_parameters', self._get),
                (GetParameterTypes, 'get_parameter_types', self._get_types),
                (ListParameters, 'list_parameters', self._list),
                (SetParameters, 'set_parameters', self._set),
                (SetParametersAtomically, 'set_parameters_atomically', self._set_atomically)):
            node.create_service(kind, f'{name}/{suffix}', callback,
                                qos_profile=qos_profile_parameters)

    def _describe(self, request: Any, response: Any) -> Any:
        try:
            response.descriptors = [self._node.describe_parameter(n) for n in request.names]
        except ParameterNotDeclaredException:
            response.descriptors = []
        return response

    def _get(self, request: Any, response: Any) -> Any:
        try:
            response.values = [self._node.get_parameter(n).get_parameter_value()
                               for n in request.names]
        except (ParameterNotDeclaredException, ParameterUninitializedException):
            response.values = []
        return response

    def _get_types(self, request: Any, response: Any) -> Any:
        try:
            response.types = [self._node.get_parameter_type(n) for n in request.names]
        except ParameterNotDeclaredException:
            response.types = []
        return response

    def _list(self, request: Any, response: Any) -> Any:
        try:
            response.result = self._node.list_parameters(request.prefixes, request.depth)
        except (TypeError, ValueError):
            response.result = ListParametersResult()
        return response

    def _too_large(self, msgs: list) -> str | None:
        if len(msgs) > MAX_PARAMETERS_PER_REQUEST:
            return (f'{len(msgs)} parameters in one request, more than '
                    f'{MAX_PARAMETERS_PER_REQUEST}: refused whole')
        return None

    def _apply(self, params: list[Parameter]) -> SetParametersResult:
        try:
            return self._node.set_parameters_atomically(params)
        except ParameterException as exc:
            return _failed(str(exc))

    def _checked(self, param: Parameter) -> str | None:
        try:
            return self._precheck(param)
        except Exception:  # noqa: BLE001 - a precheck that failed: the apply decides
            return None

    def _typed(self, param: Parameter) -> tuple[Parameter, str | None, str | None]:
        """``param`` in the type its parameter was declared with: (parameter,
        a note if it was converted, the reason if it cannot be). Undeclared,
        dynamically typed and deleted (NOT_SET) parameters are rclpy's to answer.
        """
        node, given = self._node, param.type_
        if given == Parameter.Type.NOT_SET or not node.has_parameter(param.name):
            return param, None, None
        descriptor = node.describe_parameter(param.name)
        declared = Parameter.Type(descriptor.type)
        if descriptor.dynamic_typing or given == declared:
            return param, None, None
        if (declared, given) in _COERCIONS:
            if declared == Parameter.Type.DOUBLE:
                old, value = param.value, float(param.value)
            else:
                old, value = list(param.value), [float(v) for v in param.value]
            return (Parameter(param.name, declared, value),
                    f"parameter '{param.name}': {_type_name(given)} {old} set as "
                    f'{_type_name(declared)} {value}', None)
        detail = self._checked(param) if self._precheck is not None else None
        reason = (f"parameter '{param.name}' is a {_type_name(declared)}, got a "
                  f'{_type_name(given)}: refused, the parameter keeps its type and value')
        return param, None, f'{detail} ({reason})' if detail else reason

    def _set(self, request: Any, response: Any) -> Any:
        msgs = list(request.parameters)
        whole = self._too_large(msgs)
        problems = [_problem(m) for m in msgs]
        if whole:
            response.results = [_failed(whole)] * len(msgs)
            return response
        typed = [self._typed(Parameter.from_parameter_msg(m)) if p is None else (None, None, p)
                 for m, p in zip(msgs, problems)]
        params = [param for param, _, _ in typed]
        notes = [note for _, note, _ in typed]
        problems = [problem for _, _, problem in typed]
        tried = all(p is None for p in problems)
        if tried and self._apply(params).successful:
            response.results = [_succeeded(note) for note in notes]
            return response
        if self._precheck is not None:
            checked = [p if p or param is None else self._checked(param)
                       for p, param in zip(problems, params)]
            if checked != problems:     # the cheap check found some: try the rest once
                problems, tried = checked, True
                rest = [param for p, param in zip(problems, params) if p is None]
                if rest and self._apply(rest).successful:
                    response.results = [_failed(p) if p else _succeeded(note)
                                        for p, note in zip(problems, notes)]
                    return response
        response.results = self._sorted_out(problems, params, notes, tried)
        return response

    def _sorted_out(self, problems: list[str | None], params: list[Parameter | None],
                    notes: list[str | None], tried: bool) -> list[SetParametersResult]:
        """Which parameters of a request that failed as a whole fail, in order
        (``tried``: the parameters without a problem already failed as one change).

        The request is split in halves, each applied as one change: a half that
        holds is kept, a half that fails is split again, down to single
        parameters (whose reason is then the node's). The halves are applied in
        order, so a later value of a name overrides an earlier one, as in the
        service's one-parameter-at-a-time rule. One conflict costs about
        log2(n) validations; at most :data:`MAX_VALIDATIONS_PER_REQUEST` are
        spent (each a model rebuild, ~1.5 ms, while setpoints wait), and the
        parameters not decided by then fail with a reason saying so.
        """
        results: list[SetParametersResult | None] = [
            _failed(p) if p else None for p in problems]
        seen: dict[tuple[str, str], SetParametersResult] = {}
        budget = [MAX_VALIDATIONS_PER_REQUEST]

        def apply(chunk: list[int]) -> SetParametersResult | None:
            key = (params[chunk[0]].name, repr(params[chunk[0]].value))
            if len(chunk) == 1 and key in seen:     # the same value, the same result
                return seen[key]
            if budget[0] <= 0:
                return None
            budget[0] -= 1
            result = self._apply([params[i] for i in chunk])
            if len(chunk) == 1:
                seen[key] = result
            return result

        def resolve(chunk: list[int], known_failed: bool) -> bool:
            """Decide ``chunk``; True if all of it was applied."""
            result = None if known_failed and len(chunk) > 1 else apply(chunk)
            if result is not None and result.successful:
                for i in chunk:
                    results[i] = _succeeded(notes[i])
                return True
            if result is None and (len(chunk) == 1 or budget[0] <= 0):
                for i in chunk:
                    results[i] = _failed(_NOT_DECIDED)
                return False
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
            resolve(todo, tried)
        return results

    def _set_atomically(self, request: Any, response: Any) -> Any:
        msgs = list(request.parameters)
        reason = self._too_large(msgs) or next((p for p in map(_problem, msgs) if p), None)
        if reason:
            response.result = _failed(reason)
            return response
        typed = [self._typed(Parameter.from_parameter_msg(m)) for m in msgs]
        reason = next((problem for _, _, problem in typed if problem), None)
        if reason:
            response.result = _failed(reason)
            return response
        response.result = self._apply([param for param, _, _ in typed])
        if response.result.successful:
            response.result = _succeeded('; '.join(note for _, note, _ in typed if note))
        return response
