"""The machines' physics, one subpackage per machine (numpy, no I/O), and the
registry of machines: which :class:`~flight_sim_dynamics.core.machine.Machine`
a model belongs to (by its type), which one a parameter file names.

Each subpackage holds what belongs to one machine: its parameters (model),
kinematics and dynamics, and its :class:`Machine` (``<name>/machine.py``);
what machines share (statuses, effects and scenes, the machine interface)
lives in :mod:`flight_sim_dynamics.core`. The 3-DOF machine's physics is
still in :mod:`flight_sim_dynamics.core`; its :class:`Machine` is built here.
The public calls that dispatch on a model are in :mod:`.api`.
"""
from __future__ import annotations

import numpy as np

from ..core.machine import ActuatorLimits, Machine
from .staicu import forward_dynamics as _forward_dynamics, forward_kinematics as _forward_kinematics
from .staicu import solver as _solver
from .staicu.model import JOINT_NAMES, LEG_NAMES, Model
from .stewart.machine import MACHINE as STEWART


def _flight_simulator_limits(model: Model) -> ActuatorLimits:
    """The 3-DOF machine's limits (parameters ``limits.*``), the same for every leg."""
    lim, legs = model.limits, len(LEG_NAMES)
    return ActuatorLimits(stroke_min=np.full(legs, lim.stroke_min),
                          stroke_max=np.full(legs, lim.stroke_max),
                          max_speed=lim.max_speed, max_force=lim.max_force)


#: The 3-DOF flight simulator of Staicu, Ocnarescu and Ungureanu (the default).
FLIGHT_SIMULATOR = Machine(
    name='flight_simulator_3dof', model_type=Model, coordinates=('surge', 'heave', 'roll'),
    units=('m', 'm', 'rad'), legs=LEG_NAMES, joints=JOINT_NAMES, solve=_solver.solve,
    solve_batch=_solver.solve_batch, forward_kinematics=_forward_kinematics.forward_kinematics,
    forward_dynamics=_forward_dynamics.forward_dynamics, actuator_limits=_flight_simulator_limits)

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
