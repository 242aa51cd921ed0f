"""Inverse dynamics: paper Section 3, eq. (18)-(23).

For every body the *required wrench* (the negative of the paper's inertia
wrench plus weight, eq. 21) is computed about the joint centre of its frame
(eq. 18-19); the wrenches are accumulated backwards along each open chain
A, B, C and the cranks D, E (eq. 20, 22); and the actuator forces follow from
the principle of virtual work with the three virtual motions of eq. (14),
whose virtual joint velocities come from the connectivity relations (11)
(eq. 23). Vectors are in the fixed frame (see :mod:`.kinematics`).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .kinematics import Geometric, Z0, cross, dot, z_cross
from .model import ACTUATED_JOINTS, Model


@dataclass
class BodyMotion:
    """Kinematic state of one body for a batch: what eq. (18) needs."""

    R: np.ndarray        # (N, 3, 3) body axes as columns (body frame -> fixed frame)
    origin: np.ndarray   # (N, 3) origin of the body frame (a joint centre)
    omega: np.ndarray    # (N, 3) absolute angular velocity omega_k0
    eps: np.ndarray      # (N, 3) absolute angular acceleration epsilon_k0
    com: np.ndarray      # (N, 3) centre of mass, fixed frame
    acc: np.ndarray      # (N, 3) acceleration of the centre of mass


def _frame(x: np.ndarray, z: np.ndarray) -> np.ndarray:
    """Rotation with columns x, z x x, z (x and z orthonormal)."""
    return np.stack((x, cross(z, x), z), axis=-1)


def _rigid(R: np.ndarray, origin: np.ndarray, omega: np.ndarray, eps: np.ndarray,
           com_body: np.ndarray, ref: np.ndarray, acc_ref: np.ndarray) -> BodyMotion:
    """Centre-of-mass acceleration of a rigid body from a reference point of it
    with known acceleration: a_c = a_ref + eps x rho + omega x (omega x rho)."""
    com = origin + R @ com_body
    rho = com - ref
    acc = acc_ref + cross(eps, rho) + cross(omega, cross(omega, rho))
    return BodyMotion(R=R, origin=origin, omega=omega, eps=eps, com=com, acc=acc)


def body_motions(model: Model, g: Geometric, V: np.ndarray, Gamma: np.ndarray,
                 qd: np.ndarray, qdd: np.ndarray) -> dict[str, BodyMotion]:
    """Absolute angular velocities/accelerations and centre-of-mass accelerations
    of every body with mass, from the relative joint rates V (eq. 13) and
    accelerations Gamma (eq. 15), composed along each chain."""
    geom = model.geometry
    bodies = model.bodies
    N = g.G.shape[0]
    zero3 = np.zeros((N, 3))
    z = np.broadcast_to(Z0, (N, 3))
    out: dict[str, BodyMotion] = {}

    # chain A: cylinder (omega_10), piston (+ v_21), rod (+ omega_32), platform (+ omega_43)
    thd, thdd = V[:, 0:1], Gamma[:, 0:1]
    Ld, Ldd = V[:, 1:2], Gamma[:, 1:2]
    RA = _frame(g.dA, z)
    omega_A, eps_A = thd * z, thdd * z
    out['cylinder_a'] = _rigid(RA, np.broadcast_to(geom.A1, (N, 3)), omega_A, eps_A,
                               bodies['cylinder_a'].com, geom.A1, zero3)
    acc_slide = Ldd * g.dA + 2.0 * Ld * thd * z_cross(g.dA)   # relative + Coriolis
    out['piston_a'] = _rigid(RA, g.A3, omega_A, eps_A, bodies['piston_a'].com,
                             geom.A1, acc_slide)
    beta_d = V[:, 0:1] + V[:, 2:3]
    beta_dd = Gamma[:, 0:1] + Gamma[:, 2:3]
    Gdd = np.zeros((N, 3))
    Gdd[:, 0:2] = qdd[:, 0:2]
    out['rod'] = _rigid(_frame(g.l, z), g.A3, beta_d * z, beta_dd * z, bodies['rod'].com,
                        g.G, Gdd)
    roll_d, roll_dd = qd[:, 2:3], qdd[:, 2:3]
    omega_P = beta_d * z + roll_d * g.l
    eps_P = beta_dd * z + roll_dd * g.l + beta_d * roll_d * z_cross(g.l)
    RP = np.stack((g.l, g.n, g.t), axis=-1)
    out['platform'] = _rigid(RP, g.A3, omega_P, eps_P, bodies['platform'].com, g.G, Gdd)

    # chains B, C: U-joint at the base (omega_10 about z0, omega_21 about e2), slider v_32
    for leg, k, P1, P4, d, e2 in (('b', 3, geom.B1, g.B4, g.dB, g.e2B),
                                  ('c', 6, geom.C1, g.C4, g.dC, g.e2C)):
        w10, w21, Lr = V[:, k:k + 1], V[:, k + 1:k + 2], V[:, k + 2:k + 3]
        e10, e21, Lrr = Gamma[:, k:k + 1], Gamma[:, k + 1:k + 2], Gamma[:, k + 2:k + 3]
        omega = w10 * z + w21 * e2
        eps = e10 * z + e21 * e2 + w10 * w21 * z_cross(e2)
        R = _frame(d, e2)
        out[f'cylinder_{leg}'] = _rigid(R, np.broadcast_to(P1, (N, 3)), omega, eps,
                                        bodies[f'cylinder_{leg}'].com, P1, zero3)
        acc_slide = Lrr * d + 2.0 * Lr * cross(omega, d)
        out[f'piston_{leg}'] = _rigid(R, P4, omega, eps, bodies[f'piston_{leg}'].com,
                                      P1, acc_slide)

    # cranks D, E: rotation about z0 at the fixed pivot
    for name, k, P1, d in (('crank_d', 9, geom.D1, g.dD), ('crank_e', 10, geom.E1, g.dE)):
        out[name] = _rigid(_frame(d, z), np.broadcast_to(P1, (N, 3)), V[:, k:k + 1] * z,
                           Gamma[:, k:k + 1] * z, bodies[name].com, P1, zero3)
    return out


def required_wrench(model: Model, name: str, motion: BodyMotion,
                    about: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """F_k0, M_k0 of eq. (21) = -(inertia wrench, eq. 18) - (weight wrench, eq. 19),
    the moment taken about the point ``about`` (the joint centre A_k).

    F = m (a_C - g), M = J_C eps + omega x J_C omega + (C - A_k) x F,
    with g = -9.81 y0 (the paper's eq. 19 writes the weight along u3: the
    vertical of this machine is y0, see mechanism.md).
    """
    body = model.bodies[name]
    acc = motion.acc.copy()
    acc[:, 1] += model.gravity
    force = body.mass * acc
    J = motion.R @ body.inertia @ np.swapaxes(motion.R, -1, -2)
    J_omega = np.einsum('nij,nj->ni', J, motion.omega)
    moment = (np.einsum('nij,nj->ni', J, motion.eps) + cross(motion.omega, J_omega)
              + cross(motion.com - about, force))
    return force, moment


def joint_forces(model: Model, g: Geometric,
                 motions: dict[str, BodyMotion]) -> tuple[np.ndarray, np.ndarray]:
    """Backward recursion of eq. (20)-(22) along chains A, B, C and cranks D, E.

    Returns tau (N, 12), the projection of the accumulated wrench on each joint
    axis (u3^T F_k for a prismatic joint, u3^T M_k for a revolute one), in the
    order of eq. (13), and tau_43 (N,), that of the platform roll joint A4.
    The massless slider E2 carries no term (tau[:, 11] = 0).
    """
    geom = model.geometry
    N = g.G.shape[0]
    tau = np.zeros((N, 12))
    # chain A, joints A1 (rev z0), A2 (prismatic dA), A3 (rev z0), A4 (rev l); A4 = A3
    A2 = g.A3 - geom.l2 * g.dA
    A1 = np.broadcast_to(geom.A1, (N, 3))
    F4, M4 = required_wrench(model, 'platform', motions['platform'], g.A3)
    F30, M30 = required_wrench(model, 'rod', motions['rod'], g.A3)
    F3, M3 = F30 + F4, M30 + M4                           # r_43 = 0
    F20, M20 = required_wrench(model, 'piston_a', motions['piston_a'], A2)
    F2, M2 = F20 + F3, M20 + M3 + cross(g.A3 - A2, F3)
    F10, M10 = required_wrench(model, 'cylinder_a', motions['cylinder_a'], A1)
    F1, M1 = F10 + F2, M10 + M2 + cross(A2 - A1, F2)
    del F1
    tau[:, 0] = M1[:, 2]                    # u3^T M_1^A, axis z0
    tau[:, 1] = dot(g.dA, F2)               # u3^T F_2^A, axis dA
    tau[:, 2] = M3[:, 2]                    # u3^T M_3^A, axis z0
    tau_43 = dot(g.l, M4)                   # u3^T M_4^A, axis l
    # chains B, C: cross at B1 (massless), cylinder B2 = B1, piston from B3 to B4
    for leg, k, P1, P4, d, e2, s0 in (('b', 3, geom.B1, g.B4, g.dB, g.e2B, geom.s_B),
                                      ('c', 6, geom.C1, g.C4, g.dC, g.e2C, geom.s_C)):
        P3 = P4 - geom.l4 * d
        F3, M3 = required_wrench(model, f'piston_{leg}', motions[f'piston_{leg}'], P3)
        base = np.broadcast_to(P1, (N, 3))
        F20, M20 = required_wrench(model, f'cylinder_{leg}', motions[f'cylinder_{leg}'], base)
        M2 = M20 + M3 + cross(P3 - base, F3)             # M_1 = M_2: massless cross, r_21 = 0
        tau[:, k] = M2[:, 2]                             # u3^T M_1^B, axis z0
        tau[:, k + 1] = dot(e2, M2)                      # u3^T M_2^B, axis e2
        tau[:, k + 2] = dot(d, F3)                       # u3^T F_3^B, axis dB
    # cranks D, E
    for name, k, P1 in (('crank_d', 9, geom.D1), ('crank_e', 10, geom.E1)):
        _, M1 = required_wrench(model, name, motions[name], np.broadcast_to(P1, (N, 3)))
        tau[:, k] = M1[:, 2]
    return tau, tau_43


def virtual_velocities(K: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The three virtual motions of eq. (14) and their virtual velocities.

    K (N, 12, 3) maps pose rates to joint rates (V = K qd, from eq. 11). The
    actuator Jacobian J (N, 3, 3) is the rows of the actuated joints; virtual
    motion a has unit rate of actuator a and zero of the others, i.e. pose rates
    J^-1 e_a. Returns (J, joint virtual velocities (N, 12, 3), roll virtual
    velocities (N, 3)); column a is virtual motion a.
    """
    J = K[:, ACTUATED_JOINTS, :]
    J_inv = np.linalg.solve(J, np.broadcast_to(np.eye(3), J.shape))
    return J, K @ J_inv, J_inv[:, 2, :]


def actuator_forces(tau: np.ndarray, tau_43: np.ndarray, V_virtual: np.ndarray,
                    roll_virtual: np.ndarray) -> np.ndarray:
    """Eq. (23): f_a = sum over joints of (virtual velocity in motion a) x (joint
    projection of the accumulated wrench). Returns (N, 3): f_A, f_B, f_C, positive
    when the actuator pushes its two ends apart."""
    return np.einsum('nja,nj->na', V_virtual, tau) + roll_virtual * tau_43[:, None]
