"""Inverse dynamics of the hexapod by the recursive relations per leg and
virtual work (docs/design/stewart.md, (S14)-(S23)).

Each effect of the model's scene adds its own terms; a disabled effect's
terms are never computed (:class:`flight_sim_dynamics.core.effects.Effects`:
gravity, platform_inertia, payload, leg_inertia, velocity_products,
friction; a hexapod has no cranks, so crank_inertia has nothing to act on).
"""
from __future__ import annotations

import numpy as np

from .kinematics import (LegAccelerations, LegPositions, LegVelocities, PlatformMotion, cross,
                         dot)
from .model import RigidBody, StewartModel


def has_inertia(model: StewartModel) -> bool:
    """True when the scene moves some body of the hexapod (platform, payload, legs)."""
    e = model.effects
    return e.platform_inertia or e.leg_inertia or (e.payload and model.payload.mass > 0.0)


def gravity_vector(model: StewartModel) -> np.ndarray:
    """The gravity vector (0, 0, -g), base frame."""
    return np.array([0.0, 0.0, -model.gravity])


# ---------------------------------------------------------------------------
# The legs' wrenches (S14)-(S15) and what they carry to P_i (S20)
# ---------------------------------------------------------------------------

def axisymmetric_product(across: float, along: float, u: np.ndarray,
                         x: np.ndarray) -> np.ndarray:
    """I x with I = I_across Pi + I_along u u^T (S15)."""
    axial = dot(u, x)[..., None] * u
    return across * (x - axial) + along * axial


def leg_forces(model: StewartModel, legs: LegPositions,
               acc: LegAccelerations) -> tuple[np.ndarray, np.ndarray]:
    """F_1, F_2 of the cylinder and rod (S14)-(S15): m_k c_k'' (leg_inertia, with
    c_1'' = l_c u'', c_2'' = a_P - l_r u'') and - m_k g (gravity); one of the
    two effects must be on.
    """
    F1 = F2 = None
    cyl, rod = model.cylinder, model.rod
    if model.effects.leg_inertia:
        F1 = (cyl.mass * cyl.com_distance) * acc.udd
        F2 = rod.mass * (acc.aP - rod.com_distance * acc.udd)
    if model.effects.gravity:
        g = gravity_vector(model)
        F1 = -cyl.mass * g if F1 is None else F1 - cyl.mass * g
        F2 = -rod.mass * g if F2 is None else F2 - rod.mass * g
        F1, F2 = np.broadcast_to(F1, legs.u.shape), np.broadcast_to(F2, legs.u.shape)
    return F1, F2


def leg_moment(model: StewartModel, legs: LegPositions, rates: LegVelocities,
               acc: LegAccelerations) -> np.ndarray:
    """N_i = sum over cylinder and rod of I_k eps_i + omega_i x I_k omega_i (S15):
    the two turn together, so one product with I_1 + I_2.
    """
    u, w, e = legs.u, rates.omega, acc.eps
    cyl, rod = model.cylinder, model.rod
    across, along = cyl.inertia_across + rod.inertia_across, cyl.inertia_along + rod.inertia_along
    return (axisymmetric_product(across, along, u, e)
            + cross(w, axisymmetric_product(across, along, u, w)))


def carried_force(model: StewartModel, legs: LegPositions, F1: np.ndarray, F2: np.ndarray,
                  N: np.ndarray | None) -> np.ndarray:
    """G_i, the leg's inertia and weight carried to P_i (S20):
    G = F2 + [Pi (l_c F1 - l_r F2) + N x u + (s2 (u . N) / c2^2) (a_1 x u)] / L.
    """
    u = legs.u
    m = model.cylinder.com_distance * F1 - model.rod.com_distance * F2
    T = m - dot(u, m)[..., None] * u                                   # Pi_i (...)
    if N is not None:
        T = T + cross(N, u) + (legs.s2 * dot(u, N) / (legs.c2 * legs.c2))[..., None] * legs.a1xu
    return F2 + T / legs.L[..., None]


# ---------------------------------------------------------------------------
# The platform's wrench (S16)
# ---------------------------------------------------------------------------

def rigid_body_wrench(body: RigidBody, platform: PlatformMotion, g: np.ndarray | None,
                      inertia: bool) -> tuple[np.ndarray, np.ndarray]:
    """(F_0, N_0 + rho x F_0) about the platform origin (S16): rho = R c,
    F_0 = m (a_c - g), N_0 = R I_c R^T eps + omega x R I_c R^T omega, computed in
    the body's frame as R (I_c eps_b + omega_b x I_c omega_b), eps_b = R^T eps,
    omega_b = R^T omega; the inertia terms only if ``inertia``, the weight only
    if g is given.
    """
    R = platform.R
    rho = R @ body.com
    if inertia:
        w, e = platform.omega, platform.eps
        a_c = platform.a + cross(e, rho) + cross(w, cross(w, rho))
        F = body.mass * (a_c if g is None else a_c - g)
        wb, eb = np.einsum('nji,nj->ni', R, w), np.einsum('nji,nj->ni', R, e)
        I = body.inertia
        M = np.einsum('nij,nj->ni', R, eb @ I.T + cross(wb, wb @ I.T))
    else:
        F = np.broadcast_to(-body.mass * g, rho.shape)
        M = 0.0
    return F, M + cross(rho, F)


def platform_wrench(model: StewartModel, platform: PlatformMotion) -> np.ndarray | None:
    """w_0 (N, 6) over platform and payload as the scene asks (S16); None if nothing acts."""
    effects = model.effects
    g = gravity_vector(model) if effects.gravity else None
    parts = []
    if effects.platform_inertia or g is not None:
        parts.append(rigid_body_wrench(model.platform, platform, g, effects.platform_inertia))
    if effects.payload and model.payload.mass > 0.0:
        parts.append(rigid_body_wrench(model.payload, platform, g, True))
    if not parts:
        return None
    return np.concatenate([sum(p[0] for p in parts), sum(p[1] for p in parts)], axis=-1)


# ---------------------------------------------------------------------------
# The actuator forces by virtual work (S21), friction (S23)
# ---------------------------------------------------------------------------

def generalised_wrench(model: StewartModel, platform: PlatformMotion, legs: LegPositions,
                       rates: LegVelocities, acc: LegAccelerations) -> np.ndarray:
    """w_0 + sum_i (G_i, r_i x G_i) (S21): the wrench, about the platform origin,
    that the actuators must balance, (N, 6).
    """
    w = platform_wrench(model, platform)
    total = np.zeros((legs.L.shape[0], 6)) if w is None else w
    if model.effects.leg_inertia or model.effects.gravity:
        F1, F2 = leg_forces(model, legs, acc)
        N = leg_moment(model, legs, rates, acc) if model.effects.leg_inertia else None
        G = carried_force(model, legs, F1, F2, N)
        total = total + np.concatenate([G.sum(axis=1), cross(legs.r, G).sum(axis=1)], axis=-1)
    return total


def actuator_forces(J: np.ndarray, wrench: np.ndarray) -> np.ndarray:
    """Forces f = J^-T (w_0 + sum_i (G_i, r_i x G_i)) (S21), (N, 6); NaN for a
    sample whose J LAPACK finds exactly singular.
    """
    JT = np.swapaxes(J, -1, -2)
    try:
        return np.linalg.solve(JT, wrench[..., None])[..., 0]
    except np.linalg.LinAlgError:       # one singular J fails the whole batch: sample by sample
        out = np.full(wrench.shape, np.nan)
        for i in range(J.shape[0]):
            try:
                out[i] = np.linalg.solve(JT[i], wrench[i])
            except np.linalg.LinAlgError:
                pass
        return out


def friction_forces(model: StewartModel, Ld: np.ndarray) -> np.ndarray:
    """c_i L_i' + F_c,i tanh(L_i' / smoothing_velocity) (S23), (N, 6)."""
    fr = model.friction
    return fr.viscous * Ld + fr.coulomb * np.tanh(Ld / fr.smoothing_velocity)

