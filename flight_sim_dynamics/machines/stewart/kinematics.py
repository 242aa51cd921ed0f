"""Inverse kinematics of the hexapod, leg by leg: positions, rates and
accelerations of the platform, the legs and their joints (docs/design/
stewart.md, (S1)-(S14), (S21)-(S22)), and forward kinematics by Newton's method.

Every function works on a batch: poses ``q`` (N, 6), per-leg vectors
(N, 6, 3) (sample, leg, xyz). Nothing here raises for a degenerate pose:
numpy carries IEEE values and the solver's status rule judges them.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np

from ...core.euler import euler_rate_matrix, euler_rate_matrix_derivative, rotation
from ...core.forward import ForwardSolution, OffWorkspace, safeguarded_newton
from ...core.machine import check_forward_options, quiet_floating_point
from ...core.status import SINGULAR, Status
from .model import MIN_LENGTH, U_JOINT_TOLERANCE, StewartModel


def dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise dot product over the last axis."""
    return np.einsum('...k,...k->...', a, b)


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise cross product over the last axis (broadcast)."""
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    return np.stack([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0], axis=-1)


# ---------------------------------------------------------------------------
# The platform (S1)-(S3); R, E and dE/dt are core/euler.py's batch forms
# ---------------------------------------------------------------------------

@dataclass(frozen=True)
class PlatformMotion:
    """The platform's pose and motion in the base frame (S1)-(S3)."""

    p: np.ndarray       # (N, 3) origin
    R: np.ndarray       # (N, 3, 3) orientation
    E: np.ndarray       # (N, 3, 3) Euler-rate matrix
    v: np.ndarray       # (N, 3) velocity of the origin
    omega: np.ndarray   # (N, 3) angular velocity
    a: np.ndarray       # (N, 3) acceleration of the origin
    eps: np.ndarray     # (N, 3) angular acceleration


def platform_motion(model: StewartModel, q: np.ndarray, qd: np.ndarray,
                    qdd: np.ndarray) -> PlatformMotion:
    """p, R (S1); omega = E rates (S2); eps = E rates' + dE/dt rates (S3)."""
    E = euler_rate_matrix(q)
    omega = np.einsum('nij,nj->ni', E, qd[:, 3:])
    eps = (np.einsum('nij,nj->ni', E, qdd[:, 3:])
           + np.einsum('nij,nj->ni', euler_rate_matrix_derivative(q, qd), qd[:, 3:]))
    return PlatformMotion(p=model.home + q[:, :3], R=rotation(q), E=E, v=qd[:, :3],
                          omega=omega, a=qdd[:, :3], eps=eps)


# ---------------------------------------------------------------------------
# Leg i: position (S4)-(S5)
# ---------------------------------------------------------------------------

@dataclass(frozen=True)
class LegPositions:
    """Leg vectors and U-joint angles (S4)-(S5); per leg (N, 6[, 3])."""

    r: np.ndarray        # R p_i, platform joint from the platform origin
    P: np.ndarray        # platform joints P_i
    L: np.ndarray        # lengths |P_i - B_i|
    u: np.ndarray        # unit leg vectors
    s2: np.ndarray       # sin theta_2 = a_1,i . u_i
    c2: np.ndarray       # cos theta_2 = |a_1,i x u_i|
    a1xu: np.ndarray     # a_1,i x u_i (norm c2)
    theta1: np.ndarray   # U-joint angle about a_1,i
    theta2: np.ndarray   # U-joint angle about a_2,i


def leg_positions(model: StewartModel, p: np.ndarray, R: np.ndarray) -> LegPositions:
    """r_i = R p_i, P_i = p + r_i, d_i = P_i - B_i, L_i = |d_i|, u_i = d_i / L_i (S4);
    theta_2 = asin(a_1 . u) (as atan2(s2, c2), exact near +-90 deg),
    theta_1 = atan2(-e2 . u, e3 . u) (S5).
    """
    r = np.einsum('nij,kj->nki', R, model.platform_joints)
    P = p[:, None, :] + r
    d = P - model.base_joints
    L = np.sqrt(dot(d, d))
    u = d / L[..., None]
    a1 = model.base_axes
    s2 = dot(u, a1)
    a1xu = cross(a1, u)
    c2 = np.sqrt(dot(a1xu, a1xu))
    local = np.einsum('kji,nkj->nki', model.leg_frames, u)    # C_i^T u_i
    return LegPositions(r=r, P=P, L=L, u=u, s2=s2, c2=c2, a1xu=a1xu,
                        theta1=np.arctan2(-local[..., 1], local[..., 2]),
                        theta2=np.arctan2(s2, c2))


def leg_lengths(model: StewartModel, q: np.ndarray) -> np.ndarray:
    """L_i(q) (S1), (S4), (N, 6)."""
    q = np.atleast_2d(q)
    return leg_positions(model, model.home + q[:, :3], rotation(q)).L


def spherical_joint_angles(R: np.ndarray, u: np.ndarray) -> np.ndarray:
    """Angle of each leg u_i from the platform's z axis R z (the spherical
    joint's tilt, for its optional limit), (N, 6).
    """
    return np.arccos(np.clip(dot(u, R[:, None, :, 2]), -1.0, 1.0))


def degenerate_legs(legs: LegPositions) -> np.ndarray:
    """(N, 6) True where a leg cannot be solved: length ~0 (S4) or its U-joint
    singular, u_i along a_1,i (S5), or not finite ("Singular cases").
    """
    ok = (legs.L > MIN_LENGTH) & (legs.c2 >= U_JOINT_TOLERANCE)
    return ~ok


# ---------------------------------------------------------------------------
# Leg i: velocities (S6)-(S9) and accelerations (S10)-(S13)
# ---------------------------------------------------------------------------

@dataclass(frozen=True)
class LegVelocities:
    """Rates along each leg (S6)-(S9)."""

    vP: np.ndarray       # velocity of P_i (N, 6, 3)
    Ld: np.ndarray       # dL/dt (N, 6)
    ud: np.ndarray       # du/dt (N, 6, 3)
    theta1d: np.ndarray  # (N, 6)
    theta2d: np.ndarray  # (N, 6)
    sigma: np.ndarray    # spin about u_i imposed by the U-joint (N, 6)
    omega: np.ndarray    # angular velocity of the leg (N, 6, 3)


def leg_velocities(model: StewartModel, legs: LegPositions,
                   platform: PlatformMotion) -> LegVelocities:
    """v_P = v + omega x r (S6); dL/dt = u . v_P, du/dt = (v_P - dL/dt u) / L (S7);
    theta_1', theta_2' from the orthogonal closure (S8); omega_i = u x u' + sigma u,
    sigma = sin theta_2 theta_1' (S9).
    """
    vP = platform.v[:, None, :] + cross(platform.omega[:, None, :], legs.r)
    Ld = dot(legs.u, vP)
    ud = (vP - Ld[..., None] * legs.u) / legs.L[..., None]
    theta1d = dot(legs.a1xu, ud) / (legs.c2 * legs.c2)
    theta2d = dot(model.base_axes, ud) / legs.c2
    sigma = legs.s2 * theta1d
    omega = cross(legs.u, ud) + sigma[..., None] * legs.u
    return LegVelocities(vP=vP, Ld=Ld, ud=ud, theta1d=theta1d, theta2d=theta2d, sigma=sigma,
                         omega=omega)


@dataclass(frozen=True)
class LegAccelerations:
    """Accelerations along each leg (S10)-(S13)."""

    aP: np.ndarray        # acceleration of P_i (N, 6, 3)
    Ldd: np.ndarray       # d2L/dt2 (N, 6)
    udd: np.ndarray       # d2u/dt2 (N, 6, 3)
    theta1dd: np.ndarray  # (N, 6)
    theta2dd: np.ndarray  # (N, 6)
    eps: np.ndarray       # angular acceleration of the leg (N, 6, 3)


def leg_accelerations(model: StewartModel, legs: LegPositions, rates: LegVelocities,
                      platform: PlatformMotion) -> LegAccelerations:
    """a_P (S10); L'' and u'' (S11); theta_1'', theta_2'' (S12);
    eps_i = u x u'' + sigma' u + sigma u', sigma' = s2 theta_1'' + (a_1 . u') theta_1' (S13).
    """
    w = platform.omega[:, None, :]
    aP = (platform.a[:, None, :] + cross(platform.eps[:, None, :], legs.r)
          + cross(w, cross(w, legs.r)))
    u, ud, L = legs.u, rates.ud, legs.L
    Ldd = dot(u, aP) + L * dot(ud, ud)
    udd = (aP - Ldd[..., None] * u - 2.0 * rates.Ld[..., None] * ud) / L[..., None]
    c2sq = legs.c2 * legs.c2
    a1ud = dot(model.base_axes, ud)
    theta1dd = (dot(legs.a1xu, udd) + 2.0 * legs.s2 * a1ud * rates.theta1d) / c2sq
    theta2dd = (dot(model.base_axes, udd) + legs.s2 * a1ud * a1ud / c2sq) / legs.c2
    sigma_d = legs.s2 * theta1dd + a1ud * rates.theta1d
    eps = cross(u, udd) + sigma_d[..., None] * u + rates.sigma[..., None] * ud
    return LegAccelerations(aP=aP, Ldd=Ldd, udd=udd, theta1dd=theta1dd, theta2dd=theta2dd,
                            eps=eps)


# ---------------------------------------------------------------------------
# Jacobians (S21)-(S22)
# ---------------------------------------------------------------------------

def actuator_jacobian(legs: LegPositions) -> np.ndarray:
    """J, row i = [u_i^T (r_i x u_i)^T]: dL/dt = J (v, omega) (S21), (N, 6, 6)."""
    return np.concatenate([legs.u, cross(legs.r, legs.u)], axis=-1)


def pose_jacobian(J: np.ndarray, E: np.ndarray) -> np.ndarray:
    """J_L = dL/dq = J diag(E3, E) (S22), (N, 6, 6)."""
    return np.concatenate([J[..., :3], J[..., 3:] @ E], axis=-1)


def jacobian_condition(J: np.ndarray) -> np.ndarray:
    """2-norm condition number of J (lengths in m, angles in rad); SINGULAR
    where J is singular or not finite, (N,).
    """
    finite = np.all(np.isfinite(J), axis=(-2, -1))
    sigma = np.linalg.svd(np.where(finite[:, None, None], J, 0.0), compute_uv=False)
    with np.errstate(divide='ignore', invalid='ignore'):
        cond = sigma[:, 0] / sigma[:, -1]
    return np.where(finite & np.isfinite(cond), cond, SINGULAR)


# ---------------------------------------------------------------------------
# Forward kinematics: the pose from six leg lengths
# ---------------------------------------------------------------------------

def _lengths_and_jacobian(model: StewartModel, q: np.ndarray
                          ) -> tuple[np.ndarray, np.ndarray, bool]:
    q = q[None, :]
    legs = leg_positions(model, model.home + q[:, :3], rotation(q))
    J_L = pose_jacobian(actuator_jacobian(legs), euler_rate_matrix(q))[0]
    return legs.L[0], J_L, not degenerate_legs(legs).any()


@quiet_floating_point
def forward_kinematics(model: StewartModel, lengths: Sequence[float],
                       initial: Sequence[float] = (0.0,) * 6, *, tolerance: float = 1e-12,
                       max_iterations: int = 50) -> ForwardSolution:
    """The pose whose leg lengths are ``lengths`` (m, legs 1-6): Newton's method
    on L(q) = L* with J_L (S22) from ``initial``, each step halved until the
    residual decreases on a regular pose (:func:`~flight_sim_dynamics.core.
    forward.safeguarded_newton`, the rule of every machine). ok when max |L - L*| <= tolerance;
    unreachable when the iteration stalls at a minimum of |L - L*| > 0
    (J_L^T (L - L*) ~ 0: no pose has these lengths nearby); not_converged
    otherwise (e.g. stalled against a singular or degenerate pose). Never raises for bad
    numbers; ValueError for arguments that are not six numbers each and for bad
    options (:func:`~flight_sim_dynamics.core.machine.check_forward_options`).
    """
    check_forward_options(tolerance, max_iterations)
    target, start = six_numbers('lengths', lengths), six_numbers('initial', initial)
    zero = np.zeros(6)
    if not (np.all(np.isfinite(target)) and np.all(np.isfinite(start))):
        return ForwardSolution(zero, Status.INVALID_INPUT, float('inf'), 0,
                               'lengths and initial pose must be finite')
    if np.any(target <= 0.0):
        return ForwardSolution(zero, Status.INVALID_INPUT, float('inf'), 0,
                               f'leg lengths must be positive, got {target.tolist()}')

    def lengths_at(q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        L, J_L, regular = _lengths_and_jacobian(model, q)
        if not regular:
            raise OffWorkspace('a leg of zero length or a singular U-joint', outside=False)
        return L, J_L
    try:
        return safeguarded_newton(lengths_at, target, start, tolerance, max_iterations)
    except OffWorkspace:        # the initial pose's (the line search takes the trials')
        return ForwardSolution(zero, Status.INVALID_INPUT, float('inf'), 0,
                               'initial pose is degenerate (a leg of zero length or a '
                               'singular U-joint)')


def six_numbers(name: str, value: object) -> np.ndarray:
    """Six real numbers as a float array, or ValueError naming the argument
    (NaN and infinities are numbers: a status judges them).
    """
    if isinstance(value, (str, bytes)) or np.ma.isMaskedArray(value) or (
            not isinstance(value, np.ndarray) and has_bool(value)):
        raise ValueError(f'{name} must be 6 numbers, got {value!r:.200}')
    try:
        arr = np.asarray(value)
    except (ValueError, TypeError):
        raise ValueError(f'{name} must be 6 numbers, got {value!r:.200}') from None
    if arr.shape != (6,) or arr.dtype.kind not in 'fiu':
        raise ValueError(f'{name} must be 6 numbers, got {value!r:.200}')
    return arr.astype(float)


def has_bool(value: object) -> bool:
    """True if a (nested) list holds a bool, which numpy would read as 0 or 1."""
    if isinstance(value, (bool, np.bool_)):
        return True
    if isinstance(value, (list, tuple)):
        return any(has_bool(v) for v in value)
    return False
