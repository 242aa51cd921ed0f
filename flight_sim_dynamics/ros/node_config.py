"""The node's parameters as one typed, validated record, derived from the one
declaration of them (``config.parameters.NODE_PARAMETERS``), in the spirit of
generate_parameter_library: one field per declared parameter, named after it
(``sync.max_pending`` -> ``sync_max_pending``), typed after its kind. No
second list of the node's parameters exists: a parameter added to the schema
is a field here.
"""
from __future__ import annotations

from dataclasses import make_dataclass
from typing import Any, Mapping

from ..config.parameters import NODE_PARAMETERS, ParameterError, check_value

#: Python type of each parameter kind of the schema (what check_value returns).
_TYPES: dict[str, Any] = {'double': float, 'integer': int, 'string': str, 'bool': bool,
                          'double_array': list[float]}

NODE_PARAMETER_NAMES = tuple(spec.name for spec in NODE_PARAMETERS)


def field_name(parameter: str) -> str:
    """The NodeConfig field of a node parameter: its dotted name, dots as
    underscores.
    """
    return parameter.replace('.', '_')


def _from_values(cls: type, values: Mapping[str, Any]) -> Any:
    """Check every node parameter in ``values`` (dotted names; defaults for the
    absent ones); raises ParameterError, also for a name that is not a node
    parameter.
    """
    for name in values:
        if name not in NODE_PARAMETER_NAMES:
            raise ParameterError(name, values[name], 'not a node parameter')
    return cls(**{field_name(spec.name): check_value(
        spec, values[spec.name] if spec.name in values else spec.default)
        for spec in NODE_PARAMETERS})


NodeConfig = make_dataclass(
    'NodeConfig', [(field_name(spec.name), _TYPES[spec.kind]) for spec in NODE_PARAMETERS],
    frozen=True, slots=True,
    namespace={'from_values': classmethod(_from_values)})
NodeConfig.__module__ = __name__
NodeConfig.__doc__ = ('The validated node parameters: one field per parameter of '
                      '``NODE_PARAMETERS`` (``limits.warn_fraction`` -> '
                      '``limits_warn_fraction``); build it with ``NodeConfig.from_values``.')
