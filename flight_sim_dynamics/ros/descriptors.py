"""The node's parameters as ROS sees them, derived from the schema
(``config.parameters``): a ParameterDescriptor per parameter, the declared
defaults, values converted between rclpy and plain Python. No rclpy import:
only the ``rcl_interfaces`` message types.

Every parameter is statically typed: its declared type (``describe``,
``get_parameter_types``) is the schema's kind, whatever is sent to it. An
integer given for a double (``mass: 2`` in YAML, ``-p mass:=2``, ``ros2 param
set ... 2``) is the one exact conversion (:func:`declared_value`), made
explicitly before ROS sees it; any other type is refused (issue 15 #2: with
dynamic typing, a rejected string left its type in the descriptor).
"""
from __future__ import annotations

import array
import sys
from typing import Any

import numpy as np
from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor

from ..config import parameters as prm

MODEL_NAMES = frozenset(spec.name for spec in prm.MODEL_PARAMETERS)
NODE_NAMES = frozenset(spec.name for spec in prm.NODE_PARAMETERS)


def descriptor_for(spec: prm.ParamSpec) -> ParameterDescriptor:
    """The ParameterDescriptor of one parameter of the schema: description
    with unit, range where there is one. Statically typed (the type is set
    from the declared value's, :func:`declared_value`).
    """
    text = spec.full_description
    if spec.exclusive_minimum and spec.minimum is not None:
        text += f' (must be > {spec.minimum:g})'
    if spec.choices:
        text += f" (one of: {', '.join(spec.choices)})"
    if spec.length:
        text += f' ({spec.length} numbers)'
    d = ParameterDescriptor(description=text, read_only=False)
    if spec.kind == 'double':
        if spec.minimum is not None or spec.maximum is not None:
            big = sys.float_info.max
            d.floating_point_range = [FloatingPointRange(
                from_value=float(spec.minimum if spec.minimum is not None else -big),
                to_value=float(spec.maximum if spec.maximum is not None else big),
                step=0.0)]
    elif spec.kind == 'double_array':
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


def _is_int(value: Any) -> bool:
    return isinstance(value, (int, np.integer)) and not isinstance(value, (bool, np.bool_))


def declared_value(spec: prm.ParamSpec, value: Any) -> Any:
    """``value`` in the type ``spec`` declares: an integer (or integer array)
    for a double (array) becomes the same float(s); any other value is
    returned as it is. The one conversion of the parameters (as in
    :func:`parameters.validate`).
    """
    if spec.kind == 'double' and _is_int(value):
        return float(value)
    if (spec.kind == 'double_array' and isinstance(value, (list, tuple, array.array, np.ndarray))
            and len(value) and all(_is_int(v) for v in value)):
        return [float(v) for v in value]
    return value


def ros_value(spec: prm.ParamSpec, value: Any) -> Any:
    """A value as rclpy wants it for declaration (the declared type)."""
    if spec.kind == 'double_array':
        return [float(v) for v in value]
    if spec.kind == 'double':
        return float(value)
    return value


def has_kind(spec: prm.ParamSpec, value: Any) -> bool:
    """Whether ``value`` (as rclpy holds it) is of the type ``spec`` declares."""
    if spec.kind == 'double_array':
        return (isinstance(value, (list, tuple, array.array, np.ndarray)) and len(value) > 0
                and all(isinstance(v, float) for v in value))
    kind = {'double': float, 'integer': int, 'string': str, 'bool': bool}[spec.kind]
    return isinstance(value, kind) and isinstance(value, bool) == (spec.kind == 'bool')


def declarations(given: dict[str, Any]) -> list[tuple[str, Any, ParameterDescriptor]]:
    """``(name, value, descriptor)`` of every parameter of the schema, for
    ``declare_parameters(..., ignore_override=True)``: the value from
    ``given`` (the --ros-args and params-file values) in the declared type,
    else the packaged default. A given value of another type raises
    :class:`ParameterError` (the schema's reason), never rclpy's.
    """
    defaults = packaged_defaults()
    result = []
    for spec in prm.ALL_PARAMETERS:
        if spec.name in given:
            value = declared_value(spec, given[spec.name])
            if not has_kind(spec, value):
                prm.check_value(spec, plain(value))     # raises the schema's reason
                raise prm.ParameterError(spec.name, plain(value),
                                         f'expected a {spec.kind.replace("_", " ")}')
            value = ros_value(spec, value)
        else:
            value = ros_value(spec, defaults[spec.name])
        result.append((spec.name, value, descriptor_for(spec)))
    return result


def packaged_defaults() -> dict[str, Any]:
    """Declared defaults: the packaged YAML (so `dynamics_node` with no params
    file runs the packaged configuration), falling back to the schema.
    """
    try:
        return prm.validate(prm.read_params_file(prm.default_params_path()), require_all=False)
    except (prm.ParameterError, FileNotFoundError):
        return prm.defaults()
