"""Validation of parameter values against the schema (:mod:`.schema`), strict:
a missing, unknown or mistyped key, a value out of range, an impossible inertia
tensor is a :class:`ParameterError` naming key and value. The one conversion:
an integer for a floating-point parameter (``mass: 2``, exact).
"""
from __future__ import annotations

import math
from typing import Any, Iterable, Mapping

import numpy as np

from ..core.inertia import inertia_tensor
from ..core.machine import ModelValueError
from ..core.effects import Effects
from ..machines import default_machine
from .errors import ParameterError, did_you_mean
from .schema import ParamSpec, all_parameters, defaults, model_parameters, specs


def _number(spec: ParamSpec, value: Any, item: Any, where: str = '') -> float:
    """One number of ``value`` (``item``), as a finite float within the spec's bounds."""
    key = spec.name
    if isinstance(item, bool) or not isinstance(item, (int, float)):
        raise ParameterError(key, value, f'expected a number{where}, got {type(item).__name__}')
    try:
        v = float(item)
    except OverflowError:       # an int beyond the float range (10**400)
        raise ParameterError(key, value, f'must be finite{where}') from None
    if not math.isfinite(v):
        raise ParameterError(key, value, f'must be finite{where}')
    unit = f' {spec.unit}' if spec.unit else ''
    if spec.minimum is not None:
        if spec.exclusive_minimum and v <= spec.minimum:
            raise ParameterError(key, value, f'must be > {spec.minimum:g}{unit}{where}')
        if not spec.exclusive_minimum and v < spec.minimum:
            raise ParameterError(key, value, f'must be >= {spec.minimum:g}{unit}{where}')
    if spec.maximum is not None and v > spec.maximum:
        raise ParameterError(key, value, f'must be <= {spec.maximum:g}{unit}{where}')
    return v


def check_value(spec: ParamSpec, value: Any) -> Any:
    """Type- and range-check one value against its spec; returns it in its
    canonical Python type (float, list of floats, int, str, bool).
    """
    key = spec.name
    if spec.kind == 'double':
        return _number(spec, value, value)
    if spec.kind == 'double_array':
        if isinstance(value, (str, bytes)) or not isinstance(value, (list, tuple, np.ndarray)):
            raise ParameterError(key, value, f'expected a list of {spec.length} numbers')
        if spec.length is not None and len(value) != spec.length:
            raise ParameterError(key, value, f'expected {spec.length} numbers, got {len(value)}')
        return [_number(spec, value, v, f' (element {i})') for i, v in enumerate(value)]
    if spec.kind == 'integer':
        if isinstance(value, bool) or not isinstance(value, int):
            raise ParameterError(key, value, f'expected an integer, got {type(value).__name__}')
        if spec.minimum is not None and value < spec.minimum:
            raise ParameterError(key, value, f'must be >= {spec.minimum:g}')
        if spec.maximum is not None and value > spec.maximum:
            raise ParameterError(key, value, f'must be <= {spec.maximum:g}')
        return value
    if spec.kind == 'string':
        if not isinstance(value, str):
            raise ParameterError(key, value, f'expected a string, got {type(value).__name__}')
        if spec.max_length is not None and len(value) > spec.max_length:
            raise ParameterError(key, value, f'longer than {spec.max_length} characters '
                                             f'({len(value)})')
        if spec.choices is not None and value not in spec.choices:
            raise ParameterError(key, value, f"must be one of {', '.join(spec.choices)}"
                                 + did_you_mean(value, spec.choices))
        return value
    if spec.kind == 'bool':
        if not isinstance(value, bool):
            raise ParameterError(key, value, f'expected true or false, got {type(value).__name__}')
        return value
    raise AssertionError(f'unknown parameter kind {spec.kind}')  # pragma: no cover


def check_inertia(key: str, value: Iterable[float]) -> np.ndarray:
    """A 3x3 inertia tensor (eq. 18-19: J of each body about its centre of
    mass) must be finite, symmetric and physically possible: principal moments
    >= 0 and each no larger than the sum of the other two
    (:func:`flight_sim_dynamics.core.inertia.inertia_tensor`); ParameterError otherwise.
    """
    values = list(value)
    try:
        return inertia_tensor(key, values)
    except ModelValueError as exc:
        raise ParameterError(key, values, str(exc)) from None


def check_names(values: Mapping[str, Any], where: str = '') -> None:
    """Every name must be a parameter of the schema; an unknown one is an
    error with the closest known name ("did you mean"). ``where``: the file
    the names come from, for the message.
    """
    known = specs()
    for key in values:
        if key not in known:
            place = f' in {where}' if where else ''
            raise ParameterError(key, values[key],
                                 f'unknown parameter{place}' + did_you_mean(key, known))


def validate(values: Mapping[str, Any], *, require_all: bool = True) -> dict[str, Any]:
    """Check a flat dict of parameters against the schema (unknown keys are
    errors); returns the complete, canonical flat dict. Absent parameters take
    their defaults, except required model parameters (gravity, geometry,
    bodies) with ``require_all``.
    """
    result = checked_values(values, require_all=require_all)
    build(result)
    return result


def checked_values(values: Mapping[str, Any], *, require_all: bool = True) -> dict[str, Any]:
    """:func:`validate`'s checks of each value (names, types, bounds, the
    required ones given), not those of the whole: the complete canonical flat dict.
    """
    check_names(values)
    result = defaults()
    model_names = {spec.name for spec in model_parameters()}
    for spec in all_parameters():
        if spec.name in values:
            result[spec.name] = check_value(spec, values[spec.name])
        elif require_all and spec.required and spec.name in model_names:
            raise ParameterError(spec.name, None, 'missing (every model parameter must be given)')
    return result


def nested(flat: Mapping[str, Any]) -> dict[str, Any]:
    """Dotted names back to nested maps, as a parameter file writes them."""
    tree: dict[str, Any] = {}
    for key, value in flat.items():
        *groups, leaf = key.split('.')
        node = tree
        for group in groups:
            node = node.setdefault(group, {})
        node[leaf] = value
    return tree


def build(values: Mapping[str, Any], effects: Effects | None = None) -> Any:
    """The default machine's model of complete, canonical ``values`` (flat
    dotted names, :func:`checked_values`), simulating ``effects`` (None: the
    machine's default), by its builder (:attr:`Machine.from_params`, which checks
    the whole: inertia tensors, limits, the geometry); a ParameterError naming
    the key it refuses.
    """
    try:
        return default_machine().from_params(nested(values), effects=effects)
    except ModelValueError as exc:
        raise ParameterError(exc.key, values.get(exc.key), str(exc)) from None
