"""The public calls on a model of any machine.

Each finds the model's machine (:func:`.by_model_type`, by the model's type)
and calls its function, with the machine's vectors (three numbers for the
3-DOF machine, six for a hexapod)::

    import flight_sim_dynamics as fsd
    hexa = fsd.load_model('stewart_6dof')
    sol = fsd.solve(hexa, q, qd, qdd)                # sol.length, .force, .status
    fd = fsd.forward_dynamics(hexa, q, qd, sol.force)
    fsd.machine_of(hexa).coordinates                 # ('surge', 'sway', 'heave', ...)

The dispatch is one dictionary look-up by type (its cost: ``python -m
benchmarks.dispatch``); results are the machine's own, bit for bit.
"""
from __future__ import annotations

from typing import Any, Sequence

import numpy as np

from ..core import simulation
from ..core.machine import Machine
from ..core.status import Status
from ..core.servo import DEFAULT_BANDWIDTH_HZ, DEFAULT_DAMPING, Servo
from . import by_model_type, machines


def machine_of(model: object) -> Machine:
    """The machine ``model`` belongs to; TypeError for anything that is not a
    model of :func:`flight_sim_dynamics.load_model`.
    """
    machine = by_model_type().get(type(model))
    if machine is not None:
        return machine
    for machine in machines():      # a subclass of a machine's model
        if isinstance(model, machine.model_type):
            return machine
    raise TypeError(f'expected a model of load_model() (one of '
                    f'{", ".join(m.model_type.__name__ for m in machines())}), '
                    f'got {type(model).__name__}')


def solve(model: Any, q: Sequence[float], qd: Sequence[float], qdd: Sequence[float]) -> Any:
    """One sample of the model's machine: pose ``q``, its rates ``qd`` and
    accelerations ``qdd`` (one number per coordinate of
    ``machine_of(model).coordinates``); per leg length, stroke, rate,
    acceleration, force, power, and the status. Never raises for a bad pose or
    bad numbers; ValueError for arguments of the wrong size
    (:func:`flight_sim_dynamics.machines.staicu.solver.solve`,
    :func:`flight_sim_dynamics.machines.stewart.solver.solve`).
    """
    call = machine_of(model).solve
    return call(model, q, qd, qdd)


def solve_batch(model: Any, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> Any:
    """N samples (arrays (N, coordinates)); every field gets a leading N axis."""
    call = machine_of(model).solve_batch
    return call(model, q, qd, qdd)


def forward_kinematics(model: Any, lengths: Sequence[float], *args: Any, **kwargs: Any) -> Any:
    """The pose whose leg lengths are ``lengths`` (one per leg), by Newton's
    method from ``initial`` (default: home); ``tolerance``, ``max_iterations``
    as the machine's function takes them. Never raises for bad numbers.
    """
    call = machine_of(model).forward_kinematics
    return call(model, lengths, *args, **kwargs)


def forward_dynamics(model: Any, q: Sequence[float], qd: Sequence[float],
                     force: Sequence[float]) -> Any:
    """The accelerations that actuator forces ``force`` (one per leg) produce
    at ``q``, ``qd``: ``solve(model, q, qd, fd.acceleration).force == force``.
    ValueError for arguments of the wrong size and for a scene without inertia.
    """
    call = machine_of(model).forward_dynamics
    return call(model, q, qd, force)


def poses_along(model: Any, lengths: np.ndarray) -> list[Any]:
    """Forward kinematics of every row of ``lengths`` (N, legs), each from the
    pose of the row before (else from home): a measured stroke history read
    back as poses, one result (pose, status, residual) per row.
    """
    call = machine_of(model).forward_kinematics
    home = (0.0,) * machine_of(model).dof
    results = []
    initial = home
    for row in lengths:
        result = call(model, row, initial)
        if result.status != Status.OK and initial != home:
            result = call(model, row)
        initial = tuple(result.pose) if result.status == Status.OK else home
        results.append(result)
    return results


def simulate(plant: Any, **kwargs: Any) -> simulation.Simulation:
    """The digital twin of the plant's machine
    (:func:`flight_sim_dynamics.core.simulation.simulate`): open loop
    (``forces=``, one column per leg) or closed loop (``reference=``,
    ``feedforward=``, ``servo=``); ``initial`` = (q, qd), ``step``; vectors of
    the machine's sizes. ValueError for bad arguments.
    """
    return simulation.simulate(machine_of(plant), plant, **kwargs)


def servo_for_bandwidth(model: Any, hz: float = DEFAULT_BANDWIDTH_HZ,
                        damping: float = DEFAULT_DAMPING) -> Servo:
    """Servo gains of ``hz`` and ``damping`` for the model's machine
    (:meth:`flight_sim_dynamics.core.servo.Servo.for_bandwidth`).
    """
    return Servo.for_bandwidth(machine_of(model), model, hz, damping)


def absent_effects(model: Any) -> dict[str, str]:
    """The effects whose parameters are all zero in ``model`` (so that switching
    them on changes nothing), each with the parameters that make it so: the
    payload (no mass, no inertia), friction (no viscous nor Coulomb coefficient).
    """
    out = {}
    payload = getattr(model, 'payload', None)
    if payload is not None and payload.mass == 0 and not np.any(payload.inertia):
        out['payload'] = 'payload.mass 0 kg'
    friction = getattr(model, 'friction', None)
    if friction is not None and not np.any(friction.viscous) and not np.any(friction.coulomb):
        out['friction'] = 'friction.viscous and friction.coulomb 0'
    return out
