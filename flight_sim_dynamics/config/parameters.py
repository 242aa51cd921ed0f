"""Parameters: the one rule for reading parameter files, and the default
machine's model built from validated values (schema :mod:`.schema`, checks
:mod:`.validation`, both re-exported here; ``MODEL_PARAMETERS``,
``ALL_PARAMETERS``, ``SPECS``: the default machine's, read from the registry
when asked for).

One YAML file in ROS 2 parameter format (``flight_sim_dynamics:
ros__parameters: ...``, nested maps as dotted names ``bodies.rod.mass``) feeds
the solver (:func:`load_model`), the command line (``--params``) and the node
(``--params-file``), by one rule (:func:`read_params`): a file may be partial
(it overrides the packaged defaults); an unknown name is an error ("did you
mean", naming the file); ``qos_overrides.*`` are the node's, ignored by
:func:`load_model`, and so is the ``cueing`` group (the motion-cueing
planner's, checked: :func:`.cueing.split_cueing`); the file is read by
:mod:`.yaml_io`'s rules, so that every bad file is one :class:`ParameterError`
naming it.
"""
from __future__ import annotations

import os
from dataclasses import make_dataclass
from typing import Any, Collection, Mapping, Sequence

from .cueing import split_cueing
from .errors import ParameterError
from .files import (DEFAULT_PARAMS_FILE, NODE_NAME, PACKAGE_NAME,
                    check_file_values, default_params_path, flatten, params_files_in,
                    read_params_file, read_params_sections, without_ros)
from .scenes import Scene, SceneError, load_scene
from .schema import LAZY_NAMES, NODE_PARAMETERS, ParamSpec, defaults, specs
from .validation import build, check_inertia, check_names, check_value, checked_values, validate
from .whole_machine import check_home

__all__ = ['DEFAULT_PARAMS_FILE', 'NODE_NAME', 'NODE_PARAMETERS', 'NodeConfig', 'PACKAGE_NAME',
           'ParamSpec', 'ParameterError', 'Scene', 'SceneError', 'check_inertia',
           'check_value', 'checked_values', 'default_params_path', 'defaults', 'flatten',
           'load_model', 'model_from_values', 'read_params', 'read_params_file', 'validate']


def __getattr__(name: str) -> Any:
    """``MODEL_PARAMETERS``, ``ALL_PARAMETERS``, ``SPECS``: the default
    machine's, read from the registry when asked for (:mod:`.schema`).
    """
    if name in LAZY_NAMES:
        return LAZY_NAMES[name]()
    raise AttributeError(f'module {__name__!r} has no attribute {name!r}')


def read_params(path: str | os.PathLike[str], node: str = '/' + NODE_NAME
                ) -> tuple[dict[str, Any], dict[str, Any]]:
    """Read one parameter file by the one rule (module docstring): (its schema
    parameters, its ``qos_overrides.*``), flat dicts of dotted names; each value
    of a known name checked, the whole when a model is built from them.
    """
    return params_of(read_params_sections(path, node), path)


def params_of(flat: Mapping[str, Any], path: str | os.PathLike[str]
              ) -> tuple[dict[str, Any], dict[str, Any]]:
    """:func:`read_params` of the parameters ``flat`` read from ``path``
    (:func:`.files.read_params_sections`).
    """
    if 'machine' in flat:       # another machine's file (config/stewart_6dof.yaml)
        raise ParameterError('machine', flat['machine'], f'the file names a machine: the 3-DOF '
                             f"machine's files name none (fsd.load_model loads any machine's "
                             f'file; the node serves the 3-DOF machine) in {path}')
    check_file_values(flat, str(path))
    flat, _ = split_cueing(flat, str(path))     # the motion-cueing planner's group, checked
    values, qos = without_ros(flat)
    check_names(values, str(path))
    return values, qos


def model_from_values(values: Mapping[str, Any], *, require_all: bool = True,
                      scene: Scene | str | None = None, changed: Collection[str] | None = None,
                      source: str | None = None) -> Any:
    """Validate ``values`` (flat dotted names) and build the default machine's
    model (its :attr:`~flight_sim_dynamics.core.machine.Machine.from_params`), with
    the effects and overrides of ``scene`` (a :class:`~.scenes.Scene`, name or
    path; None: the ``scene`` parameter, else ``full``). :class:`ParameterError`
    if anything is invalid, including a geometry whose loops cannot close at the
    central configuration (eq. 7-8) and a home pose that does not solve
    (:func:`.whole_machine.check_home`: blamed on those of ``changed`` that
    decide it, None: of ``values``; ``source``: where the values come from);
    :class:`~.scenes.SceneError` for a bad scene.
    """
    if scene is None:
        spec = specs()['scene']
        scene = values.get('scene', spec.default)
        if not isinstance(scene, str):
            raise ParameterError('scene', scene, 'expected a scene name or a file path')
        scene = check_value(spec, scene)
    scene = scene if isinstance(scene, Scene) else load_scene(scene)
    values = dict(values)
    values['scene'] = scene.name if scene.path is None else str(scene.path)
    for key, value in scene.parameters.items():
        values[key] = value
    checked = checked_values(values, require_all=require_all)
    model = build({**checked, 'scene': scene.name}, scene.effects)
    check_home(model, values.keys() if changed is None else changed, checked, source)
    return model


def packaged_values() -> dict[str, Any]:
    """The parameters of the packaged file (the defaults every file overrides)."""
    return read_params(default_params_path())[0]


def load_model(path: str | os.PathLike[str] | None = None,
               scene: str | os.PathLike[str] | None = None) -> Any:
    """Load and validate a 3-DOF parameter file (None: the packaged defaults;
    by the rule of the module docstring, node parameters accepted) and a scene
    (a name from config/scenes or a path; None: the file's ``scene``
    parameter, else ``full``, the paper's model). Raises
    :class:`ParameterError` for any bad file or value, and for a file that
    names a machine (the node's and the twin's loader: they serve the 3-DOF
    machine; :func:`.machine_files.load_model`, ``fsd.load_model``, loads any
    machine's file).
    """
    return model_of_params(None if path is None else read_params_sections(path), path, scene)


def model_of_params(flat: Mapping[str, Any] | None, path: str | os.PathLike[str] | None,
                    scene: str | os.PathLike[str] | None = None) -> Any:
    """:func:`load_model` of the parameters ``flat`` read from ``path``
    (:func:`.files.read_params_sections`; None: the packaged defaults alone).
    """
    values = packaged_values()
    own: Mapping[str, Any] = {}
    if flat is not None:
        own = params_of(flat, path)[0]
        values.update(own)
    return model_from_values(values, require_all=True, scene=scene, changed=own.keys(),
                             source=None if path is None else str(path))


def check_params_files(args: Sequence[str], node: str = '/' + NODE_NAME) -> None:
    """The one rule on the ``--params-file`` files of a node's command line
    ``args`` (``node``: its fully qualified name), values over the packaged ones
    validated as load_model does: a bad file is one ParameterError.
    """
    values = packaged_values()
    for path in params_files_in(args):
        values.update(read_params(path, node)[0])
    validate(values)


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
