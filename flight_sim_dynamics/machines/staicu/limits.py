"""The 3-DOF machine's limit usages: how much of its stroke, speed and force
limits each leg uses (:class:`~flight_sim_dynamics.core.machine.LimitUsage`).
:func:`leg_usages` is the status ``limit``'s rule (a usage above 1), written
once for floats and arrays alike (:func:`.status_rule.sample_status` reads it;
``kernel.c`` transcribes it).
"""
from __future__ import annotations

from dataclasses import replace
from typing import Any, Sequence

import numpy as np

from ...core.machine import LimitUsage, narrowed_limits, stroke_usage
from ...core.vectors import Scalar, backend
from .model import Limits, Model

#: Leg labels of the usages' names, in the order of the legs.
LABELS = ('A', 'B', 'C')
#: The limits of each leg, in the order of a leg's usages.
KINDS = ('stroke', 'speed', 'force')
#: The usages' names, leg by leg (``stroke A``, ``speed A``, ``force A``, ``stroke B`` ...).
NAMES = tuple(f'{kind} {leg}' for leg in LABELS for kind in KINDS)

_FLOATS, _ARRAY = backend(False), backend(True)


def leg_usages(limits: Limits, xp: Any, stroke: Sequence[Scalar], rate: Sequence[Scalar],
               force: Sequence[Scalar]) -> list[Scalar]:
    """The usages in the order of :data:`NAMES`, floats or arrays (``xp``:
    :func:`flight_sim_dynamics.core.vectors.backend`) of the legs' strokes,
    rates and forces.
    """
    out: list[Scalar] = []
    for s, r, f in zip(stroke, rate, force):
        out += [stroke_usage(s, limits.stroke_min, limits.stroke_max, xp),
                xp.abs(r) / limits.max_speed, xp.abs(f) / limits.max_force]
    return out


def limit_usage(model: Model, solution: Any) -> LimitUsage:
    """The :class:`LimitUsage` of a solution of :func:`.solver.solve` (9 usages)
    or :func:`.solver.solve_batch` ((N, 9)).
    """
    stroke, rate, force = solution.stroke, solution.rate, solution.force
    if np.ndim(force) == 1:     # one sample (the node's every cycle): plain floats, 5x faster
        try:
            return LimitUsage(NAMES, np.array(leg_usages(
                model.limits, _FLOATS, stroke.tolist(), rate.tolist(), force.tolist())))
        except ArithmeticError:     # a stroke range too narrow for floats: numpy's IEEE
            pass
    # legs on the first axis, samples (if any) after: one column per usage
    stroke, rate, force = (np.asarray(v).T for v in (stroke, rate, force))
    with np.errstate(all='ignore'):
        columns = leg_usages(model.limits, _ARRAY, stroke, rate, force)
    return LimitUsage(NAMES, np.stack(columns, axis=-1))


def tightened(model: Model, stroke: float, fraction: float) -> Model:
    """``model`` within margins of its limits (:func:`~flight_sim_dynamics.core.
    machine.narrowed_limits`): strokes ``stroke`` m inside each end, speed,
    force and both conditions times ``1 - fraction``.
    """
    return replace(model, limits=narrowed_limits(
        model.limits, ('stroke_min', 'stroke_max'),
        ('max_speed', 'max_force', 'max_kinematic_condition', 'max_jacobian_condition'),
        stroke, fraction))
