"""Validation of parameter values against the schema (:mod:`.schema`), strict:
a missing, unknown or mistyped key, a value out of range, an impossible inertia
tensor is a :class:`ParameterError` naming key and value. The one conversion:
an integer for a floating-point parameter (``mass: 2``, exact).
"""
from __future__ import annotations

from typing import Any, Iterable, Mapping

import numpy as np

from ..core.inertia import inertia_tensor
from ..core.machine import ModelValueError
from ..core.parameter_spec import check_value as spec_check
from ..core.effects import Effects
from ..machines import default_machine
from .errors import ParameterError, did_you_mean
from .schema import ParamSpec, all_parameters, defaults, model_parameters, specs


def check_value(spec: ParamSpec, value: Any) -> Any:
    """One value checked against its spec, canonical
    (:func:`flight_sim_dynamics.core.parameter_spec.check_value`, the one check);
    a :class:`ParameterError` naming key and value.
    """
    try:
        return spec_check(spec, value)
    except ModelValueError as exc:
        raise ParameterError(exc.key, value, str(exc)) from None


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
