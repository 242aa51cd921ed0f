"""Inverse dynamics: paper Section 3, eq. (18)-(23).

For every body the *required wrench* (the negative of the paper's inertia
wrench plus weight, eq. 21) is computed about the joint centre of its frame
(eq. 18-19); the wrenches are accumulated backwards along each open chain
A, B, C and the cranks D, E (eq. 20, 22); and the actuator forces follow from
the principle of virtual work with the three virtual motions of eq. (14),
whose virtual joint velocities come from the connectivity relations (11)
(eq. 23). Vectors are 3-tuples of components in the fixed frame
(:mod:`.vectors`, :mod:`.kinematics`).
"""
from __future__ import annotations

from dataclasses import dataclass

from .kinematics import Z0, Geometric
from .model import ACTUATED_JOINTS, Body, Model
from .vectors import (Scalar, Vec, add, axpy, cross, dot, from_frame, mat_vec, scale, sub,
                      to_frame, zx)


@dataclass
class BodyMotion:
    """Kinematic state of one body: what eq. (18) needs."""

    axes: tuple[Vec, Vec, Vec]   # body axes x, y, z in the fixed frame (columns of a_k0^T)
    omega: Vec                   # absolute angular velocity omega_k0
    eps: Vec                     # absolute angular acceleration epsilon_k0
    com: Vec                     # centre of mass, fixed frame
    acc: Vec                     # acceleration of the centre of mass


def _rigid(body: Body, axes: tuple[Vec, Vec, Vec], origin: Vec, omega: Vec, eps: Vec,
           ref: Vec, acc_ref: Vec) -> BodyMotion:
    """Centre-of-mass acceleration from a point ``ref`` of the same body with
    known acceleration: a_C = a_ref + eps x rho + omega x (omega x rho)."""
    com = add(origin, from_frame(axes, body.com_t))
    rho = sub(com, ref)
    acc = add(add(acc_ref, cross(eps, rho)), cross(omega, cross(omega, rho)))
    return BodyMotion(axes=axes, omega=omega, eps=eps, com=com, acc=acc)


def body_motions(model: Model, g: Geometric, V: list, Gamma: list,
                 qd: tuple, qdd: tuple) -> dict[str, BodyMotion]:
    """Absolute angular velocities/accelerations and centre-of-mass accelerations
    of every body with mass, from the relative joint rates V (eq. 13) and
    accelerations Gamma (eq. 15), composed along each chain."""
    geom = model.geometry
    bodies = model.bodies
    zero: Vec = (0.0, 0.0, 0.0)
    out: dict[str, BodyMotion] = {}
    # chain A: cylinder (omega_10), piston (+ v_21), rod (+ omega_32), platform (+ omega_43)
    thd, thdd, Ld, Ldd = V[0], Gamma[0], V[1], Gamma[1]
    zdA = zx(g.dA)
    axes_A = (g.dA, zdA, Z0)
    omega_A, eps_A = (0.0, 0.0, thd), (0.0, 0.0, thdd)
    out['cylinder_a'] = _rigid(bodies['cylinder_a'], axes_A, zero, omega_A, eps_A, zero, zero)
    acc_slide = axpy(Ldd, g.dA, scale(2.0 * Ld * thd, zdA))     # relative + Coriolis
    out['piston_a'] = _rigid(bodies['piston_a'], axes_A, g.A3, omega_A, eps_A, zero, acc_slide)
    beta_d, beta_dd = V[0] + V[2], Gamma[0] + Gamma[2]
    Gdd = (qdd[0], qdd[1], 0.0)
    zl = zx(g.l)
    out['rod'] = _rigid(bodies['rod'], (g.l, zl, Z0), g.A3, (0.0, 0.0, beta_d),
                        (0.0, 0.0, beta_dd), g.G, Gdd)
    roll_d, roll_dd = qd[2], qdd[2]
    omega_P = (roll_d * g.l[0], roll_d * g.l[1], beta_d)
    eps_P = (roll_dd * g.l[0] + beta_d * roll_d * zl[0],
             roll_dd * g.l[1] + beta_d * roll_d * zl[1], beta_dd)
    out['platform'] = _rigid(bodies['platform'], (g.l, g.n, g.t), g.A3, omega_P, eps_P,
                             g.G, Gdd)
    # chains B, C: U-joint at the base (omega_10 about z0, omega_21 about e2), slider v_32
    base_x = geom.d2 + geom.d3 + geom.d4
    for leg, k, P1, P4, d, e2 in (('b', 3, (base_x, 0.0, geom.d5), g.B4, g.dB, g.e2B),
                                  ('c', 6, (base_x, 0.0, -geom.d5), g.C4, g.dC, g.e2C)):
        w10, w21, Lr = V[k], V[k + 1], V[k + 2]
        e10, e21, Lrr = Gamma[k], Gamma[k + 1], Gamma[k + 2]
        omega = (w21 * e2[0], w21 * e2[1], w10)
        ze2 = zx(e2)
        eps = (e21 * e2[0] + w10 * w21 * ze2[0], e21 * e2[1] + w10 * w21 * ze2[1], e10)
        axes = (d, cross(e2, d), e2)
        out[f'cylinder_{leg}'] = _rigid(bodies[f'cylinder_{leg}'], axes, P1, omega, eps,
                                        P1, zero)
        acc_slide = axpy(Lrr, d, scale(2.0 * Lr, cross(omega, d)))
        out[f'piston_{leg}'] = _rigid(bodies[f'piston_{leg}'], axes, P4, omega, eps,
                                      P1, acc_slide)
    # cranks D, E: rotation about z0 at the fixed pivot
    for name, k, P1, d in (('crank_d', 9, (geom.d2 + geom.d3, 0.0, 0.0), g.dD),
                           ('crank_e', 10, (geom.d2, 0.0, 0.0), g.dE)):
        out[name] = _rigid(bodies[name], (d, zx(d), Z0), P1, (0.0, 0.0, V[k]),
                           (0.0, 0.0, Gamma[k]), P1, zero)
    return out


def required_wrench(body: Body, motion: BodyMotion, gravity: float,
                    about: Vec) -> tuple[Vec, Vec]:
    """F_k0, M_k0 of eq. (21) = -(inertia wrench, eq. 18) - (weight wrench, eq. 19),
    the moment taken about the point ``about`` (the joint centre A_k).

    F = m (a_C - g), M = J_C eps + omega x J_C omega + (C - A_k) x F, with
    g = -gravity y0 (the paper's eq. 19 writes the weight along u3: the
    vertical of this machine is y0, see mechanism.md). J_C is applied in the
    body frame (J_C = R J R^T).
    """
    a = motion.acc
    force = (body.mass * a[0], body.mass * (a[1] + gravity), body.mass * a[2])
    w = to_frame(motion.axes, motion.omega)
    e = to_frame(motion.axes, motion.eps)
    Jw = mat_vec(body.inertia_t, w)
    moment_body = add(mat_vec(body.inertia_t, e), cross(w, Jw))
    moment = add(from_frame(motion.axes, moment_body), cross(sub(motion.com, about), force))
    return force, moment


def joint_forces(model: Model, g: Geometric,
                 motions: dict[str, BodyMotion]) -> tuple[list, Scalar]:
    """Backward recursion of eq. (20)-(22) along chains A, B, C and cranks D, E.

    Returns tau (12 components), the projection of the accumulated wrench on
    each joint axis (u3^T F_k for a prismatic joint, u3^T M_k for a revolute
    one) in the order of eq. (13), and tau_43, that of the platform roll joint
    A4. The massless slider E2 carries no term (tau[11] = 0).
    """
    geom = model.geometry
    bodies = model.bodies
    grav = model.gravity
    tau = [0.0] * 12
    # chain A, joints A1 (rev z0), A2 (prismatic dA), A3 (rev z0), A4 (rev l); A4 = A3
    A1: Vec = (0.0, 0.0, 0.0)
    A2 = axpy(-geom.l2, g.dA, g.A3)
    F4, M4 = required_wrench(bodies['platform'], motions['platform'], grav, g.A3)
    F30, M30 = required_wrench(bodies['rod'], motions['rod'], grav, g.A3)
    F3, M3 = add(F30, F4), add(M30, M4)                                  # r_43 = 0
    F20, M20 = required_wrench(bodies['piston_a'], motions['piston_a'], grav, A2)
    F2 = add(F20, F3)
    M2 = add(add(M20, M3), cross(sub(g.A3, A2), F3))
    F10, M10 = required_wrench(bodies['cylinder_a'], motions['cylinder_a'], grav, A1)
    M1 = add(add(M10, M2), cross(A2, F2))                                # r_21 = A2 - A1
    tau[0] = M1[2]                      # u3^T M_1^A, axis z0
    tau[1] = dot(g.dA, F2)              # u3^T F_2^A, axis dA
    tau[2] = M3[2]                      # u3^T M_3^A, axis z0
    tau_43 = dot(g.l, M4)               # u3^T M_4^A, axis l
    # chains B, C: cross at B1 (massless), cylinder B2 = B1, piston from B3 to B4
    base_x = geom.d2 + geom.d3 + geom.d4
    for leg, k, P1, P4, d, e2 in (('b', 3, (base_x, 0.0, geom.d5), g.B4, g.dB, g.e2B),
                                  ('c', 6, (base_x, 0.0, -geom.d5), g.C4, g.dC, g.e2C)):
        P3 = axpy(-geom.l4, d, P4)
        F3, M3 = required_wrench(bodies[f'piston_{leg}'], motions[f'piston_{leg}'], grav, P3)
        _, M20 = required_wrench(bodies[f'cylinder_{leg}'], motions[f'cylinder_{leg}'],
                                 grav, P1)
        M2 = add(add(M20, M3), cross(sub(P3, P1), F3))    # M_1 = M_2: massless cross
        tau[k] = M2[2]                  # u3^T M_1^B, axis z0
        tau[k + 1] = dot(e2, M2)        # u3^T M_2^B, axis e2
        tau[k + 2] = dot(d, F3)         # u3^T F_3^B, axis dB
    # cranks D, E
    for name, k, P1 in (('crank_d', 9, (geom.d2 + geom.d3, 0.0, 0.0)),
                        ('crank_e', 10, (geom.d2, 0.0, 0.0))):
        _, M1 = required_wrench(bodies[name], motions[name], grav, P1)
        tau[k] = M1[2]
    return tau, tau_43


def actuator_jacobian(K: tuple[list, list, list]) -> list:
    """J (3x3 nested lists): row i = actuator i, column k = pose coordinate k;
    the actuated rows of V = K qd (eq. 11)."""
    return [[K[k][j] for k in range(3)] for j in ACTUATED_JOINTS]


def _inverse3(m: list) -> list:
    """Inverse of a 3x3 (nested lists of components) by the adjugate."""
    (a, b, c), (d, e, f), (g, h, i) = m
    A, B, C = e * i - f * h, f * g - d * i, d * h - e * g
    inv_det = 1.0 / (a * A + b * B + c * C)
    return [[A * inv_det, (c * h - b * i) * inv_det, (b * f - c * e) * inv_det],
            [B * inv_det, (a * i - c * g) * inv_det, (c * d - a * f) * inv_det],
            [C * inv_det, (b * g - a * h) * inv_det, (a * e - b * d) * inv_det]]


def virtual_velocities(K: tuple[list, list, list], J: list) -> tuple[list, list]:
    """The three virtual motions of eq. (14): motion a has unit rate of actuator a
    and zero rate of the others, i.e. pose rates J^-1 e_a. Returns the virtual
    joint velocities Vv[j][a] (12 x 3, eq. 11) and the virtual roll rates
    (omega_43a, 3)."""
    Jinv = _inverse3(J)
    Vv = [[K[0][j] * Jinv[0][a] + K[1][j] * Jinv[1][a] + K[2][j] * Jinv[2][a]
           for a in range(3)] for j in range(12)]
    return Vv, Jinv[2]


def actuator_forces(tau: list, tau_43: Scalar, Vv: list, roll_v: list) -> list:
    """Eq. (23): f_a = sum over joints of (virtual velocity in motion a) x (joint
    projection of the accumulated wrench). Returns [f_A, f_B, f_C], positive when
    the actuator pushes its two ends apart."""
    return [sum(Vv[j][a] * tau[j] for j in range(11))   # tau[11] = 0: slider E2 is massless
            + roll_v[a] * tau_43 for a in range(3)]
