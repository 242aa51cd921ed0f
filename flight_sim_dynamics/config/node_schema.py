"""The parameters the dynamics node declares, for the machine its parameters
name (``machine: <name>``; none: the default machine): the
machine's own (:attr:`Machine.parameter_specs`), the node's
(:data:`.schema.NODE_PARAMETERS`, shared), their start-up values and the model
of a complete set (:class:`NodeSchema`).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable, Collection, Mapping, Sequence

from ..core.machine import Machine
from ..core.parameter_spec import ParamSpec
from .errors import ParameterError
from .files import NODE_NAME, params_files_in, read_params_sections
from .machine_files import (load_layers, model_of_values, named_machine, node_values,
                            packaged_file)
from .schema import NODE_PARAMETERS

#: The parameter naming the machine (read-only: fixed at start-up).
MACHINE = 'machine'
#: Its declaration, for a machine whose own declarations leave it out (a plugin's).
MACHINE_SPEC = ParamSpec(MACHINE, 'string', None, 'the machine the parameter file describes '
                         "(a packaged file's name, or a machine's kind for one of your own)")
_SOURCE = "the node's parameters"


@dataclass(frozen=True)
class NodeSchema:
    """What a node declares for ``machine``: ``specs`` (name -> declaration,
    the machine's then the node's), the ``defaults`` a start-up value overrides
    (the packaged file's; a name without one is declared only when given), and
    ``build(values, changed) -> model`` of a complete set of the machine's
    values, ``changed`` the names a set changes (None: all), those a refused
    home pose is blamed on (:func:`.whole_machine.check_home`).
    """

    machine: Machine
    model_specs: tuple[ParamSpec, ...]
    defaults: Mapping[str, Any]
    build: Callable[[Mapping[str, Any], Collection[str] | None], Any]

    @property
    def specs(self) -> dict[str, ParamSpec]:
        return {s.name: s for s in self.model_specs + NODE_PARAMETERS}

    def model(self, values: Mapping[str, Any], changed: Collection[str] | None = None) -> Any:
        """The model of ``values`` (at least every declared model parameter);
        ``changed``: the names a parameter set changes (None: every value).
        """
        ours = {s.name: values[s.name] for s in self.model_specs if s.name in values}
        return self.build(ours, None if changed is None else [k for k in changed if k in ours])


def node_schema(machine_name: Any = None) -> NodeSchema:
    """The schema of the machine a node's ``machine`` parameter names (None:
    none given, the default machine; :func:`.machine_files.named_machine`), by
    the rule of its files (:mod:`.machine_files`): its declarations (and
    ``machine``'s, when given), its packaged file's values
    (:func:`.machine_files.packaged_file`; a machine of one's own: none) over
    the declared defaults, its model built by
    :func:`.machine_files.model_of_values`. A ParameterError for a name no
    machine answers to.
    """
    machine = named_machine(machine_name, _SOURCE)
    defaults = {s.name: s.default for s in NODE_PARAMETERS + machine.parameter_specs
                if s.default is not None}
    try:
        packaged = packaged_file(machine_name)
    except FileNotFoundError:       # an install without config/: the declared defaults
        packaged = None
    if packaged is not None:
        flat = read_params_sections(packaged)
        defaults.update({k: v for k, v in flat.items() if k in machine.parameters})
        defaults.update(node_values(flat, str(packaged)))
    specs = machine.parameter_specs
    if machine_name is not None:
        defaults[MACHINE] = machine_name
        # the node's `machine` parameter is declared whatever the machine's specs say
        if all(spec.name != MACHINE for spec in specs):
            specs = (MACHINE_SPEC,) + specs
    return NodeSchema(machine, specs, defaults,
                      lambda values, changed: model_of_values(
                          machine, values, _SOURCE,
                          changed=values.keys() if changed is None else changed))


def _unreached(path: str, node: str, machine: Any) -> ParameterError:
    """The error of a file naming ``machine`` whose section does not reach ``node``."""
    return ParameterError(MACHINE, machine, (
        f'{path} names this machine, but ROS gave the node {node} no parameter of '
        'that file (its section must be the node\'s fully qualified name, or match it: '
        '/**, /**/flight_sim_dynamics, to reach a node in a namespace); the node would '
        'run another machine'))


def _sections(path: str, node: str) -> dict[str, Any]:
    """The file's parameters for the node ``node`` (:func:`.files.read_params_sections`);
    a file with no section for it that names a machine for the root namespace's
    node (a bare ``flight_sim_dynamics``) is refused by that machine's name.
    """
    try:
        return read_params_sections(path, node)
    except ParameterError:
        try:
            root = read_params_sections(path)
        except ParameterError:
            root = {}
        if node == '/' + NODE_NAME or MACHINE not in root:
            raise
        raise _unreached(path, node, root[MACHINE]) from None


def check_node_params_files(args: Sequence[str], node: str = '/' + NODE_NAME,
                            machine: Any = None) -> None:
    """The one rule on the ``--params-file`` files of a node's command line
    (``node``: its fully qualified name; ``machine``: the ``machine`` parameter
    it was given, None: none): the files, merged in order, are checked as
    ``load_model`` reads them (:func:`.machine_files.load_layers`). A bad file
    is one ParameterError, as is a file naming a machine whose section ROS did
    not give the node (a section named ``flight_sim_dynamics`` reaches only the
    node of that name in the root namespace).
    """
    layers = [(path, _sections(path, node)) for path in params_files_in(args)]
    if not layers:
        return
    named = [(path, flat) for path, flat in layers if MACHINE in flat]
    if named and named[-1][1][MACHINE] != machine:
        path, flat = named[-1]
        raise _unreached(path, node, flat[MACHINE])
    load_layers(layers)
