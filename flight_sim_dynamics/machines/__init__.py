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
"""
from __future__ import annotations

from ..core.machine import Machine
from .staicu.machine import MACHINE as FLIGHT_SIMULATOR
from .stewart.machine import MACHINE as STEWART

#: Every machine, the default first.
MACHINES = (FLIGHT_SIMULATOR, STEWART)
#: A model's type -> its machine.
BY_MODEL_TYPE = {machine.model_type: machine for machine in MACHINES}
#: The name of a packaged parameter file (config/<name>.yaml, ``machine: <name>``) -> its machine.
PACKAGED = {name: machine for machine in MACHINES for name in machine.parameter_files}
#: The kind of a machine of one's own (a complete file naming a machine that is
#: not packaged): a 6-UPS hexapod, the one kind described by explicit joint coordinates.
OWN_MACHINE = STEWART


def machine_named(name: str) -> Machine:
    """The machine a parameter file's ``machine: <name>`` describes."""
    return PACKAGED.get(name, OWN_MACHINE)
