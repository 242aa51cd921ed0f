"""The node's validated parameters (:class:`NodeConfig`) and the names of the
configuration the other layers read (ros/, scripts/): the schema's
(:mod:`.schema`; ``MODEL_PARAMETERS``, ``ALL_PARAMETERS``, ``SPECS``: the
default machine's, read from the registry when asked for), the check of one
value (:func:`.validation.check_value`), the errors. Parameter files, every
machine's, are read by one loader: :mod:`.machine_files` (``fsd.load_model``).
"""
from __future__ import annotations

from dataclasses import make_dataclass
from typing import Any, Mapping

from .errors import ParameterError
from .files import DEFAULT_PARAMS_FILE, NODE_NAME, PACKAGE_NAME, default_params_path, flatten
from .scenes import Scene, SceneError
from .schema import LAZY_NAMES, NODE_PARAMETERS, ParamSpec, defaults
from .validation import check_value

__all__ = ['DEFAULT_PARAMS_FILE', 'NODE_NAME', 'NODE_PARAMETERS', 'NodeConfig', 'PACKAGE_NAME',
           'ParamSpec', 'ParameterError', 'Scene', 'SceneError', 'check_value',
           'default_params_path', 'defaults', 'flatten']


def __getattr__(name: str) -> Any:
    """``MODEL_PARAMETERS``, ``ALL_PARAMETERS``, ``SPECS``: the default
    machine's, read from the registry when asked for (:mod:`.schema`).
    """
    if name in LAZY_NAMES:
        return LAZY_NAMES[name]()
    raise AttributeError(f'module {__name__!r} has no attribute {name!r}')


def _node_config(cls: type, values: Mapping[str, Any]) -> Any:
    """Check every node parameter in ``values`` (dotted names; defaults for the
    absent ones); raises ParameterError, also for a name that is no node parameter.
    """
    names = {spec.name for spec in NODE_PARAMETERS}
    for name in values:
        if name not in names:
            raise ParameterError(name, values[name], 'not a node parameter')
    return cls(**{spec.name.replace('.', '_'): check_value(spec, values.get(spec.name,
                                                                            spec.default))
                  for spec in NODE_PARAMETERS})


#: The validated node parameters, one field per parameter of NODE_PARAMETERS
#: (``limits.warn_fraction`` -> ``limits_warn_fraction``), typed by its kind;
#: build it with ``NodeConfig.from_values``.
NodeConfig = make_dataclass(
    'NodeConfig', [(spec.name.replace('.', '_'),
                    {'double': float, 'integer': int, 'string': str, 'bool': bool,
                     'double_array': list}[spec.kind]) for spec in NODE_PARAMETERS],
    frozen=True, slots=True, namespace={'from_values': classmethod(_node_config)})
NodeConfig.__module__ = __name__
