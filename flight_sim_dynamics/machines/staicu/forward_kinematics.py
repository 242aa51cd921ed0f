"""Forward kinematics: the pose (surge, heave, roll) from three leg lengths, L(q) =
L* by a safeguarded Newton iteration on J = dL/dq (eq. 5-8, 11-12): damped near a
singular J, a line search that keeps poses reachable (eq. 7); ok at the tolerance,
unreachable when J^T r ~ 0, else not_converged after ``max_iterations``.
"""
from __future__ import annotations

from typing import Sequence

import numpy as np

from ...core.forward import ForwardSolution, OffWorkspace, safeguarded_newton
from ...core.machine import check_forward_options, quiet_floating_point
from ...core.status import Status
from ...core.vectors import backend
from . import kernel
from .dynamics import actuator_jacobian
from .kinematics import (LOOP_REASONS, LOOPS, UnreachablePoseError, factorize, inverse_geometry,
                         pose_rate_columns, solve_connectivity)
from .model import Model
from .solver import three_numbers

_XP = backend(False)
_REST = (0.0, 0.0, 0.0)


def _lengths_and_jacobian(model: Model, q: tuple[float, float, float]
                          ) -> tuple[np.ndarray, np.ndarray]:
    """L(q) and J_L at ``q`` (eq. 5-8, 11-12); UnreachablePoseError where a loop
    cannot close. The solver's kernel when it is enabled: a solve at rest takes
    8 us, the Python terms alone 57 us (an unreachable pose: 22 us), and the
    search on unreachable lengths makes about 20,000 of them.
    """
    if kernel.enabled():
        out, (code, info, *_) = kernel.solve_row(model, tuple(map(float, q)), _REST, _REST)
        status = kernel.STATUS_BY_CODE[code]
        if status is Status.UNREACHABLE:
            loop = LOOPS[int(info)]
            raise UnreachablePoseError(loop, LOOP_REASONS[loop])
        if status is Status.INVALID_INPUT:      # a trial that is not finite: worse than any
            return np.full(3, np.nan), np.full((3, 3), np.nan)
        return out[kernel.OUT['length']], out[kernel.OUT['jacobian']].reshape(3, 3)
    g = inverse_geometry(model, q, _XP)
    f = factorize(model, g)
    K = tuple(solve_connectivity(g, f, P) for P in pose_rate_columns(g))
    return np.array(g.length, dtype=float), np.array(actuator_jacobian(K), dtype=float)


@quiet_floating_point
def forward_kinematics(model: Model, lengths: Sequence[float],
                       initial: Sequence[float] = (0.0, 0.0, 0.0), *,
                       tolerance: float = 1e-12, max_iterations: int = 50) -> ForwardSolution:
    """Pose (surge, heave, roll) whose leg lengths (m, A, B, C) are ``lengths``,
    by Newton's method from ``initial``; if that fails, by continuation in the
    lengths (20, then 200 steps: the assembly mode of ``initial``), then from
    seed poses, keeping the working mode (the sign of det dL/dq at the centre).
    Never raises for bad numbers (the status says); ValueError for an argument
    that is not three numbers (:func:`.solver.three_numbers`) and for bad options
    (:func:`~flight_sim_dynamics.core.machine.check_forward_options`).
    """
    check_forward_options(tolerance, max_iterations)
    arrays = []
    for name, value in (('lengths', lengths), ('initial', initial)):
        arr = np.array(three_numbers(name, value))
        if not np.all(np.isfinite(arr)):
            return _invalid(f'{name} must be finite, got {arr.tolist()}')
        arrays.append(arr)
    target, start = arrays
    if np.any(target <= 0.0):
        return _invalid(f'leg lengths must be positive, got {target.tolist()}')
    try:
        L0, _ = _lengths_and_jacobian(model, tuple(start))
    except UnreachablePoseError as exc:
        return _invalid(f'initial pose is unreachable: {exc}')
    result = _newton(model, target, start, tolerance, max_iterations)
    if result.status == Status.OK:
        return result
    iterations = result.iterations
    for steps in (20, 200):
        q = start
        for k in range(1, steps + 1):
            step = _newton(model, L0 + (target - L0) * (k / steps), q,
                           tolerance if k == steps else 1e-10, max_iterations)
            iterations += step.iterations
            if step.status != Status.OK:
                break
            q = step.pose
        else:
            return ForwardSolution(q, Status.OK, step.residual, iterations)
    # last resort: seed poses, working mode only, the one nearest to ``initial`` first
    mode = np.sign(np.linalg.det(_lengths_and_jacobian(model, (0.0, 0.0, 0.0))[1]))
    for seed in sorted(_SEEDS, key=lambda p: float(np.sum((np.array(p) - start) ** 2))):
        try:
            _lengths_and_jacobian(model, seed)
        except UnreachablePoseError:
            continue
        trial = _newton(model, target, np.array(seed), tolerance, max_iterations)
        iterations += trial.iterations
        if trial.status == Status.OK and np.sign(
                np.linalg.det(_lengths_and_jacobian(model, tuple(trial.pose))[1])) == mode:
            return ForwardSolution(trial.pose, Status.OK, trial.residual, iterations)
    return ForwardSolution(result.pose, result.status, result.residual, iterations,
                           result.detail)


#: Seed poses of the last-resort search (surge m, heave m, roll rad).
_SEEDS = tuple((x, y, r) for x in (-0.3, -0.1, 0.1, 0.2) for y in (-0.25, 0.0, 0.3, 0.7)
               for r in (-0.9, -0.4, 0.0, 0.4, 0.9))


def _invalid(detail: str) -> ForwardSolution:
    return ForwardSolution(np.zeros(3), Status.INVALID_INPUT, 0.0, 0, detail)


def _newton(model: Model, target: np.ndarray, start: np.ndarray, tolerance: float,
            max_iterations: int) -> ForwardSolution:
    """:func:`~flight_sim_dynamics.core.forward.safeguarded_newton` of L(q) = target
    from ``start`` (reachable).
    """
    def lengths_at(q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        try:
            return _lengths_and_jacobian(model, tuple(q))
        except UnreachablePoseError as exc:
            raise OffWorkspace(f'loop {exc.loop}: {exc.reason}') from None
    return safeguarded_newton(lengths_at, target, start, tolerance, max_iterations)
