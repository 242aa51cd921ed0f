"""One cycle of the node, without ROS: from a synchronised setpoint to the
numbers to publish and what they mean for the diagnostics.

:func:`rates_of` fills in the rates and accelerations a planner did not send,
:func:`solve_setpoint` is the one place where the node calls the solver (the
paper's inverse kinematics and dynamics, eqs. 5-23, through
:func:`flight_sim_dynamics.solve`), :func:`outputs_of` checks the solution
before anything is published, :func:`assess` does the bookkeeping that only
feeds the diagnostics. :class:`Runtime` is what a cycle reads from the
parameters, built (validated) by :func:`runtime_from_values`.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Callable, Mapping, Sequence

import flight_sim_dynamics as fsd

from ..config import parameters as prm
from ..core.model import Model
from ..core.status import Status
from .descriptors import MODEL_NAMES, NODE_NAMES
from .diagnostics import ERROR, WARN, CycleStats, check_limits
from ..core.estimator import DerivativeEstimator
from .inputs import (NON_FINITE_OUTPUT, SOLVER_ERROR, UNREACHABLE, WARMING_UP,
                     SetpointError, Vec3, check_acceleration, unfollowable)
from .node_config import NodeConfig
from .synchroniser import Setpoint

#: A log line due: (level, throttling key, message built only if not throttled).
LogLine = tuple[int, str, Callable[[], str]]


@dataclass(frozen=True)
class Runtime:
    """What a cycle needs from the parameters: swapped as one reference."""

    model: Model
    config: NodeConfig


def runtime_from_values(values: Mapping[str, Any], current: Runtime | None = None,
                        changed: Sequence[str] = ()) -> Runtime:
    """Validate every parameter (``values``: dotted names) and build the
    Runtime; with ``current``, the model is rebuilt only when one of the
    ``changed`` names is a model parameter. Raises ParameterError (or the
    solver's error for a geometry it cannot handle).
    """
    model = current.model if current is not None else None
    if model is None or any(name in MODEL_NAMES for name in changed):
        model = prm.model_from_values({k: values[k] for k in MODEL_NAMES}, require_all=True)
    return Runtime(model, NodeConfig.from_values({k: values[k] for k in NODE_NAMES}))


def rates_of(sp: Setpoint, config: NodeConfig, estimator: DerivativeEstimator,
             stats: CycleStats) -> tuple[Vec3, Vec3]:
    """The rates and accelerations of a setpoint: the given ones, else
    estimated (counted); raises SetpointError for an absurd estimated
    acceleration. The setpoint is not yet in the estimator's history: the
    caller commits it once it is answered (a rejected one leaves no trace).
    """
    twist, accel = sp.twist, sp.accel
    qd, qdd = estimator.estimate(sp.stamp_ns * 1e-9, sp.pose.q,
                               None if twist is None else twist.q,
                               None if accel is None else accel.q)
    if twist is None:
        stats.estimated_twist += 1
    if qdd is None:
        raise SetpointError(WARMING_UP, 'not answered: its acceleration would be estimated '
                                        'from a rate the node assumed (the first setpoint of '
                                        'a stream is taken at rest); the next ones are')
    if accel is None:
        stats.estimated_accel += 1
        check_acceleration(qdd, config.input_max_linear_acceleration,
                           config.input_max_angular_acceleration, 'estimated acceleration')
    return qd, qdd


def solve_setpoint(model: Model, q: Sequence[float], qd: Sequence[float],
                   qdd: Sequence[float]) -> Any:
    """Solve one setpoint. Raises SetpointError when there is nothing to
    publish: reason ``unreachable`` (the solver's status unreachable) or
    ``solver_error`` (invalid input, or any exception of the solver).
    """
    try:
        sol = fsd.solve(model, q, qd, qdd)
    except Exception as exc:  # noqa: BLE001 - a malformed call: never escape a callback
        raise SetpointError(SOLVER_ERROR, f'{type(exc).__name__}: {exc}') from None
    if sol.status is Status.UNREACHABLE:
        raise SetpointError(UNREACHABLE, f'unreachable pose: {sol.detail}')
    if sol.status is Status.INVALID_INPUT:
        raise SetpointError(SOLVER_ERROR, f'invalid input: {sol.detail}')
    return sol


def outputs_of(sol: Any) -> tuple[list[float], ...]:
    """(length, rate, force, joints, joint_rates) of a solution as plain
    floats (cheaper than numpy for 3 and 12 numbers); raises SetpointError
    (``non_finite_output``) if any is not finite: nothing non-finite is
    published.
    """
    length, rate, force = sol.length.tolist(), sol.rate.tolist(), sol.force.tolist()
    joints, joint_rates = sol.joints.tolist(), sol.joint_rates.tolist()
    # a sum is finite iff every term is (inf - inf is nan)
    if not math.isfinite(sum(length) + sum(rate) + sum(force) + sum(joints)
                         + sum(joint_rates)):
        raise SetpointError(NON_FINITE_OUTPUT, 'solver returned a non-finite value '
                                               '(not published)')
    return length, rate, force, joints, joint_rates


def assess(sol: Any, sp: Setpoint, runtime: Runtime, stats: CycleStats, seconds: float,
           rate: list[float], force: list[float]) -> list[LogLine]:
    """Record a published solution in ``stats`` (ignored components, near
    singularity, actuator limits, solve time ``seconds``); returns the log
    lines due (usually none).
    """
    config = runtime.config
    lines: list[LogLine] = []
    ignored = unfollowable(sp.pose, sp.twist, sp.accel, -sol.beta,
                           config.input_position_tolerance, config.input_angle_tolerance)
    if ignored:
        for component in ignored:
            stats.ignored[component] += 1
        stats.note(WARN, 'ignored ' + '/'.join(ignored))
        lines.append((WARN, 'ignored', lambda: 'motion the mechanism cannot follow, ignored: '
                      + ', '.join(ignored)))
    if sol.status is Status.NEAR_SINGULAR:
        stats.near_singular += 1
        stats.note(WARN, 'near singular')
        lines.append((WARN, 'near_singular', lambda: f'near singular: {sol.detail}'))
    limits = check_limits(sol.stroke.tolist(), rate, force, runtime.model.limits,
                          config.limits_warn_fraction)
    if limits.exceeded:
        stats.limit_exceeded += 1
        stats.note(ERROR, 'limit exceeded')
        lines.append((ERROR, 'limit', lambda: 'actuator limit exceeded (published anyway): '
                      + ', '.join(limits.exceeded)))
    elif limits.near:
        stats.near_limit += 1
        stats.note(WARN, 'near an actuator limit')
    stats.solved(seconds, sol.kinematic_condition, sol.jacobian_condition,
                 (force[0], force[1], force[2]))
    return lines
