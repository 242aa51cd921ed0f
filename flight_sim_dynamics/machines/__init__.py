"""The machines' physics, one subpackage per machine (numpy, no I/O), and the
registry of machines: which :class:`~flight_sim_dynamics.core.machine.Machine`
a model belongs to (by its type), which one a parameter file names.

Each subpackage holds what belongs to one machine: its parameters (model),
kinematics and dynamics, its kernel and its :class:`Machine`
(``<name>/machine.py``): :mod:`.staicu`, the paper's 3-DOF flight simulator,
and :mod:`.stewart`, 6-UPS hexapods. What machines share (statuses, effects
and scenes, the kernel switch, the machine interface) lives in
:mod:`flight_sim_dynamics.core`. The public calls that dispatch on a model are
in :mod:`.api`.

The registry is a plugin system, as pytest finds its plugins: every machine is
an entry point of the group :data:`GROUP` (``<machine name> = <module>:<attribute>``,
the attribute a :class:`Machine`), this package's two in its ``setup.py``, any
other distribution's in its own; read on first use (:func:`machines`) and kept.
A plugin that does not load is left out with a :class:`MachinePluginWarning`
naming its entry point (the other machines still work); a file naming it gets
that reason (:func:`machine_named`).

The module's names ``MACHINES``, ``BY_MODEL_TYPE``, ``PACKAGED``,
``FLIGHT_SIMULATOR``, ``STEWART`` read the registry when asked for (a module
``__getattr__``), so that importing this package loads no machine.
"""
from __future__ import annotations

import functools
import warnings
from dataclasses import dataclass
from importlib.metadata import EntryPoint, entry_points
from typing import Any, Mapping

from ..core.machine import Machine

#: The entry-point group a distribution declares its machines in.
GROUP = 'flight_sim_dynamics.machines'
#: The default machine's name (first in :func:`machines`: a file naming no
#: machine is its, as is a command given no file).
DEFAULT = 'flight_simulator_3dof'
#: The names of the packaged machines that other code imports by name.
_ALIASES = {'FLIGHT_SIMULATOR': DEFAULT, 'STEWART': 'stewart'}


class MachinePluginWarning(UserWarning):
    """A machine's entry point did not load (its machine is left out)."""


class UnknownMachineError(LookupError):
    """No machine answers to a name: ``name``, the ``known`` names (packaged
    files' and kinds'), and ``reason`` (why, e.g. a plugin that did not load).
    """

    def __init__(self, name: Any, known: tuple[str, ...], reason: str) -> None:
        super().__init__(reason)
        self.name, self.known, self.reason = name, known, reason


@dataclass(frozen=True)
class Registry:
    """The machines found: ``machines`` (the default first, then by name),
    ``by_model_type``, ``packaged`` (a packaged file's name -> its machine),
    ``by_name`` (a machine's kind name -> it) and ``failures`` (an entry point
    that did not load -> why).
    """

    machines: tuple[Machine, ...]
    by_model_type: dict[type, Machine]
    packaged: dict[str, Machine]
    by_name: dict[str, Machine]
    failures: Mapping[str, str]


def _described(point: EntryPoint) -> str:
    dist = getattr(point, 'dist', None)
    origin = f' (distribution {dist.name})' if dist is not None else ''
    return f"entry point '{point.name} = {point.value}' of group {GROUP}{origin}"


def _load(point: EntryPoint) -> Machine:
    """The machine of ``point``; ValueError naming the entry point if it does not load."""
    try:
        machine = point.load()
    except Exception as exc:        # a plugin's own bug: any error, reported as its
        raise ValueError(f'{_described(point)} does not load: '
                         f'{type(exc).__name__}: {exc}') from exc
    if not isinstance(machine, Machine):
        raise ValueError(f'{_described(point)} loads a {type(machine).__name__}, not a '
                         'flight_sim_dynamics.core.machine.Machine')
    if machine.name != point.name:     # one name per machine: the file's `machine:` line
        raise ValueError(f"{_described(point)} loads the machine '{machine.name}': "
                         'an entry point is named after its machine')
    return machine


@functools.cache
def registry() -> Registry:
    """The machines of every installed distribution's entry points (read once;
    :func:`clear_cache` reads them again). RuntimeError when the default
    machine is not among them (this package not installed).
    """
    found: dict[str, Machine] = {}
    failures: dict[str, str] = {}
    for point in sorted(entry_points(group=GROUP), key=lambda p: p.name):
        if point.name in found or point.name in failures:
            continue    # the same name twice (two copies on the path): the first one
        try:
            found[point.name] = _load(point)
        except ValueError as exc:
            failures[point.name] = str(exc)
            warnings.warn(f'{exc}; machine {point.name!r} left out', MachinePluginWarning,
                          stacklevel=2)
    if DEFAULT not in found:
        raise RuntimeError(failures.get(DEFAULT, (
            f"no machine '{DEFAULT}' in the entry points of group {GROUP}: "
            'flight_sim_dynamics is not installed (pip install . or colcon build)')))
    ordered = (found[DEFAULT], *(m for name, m in found.items() if name != DEFAULT))
    by_type: dict[type, Machine] = {}
    for machine in ordered:
        by_type.setdefault(machine.model_type, machine)
    return Registry(machines=ordered, by_model_type=by_type,
                    packaged={name: m for m in ordered for name in m.parameter_files},
                    by_name={m.name: m for m in ordered}, failures=failures)


def clear_cache() -> None:
    """Forget the machines found: the next use reads the entry points again
    (a test that puts a plugin on the path).
    """
    registry.cache_clear()


def machines() -> tuple[Machine, ...]:
    """Every machine, the default (the 3-DOF machine) first."""
    return registry().machines


def default_machine() -> Machine:
    """The machine of a file without a ``machine:`` line."""
    return registry().machines[0]


def by_model_type() -> dict[type, Machine]:
    """A model's type -> its machine."""
    return registry().by_model_type


def packaged() -> dict[str, Machine]:
    """The name of a packaged parameter file (config/<name>.yaml, ``machine: <name>``)
    -> its machine.
    """
    return registry().packaged


def known_names() -> tuple[str, ...]:
    """The names a file's ``machine:`` line may give: the packaged files', then
    the kinds' (a machine given whole).
    """
    reg = registry()
    default = reg.machines[0]       # its files name no machine
    return (*sorted(n for n, m in reg.packaged.items() if m is not default),
            *sorted(n for n, m in reg.by_name.items()
                    if m.from_params is not None and m is not default))


def machine_named(name: Any) -> Machine:
    """The machine a parameter file's ``machine: <name>`` describes: a packaged
    file's name (its defaults apply) or a machine's kind name (:attr:`Machine.name`,
    a machine given whole). :class:`UnknownMachineError` for any other name.
    """
    reg = registry()
    if isinstance(name, str):
        if name in reg.packaged:
            return reg.packaged[name]
        if name in reg.by_name:
            return reg.by_name[name]
        if name in reg.failures:
            raise UnknownMachineError(name, known_names(), reg.failures[name])
    raise UnknownMachineError(name, known_names(),
                              f'no machine is named {name!r}; known: '
                              f"{', '.join(known_names())}")


def __getattr__(name: str) -> Any:
    """The registry's module-level names, read when asked for (module docstring)."""
    if name == 'MACHINES':
        return machines()
    if name == 'BY_MODEL_TYPE':
        return by_model_type()
    if name == 'PACKAGED':
        return packaged()
    if name in _ALIASES:
        return registry().by_name[_ALIASES[name]]
    raise AttributeError(f'module {__name__!r} has no attribute {name!r}')
