"""Inverse dynamics: paper Section 3, eq. (18)-(23).

Each body's required wrench (eq. 18-19, 21) about its joint centre, summed
backwards along the chains A, B, C and the cranks D, E (eq. 20, 22); the
actuator forces by virtual work with the virtual motions of eq. (14) (eq. 23).
Only the effects of the model's scene are computed (:mod:`.effects`).
"""
from __future__ import annotations

from dataclasses import dataclass
from types import SimpleNamespace

from ...core.effects import Effects
from ...core.vectors import (Scalar, Vec, add, axpy, cross, dot, from_frame, mat_vec, scale, sub,
                             to_frame, zx)
from .kinematics import Z0, Geometric
from .model import ACTUATED_JOINTS, BODY_NAMES, Body, Model

#: Bodies moved by each inertia effect (the payload is not one of BODY_NAMES).
CRANK_BODIES = ('crank_d', 'crank_e')
PLATFORM_BODIES = ('platform', 'payload')
LEG_BODIES = tuple(name for name in BODY_NAMES if name not in CRANK_BODIES + PLATFORM_BODIES)


def inertial_bodies(effects: Effects) -> frozenset[str]:
    """The bodies whose inertia wrench (eq. 18) the effects call for."""
    names: set[str] = set()
    if effects.platform_inertia:
        names.add('platform')
    if effects.payload:
        names.add('payload')
    if effects.leg_inertia:
        names.update(LEG_BODIES)
    if effects.crank_inertia:
        names.update(CRANK_BODIES)
    return frozenset(names)


@dataclass
class BodyState:
    """Frame of one body and, if its inertia is simulated, its motion (eq. 18)."""

    body: Body
    axes: tuple[Vec, Vec, Vec]   # body axes x, y, z in the fixed frame (columns of a_k0^T)
    com: Vec                     # centre of mass, fixed frame
    omega: Vec | None = None     # absolute angular velocity omega_k0
    eps: Vec | None = None       # absolute angular acceleration epsilon_k0
    acc: Vec | None = None       # acceleration of the centre of mass


def body_states(model: Model, g: Geometric, V: list | None, Gamma: list | None,
                qd: tuple, qdd: tuple) -> dict[str, BodyState]:
    """Frames of the bodies the scene weighs or moves and, for the moving ones,
    omega, epsilon and the centre-of-mass acceleration from V (eq. 13) and
    Gamma (eq. 15).
    """
    effects = model.effects
    geom = model.geometry
    bodies = model.bodies
    moving = inertial_bodies(effects)
    vp = effects.velocity_products
    present = set(moving) | (set(bodies) if effects.gravity else set())
    if effects.payload:
        present.add('payload')
    zero: Vec = (0.0, 0.0, 0.0)
    out: dict[str, BodyState] = {}

    def add_body(name: str, body: Body, axes: tuple[Vec, Vec, Vec], origin: Vec,
                 kinematics) -> None:
        """kinematics() -> (omega, eps, ref, acc_ref); evaluated only if inertial.
        a_C = a_ref + eps x rho + omega x (omega x rho), rho = C - ref.
        """
        if name not in present:
            return
        com = add(origin, from_frame(axes, body.com_t))
        state = BodyState(body=body, axes=axes, com=com)
        if name in moving:
            omega, eps, ref, acc_ref = kinematics()
            rho = sub(com, ref)
            acc = add(acc_ref, cross(eps, rho))
            if vp:
                acc = add(acc, cross(omega, cross(omega, rho)))
            state.omega, state.eps, state.acc = omega, eps, acc
        out[name] = state

    # chain A: cylinder (omega_10), piston (+ v_21), rod (+ omega_32), platform (+ omega_43)
    zdA = zx(g.dA)
    axes_A = (g.dA, zdA, Z0)

    def leg_a(slide: bool):
        def motion():
            omega, eps = (0.0, 0.0, V[0]), (0.0, 0.0, Gamma[0])
            if not slide:
                return omega, eps, zero, zero
            acc_slide = scale(Gamma[1], g.dA)                       # relative acceleration
            if vp:
                acc_slide = axpy(2.0 * V[1] * V[0], zdA, acc_slide)  # + Coriolis
            return omega, eps, zero, acc_slide
        return motion

    add_body('cylinder_a', bodies['cylinder_a'], axes_A, zero, leg_a(False))
    add_body('piston_a', bodies['piston_a'], axes_A, g.A3, leg_a(True))
    Gdd = (qdd[0], qdd[1], 0.0)
    zl = zx(g.l)
    add_body('rod', bodies['rod'], (g.l, zl, Z0), g.A3,
             lambda: ((0.0, 0.0, V[0] + V[2]), (0.0, 0.0, Gamma[0] + Gamma[2]), g.G, Gdd))

    def platform_motion():
        beta_d, beta_dd, roll_d, roll_dd = V[0] + V[2], Gamma[0] + Gamma[2], qd[2], qdd[2]
        omega = (roll_d * g.l[0], roll_d * g.l[1], beta_d)       # beta' z0 + roll' l
        eps = (roll_dd * g.l[0], roll_dd * g.l[1], beta_dd)
        if vp:
            eps = axpy(beta_d * roll_d, zl, eps)                 # + beta' roll' z0 x l
        return omega, eps, g.G, Gdd

    axes_P = (g.l, g.n, g.t)
    add_body('platform', bodies['platform'], axes_P, g.A3, platform_motion)
    if model.payload is not None:
        add_body('payload', model.payload, axes_P, g.A3, platform_motion)

    # chains B, C: U-joint at the base (omega_10 about z0, omega_21 about e2), slider v_32
    base_x = geom.d2 + geom.d3 + geom.d4
    for leg, k, P1, P4, d, e2 in (('b', 3, (base_x, 0.0, geom.d5), g.B4, g.dB, g.e2B),
                                  ('c', 6, (base_x, 0.0, -geom.d5), g.C4, g.dC, g.e2C)):
        axes = (d, cross(e2, d), e2)

        def leg_bc(slide: bool, k=k, P1=P1, d=d, e2=e2):
            def motion():
                w10, w21 = V[k], V[k + 1]
                omega = (w21 * e2[0], w21 * e2[1], w10)
                eps = (Gamma[k + 1] * e2[0], Gamma[k + 1] * e2[1], Gamma[k])
                if vp:
                    eps = axpy(w10 * w21, zx(e2), eps)
                if not slide:
                    return omega, eps, P1, zero
                acc_slide = scale(Gamma[k + 2], d)
                if vp:
                    acc_slide = axpy(2.0 * V[k + 2], cross(omega, d), acc_slide)
                return omega, eps, P1, acc_slide
            return motion

        add_body(f'cylinder_{leg}', bodies[f'cylinder_{leg}'], axes, P1, leg_bc(False))
        add_body(f'piston_{leg}', bodies[f'piston_{leg}'], axes, P4, leg_bc(True))

    # cranks D, E: rotation about z0 at the fixed pivot
    for name, k, P1, d in (('crank_d', 9, (geom.d2 + geom.d3, 0.0, 0.0), g.dD),
                           ('crank_e', 10, (geom.d2, 0.0, 0.0), g.dE)):
        add_body(name, bodies[name], (d, zx(d), Z0), P1,
                 lambda k=k, P1=P1: ((0.0, 0.0, V[k]), (0.0, 0.0, Gamma[k]), P1, zero))
    return out


def required_wrench(state: BodyState, gravity: float, about: Vec,
                    velocity_products: bool) -> tuple[Vec, Vec]:
    """F_k0, M_k0 of eq. (21) = -(inertia wrench, eq. 18) - (weight, eq. 19) about
    ``about`` (the joint centre A_k): F = m (a_C - g), M = J_C eps + omega x
    J_C omega + (C - A_k) x F, g = -gravity y0 (this machine's vertical), J_C
    applied in the body frame.
    """
    m = state.body.mass
    if state.acc is None:
        force = (0.0, m * gravity, 0.0)
        return force, cross(sub(state.com, about), force)
    a = state.acc
    force = (m * a[0], m * (a[1] + gravity), m * a[2])
    I = state.body.inertia_t
    moment_body = mat_vec(I, to_frame(state.axes, state.eps))
    if velocity_products:
        w = to_frame(state.axes, state.omega)
        moment_body = add(moment_body, cross(w, mat_vec(I, w)))
    moment = add(from_frame(state.axes, moment_body), cross(sub(state.com, about), force))
    return force, moment


def joint_forces(model: Model, g: Geometric,
                 states: dict[str, BodyState]) -> tuple[list, Scalar]:
    """Backward recursion of eq. (20)-(22) along chains A, B, C and cranks D, E:
    tau (12, eq. 13), the accumulated wrench on each joint axis (u3^T F_k
    prismatic, u3^T M_k revolute; tau[11] = 0, the massless slider E2), and
    tau_43 of the platform roll joint A4.
    """
    geom = model.geometry
    grav = model.gravity if model.effects.gravity else 0.0
    vp = model.effects.velocity_products
    zero: Vec = (0.0, 0.0, 0.0)

    def wrench(names: tuple[str, ...], about: Vec) -> tuple[Vec, Vec]:
        F, M = zero, zero
        for name in names:
            if name in states:
                f, m = required_wrench(states[name], grav, about, vp)
                F, M = add(F, f), add(M, m)
        return F, M

    tau = [0.0] * 12
    # chain A, joints A1 (rev z0), A2 (prismatic dA), A3 (rev z0), A4 (rev l); A4 = A3
    A2 = axpy(-geom.l2, g.dA, g.A3)
    F4, M4 = wrench(PLATFORM_BODIES, g.A3)                        # platform (+ payload)
    F30, M30 = wrench(('rod',), g.A3)
    F3, M3 = add(F30, F4), add(M30, M4)                            # r_43 = 0
    F20, M20 = wrench(('piston_a',), A2)
    F2 = add(F20, F3)
    M2 = add(add(M20, M3), cross(sub(g.A3, A2), F3))
    _, M10 = wrench(('cylinder_a',), zero)
    M1 = add(add(M10, M2), cross(A2, F2))                          # r_21 = A2 - A1
    tau[0] = M1[2]                      # u3^T M_1^A, axis z0
    tau[1] = dot(g.dA, F2)              # u3^T F_2^A, axis dA
    tau[2] = M3[2]                      # u3^T M_3^A, axis z0
    tau_43 = dot(g.l, M4)               # u3^T M_4^A, axis l
    # chains B, C: cross at B1 (massless), cylinder B2 = B1, piston from B3 to B4
    base_x = geom.d2 + geom.d3 + geom.d4
    for leg, k, P1, P4, d, e2 in (('b', 3, (base_x, 0.0, geom.d5), g.B4, g.dB, g.e2B),
                                  ('c', 6, (base_x, 0.0, -geom.d5), g.C4, g.dC, g.e2C)):
        P3 = axpy(-geom.l4, d, P4)
        F3, M3 = wrench((f'piston_{leg}',), P3)
        _, M20 = wrench((f'cylinder_{leg}',), P1)
        M2 = add(add(M20, M3), cross(sub(P3, P1), F3))    # M_1 = M_2: massless cross
        tau[k] = M2[2]                  # u3^T M_1^B, axis z0
        tau[k + 1] = dot(e2, M2)        # u3^T M_2^B, axis e2
        tau[k + 2] = dot(d, F3)         # u3^T F_3^B, axis dB
    # cranks D, E
    for name, k, P1 in (('crank_d', 9, (geom.d2 + geom.d3, 0.0, 0.0)),
                        ('crank_e', 10, (geom.d2, 0.0, 0.0))):
        tau[k] = wrench((name,), P1)[1][2]
    return tau, tau_43


def actuator_jacobian(K: tuple[list, list, list]) -> list:
    """J (3x3 nested lists): row i = actuator i, column k = pose coordinate k;
    the actuated rows of V = K qd (eq. 11).
    """
    return [[K[k][j] for k in range(3)] for j in ACTUATED_JOINTS]


def _inverse3(m: list) -> list:
    """Inverse of a 3x3 (nested lists of components) by the adjugate."""
    (a, b, c), (d, e, f), (g, h, i) = m
    A, B, C = e * i - f * h, f * g - d * i, d * h - e * g
    inv_det = 1.0 / (a * A + b * B + c * C)
    return [[A * inv_det, (c * h - b * i) * inv_det, (b * f - c * e) * inv_det],
            [B * inv_det, (a * i - c * g) * inv_det, (c * d - a * f) * inv_det],
            [C * inv_det, (b * g - a * h) * inv_det, (a * e - b * d) * inv_det]]


def virtual_velocities(K: tuple[list, list, list], J: list) -> tuple[list, list, list]:
    """The virtual motions of eq. (14), pose rates J^-1 e_a: the virtual joint
    velocities Vv[j][a] (eq. 11), the virtual roll rates omega_43a and J^-1.
    """
    Jinv = _inverse3(J)
    Vv = [[K[0][j] * Jinv[0][a] + K[1][j] * Jinv[1][a] + K[2][j] * Jinv[2][a]
           for a in range(3)] for j in range(12)]
    return Vv, Jinv[2], Jinv


def actuator_forces(tau: list, tau_43: Scalar, Vv: list, roll_v: list) -> list:
    """Eq. (23): f_a = sum_j Vv[j][a] tau_j + omega_43a tau_43 (+ pushes the ends apart)."""
    return [sum(Vv[j][a] * tau[j] for j in range(11))   # tau[11] = 0: slider E2 is massless
            + roll_v[a] * tau_43 for a in range(3)]


def friction_forces(model: Model, rate: tuple, xp: SimpleNamespace) -> list:
    """Actuator friction (not in the paper; added to eq. 23): viscous x rate +
    Coulomb x tanh(rate / smoothing velocity).
    """
    fr = model.friction
    return [fr.viscous[i] * rate[i] + fr.coulomb[i] * xp.tanh(rate[i] / fr.smoothing_velocity)
            for i in range(3)]
