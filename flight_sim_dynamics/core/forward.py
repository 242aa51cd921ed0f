"""Forward kinematics for every machine: the pose of given leg lengths by a
safeguarded Newton iteration on L(q) = L*, one stopping rule for all
(:func:`safeguarded_newton`; each machine gives its L(q) and J_L = dL/dq).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from .status import Status

#: the smallest fraction of a Newton step the line search tries
MIN_STEP = 1e-10


@dataclass(frozen=True)
class ForwardSolution:
    """Result of a machine's ``forward_kinematics``."""

    pose: np.ndarray     # the machine's coordinates; zeros unless status is ok
    status: Status       # ok, unreachable, not_converged or invalid_input
    residual: float      # max |L(pose) - L*| at the end, m
    iterations: int
    detail: str = ''


class OffWorkspace(Exception):
    """A trial pose that has no leg lengths: ``outside`` the workspace (a loop
    cannot close), or degenerate (a leg of zero length, a singular joint);
    ``reason`` says which.
    """

    def __init__(self, reason: str, outside: bool = True) -> None:
        super().__init__(reason)
        self.reason, self.outside = reason, outside


def safeguarded_newton(lengths_and_jacobian: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]],
                       target: np.ndarray, start: np.ndarray, tolerance: float,
                       max_iterations: int) -> ForwardSolution:
    """Newton's method on L(q) = ``target`` from ``start`` (a pose that has
    lengths): each step (least squares, J_L's tiny singular values cut) halved
    down to :data:`MIN_STEP` until max |L - L*| decreases at a pose that has
    lengths. ok when max |L - L*| <= ``tolerance``; unreachable when every
    shorter step leaves the workspace, or the iteration stalls at a minimum of
    |L - L*| > 0 (J_L^T r ~ 0 against |J_L| |r|: no pose nearby has these
    lengths); not_converged otherwise (stalled at a degenerate or singular
    pose, or out of iterations). ``lengths_and_jacobian(q) -> (L, J_L)`` raises
    :class:`OffWorkspace` for a pose without lengths; for ``start`` itself the
    error reaches the caller.
    """
    q = np.array(start, dtype=float)
    zero = np.zeros_like(q)
    L, J = lengths_and_jacobian(q)
    r = L - target
    norm = float(np.max(np.abs(r)))
    for iteration in range(1, max_iterations + 1):
        if norm <= tolerance:
            return ForwardSolution(q, Status.OK, norm, iteration - 1)
        with np.errstate(all='ignore'):
            step = np.linalg.lstsq(J, -r, rcond=1e-12)[0]
        alpha, blocked = 1.0, None
        while alpha >= MIN_STEP:
            trial = q + alpha * step
            try:
                L_t, J_t = lengths_and_jacobian(trial)
            except OffWorkspace as exc:
                blocked, alpha = exc, 0.5 * alpha
                continue
            r_t = L_t - target
            norm_t = float(np.max(np.abs(r_t)))
            if norm_t < norm:               # False for NaN: halved like a worse one
                q, r, J, norm = trial, r_t, J_t, norm_t
                break
            alpha *= 0.5
        else:
            if blocked is not None and blocked.outside:
                return ForwardSolution(zero, Status.UNREACHABLE, norm, iteration,
                                       'these leg lengths lie outside the workspace: '
                                       f'{blocked.reason} (closest miss {norm:.3g} m)')
            gradient = float(np.linalg.norm(J.T @ r))
            if gradient <= 1e-8 * float(np.linalg.norm(J, 2)) * float(np.linalg.norm(r)):
                return ForwardSolution(zero, Status.UNREACHABLE, norm, iteration,
                                       'no reachable pose nearby has these leg lengths '
                                       f'(closest miss {norm:.3g} m)')
            return ForwardSolution(zero, Status.NOT_CONVERGED, norm, iteration,
                                   'the line search stalled (a workspace boundary, or a '
                                   'singular or degenerate pose)')
    if norm <= tolerance:
        return ForwardSolution(q, Status.OK, norm, max_iterations)
    return ForwardSolution(zero, Status.NOT_CONVERGED, norm, max_iterations,
                           f'residual {norm:.3g} m after {max_iterations} iterations')
