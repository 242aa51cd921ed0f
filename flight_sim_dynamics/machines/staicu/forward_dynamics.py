"""Forward dynamics: the accelerations that given actuator forces produce.

The inverse dynamics (eq. 14-23) is affine in qdd (eq. 15-17: Gamma = Q^-1 S,
S affine in qdd), so f = M(q) qdd + b(q, qd), b = ``solve(q, qd, 0).force``
and M e_j = ``solve(q, qd, e_j).force - b``; forward dynamics solves
M qdd = f - b (LU). A scene without inertia (M = 0) is a ValueError. Statuses
follow :func:`.solver.solve`, with zero accelerations when not ok or limit
(an M too ill-conditioned,
:data:`flight_sim_dynamics.core.forward_dynamics.MAX_MASS_CONDITION`: near_singular).

>>> import flight_sim_dynamics as fsd
>>> model = fsd.load_model()
>>> rest = fsd.solve(model, [0, 0, 0], [0, 0, 0], [0, 0, 0]).force
>>> fd = fsd.forward_dynamics(model, [0, 0, 0], [0, 0, 0], rest)
>>> [round(float(a), 12) + 0.0 for a in fd.acceleration], str(fd.status)
([0.0, 0.0, 0.0], 'ok')
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np

from . import kernel
from ...core.forward_dynamics import solve_accelerations
from ...core.status import SEVERITY, Status
from .model import Model
from .solver import Solution, kernel_solution, solve, three_numbers

_REST = (0.0, 0.0, 0.0)
_UNIT = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))
_LEGS = 'ABC'


@dataclass(frozen=True)
class ForwardDynamics:
    """Result of :func:`forward_dynamics`. ``M`` and ``b`` are the affine terms
    of f = M qdd + b (zeros when the pose is unreachable or the input invalid).
    """

    acceleration: np.ndarray    # (surge, heave, roll) accelerations, m/s^2, m/s^2, rad/s^2
    status: Status              # ok, limit, near_singular, unreachable, invalid_input
    detail: str                 # why the status is not ok ('' when ok)
    M: np.ndarray               # (3, 3) dF/dqdd: N per m/s^2 (columns 0, 1), N per rad/s^2
    b: np.ndarray               # (3,) forces at zero acceleration, N


def require_inertia(model: Model) -> None:
    """ValueError unless the model's scene computes some inertia (M != 0)."""
    if not model.effects.any_inertia:
        raise ValueError(f"scene '{model.scene}' computes no inertia (enabled effects: "
                         f"{', '.join(model.effects.enabled()) or 'none'}), so forces do not "
                         'determine accelerations; forward dynamics and simulation need a scene '
                         'with inertia, e.g. full')


def affine_terms(model: Model, q: Sequence[float], qd: Sequence[float]
                 ) -> tuple[np.ndarray, np.ndarray, Solution]:
    """M (3, 3) and b (3,) of f = M qdd + b at (q, qd) (eq. 14, 18-23) and the
    solve at zero acceleration (M, b zeros when it is void). The kernel forms
    M by virtual power, M = J^-T sum m a_i . a_j + w_i . I w_j (eq. 23); the
    reference takes four solves.
    """
    if kernel.enabled():
        q3, qd3 = three_numbers('q', q), three_numbers('qd', qd)
        out, M, b, scalars = kernel.affine_row(model, q3, qd3)
        return M, b, kernel_solution(model, out, scalars, (q3, qd3, _REST))
    base = solve(model, q, qd, _REST)
    if SEVERITY[base.status] >= 3:
        return np.zeros((3, 3)), np.zeros(3), base
    b = base.force.copy()
    M = np.empty((3, 3))
    for j, unit in enumerate(_UNIT):
        M[:, j] = solve(model, q, qd, unit).force
    M -= b[:, None]
    return M, b, base


def forward_dynamics(model: Model, q: Sequence[float], qd: Sequence[float],
                     force: Sequence[float]) -> ForwardDynamics:
    """Accelerations (surge, heave, roll) that actuator forces ``force`` (N, A,
    B, C) produce at ``q``, ``qd`` (eq. 14, 18-23): ``solve(model, q, qd,
    acceleration).force == force``. ValueError only for arguments that are not
    three numbers and for a scene without inertia.
    """
    require_inertia(model)
    f = np.array(three_numbers('force', force))
    M, b, base = affine_terms(model, q, qd)     # validates q, qd (ValueError)
    zero = np.zeros(3)
    if SEVERITY[base.status] >= 3:
        return ForwardDynamics(zero, base.status, base.detail, M, b)
    bad = [i for i in range(3) if not math.isfinite(f[i])]
    if bad:
        return ForwardDynamics(zero, Status.INVALID_INPUT,
                               f'force[{bad[0]}] (leg {_LEGS[bad[0]]}) is not finite '
                               f'({f[bad[0]]})', M, b)
    if base.status == Status.NEAR_SINGULAR:     # solve's numbers there are finite
        return ForwardDynamics(zero, Status.NEAR_SINGULAR, base.detail, M, b)
    qdd, status, detail = solve_accelerations(M, b, f)
    if status != Status.OK:
        return ForwardDynamics(zero, status, detail, M, b)
    check = solve(model, q, qd, qdd)    # the status of the motion, as solve reports it
    if SEVERITY[check.status] >= 2:
        return ForwardDynamics(zero, check.status, check.detail, M, b)
    return ForwardDynamics(qdd, check.status, check.detail, M, b)
