"""The columns of the command line's tables, named from the machine's record
(:class:`flight_sim_dynamics.core.machine.Machine`): a trajectory is ``t``, the
pose coordinates, ``<coordinate>_rate`` and ``<coordinate>_acc``; ``solve``
writes ``<field>_<leg label>`` per leg, then the machine's scalar fields. The
module's constants are the default machine's (the registry's first).
"""
from __future__ import annotations

from typing import Sequence

from ..core.machine import Machine
from ..machines import MACHINES

#: The per-leg fields of a solution ``solve`` writes, in order.
PER_LEG_FIELDS = ('length', 'stroke', 'rate', 'force', 'power', 'acceleration')


def per_leg(machine: Machine, field: str) -> tuple[str, ...]:
    """``<field>_<label>`` for every leg of ``machine``."""
    return tuple(f'{field}_{label}' for label in machine.leg_labels)


def rate_columns(machine: Machine) -> tuple[str, ...]:
    """``<coordinate>_rate``, in the order of qd."""
    return tuple(f'{c}_rate' for c in machine.coordinates)


def acceleration_columns(machine: Machine) -> tuple[str, ...]:
    """``<coordinate>_acc``, in the order of qdd."""
    return tuple(f'{c}_acc' for c in machine.coordinates)


def trajectory_columns(machine: Machine) -> tuple[str, ...]:
    """A trajectory file's header (``example`` writes it, ``solve`` reads it)."""
    return (('t',) + machine.coordinates + rate_columns(machine)
            + acceleration_columns(machine))


def output_columns(machine: Machine) -> tuple[str, ...]:
    """``solve``'s columns before ``status`` (``--joints`` appends :func:`joint_columns`)."""
    return (('t',) + sum((per_leg(machine, f) for f in PER_LEG_FIELDS), ())
            + machine.sample_fields)


def joint_columns(machine: Machine) -> tuple[str, ...]:
    """The joint variables, their rates and accelerations (``solve --joints``)."""
    return (machine.joints + tuple(f'{j}_rate' for j in machine.joints)
            + tuple(f'{j}_acc' for j in machine.joints))


def plot_columns(machine: Machine) -> tuple[str, ...]:
    """What ``plot`` reads: t, the forces and the powers."""
    return ('t',) + per_leg(machine, 'force') + per_leg(machine, 'power')


def machine_of_columns(names: Sequence[str], field: str) -> Machine:
    """The machine most of whose ``<field>_<label>`` columns ``names`` hold
    (the first of :data:`MACHINES` on a tie: the default machine when none).
    """
    given = set(names)
    return max(MACHINES, key=lambda m: len(given.intersection(per_leg(m, field))))


#: The default machine's columns.
DEFAULT_MACHINE = MACHINES[0]
TRAJECTORY_COLUMNS = trajectory_columns(DEFAULT_MACHINE)
OUTPUT_COLUMNS = output_columns(DEFAULT_MACHINE)
JOINT_COLUMNS = joint_columns(DEFAULT_MACHINE)
PLOT_COLUMNS = plot_columns(DEFAULT_MACHINE)
LENGTH_COLUMNS = per_leg(DEFAULT_MACHINE, 'length')
