"""The one loader of parameter files, every machine's (:func:`load_model`,
the public ``fsd.load_model``; the node's start-up check and schema,
:mod:`.node_schema`, read by it too).

A file is a ROS 2 parameter file (``flight_sim_dynamics: ros__parameters:
...``, nested maps as dotted names, :func:`.files.read_params_sections`). Its
``machine: <name>`` line names its machine (:func:`.machines.machine_named`:
the name of a packaged file, ``config/<name>.yaml``, or a machine's kind, its
:attr:`Machine.name`); a file without the line is the default machine's.
Every file is read by one rule (:func:`load_layers`): the packaged file of its machine
(``config/<name>.yaml``; the default machine's: ``config/flight_sim_dynamics.yaml``;
a machine of one's own, named by its kind: none, the file is given whole)
gives the values a partial file overrides; each name must be one of its
machine's parameters (:attr:`Machine.parameters`; "did you mean", naming the
file), a file without the line whose keys are another machine's is an error
saying which; the node's parameters (:data:`.schema.NODE_PARAMETERS`) and the
``cueing`` group (the motion-cueing planner's, :func:`.cueing.split_cueing`)
are checked and left out, ``qos_overrides.*`` and rclpy's own parameters
ignored (:func:`.files.without_ros`); a scene (the file's ``scene`` or the
caller's) switches effects and overrides parameters; each value is checked
against its declaration (:attr:`Machine.parameter_specs`), then the machine's
builder (:attr:`Machine.from_params`) checks the whole and
:func:`.whole_machine.check_home` the home pose. Every bad file is one
:class:`ParameterError` naming the file and the key.
"""
from __future__ import annotations

import os
import warnings
from pathlib import Path
from typing import Any, Collection, Mapping, Sequence

from ..core.effects import EFFECT_NAMES
from ..core.machine import Machine, ModelValueError
from ..core.parameter_spec import checked_values
from .cueing import PREFIX, CueingParams, split_cueing
from ..machines import (UnknownMachineError, default_machine, known_names, machine_named,
                        machines)
from ..machines import packaged as packaged_machines
from ..machines.api import absent_effects
from .errors import IgnoredParameterWarning, ParameterError, did_you_mean
from .files import DEFAULT_PARAMS_FILE, default_params_path, read_params_sections, without_ros
from .scenes import DEFAULT_SCENE, Scene, SceneError, load_scene, scenes_dir
from .schema import NODE_PARAMETERS
from .validation import check_value, nested
from .whole_machine import check_home

#: The node's parameters, which a named machine's file may give too.
NODE_SPECS = {spec.name: spec for spec in NODE_PARAMETERS}


def load_model(path: str | os.PathLike[str] | None = None,
               scene: Scene | str | os.PathLike[str] | None = None) -> Any:
    """The model of a parameter file (None: the default machine's packaged
    file; a name: the packaged file of that name, :func:`params_path`) and a
    scene (a name from config/scenes or a path; None: the file's ``scene``
    parameter, else ``full``), by the rule of the module docstring; what the
    file gives that the scene leaves out is warned about
    (:class:`IgnoredParameterWarning`). Raises :class:`ParameterError` for any
    bad file or value.
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
    if path is None:
        return load_layers([], scene), []
    path = params_path(path)
    flat = read_params_sections(path)        # read once (a FIFO)
    model = load_layers([(str(Path(path)), flat)], scene)
    note = ignored_note(flat, str(Path(path)), model)
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
    does not use (:func:`ignored_values`, against the packaged file of its
    machine, :func:`packaged_file`; a machine of one's own: the first packaged
    file of its kind), or None.
    """
    name = flat.get('machine')
    packaged = packaged_file(name)
    if packaged is None:                 # a machine of one's own: its kind's first file
        files = machine_named(name).parameter_files     # the model was built: a known name
        packaged = packaged_path(files[0]) if files else None
    reference = {} if packaged is None else without_ros(read_params_sections(packaged))[0]
    names = ignored_values(without_ros(flat)[0], reference, model)
    return ignored_message(names, model.scene, f'{source}: ') if names else None


def ignored_message(names: Sequence[str], scene: str, where: str = '') -> str:
    """The note on ``names`` (:func:`ignored_values`) that scene ``scene`` leaves out."""
    effect = ' and '.join(sorted({key.split('.')[0] for key in names}))
    return (f"{where}{', '.join(names)} not simulated: scene '{scene}' leaves {effect} out; "
            f'a scene with {effect} simulates it (docs/scenes.md)')


def packaged_names() -> list[str]:
    """The names of the packaged parameter files (config/<name>.yaml): the default
    machine's, then the other machines'.
    """
    default = default_params_path().stem
    return [default, *sorted(name for name in packaged_machines() if name != default)]


def example_params_file() -> str:
    """The packaged file a help text shows as an example of a file naming its
    machine (``config/<name>.yaml``): the first by name of a machine other than
    the default, else the default machine's (the registry's, no file read).
    """
    default = default_machine()
    others = sorted(name for name, m in packaged_machines().items() if m is not default)
    names = others or list(default.parameter_files) or [Path(DEFAULT_PARAMS_FILE).stem]
    return f'config/{names[0]}.yaml'


def params_path(path: str | os.PathLike[str]) -> str | os.PathLike[str]:
    """A parameter file given by its path, or by the name of a packaged file
    (a string without a ``.yaml`` / ``.yml`` suffix or a folder, as scenes are
    named: ``'<name>'`` for config/<name>.yaml), found where the default
    machine's file is (:func:`.files.default_params_path`: the installed share
    directory), so from any folder. Another name is read as a file when one of
    that name exists, else it is a :class:`ParameterError` listing the packaged
    names.
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
    the input checks', ...) of a parameter file of any machine (None: the default
    machine's packaged file), each checked: the file's over its packaged file's
    (:func:`packaged_file`) over the declared defaults. What the node would run
    with, for a command that does as the node does.
    """
    values = {spec.name: spec.default for spec in NODE_PARAMETERS}
    own = {} if path is None else read_params_sections(params_path(path))
    packaged = packaged_file(own.get('machine'))
    if packaged is not None:
        values.update(node_values(read_params_sections(packaged), str(packaged)))
    if path is not None:
        values.update(node_values(own, str(path)))
    return values


def load_cueing(path: str | os.PathLike[str] | None = None) -> CueingParams:
    """The ``cueing`` group of a parameter file (None: the default machine's
    packaged file) over its packaged file's (:func:`packaged_file`), as the
    model's values are (a partial file overrides them; a machine of one's own:
    the design's defaults).
    ParameterError naming the key and the file.
    """
    own = {} if path is None else read_params_sections(path)
    packaged = packaged_file(own.get('machine'))
    if path is not None:
        split_cueing(own, str(path))              # the file's own group checked, named
    values = {} if packaged is None else {
        k: v for k, v in read_params_sections(packaged).items() if k.startswith(PREFIX)}
    values.update({k: v for k, v in own.items() if k.startswith(PREFIX)})
    return split_cueing(values, str(path or packaged))[1]


def packaged_path(name: str) -> Path:
    """The packaged parameter file of the machine ``name`` (config/<name>.yaml)."""
    return default_params_path().parent / f'{name}.yaml'


def packaged_file(name: Any) -> Path | None:
    """The packaged file under a file whose ``machine:`` line gives ``name``
    (None: no line, the default machine's, :func:`.files.default_params_path`;
    a packaged file's name: that file; a machine's kind: None, a file of one's
    own gives every value).
    """
    if name is None:
        return default_params_path()
    return packaged_path(name) if isinstance(name, str) and name in packaged_machines() \
        else None


def launch_params_file(machine: str = '', params_file: str = '') -> Path:
    """The parameter file of the launch file's ``machine`` and ``params_file``
    arguments: ``params_file`` when given, else the packaged file of ``machine``
    (``<name>``: config/<name>.yaml; empty: the default machine's).
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
                         f"{', '.join(sorted(files))} (none: the default machine, "
                         f'{_title(default_machine())}, {default.name})'
                         + did_you_mean(machine, files))
    return packaged_path(machine)


def _title(machine: Machine) -> str:
    """A machine's name in messages: its title, else its name."""
    return machine.title or machine.name


def _check_names(values: Mapping[str, Any], machine: Machine, name: str | None,
                 source: str) -> None:
    """Every name of a file (its ``machine:`` line ``name``, None: none) must be
    one of its machine's parameters; "did you mean" the closest.
    """
    default = default_machine()
    known = machine.parameters | NODE_SPECS.keys()      # a file gives the node's too
    for key in values:
        if key in machine.parameters:
            continue
        if name is None:
            raise ParameterError(key, values[key], f'unknown parameter in {source}'
                                 + did_you_mean(key, known))
        other = (f' (a parameter of the default machine, {_title(default)}, whose files '
                 'name no machine)') if machine is not default and key in default.parameters \
            else ''
        raise ParameterError(key, values[key], f"unknown parameter of machine '{name}'"
                             f'{other} in {source}' + did_you_mean(key, known))


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
        spec = next((s for s in machine.parameter_specs if s.name == 'scene'), None)
        if spec is not None:            # its declared bounds (a path's length)
            try:
                check_value(spec, scene)
            except ParameterError as exc:
                raise ParameterError('scene', scene, f'{exc.reason} in {source}') from None
    return load_scene(scene, names=machine.parameters - {'machine', 'scene'})


def named_machine(name: Any, source: str) -> Machine:
    """The machine a file's (or a node's) ``machine: <name>`` describes (None:
    no line, the default machine; a packaged file's name or a machine's kind,
    :func:`.machines.machine_named`); a ParameterError naming the key
    ``machine`` for no name, an unknown one (the known ones listed) and the
    default machine's kind (its files name none).
    """
    if name is None:
        return default_machine()
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
    """A file without a ``machine:`` line is the default machine's: a
    ParameterError (key ``machine``) when its keys unknown to that machine are
    another machine's (most of them: that one), saying which and to name it,
    before the default machine's checks would refuse some value of them (e.g. a
    vector of another length).
    """
    own, _ = split_cueing(without_ros(flat)[0], source)
    known = default_machine().parameters | NODE_SPECS.keys()
    foreign = {key for key in own if key not in known}
    if not foreign:
        return
    candidates = [m for m in machines() if m.from_params is not None and foreign & m.parameters]
    if not candidates:
        return                      # no other machine's: the default's checks name the key
    best = max(candidates, key=lambda m: len(foreign & m.parameters))    # the first on a tie
    keys = sorted(foreign & best.parameters)
    packaged = (f" or 'machine: {best.parameter_files[0]}' (that packaged file's values "
                'under yours)') if best.parameter_files else ''
    raise ParameterError('machine', None, (
        f"{source} names no machine, so it is read as the default machine's "
        f"({_title(default_machine())}), but "
        f"{', '.join(keys[:4])}{' ...' if len(keys) > 4 else ''} look like the keys of "
        f"machine '{best.name}' ({_title(best)}): add the line "
        f"'machine: {best.name}' (a whole file){packaged}"))


def node_values(flat: Mapping[str, Any], source: str) -> dict[str, Any]:
    """The node's parameters among a file's ``flat`` (dotted names), each value
    checked (one file serves the model and the node, every machine's);
    ``limits.warn_fraction`` is one of them.
    """
    out = {}
    for key in flat.keys() & NODE_SPECS.keys():
        try:
            out[key] = check_value(NODE_SPECS[key], flat[key])
        except ParameterError as exc:
            raise ParameterError(exc.key, exc.value, f'{exc.reason} in {source}') from None
    return out


def file_values(flat: Mapping[str, Any], machine: Machine, source: str) -> dict[str, Any]:
    """The model's values a file (its parameters ``flat``, read from ``source``)
    gives its machine ``machine``: its ``cueing`` group and the node's
    parameters checked and left out (:func:`.cueing.split_cueing`,
    :func:`node_values`), ROS's own ignored, each name one of the machine's.
    """
    own, _ = split_cueing(without_ros(flat)[0], source)     # the motion-cueing planner's
    node_values(own, source)
    own = {k: v for k, v in own.items() if k not in NODE_SPECS}
    _check_names(own, machine, own.get('machine'), source)
    return own


def load_layers(layers: Sequence[tuple[str, Mapping[str, Any]]],
                scene: Scene | str | os.PathLike[str] | None = None) -> Any:
    """The model of parameter files ``layers`` ((path, its parameters
    ``flat``), each over those before, as ROS reads ``--params-file`` files;
    none: the default machine's packaged file) over the packaged file of their
    machine (:func:`packaged_file`), with ``scene`` (None: the files'): the
    rule of the module docstring. A file without a ``machine:`` line whose keys
    are another machine's is refused (:func:`_check_unnamed`).
    """
    merged: dict[str, Any] = {}
    for _, flat in layers:
        merged.update(flat)
    name = merged.get('machine')
    packaged = packaged_file(name)
    source = os.pathsep.join(path for path, _ in layers) or str(packaged)
    if name is None and layers:
        _check_unnamed(merged, source)
    machine = named_machine(name, source)
    own: dict[str, Any] = {}
    for path, flat in layers:
        own.update(file_values(flat, machine, path))
    values: dict[str, Any] = {}
    origin = {key: source for key in own}   # the file each value comes from
    if packaged is not None:
        values = file_values(read_params_sections(packaged), machine, str(packaged))
        origin = {**{key: str(packaged) for key in values}, **origin}
    values.update(own)
    return model_of_values(machine, values, source, scene, origin)


def model_of_values(machine: Machine, values: Mapping[str, Any], source: str,
                    scene: Scene | str | os.PathLike[str] | None = None,
                    origin: Mapping[str, str] | None = None,
                    changed: Collection[str] | None = None) -> Any:
    """The model of a machine's complete ``values`` (dotted names, read
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
    packaged = packaged_file(name) is not None
    origin = origin or {}
    chosen = _scene(scene, values, machine, source)
    values.update(chosen.parameters)
    values['scene'] = chosen.name
    try:
        # every value within its declaration first (type, size, bounds: a mass of
        # 1e308 kg is refused by its bound, before any solve), canonical
        model = machine.from_params(nested(checked_values(machine.parameter_specs, values)),
                                    effects=chosen.effects)
    except ModelValueError as exc:
        key = exc.key
        if key in chosen.parameters:
            where = chosen.path or scenes_dir() / f'{chosen.name}.yaml'
            raise SceneError(chosen.name, f"{where}: {ParameterError(key, values[key], str(exc))}"
                             ) from None
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
