"""The check of one value against its declaration, as the configuration
reports it: :func:`check_value`, a :class:`ParameterError` naming key and
value (the check itself is core's, every machine's:
:func:`flight_sim_dynamics.core.parameter_spec.check_value`); and dotted names
back to a file's nested maps (:func:`nested`).
"""
from __future__ import annotations

from typing import Any, Mapping

from ..core.parameter_spec import ModelValueError, ParamSpec
from ..core.parameter_spec import check_value as spec_check
from .errors import ParameterError


def check_value(spec: ParamSpec, value: Any) -> Any:
    """One value checked against its spec, canonical
    (:func:`flight_sim_dynamics.core.parameter_spec.check_value`, the one check);
    a :class:`ParameterError` naming key and value.
    """
    try:
        return spec_check(spec, value)
    except ModelValueError as exc:
        raise ParameterError(exc.key, value, str(exc)) from None


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
