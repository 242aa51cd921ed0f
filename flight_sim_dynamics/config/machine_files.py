"""The model of any machine's parameter file (:func:`load_model`, the public
``fsd.load_model``): a file without a ``machine`` line is the 3-DOF
machine's (:func:`.parameters.load_model`); a file that names its machine
(``machine: stewart_6dof``) is read here, by the one rule of the 3-DOF files
(:mod:`.parameters`): a packaged machine's file
(``config/<machine>.yaml``) gives the defaults a partial file overrides; a
machine of one's own is named by its machine's kind (:attr:`Machine.name`,
``machine: stewart``) and given whole; any other name is an error (naming the
key ``machine``, the known names, "did you mean"); a file without the line
whose keys are another machine's is an error saying which; a scene (the file's ``scene``
or the caller's) switches effects and overrides parameters as for the 3-DOF
machine. The machine's own builder checks the values; every bad file is one
:class:`ParameterError` naming the file and the key.
"""
from __future__ import annotations

import os
import warnings
from pathlib import Path
from typing import Any, Collection, Mapping, Sequence

from ..core.effects import EFFECT_NAMES
from ..core.machine import Machine, ModelValueError
from .cueing import PREFIX, CueingParams, split_cueing
from ..machines import (UnknownMachineError, default_machine, known_names, machine_named,
                        machines)
from ..machines import packaged as packaged_machines
from ..machines.api import absent_effects
from . import parameters
from .errors import IgnoredParameterWarning, ParameterError, did_you_mean
from .files import default_params_path, read_params_sections, without_ros
from .scenes import DEFAULT_SCENE, Scene, SceneError, load_scene, scenes_dir
from .schema import NODE_PARAMETERS, specs
from .validation import check_value, nested
from .whole_machine import check_home

#: The node's parameters, which a named machine's file may give too.
NODE_SPECS = {spec.name: spec for spec in NODE_PARAMETERS}


def load_model(path: str | os.PathLike[str] | None = None,
               scene: Scene | str | os.PathLike[str] | None = None) -> Any:
    """The model of a parameter file (None: the packaged 3-DOF machine; a name:
    the packaged file of that name, :func:`params_path`) and a scene (a name
    from config/scenes or a path; None: the file's ``scene`` parameter, else
    ``full``): the machine the file names (``machine: <name>``), else the 3-DOF
    machine (:func:`.parameters.load_model`). Raises :class:`ParameterError`
    for any bad file or value.
    """
    model, notes = load_model_noting(path, scene)
    for note in notes:
        warnings.warn(note, IgnoredParameterWarning, stacklevel=2)
    return model


def load_model_noting(path: str | os.PathLike[str] | None = None,
                      scene: Scene | str | os.PathLike[str] | None = None
                      ) -> tuple[Any, list[str]]:
    """:func:`load_model` and its notes (:func:`ignored_note`) returned, not
    warned: for a command that prints them.
    """
    path = None if path is None else params_path(path)
    flat = None if path is None else read_params_sections(path)    # read once (a FIFO)
    if flat is not None and 'machine' in flat:
        model = load_named_model(flat, path, scene)
    else:
        if flat is not None:
            _check_unnamed(flat, str(Path(path)))
        model = parameters.model_of_params(flat, path, scene)
    note = None if flat is None else ignored_note(flat, str(Path(path)), model)
    return model, [] if note is None else [note]


def ignored_values(given: Mapping[str, Any], reference: Mapping[str, Any],
                   model: Any) -> list[str]:
    """The names in ``given`` (a file's values, dotted names) of parameters of an
    effect the scene of ``model`` leaves out (the effect's own name or group:
    ``payload.*``, ``friction.*``, ``gravity``) that would change its forces:
    not ``reference``'s value (the packaged file's, which a copied file
    repeats), and of an effect that is there (:func:`.machines.api.absent_effects`:
    no 0 kg payload).
    """
    absent = absent_effects(model)
    return sorted(key for key, value in given.items()
                  if (group := key.split('.')[0]) in EFFECT_NAMES
                  and not getattr(model.effects, group) and group not in absent
                  and (key not in reference or value != reference[key]))


def ignored_note(flat: Mapping[str, Any], source: str, model: Any) -> str | None:
    """What the file ``source`` (its parameters ``flat``) gives that ``model``
    does not use (:func:`ignored_values`, against
    the packaged file of its machine: the named one, else the 3-DOF machine's;
    a machine of one's own: the first packaged file of its kind), or None.
    """
    name = flat.get('machine')
    if name is None:
        reference = parameters.packaged_values()
    else:
        kind = machine_named(name)           # the model was built: a known name
        packaged = name if name in packaged_machines() else next(iter(kind.parameter_files),
                                                                None)
        reference = {} if packaged is None else \
            without_ros(read_params_sections(packaged_path(packaged)))[0]
    names = ignored_values(without_ros(flat)[0], reference, model)
    return ignored_message(names, model.scene, f'{source}: ') if names else None


def ignored_message(names: Sequence[str], scene: str, where: str = '') -> str:
    """The note on ``names`` (:func:`ignored_values`) that scene ``scene`` leaves out."""
    effect = ' and '.join(sorted({key.split('.')[0] for key in names}))
    return (f"{where}{', '.join(names)} not simulated: scene '{scene}' leaves {effect} out; "
            f'a scene with {effect} simulates it (docs/scenes.md)')


def packaged_names() -> list[str]:
    """The names of the packaged parameter files (config/<name>.yaml): the 3-DOF
    machine's, then the other machines'.
    """
    default = default_params_path().stem
    return [default, *sorted(name for name in packaged_machines() if name != default)]


def params_path(path: str | os.PathLike[str]) -> str | os.PathLike[str]:
    """A parameter file given by its path, or by the name of a packaged file
    (a string without a ``.yaml`` / ``.yml`` suffix or a folder, as scenes are
    named: ``'stewart_6dof'``), found where the packaged 3-DOF file is
    (:func:`.files.default_params_path`: the installed share directory), so
    from any folder. Another name is read as a file when one of that name
    exists, else it is a :class:`ParameterError` listing the packaged names.
    """
    if not isinstance(path, str) or path.endswith(('.yaml', '.yml')) or os.sep in path \
            or (os.altsep and os.altsep in path):
        return path
    names = packaged_names()
    if path in names:
        return packaged_path(path)
    try:
        if Path(path).exists():
            return path
    except (OSError, ValueError):       # a name too long for the file system, a NUL
        pass
    raise ParameterError('params_file', path, 'no such file, nor the name of a packaged '
                                              f"parameter file ({', '.join(names)})"
                         + did_you_mean(path, names))


def load_node_values(path: str | os.PathLike[str] | None = None) -> dict[str, Any]:
    """The node's parameters (:data:`.schema.NODE_PARAMETERS`: the estimator's,
    the input checks', ...) of a parameter file of any machine (None: the packaged
    3-DOF machine's), each checked: the file's over its packaged file's (the named
    one, else the 3-DOF machine's; a machine of one's own: none) over the declared
    defaults. What the node would run with, for a command that does as the node does.
    """
    values = {spec.name: spec.default for spec in NODE_PARAMETERS}
    own = {} if path is None else read_params_sections(params_path(path))
    name = own.get('machine')
    packaged = (default_params_path() if name is None
                else packaged_path(name) if name in packaged_machines() else None)
    if packaged is not None:
        values.update(node_values(read_params_sections(packaged), str(packaged)))
    if path is not None:
        values.update(node_values(own, str(path)))
    return values


def load_cueing(path: str | os.PathLike[str] | None = None) -> CueingParams:
    """The ``cueing`` group of a parameter file (None: the packaged 3-DOF
    machine's) over its packaged file's, as the model's values are (a partial
    file overrides them; a machine of one's own: the design's defaults).
    ParameterError naming the key and the file.
    """
    own = {} if path is None else read_params_sections(path)
    name = own.get('machine')
    packaged = (default_params_path() if name is None
                else packaged_path(name) if name in packaged_machines() else None)
    if path is not None:
        split_cueing(own, str(path))              # the file's own group checked, named
    values = {} if packaged is None else {
        k: v for k, v in read_params_sections(packaged).items() if k.startswith(PREFIX)}
    values.update({k: v for k, v in own.items() if k.startswith(PREFIX)})
    return split_cueing(values, str(path or packaged))[1]


def packaged_path(name: str) -> Path:
    """The packaged parameter file of the machine ``name`` (config/<name>.yaml)."""
    return default_params_path().parent / f'{name}.yaml'


def launch_params_file(machine: str = '', params_file: str = '') -> Path:
    """The parameter file of the launch file's ``machine`` and ``params_file``
    arguments: ``params_file`` when given, else the packaged file of ``machine``
    (``stewart_6dof``: config/stewart_6dof.yaml; empty: the 3-DOF machine's).
    ValueError for both given or a machine that is not packaged.
    """
    if params_file and machine:
        raise ValueError(f'give machine ({machine}) or params_file ({params_file}), not both: '
                         'a params file names its machine')
    if params_file:
        return Path(params_file)
    default = default_params_path()
    if not machine or machine == default.stem:
        return default
    files = packaged_machines()
    if machine not in files:
        raise ValueError(f'machine {machine!r} is not packaged; choose one of '
                         f"{', '.join(sorted(files))} (none: the 3-DOF machine, "
                         f'{default.name})' + did_you_mean(machine, files))
    return packaged_path(machine)


def _check_names(values: Mapping[str, Any], machine: Machine, name: str, source: str) -> None:
    """Every name of a file must be one of its machine's parameters."""
    for key in values:
        if key not in machine.parameters:
            other = ' (a parameter of the 3-DOF machine, whose files name no machine)' \
                if key in specs() else ''
            raise ParameterError(key, values[key], f"unknown parameter of machine '{name}'"
                                 f'{other} in {source}' + did_you_mean(key, machine.parameters))


def _scene(scene: Scene | str | os.PathLike[str] | None, values: Mapping[str, Any],
           machine: Machine, source: str) -> Scene:
    """The scene asked for (else the file's ``scene``, else full), its overrides
    checked against the machine's parameter names.
    """
    if isinstance(scene, Scene):
        return scene
    if scene is None:
        scene = values.get('scene', DEFAULT_SCENE)
        if not isinstance(scene, str) or not scene:
            raise ParameterError('scene', scene, f'expected a scene name or a file path in '
                                                 f'{source}')
    return load_scene(scene, names=machine.parameters - {'machine', 'scene'})


def _check_specs(machine: Machine, values: Mapping[str, Any]) -> None:
    """Every value within its declaration (:attr:`Machine.parameter_specs`: type,
    size, bounds), as the node's descriptors declare it: ModelValueError naming
    the key (a mass of 1e308 kg is refused by its bound, before any solve).
    """
    for spec in machine.parameter_specs:
        if spec.name in values:
            try:
                check_value(spec, values[spec.name])
            except ParameterError as exc:
                raise ModelValueError(exc.key, exc.reason) from None


def named_machine(name: Any, source: str) -> Machine:
    """The machine a file's (or a node's) ``machine: <name>`` describes (a
    packaged file's name or a machine's kind, :func:`.machines.machine_named`); a
    ParameterError naming the key ``machine`` for no name, an unknown one (the
    known ones listed) and the 3-DOF machine's (its files name none).
    """
    if not isinstance(name, str) or not name:
        raise ParameterError('machine', name, f'expected the name of a machine in {source}')
    if name == default_machine().name:
        raise ParameterError('machine', name, f'the {name} machine\'s files name no machine: '
                                              f'leave this line out in {source}')
    try:
        machine = machine_named(name)
    except UnknownMachineError as exc:
        raise ParameterError('machine', name, f'{exc.reason} in {source}'
                             + did_you_mean(name, exc.known)) from None
    if machine.from_params is None:
        raise ParameterError('machine', name, f'the {name} machine reads no parameter files '
                                              f"(known: {', '.join(known_names())}) in {source}")
    return machine


def _check_unnamed(flat: Mapping[str, Any], source: str) -> None:
    """A file without a ``machine:`` line is the 3-DOF machine's: a ParameterError
    (key ``machine``) when its keys unknown to that machine are another machine's
    (most of them: that one), saying which and to name it, before the 3-DOF
    machine's checks would refuse some value of them (a hexapod's six numbers).
    """
    own, _ = split_cueing(without_ros(flat)[0], source)
    known = specs()
    foreign = {key for key in own if key not in known}
    if not foreign:
        return
    candidates = [m for m in machines() if m.from_params is not None and foreign & m.parameters]
    if not candidates:
        return                      # no other machine's: the 3-DOF checks name the key
    best = max(candidates, key=lambda m: len(foreign & m.parameters))    # the first on a tie
    keys = sorted(foreign & best.parameters)
    packaged = (f" or 'machine: {best.parameter_files[0]}' (that packaged file's values "
                'under yours)') if best.parameter_files else ''
    raise ParameterError('machine', None, (
        f"{source} names no machine, so it is read as the 3-DOF machine's, but "
        f"{', '.join(keys[:4])}{' ...' if len(keys) > 4 else ''} look like the keys of "
        f"machine '{best.name}' ({best.title or best.name}): add the line "
        f"'machine: {best.name}' (a whole file){packaged}"))


def node_values(flat: Mapping[str, Any], source: str) -> dict[str, Any]:
    """The node's parameters among a named machine's ``flat`` (dotted names),
    each value checked (one file serves the model and the node, as for the
    3-DOF machine); ``limits.warn_fraction`` is one of them.
    """
    out = {}
    for key in flat.keys() & NODE_SPECS.keys():
        try:
            out[key] = check_value(NODE_SPECS[key], flat[key])
        except ParameterError as exc:
            raise ParameterError(exc.key, exc.value, f'{exc.reason} in {source}') from None
    return out


def load_named_model(flat: Mapping[str, Any], path: str | os.PathLike[str],
                     scene: Scene | str | os.PathLike[str] | None = None) -> Any:
    """The model of the parameter file ``path`` whose parameters ``flat``
    (dotted names) name its machine, with ``scene`` (None: the file's); the
    node's parameters and the ``cueing`` group it gives are checked
    (:func:`node_values`, :func:`.cueing.split_cueing`) and left out.
    """
    source = str(Path(path))
    own, _ = split_cueing(without_ros(flat)[0], source)     # the motion-cueing planner's
    name = own['machine']
    machine = named_machine(name, source)
    node_values(own, source)
    own = {k: v for k, v in own.items() if k not in NODE_SPECS}
    _check_names(own, machine, name, source)
    packaged = name in packaged_machines()
    origin = {key: source for key in own}   # the file each value comes from
    values = {}
    if packaged:
        defaults = packaged_path(name)
        values, _ = split_cueing(without_ros(read_params_sections(defaults))[0], str(defaults))
        origin = {**{key: str(defaults) for key in values}, **origin}
    values.update(own)
    return model_of_values(machine, values, source, scene, origin)


def model_of_values(machine: Machine, values: Mapping[str, Any], source: str,
                    scene: Scene | str | os.PathLike[str] | None = None,
                    origin: Mapping[str, str] | None = None,
                    changed: Collection[str] | None = None) -> Any:
    """The model of a named machine's complete ``values`` (dotted names, read
    from ``source``; ``origin``: the file of each value where others) with
    ``scene`` (None: the values' ``scene``), each value within its declaration,
    built and checked by the machine, its home pose solved
    (:func:`.whole_machine.check_home`, blamed on those of ``changed`` that
    decide it; None: the values of ``source``).
    """
    if changed is None:
        changed = [key for key in values if (origin or {}).get(key, source) == source]
    values = dict(values)
    name = values.get('machine')
    packaged = name in packaged_machines()
    origin = origin or {}
    chosen = _scene(scene, values, machine, source)
    values.update(chosen.parameters)
    values['scene'] = chosen.name
    try:
        _check_specs(machine, values)
        model = machine.from_params(nested(values), effects=chosen.effects)
    except ModelValueError as exc:
        key = exc.key
        if key in chosen.parameters:
            where = chosen.path or scenes_dir() / f'{chosen.name}.yaml'
            raise SceneError(chosen.name, f"{where}: key '{key}': {exc}") from None
        # the packaged file is valid alone: a value of it is refused for the
        # user's file (e.g. a length_max below the file's length_min)
        given = origin.get(key, source)
        reason = f'{exc} in {source}' if given == source else \
            f'{exc} (the value of {given}) with {source}'
        if key not in values and not packaged:
            files = machine.parameter_files
            reason += (f"; 'machine: {name}' is a machine of your own, which gives every "
                       'section' + (f" (a packaged one's file gives the defaults: "
                                    f"{', '.join(files)})" if files else ''))
        raise ParameterError(key, values.get(key), reason) from None
    except ValueError as exc:       # a builder's error without a key
        raise ParameterError('params_file', source, str(exc)) from None
    check_home(model, changed, values, source)
    return model
