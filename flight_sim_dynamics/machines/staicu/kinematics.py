"""Kinematics of the flight simulator: paper Section 2, eq. (1)-(17).

Vectors (:mod:`.vectors`) are in the paper's fixed frame Ox0y0z0 (x0 forward,
y0 up, z0 to the B side): the projections of the paper's local relations
(eq. 1-2), every joint axis u3 being one of the unit vectors used here.
Joint variables (eq. 13), measured from the central configuration (this fixes
the paper's unstated alpha_i of eq. 1-2):

=========== ===============================================================
phi_10_A    rotation of leg A about z0 at A1 (rad)
lambda_21_A stroke of actuator A: L_A - (s_A + l2) (m)
phi_32_A    rotation of the rod A3G relative to leg A, about z0 (rad)
phi_10_B    U-joint B1, first axis z0 (azimuth of leg B) (rad)
phi_21_B    U-joint B1, second axis e2 = unit(z0 x dB) (rad)
lambda_32_B stroke of actuator B: L_B - (s_B + l4) (m)
(C as B)
phi_10_D    rotation of crank D about z0 at D1 (rad)
phi_10_E    rotation of crank E about z0 at E1 (rad)
lambda_E2   slider E2 along the rod: D2E2 - s (m)
=========== ===============================================================

and phi_43_A = roll (platform about the rod axis l).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from types import SimpleNamespace

import numpy as np

from ...core.vectors import Scalar, Vec, axpy, backend, cross, dot, scale, sub, zx
from .model import CentralConfiguration, Geometry, Model

Z0: Vec = (0.0, 0.0, 1.0)
_ANGLES = (0, 2, 3, 4, 6, 7, 9, 10)   # joint variables that are angles


class UnreachablePoseError(ValueError):
    """A pose the mechanism cannot take: a loop of eq. (7) cannot close."""

    def __init__(self, loop: str, reason: str, index: int | None = None) -> None:
        self.loop, self.reason, self.index = loop, reason, index
        where = '' if index is None else f' (sample {index})'
        super().__init__(f'unreachable pose{where}: loop {loop}: {reason}')


class GeometryError(ValueError):
    """The geometry itself cannot close its loops (eq. 7) at the central
    configuration.
    """

    def __init__(self, key: str, reason: str) -> None:
        self.key = key
        super().__init__(reason)


LOOP_REASONS = {
    'D': 'crank D cannot reach the rod (|D2 - D1| = l5 has no solution)',
    'E': 'crank E cannot reach the rod line (|E2 - E1| = l6 has no solution)',
    'E2 on rod': 'slider E2 would leave the rod between A3 and G',
    'A': 'leg A has zero length',
    'B': 'leg B is degenerate (zero length, or along the U-joint axis z0)',
    'C': 'leg C is degenerate (zero length, or along the U-joint axis z0)',
}
#: The loops in the order checked: a pose is unreachable by the first that cannot close.
LOOPS = tuple(LOOP_REASONS)
_CULPRIT_KEY = {'D': 'l5', 'E': 'l6', 'E2 on rod': 'l6', 'A': 's_A', 'B': 'd5', 'C': 'd5'}


# Inverse geometry (eq. 5-8)
@dataclass
class Geometric:
    """Positions of eq. (5)-(8) for one pose (float components) or a batch
    (array components).
    """

    xp: SimpleNamespace  # elementary functions matching the components
    G: Vec               # characteristic point of the platform
    roll: Scalar         # phi = phi_43_A, eq. (5)
    beta: Scalar         # parasitic pitch: absolute angle of the rod about z0
    l: Vec               # rod / platform longitudinal axis, A3 -> G
    t: Vec               # platform lateral axis (right)
    n: Vec               # platform normal (up)
    A3: Vec              # joint A3 = A4
    D2: Vec
    E2: Vec
    u: Scalar            # |G - E2| along the rod
    B4: Vec
    C4: Vec
    length: tuple[Scalar, Scalar, Scalar]   # L_A, L_B, L_C, joint centre to joint centre
    dA: Vec              # unit leg axes, base joint -> platform joint
    dB: Vec
    dC: Vec
    e2B: Vec             # second U-joint axes, unit(z0 x dB)
    e2C: Vec
    hB: Scalar           # |z0 x dB|: 0 = leg along the U-joint axis (singular)
    hC: Scalar
    dD: Vec              # unit crank axes D1 -> D2, E1 -> E2
    dE: Vec
    raw: list            # 12 joint variables before subtracting the central values
    valid: dict          # loop -> closes (bool or boolean array)


def _crank_d_beta(geom: Geometry, G: Vec, xp: SimpleNamespace) -> tuple[Scalar, Scalar]:
    """Loop D of eq. (7): |G - (h - d1) l(beta) - D1| = l5, root near zero:
    beta = angle(w) - atan2(sqrt(|w|^2 - k^2), k), w = G - D1, c = h - d1,
    k = (|w|^2 + c^2 - l5^2) / (2c), the root of (|w| - k)(|w| + k) for its
    digits. Returns beta and the discriminant (negative = open).
    """
    c = geom.h - geom.d1
    wx, wy = G[0] - (geom.d2 + geom.d3), G[1]
    rho2 = wx * wx + wy * wy
    rho = xp.sqrt(rho2)
    k = (rho2 + c * c - geom.l5 * geom.l5) / (2.0 * c)
    disc = (rho - k) * (rho + k)
    return xp.atan2(wy, wx) - xp.atan2(xp.sqrt(xp.clip0(disc)), k), disc


def _crank_e_u(geom: Geometry, G: Vec, l: Vec, xp: SimpleNamespace) -> tuple[Scalar, Scalar]:
    """Loop E of eq. (7): E2 = G - u l with |E2 - E1| = l6, u^2 - 2 p u + (|w|^2 -
    l6^2) = 0 (w = G - E1, p = w.l); the smaller root, without cancellation.
    Returns u and the discriminant (negative = open).
    """
    wx, wy = G[0] - geom.d2, G[1]
    p = wx * l[0] + wy * l[1]
    c0 = wx * wx + wy * wy - geom.l6 * geom.l6
    disc = p * p - c0
    root = xp.sqrt(xp.clip0(disc))
    denominator = p + root
    if xp.batch:
        with np.errstate(divide='ignore', invalid='ignore'):
            u = np.where(denominator > 0.0, c0 / denominator, p - root)
    else:
        u = c0 / denominator if denominator > 0.0 else p - root
    return u, disc


def _unit_leg(P4: Vec, P1: Vec, xp: SimpleNamespace) -> tuple[Scalar, Vec, Scalar, Vec]:
    """Length, unit axis, |z0 x d| and second U-joint axis e2 of a leg P1 -> P4."""
    v = sub(P4, P1)
    L = xp.sqrt(dot(v, v))
    d = scale(1.0 / L, v)
    h = xp.hypot(d[0], d[1])
    return L, d, h, (-d[1] / h, d[0] / h, 0.0)


def closure(geom: Geometry, q: tuple[Scalar, Scalar, Scalar], xp: SimpleNamespace) -> Geometric:
    """Positions of every joint for the pose q = (surge, heave, roll) and which
    loops close (mechanism.md steps 1-5; eq. 7-8).
    """
    surge, heave, roll = q
    G = (geom.d2 + geom.d3 + geom.d4 + surge, geom.h_G + heave, 0.0)
    beta, disc_d = _crank_d_beta(geom, G, xp)
    cb, sb = xp.cos(beta), xp.sin(beta)
    cr, sr = xp.cos(roll), xp.sin(roll)
    l = (cb, sb, 0.0)
    t = (sb * sr, -cb * sr, cr)           # t0 cos(roll) + (l x t0) sin(roll)
    n = (-cr * sb, cr * cb, sr)           # t x l
    A3 = axpy(-geom.h, l, G)
    D2 = axpy(-(geom.h - geom.d1), l, G)
    u, disc_e = _crank_e_u(geom, G, l, xp)
    E2 = axpy(-u, l, G)
    half_b = 0.5 * geom.b
    B4 = axpy(half_b, t, G)
    C4 = axpy(-half_b, t, G)
    LA = xp.hypot(A3[0], A3[1])
    dA = (A3[0] / LA, A3[1] / LA, 0.0)
    B1 = (geom.d2 + geom.d3 + geom.d4, 0.0, geom.d5)
    C1 = (B1[0], 0.0, -geom.d5)
    LB, dB, hB, e2B = _unit_leg(B4, B1, xp)
    LC, dC, hC, e2C = _unit_leg(C4, C1, xp)
    dD = ((D2[0] - geom.d2 - geom.d3) / geom.l5, D2[1] / geom.l5, 0.0)
    dE = ((E2[0] - geom.d2) / geom.l6, E2[1] / geom.l6, 0.0)
    theta_A = xp.atan2(dA[1], dA[0])
    L0 = geom.L0
    raw = [theta_A, LA - L0[0], beta - theta_A,
           xp.atan2(dB[1], dB[0]), -xp.atan2(dB[2], hB), LB - L0[1],
           xp.atan2(dC[1], dC[0]), -xp.atan2(dC[2], hC), LC - L0[2],
           xp.atan2(dD[1], dD[0]), xp.atan2(dE[1], dE[0]),
           (geom.h - geom.d1) - u]            # D2E2; the central value s is removed later
    tiny = 1e-9
    valid = {'D': disc_d >= 0.0, 'E': disc_e >= 0.0,
             'E2 on rod': (u >= 0.0) & (u <= geom.h),
             'A': LA > tiny, 'B': (LB > tiny) & (hB > tiny), 'C': (LC > tiny) & (hC > tiny)}
    return Geometric(xp=xp, G=G, roll=roll, beta=beta, l=l, t=t, n=n, A3=A3, D2=D2, E2=E2,
                     u=u, B4=B4, C4=C4, length=(LA, LB, LC), dA=dA, dB=dB, dC=dC,
                     e2B=e2B, e2C=e2C, hB=hB, hC=hC, dD=dD, dE=dE, raw=raw, valid=valid)


def central_configuration(geom: Geometry) -> CentralConfiguration:
    """Solve the loops at q = 0 and fix the zeros of the joint variables
    (the paper's alpha_i, eq. 1-2) and the slider offset s = D2E2 (eq. 8).
    """
    xp = backend(False)
    with np.errstate(all='ignore'):
        try:
            g = closure(geom, (0.0, 0.0, 0.0), xp)
        except (ZeroDivisionError, ValueError) as exc:
            raise GeometryError('h', f'degenerate geometry ({exc})') from None
    for loop in LOOPS:
        if not g.valid[loop]:
            raise GeometryError(_CULPRIT_KEY[loop], LOOP_REASONS[loop])
    raw = np.array(g.raw, dtype=float)
    if not np.all(np.isfinite(raw)):
        raise GeometryError('h', 'degenerate geometry (non-finite joint variables)')
    zero = raw.copy()
    zero[[1, 5, 8]] = 0.0       # strokes are measured from zero stroke, not from q = 0
    return CentralConfiguration(beta0=float(g.beta), s=float(raw[11]), joint_zero=zero,
                                length=np.array(g.length, dtype=float))


def inverse_geometry(model: Model, q: tuple[Scalar, Scalar, Scalar],
                     xp: SimpleNamespace, check: bool = True) -> Geometric:
    """Inverse geometric problem (eq. 5-8): the 12 joint variables of the pose
    q; with ``check``, UnreachablePoseError naming the loop of eq. (7) that
    cannot close, else ``valid`` tells per sample.
    """
    if xp.batch:
        with np.errstate(all='ignore'):
            g = closure(model.geometry, q, xp)
    else:
        try:
            g = closure(model.geometry, q, xp)
        except (ZeroDivisionError, ValueError):
            raise UnreachablePoseError('A', 'degenerate leg geometry') from None
    for loop in LOOPS:
        if check and not xp.all(g.valid[loop]):
            raise UnreachablePoseError(loop, LOOP_REASONS[loop], xp.first_false(g.valid[loop]))
    zero = model.central.joint_zero
    raw = [v - z for v, z in zip(g.raw, zero)]
    for i in _ANGLES:   # wrap the angle differences into (-pi, pi]
        raw[i] = (raw[i] + math.pi) % (2.0 * math.pi) - math.pi
    g.raw = raw
    return g


# Velocities: connectivity relations Q V = P (eq. 11-13)
@dataclass
class Connectivity:
    """Block factorisation of the connectivity matrix Q of eq. (11)-(12): loop D
    fixes beta-dot and omega_10^D; then loops A, B, C (orthogonal columns:
    projections) and E (Cramer) are independent. Q is never formed.
    """

    aD: Vec      # Q columns of loop D: beta-dot (z0 x (G - D2)), omega_10^D (z0 x (D2 - D1))
    bD: Vec
    detD: Scalar
    cA: Vec      # z0 x (G - A3): beta-dot column of loop A (q_i3^A)
    aE: Vec      # loop E: omega_10^E column, beta-dot column; the slider column is -l
    cE: Vec
    detE: Scalar
    cB: Vec      # -(z0 x (B4 - G)): beta-dot column of loop B (q_j1^B = q_j3^B)
    cC: Vec
    eB: Vec      # e2 x dB: direction of the omega_21^B column
    eC: Vec


def factorize(model: Model, g: Geometric) -> Connectivity:
    """The per-pose factors of Q (eq. 11-12) that :func:`solve_connectivity` uses."""
    geom = model.geometry
    D1 = (geom.d2 + geom.d3, 0.0, 0.0)
    E1 = (geom.d2, 0.0, 0.0)
    aD, bD = zx(sub(g.G, g.D2)), zx(sub(g.D2, D1))
    aE, bE = zx(sub(g.E2, E1)), g.l
    return Connectivity(
        aD=aD, bD=bD, detD=aD[0] * bD[1] - aD[1] * bD[0],
        cA=zx(sub(g.G, g.A3)),
        aE=aE, cE=zx(sub(g.G, g.E2)), detE=-(aE[0] * bE[1] - aE[1] * bE[0]),
        cB=scale(-1.0, zx(sub(g.B4, g.G))), cC=scale(-1.0, zx(sub(g.C4, g.G))),
        eB=cross(g.e2B, g.dB), eC=cross(g.e2C, g.dC))


def solve_connectivity(g: Geometric, f: Connectivity, r: list) -> list:
    """Solve Q X = r (eq. 11 and 16) by block substitution; r and X are lists of
    12 components (rows: loop A x0,y0; B x0,y0,z0; C x0,y0,z0; D x0,y0; E x0,y0).
    """
    X = [0.0] * 12
    # loop D: aD beta-dot + bD omega_10^D = r_D
    beta_dot = (r[8] * f.bD[1] - r[9] * f.bD[0]) / f.detD
    X[9] = (f.aD[0] * r[9] - f.aD[1] * r[8]) / f.detD
    # loop A: omega_10^A z0 x (A3 - A1) + v_21^A dA = r_A - beta-dot cA
    rx, ry = r[0] - f.cA[0] * beta_dot, r[1] - f.cA[1] * beta_dot
    dA = g.dA
    X[1] = dA[0] * rx + dA[1] * ry
    X[0] = (dA[0] * ry - dA[1] * rx) / g.length[0]
    X[2] = beta_dot - X[0]
    # loop E: omega_10^E aE - v l = r_E - beta-dot cE   (Cramer, columns aE and -l)
    rx, ry = r[10] - f.cE[0] * beta_dot, r[11] - f.cE[1] * beta_dot
    l = g.l
    X[10] = (-rx * l[1] + ry * l[0]) / f.detE
    X[11] = (f.aE[0] * ry - f.aE[1] * rx) / f.detE
    # loops B, C: columns L h e2, L (e2 x d), d are orthogonal
    for k, row, c, e2, e, d, h, L in ((3, 2, f.cB, g.e2B, f.eB, g.dB, g.hB, g.length[1]),
                                      (6, 5, f.cC, g.e2C, f.eC, g.dC, g.hC, g.length[2])):
        rr = (r[row] - c[0] * beta_dot, r[row + 1] - c[1] * beta_dot, r[row + 2])
        X[k] = dot(e2, rr) / (L * h)
        X[k + 1] = dot(e, rr) / L
        X[k + 2] = dot(d, rr)
    return X


def pose_rate_columns(g: Geometric) -> tuple[list, list, list]:
    """The columns of P per unit surge, heave and roll rate (eq. 12): P = P_q qd."""
    rB, rC = sub(g.B4, g.G), sub(g.C4, g.G)
    lB, lC = cross(g.l, rB), cross(g.l, rC)
    surge = [1.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 1.0, 0.0]
    heave = [0.0, 1.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 1.0]
    roll = [0.0, 0.0, lB[0], lB[1], lB[2], lC[0], lC[1], lC[2], 0.0, 0.0, 0.0, 0.0]
    return surge, heave, roll


def connectivity_matrix(model: Model, g: Geometric) -> tuple[np.ndarray, np.ndarray]:
    """Q (N, 12, 12) and P_q (N, 12, 3) as dense arrays (eq. 11-12), for cond(Q)."""
    f = factorize(model, g)
    geom = model.geometry
    cols = {}   # (row block, column) -> vector
    cols[('A', 0)] = zx(sub(g.G, (0.0, 0.0, 0.0)))                         # q_i1^A
    cols[('A', 1)] = g.dA                                                   # q_i2^A
    cols[('A', 2)] = f.cA                                                   # q_i3^A
    for blk, k, P1, P4, d, e2, c in (('B', 3, (geom.d2 + geom.d3 + geom.d4, 0.0, geom.d5),
                                      g.B4, g.dB, g.e2B, f.cB),
                                     ('C', 6, (geom.d2 + geom.d3 + geom.d4, 0.0, -geom.d5),
                                      g.C4, g.dC, g.e2C, f.cC)):
        rho = sub(P4, P1)
        cols[(blk, 0)] = cols[(blk, 2)] = c                                 # q_j1, q_j3
        cols[(blk, k)] = zx(rho)                                            # q_j4^B
        cols[(blk, k + 1)] = cross(e2, rho)                                 # q_j5^B
        cols[(blk, k + 2)] = d                                              # q_j6^B
    cols[('D', 0)] = cols[('D', 2)] = f.aD                                  # q_i1^D, q_i3^D
    cols[('D', 9)] = f.bD                                                   # q_i10^D
    cols[('E', 0)] = cols[('E', 2)] = f.cE                                  # q_i1^E, q_i3^E
    cols[('E', 10)] = f.aE                                                  # q_i11^E
    cols[('E', 11)] = scale(-1.0, g.l)                                      # q_i12^E
    rows = {'A': (0, 2), 'B': (2, 3), 'C': (5, 3), 'D': (8, 2), 'E': (10, 2)}
    n = np.size(g.G[0])
    Q = np.zeros((n, 12, 12))
    for (blk, col), vec in cols.items():
        start, size = rows[blk]
        for i in range(size):
            Q[:, start + i, col] = vec[i]
    Pq = np.zeros((n, 12, 3))
    for j, column in enumerate(pose_rate_columns(g)):
        for i in range(12):
            Pq[:, i, j] = column[i]
    return Q, Pq


# Accelerations: column S = P-dot - Q-dot V (eq. 15-17)
def acceleration_column(model: Model, g: Geometric, V: list,
                        qd: tuple[Scalar, Scalar, Scalar],
                        qdd: tuple[Scalar, Scalar, Scalar]) -> list:
    """S of eq. (16)-(17) (12 components), Q Gamma = S: per loop the platform
    side's acceleration minus the chain's velocity products (s_i^A ... s_i^E).
    """
    geom = model.geometry
    Gdd = (qdd[0], qdd[1], 0.0)
    roll_d, roll_dd = qd[2], qdd[2]
    beta_d = V[0] + V[2]
    beta_d2 = beta_d * beta_d
    zl = zx(g.l)
    S = [0.0] * 12
    # loop A: S_A = G'' - (2 L' th' z x dA - th'^2 L dA - beta'^2 h l)
    th, Ld, LA = V[0], V[1], g.length[0]
    zdA = zx(g.dA)
    for i in (0, 1):
        S[i] = (Gdd[i] - 2.0 * Ld * th * zdA[i] + th * th * LA * g.dA[i]
                + beta_d2 * geom.h * g.l[i])
    # loops B, C
    omega_P = (roll_d * g.l[0], roll_d * g.l[1], beta_d)    # beta' z0 + roll' l
    eps_bias = axpy(roll_dd, g.l, scale(beta_d * roll_d, zl))     # eps_P without beta''
    base_x = geom.d2 + geom.d3 + geom.d4
    for row, k, P4, P1, d, e2 in ((2, 3, g.B4, (base_x, 0.0, geom.d5), g.dB, g.e2B),
                                  (5, 6, g.C4, (base_x, 0.0, -geom.d5), g.dC, g.e2C)):
        r = sub(P4, g.G)
        rho = sub(P4, P1)
        w10, w21, Lr = V[k], V[k + 1], V[k + 2]
        omega = (w21 * e2[0], w21 * e2[1], w10)
        platform = cross(eps_bias, r)
        platform = axpy(1.0, cross(omega_P, cross(omega_P, r)), platform)
        chain = scale(w10 * w21, cross(zx(e2), rho))
        chain = axpy(1.0, cross(omega, cross(omega, rho)), chain)
        chain = axpy(2.0 * Lr, cross(omega, d), chain)
        for i in range(3):
            S[row + i] = Gdd[i] + platform[i] - chain[i]
    # loop D: S_D = G'' + beta'^2 (G - D2) + th_D'^2 (D2 - D1)
    thD2 = V[9] * V[9]
    D1x = geom.d2 + geom.d3
    S[8] = Gdd[0] + beta_d2 * (g.G[0] - g.D2[0]) + thD2 * (g.D2[0] - D1x)
    S[9] = Gdd[1] + beta_d2 * (g.G[1] - g.D2[1]) + thD2 * g.D2[1]
    # loop E: S_E = G'' + 2 v beta' z x l + beta'^2 (G - E2) + th_E'^2 (E2 - E1)
    thE2, v = V[10] * V[10], V[11]
    S[10] = (Gdd[0] + 2.0 * v * beta_d * zl[0] + beta_d2 * (g.G[0] - g.E2[0])
             + thE2 * (g.E2[0] - geom.d2))
    S[11] = Gdd[1] + 2.0 * v * beta_d * zl[1] + beta_d2 * (g.G[1] - g.E2[1]) + thE2 * g.E2[1]
    return S
