"""The hexapod's limit usages (:class:`~flight_sim_dynamics.core.machine.LimitUsage`):
how much of its length, speed and force limits each leg uses, and of its U-
and spherical joint angle limits where the model sets them. :func:`usages` is
the status ``limit``'s rule (a usage above 1; :mod:`.solver` reads it,
``kernel.c`` transcribes it).
"""
from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np

from ...core.machine import LimitUsage, narrowed_limits, stroke_usage
from ...core.vectors import backend
from .model import LEG_NAMES, Limits, StewartModel

#: Leg labels of the usages' names, in the order of the legs.
LABELS = tuple(str(i) for i in range(1, len(LEG_NAMES) + 1))
_FLOATS = backend(False)


def kinds(limits: Limits) -> tuple[str, ...]:
    """The limits of each leg, in the order of a leg's usages: stroke (its
    length's), speed, force, then ``u_joint`` and ``spherical`` where set.
    """
    return (('stroke', 'speed', 'force')
            + (('u_joint',) if limits.u_joint_max_angle is not None else ())
            + (('spherical',) if limits.spherical_joint_max_angle is not None else ()))


def names(limits: Limits) -> tuple[str, ...]:
    """The usages' names, leg by leg (``stroke 1``, ``speed 1``, ... ``stroke 2`` ...)."""
    key = kinds(limits)
    found = _NAMES.get(key)
    if found is None:       # made once per set of kinds (4 at most): the node asks every cycle
        found = _NAMES[key] = tuple(f'{kind} {leg}' for leg in LABELS for kind in key)
    return found


_NAMES: dict[tuple[str, ...], tuple[str, ...]] = {}


def usages(limits: Limits, length: np.ndarray, rate: np.ndarray, force: np.ndarray,
           joints: Any = None, spherical_angles: Any = None) -> np.ndarray:
    """The usages in the order of :func:`names`, (..., 6 x kinds) of the legs'
    lengths, rates and forces (..., 6), joint variables (..., 6, 3) and
    spherical joint angles (..., 6); the angles are read only where their
    limit is set (a kernel's batch computes them on first read).
    """
    columns = [stroke_usage(length, limits.length_min, limits.length_max),
               np.abs(rate) / limits.max_speed, np.abs(force) / limits.max_force]
    if limits.u_joint_max_angle is not None:    # the larger of theta_1, theta_2
        columns.append(np.abs(np.asarray(joints)[..., :2]).max(axis=-1)
                       / limits.u_joint_max_angle)
    if limits.spherical_joint_max_angle is not None:
        columns.append(np.asarray(spherical_angles) / limits.spherical_joint_max_angle)
    stacked = np.stack(np.broadcast_arrays(*columns), axis=-1)      # (..., 6, kinds)
    # legs times kinds spelled out: -1 cannot be inferred for an empty batch
    return stacked.reshape(stacked.shape[:-2] + (stacked.shape[-2] * stacked.shape[-1],))


def limit_usage(model: StewartModel, solution: Any) -> LimitUsage:
    """The :class:`LimitUsage` of a solution of :func:`.solver.solve` or
    :func:`.solver.solve_batch` ((N, ...)).
    """
    lim = model.limits
    if np.ndim(solution.force) == 1:    # one sample (the node's every cycle): floats, faster
        try:
            return LimitUsage(names(lim), np.array(_sample_usages(lim, solution)))
        except ArithmeticError:     # a length range too narrow for floats: numpy's IEEE
            pass
    with np.errstate(all='ignore'):
        values = usages(lim, np.asarray(solution.length), np.asarray(solution.rate),
                        np.asarray(solution.force),
                        solution.joints if lim.u_joint_max_angle is not None else None,
                        solution.spherical_angles
                        if lim.spherical_joint_max_angle is not None else None)
    return LimitUsage(names(lim), values)


def _sample_usages(lim: Limits, solution: Any) -> list[float]:
    """:func:`usages` of one sample on plain floats (the same IEEE operations)."""
    u_max, ball_max = lim.u_joint_max_angle, lim.spherical_joint_max_angle
    joints = solution.joints.tolist() if u_max is not None else None
    ball = solution.spherical_angles.tolist() if ball_max is not None else None
    out: list[float] = []
    for k, (L, Ld, f) in enumerate(zip(solution.length.tolist(), solution.rate.tolist(),
                                       solution.force.tolist())):
        out += [stroke_usage(L, lim.length_min, lim.length_max, _FLOATS),
                abs(Ld) / lim.max_speed, abs(f) / lim.max_force]
        if joints is not None:
            # NaN-propagating like numpy's max (a solution's joints are never NaN)
            out.append(_FLOATS.maximum(abs(joints[k][0]), abs(joints[k][1])) / u_max)
        if ball is not None:
            out.append(ball[k] / ball_max)
    return out


def tightened(model: StewartModel, stroke: float, fraction: float) -> StewartModel:
    """``model`` within margins of its limits (:func:`~flight_sim_dynamics.core.
    machine.narrowed_limits`): leg lengths ``stroke`` m inside each end, speed,
    force, the Jacobian's condition and the joint angles (where set) times
    ``1 - fraction``.
    """
    return replace(model, limits=narrowed_limits(
        model.limits, ('length_min', 'length_max'),
        ('max_speed', 'max_force', 'max_jacobian_condition', 'u_joint_max_angle',
         'spherical_joint_max_angle'), stroke, fraction))
