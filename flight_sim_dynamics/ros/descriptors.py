"""The node's parameters as ROS sees them, derived from the schema
(``config.parameters``): a ParameterDescriptor per parameter, the declared
defaults, values converted between rclpy and plain Python. No rclpy import:
only the ``rcl_interfaces`` message types.
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
    with unit, range where there is one; doubles are dynamically typed so
    that an integer (``mass: 2``) is accepted as it is by
    :func:`parameters.validate`. Our on-set callback does the type check.
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


def packaged_defaults() -> dict[str, Any]:
    """Declared defaults: the packaged YAML (so `dynamics_node` with no params
    file runs the packaged configuration), falling back to the schema.
    """
    try:
        return prm.validate(prm.read_params_file(prm.default_params_path()), require_all=False)
    except (prm.ParameterError, FileNotFoundError):
        return prm.defaults()
