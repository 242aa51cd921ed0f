"""Forward dynamics of the hexapod: the pose accelerations that given actuator
forces produce.

The inverse dynamics (S14)-(S21) is affine in qdd (S10)-(S13), so
f = M(q) qdd + b(q, qd): b is the solve at qdd = 0, M's column j the solve at
qdd = e_j minus b, all seven in one batch. Forward dynamics solves
M qdd = f - b. ``mass_matrix`` = J_L^T M (S22) is the symmetric mass matrix
of Lagrange's equations in pose coordinates (T = qd^T mass_matrix qd / 2).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...core.status import SEVERITY, Status
from .dynamics import has_inertia
from .kinematics import six_numbers
from .model import StewartModel
from .solver import StewartSolution, sample, solve_batch

#: Largest condition number of M solved: beyond it, qdd would not reproduce f to 1e-8.
MAX_MASS_CONDITION = 1e8


@dataclass(frozen=True)
class AffineTerms:
    """f = M qdd + b at (q, qd) (zeros where the solve is void)."""

    M: np.ndarray            # (6, 6) df/dqdd, N per m/s^2 (columns 0-2), N per rad/s^2
    b: np.ndarray            # (6,) forces at qdd = 0, N
    mass_matrix: np.ndarray  # (6, 6) J_L^T M: symmetric, positive definite (S22)
    solution: StewartSolution  # the solve at qdd = 0


def affine_terms(model: StewartModel, q, qd) -> AffineTerms:
    """M, b of f = M qdd + b at (q, qd) by seven solves in one batch."""
    q6, qd6 = six_numbers('q', q), six_numbers('qd', qd)
    qdd = np.vstack([np.zeros(6), np.eye(6)])
    sol = solve_batch(model, np.tile(q6, (7, 1)), np.tile(qd6, (7, 1)), qdd)
    b = sol.force[0]
    M = (sol.force[1:] - b).T
    mass = sol.jacobian[0].T @ M
    return AffineTerms(M, b, mass, sample(sol, 0))


@dataclass(frozen=True)
class ForwardDynamics:
    """Result of :func:`forward_dynamics`."""

    acceleration: np.ndarray  # (6,) qdd; zeros unless ok or limit
    status: Status
    detail: str
    M: np.ndarray
    b: np.ndarray


def forward_dynamics(model: StewartModel, q, qd, force) -> ForwardDynamics:
    """Pose accelerations qdd that actuator forces ``force`` (N, legs 1-6)
    produce at (q, qd): ``solve(model, q, qd, qdd).force == force``. Statuses
    as :func:`.solver.solve`; near_singular also when M is too ill-conditioned
    (pitch at +-90 deg: the Euler rates cannot carry the motion). ValueError
    for arguments that are not six numbers and for a scene without inertia.
    """
    if not has_inertia(model):
        raise ValueError(f"scene '{model.scene}' computes no inertia, so forces do not "
                         'determine accelerations; forward dynamics needs a scene with inertia')
    f = six_numbers('force', force)
    terms = affine_terms(model, q, qd)
    base = terms.solution
    zero = np.zeros(6)
    status, detail = base.status, base.detail
    if SEVERITY[status] >= SEVERITY[Status.UNREACHABLE]:
        return ForwardDynamics(zero, status, detail, terms.M, terms.b)
    bad = np.flatnonzero(~np.isfinite(f))
    if bad.size:
        return ForwardDynamics(zero, Status.INVALID_INPUT,
                               f'force[{bad[0]}] (leg {bad[0] + 1}) is not finite ({f[bad[0]]})',
                               terms.M, terms.b)
    if status is Status.NEAR_SINGULAR:
        return ForwardDynamics(zero, status, detail, terms.M, terms.b)
    sigma = np.linalg.svd(terms.M, compute_uv=False)
    if not (sigma[-1] > 0.0 and sigma[0] <= sigma[-1] * MAX_MASS_CONDITION):
        return ForwardDynamics(zero, Status.NEAR_SINGULAR,
                               'M is too ill-conditioned: accelerations cannot be resolved',
                               terms.M, terms.b)
    qdd = np.linalg.solve(terms.M, f - terms.b)
    if not np.all(np.isfinite(qdd)):
        return ForwardDynamics(zero, Status.INVALID_INPUT,
                               'results are not finite: input too large', terms.M, terms.b)
    check = solve_batch(model, six_numbers('q', q)[None, :], six_numbers('qd', qd)[None, :],
                        qdd[None, :])
    status = check.status[0]
    if SEVERITY[status] >= SEVERITY[Status.NEAR_SINGULAR]:
        return ForwardDynamics(zero, status, check.detail[0], terms.M, terms.b)
    return ForwardDynamics(qdd, status, check.detail[0], terms.M, terms.b)
