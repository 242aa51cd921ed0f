"""Forward dynamics: the accelerations that given actuator forces produce.

The inverse dynamics of the paper (eq. 14-23) is affine in the accelerations:
the recursion eq. (18)-(22) propagates the body accelerations, which are
linear in qdd (eq. 15-17: Gamma = Q^-1 S, S affine in qdd), to the joint
forces, and eq. (14) and (23) map those to the actuator forces linearly. So
for a pose q and rates qd

    f = M(q, qd) qdd + b(q, qd)

with b the forces of the same motion without acceleration,
``solve(q, qd, 0).force``, and column j of M the extra force of a unit
acceleration of coordinate j, ``solve(q, qd, e_j).force - b``. (M depends on
q only; b holds gravity, the velocity products and friction, each when the
scene simulates it.) Forward dynamics solves M qdd = f - b (an LU solve,
never an inverse). A scene without inertia (``quasi_static``) has M = 0 and
cannot be simulated: :class:`ValueError` naming the scene.

Statuses follow :func:`.solver.solve` (:mod:`.status`): invalid input
(non-finite q, qd or force) gives ``invalid_input``, a pose that cannot be
assembled ``unreachable``, a pose past the model's near-singularity
thresholds or an M too ill-conditioned to solve (:data:`MAX_MASS_CONDITION`)
``near_singular``; all with zero accelerations. Otherwise the status and
detail are those of ``solve(q, qd, acceleration)`` (``limit`` when a stroke,
speed or force limit is exceeded). No NaN or infinity ever.

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
from .model import Model
from .solver import Solution, kernel_solution, solve, three_numbers
from .status import SEVERITY, Status

#: Largest 2-norm condition number of M (N per m/s^2 and N per rad/s^2) that
#: forward dynamics solves: rounding errors of the solve grow like
#: eps x condition, so beyond 1e8 the accelerations would not reproduce the
#: forces to 1e-8. Within the packaged limits (Jacobian condition <= 100) M's
#: condition stays below about 1e4.
MAX_MASS_CONDITION = 1e8

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
    """M (3, 3) and b (3,) of f = M qdd + b at (q, qd) (eq. 14, 18-23), and the
    solve at zero acceleration (lengths, rates, status of the state); when
    that solve's status is unreachable or invalid_input, M and b are zeros
    (check the status first).

    With the compiled kernel (:mod:`.kernel`), one call: the pose's geometry
    and Jacobians once, b = the force of the solve at qdd = 0, and M from the
    bodies' accelerations for the unit accelerations e_j alone (no gravity,
    velocity products, friction: the terms of b; friction reads the leg
    rates, not qdd, so f stays affine in qdd with it), which are their
    velocities per unit qd_j: M = J^-T sum m a_i . a_j + w_i . I w_j by virtual
    power (eq. 23). Otherwise, the reference: four solves, b = solve(q, qd,
    0).force and M e_j = solve(q, qd, e_j).force - b. The two agree to
    rounding (test_twin_kernel.py).
    """
    if kernel._enabled:
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


def solve_accelerations(M: np.ndarray, b: np.ndarray, force: np.ndarray
                        ) -> tuple[np.ndarray, Status, str]:
    """Qdd with M qdd = force - b (LU, never an inverse), with status ok; or
    zeros with near_singular when M is too ill-conditioned to solve
    (:data:`MAX_MASS_CONDITION`), invalid_input when the result is not finite
    (forces too large).
    """
    if not np.all(np.isfinite(M)):
        return np.zeros(3), Status.NEAR_SINGULAR, 'exact singularity: M is not finite'
    sigma = np.linalg.svd(M, compute_uv=False)
    if not (sigma[-1] > 0.0 and sigma[0] <= sigma[-1] * MAX_MASS_CONDITION):
        condition = sigma[0] / sigma[-1] if sigma[-1] > 0 else math.inf
        return np.zeros(3), Status.NEAR_SINGULAR, (
            f'condition of M {condition:.3g} > {MAX_MASS_CONDITION:g}: '
            'accelerations cannot be resolved')
    qdd = np.linalg.solve(M, force - b)
    if not np.all(np.isfinite(qdd)):
        return np.zeros(3), Status.INVALID_INPUT, 'results are not finite: input too large'
    return qdd, Status.OK, ''


def _force_vector(force: Sequence[float]) -> np.ndarray:
    """Three real numbers, or ValueError naming the argument (as solve's q)."""
    try:
        arr = np.asarray(force, dtype=float)
    except (TypeError, ValueError):
        arr = None
    if arr is None or arr.shape != (3,) or isinstance(force, (str, bytes)):
        raise ValueError(f'force must be 3 numbers (legs A, B, C, N), got {force!r:.200}')
    return arr


def forward_dynamics(model: Model, q: Sequence[float], qd: Sequence[float],
                     force: Sequence[float]) -> ForwardDynamics:
    """Accelerations (surge, heave, roll) produced by actuator forces ``force``
    (legs A, B, C, N; + extends) at pose ``q`` and rates ``qd``, within the
    model's scene: qdd solving M qdd = force - b, M and b from the recursive
    solver (eq. 14, 18-23; see the module's docstring).

    ``solve(model, q, qd, result.acceleration).force == force`` (to rounding).
    Never raises for a bad pose or bad numbers (``status`` and ``detail`` say
    what happened); raises ValueError for arguments that are not three numbers
    and for a scene without inertia.
    """
    require_inertia(model)
    f = _force_vector(force)
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
