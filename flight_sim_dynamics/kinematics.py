"""Kinematics of the flight simulator: paper Section 2, eq. (1)-(17).

All vectors are expressed in the fixed frame Ox0y0z0 of the paper (x0 forward,
y0 up, z0 lateral to the right/B side). The paper writes the same relations
with the local transformation matrices a_k0, b_k0, ... (eq. 1-2); projecting on
the fixed frame gives identical scalars, since every joint axis u3 of the paper
is, in the fixed frame, one of the unit vectors used here (z0 for the planar
joints of chain A and the cranks, z0 and e2 for the U-joints of legs B, C, the
leg axis for the prismatic joints and the rod axis l for the slider E2 and
the platform roll).

Every function works on a batch of N samples (arrays with a leading N axis),
so one call solves a whole trajectory; a single control cycle is N = 1.

Joint variables (eq. 13), each measured from the central configuration
(this fixes the paper's unstated alpha_i of eq. 1-2):

========== ================================================================
phi_10_A   rotation of leg A about z0 at A1 (rad)
lambda_21_A stroke of actuator A: L_A - (s_A + l2) (m)
phi_32_A   rotation of the rod A3G relative to leg A, about z0 (rad)
phi_10_B   U-joint B1, first axis z0 (azimuth of leg B) (rad)
phi_21_B   U-joint B1, second axis e2 = unit(z0 x dB) (rad)
lambda_32_B stroke of actuator B: L_B - (s_B + l4) (m)
(C as B)
phi_10_D   rotation of crank D about z0 at D1 (rad)
phi_10_E   rotation of crank E about z0 at E1 (rad)
lambda_E2  slider E2 along the rod, D2E2 - s (m)
========== ================================================================

and phi_43_A = roll (platform about the rod axis l).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .model import CentralConfiguration, Geometry, Model

Z0 = np.array([0.0, 0.0, 1.0])


class UnreachablePoseError(ValueError):
    """A pose the mechanism cannot take: a loop of eq. (7) cannot close."""

    def __init__(self, loop: str, reason: str, index: int | None = None) -> None:
        self.loop = loop
        self.reason = reason
        self.index = index
        where = '' if index is None else f' (sample {index})'
        super().__init__(f'unreachable pose{where}: loop {loop}: {reason}')


class GeometryError(ValueError):
    """The geometry itself cannot close its loops at the central configuration."""

    def __init__(self, key: str, reason: str) -> None:
        self.key = key
        super().__init__(reason)


# ----------------------------------------------------------------------------
# small vector helpers on (..., 3) arrays (faster than np.cross for 3-vectors)
# ----------------------------------------------------------------------------
def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Cross product of (..., 3) arrays."""
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    return np.stack((a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0), axis=-1)


def z_cross(v: np.ndarray) -> np.ndarray:
    """u3~ v: z0 x v, the paper's skew-symmetric u3 applied to v (eq. 10)."""
    return np.stack((-v[..., 1], v[..., 0], np.zeros_like(v[..., 0])), axis=-1)


def dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.einsum('...i,...i->...', a, b)


def norm(v: np.ndarray) -> np.ndarray:
    return np.sqrt(dot(v, v))


def _wrap(angle: np.ndarray) -> np.ndarray:
    return (angle + np.pi) % (2.0 * np.pi) - np.pi


# ----------------------------------------------------------------------------
# Inverse geometry (eq. 5-8)
# ----------------------------------------------------------------------------
@dataclass
class Geometric:
    """Positions of the mechanism for a batch of poses (inverse geometry)."""

    G: np.ndarray       # (N, 3) characteristic point of the platform
    roll: np.ndarray    # (N,)  phi = phi_43_A, eq. (5)
    beta: np.ndarray    # (N,)  parasitic pitch: absolute angle of the rod about z0
    l: np.ndarray       # (N, 3) rod / platform longitudinal axis, A3 -> G
    t: np.ndarray       # (N, 3) platform lateral axis (right)
    n: np.ndarray       # (N, 3) platform normal (up)
    A3: np.ndarray      # (N, 3) joint A3 = A4
    D2: np.ndarray      # (N, 3)
    E2: np.ndarray      # (N, 3)
    u: np.ndarray       # (N,)  |G - E2| along the rod
    B4: np.ndarray      # (N, 3)
    C4: np.ndarray      # (N, 3)
    length: np.ndarray  # (N, 3) leg lengths L_A, L_B, L_C, joint centre to joint centre
    dA: np.ndarray      # (N, 3) unit leg axes, base joint -> platform joint
    dB: np.ndarray
    dC: np.ndarray
    e2B: np.ndarray     # (N, 3) second U-joint axes, unit(z0 x dB)
    e2C: np.ndarray
    dD: np.ndarray      # (N, 3) unit crank axes D1 -> D2, E1 -> E2
    dE: np.ndarray
    raw: np.ndarray     # (N, 12) joint variables before subtracting the central values


def _crank_d_beta(geom: Geometry, G: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Loop D of eq. (7): |G - (h - d1) l(beta) - D1| = l5, root near zero.

    With w = G - D1 and c = h - d1 the condition is w.l = k,
    k = (|w|^2 + c^2 - l5^2) / (2c); so beta = angle(w) - atan2(sqrt(|w|^2 - k^2), k).
    The square root is taken of (|w| - k)(|w| + k), which keeps its digits
    near the closure limit. Returns beta and the discriminant (negative = open).
    """
    c = geom.h - geom.d1
    w = G - geom.D1
    rho2 = w[..., 0] ** 2 + w[..., 1] ** 2
    rho = np.sqrt(rho2)
    k = (rho2 + c * c - geom.l5 ** 2) / (2.0 * c)
    disc = (rho - k) * (rho + k)
    beta = np.arctan2(w[..., 1], w[..., 0]) - np.arctan2(np.sqrt(np.maximum(disc, 0.0)), k)
    return beta, disc


def _crank_e_u(geom: Geometry, G: np.ndarray, l: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Loop E of eq. (7): E2 = G - u l on the rod with |E2 - E1| = l6.

    u^2 - 2 p u + (|w|^2 - l6^2) = 0 with w = G - E1, p = w.l; the machine's root
    is the smaller one, written as (|w|^2 - l6^2) / (p + sqrt(p^2 - |w|^2 + l6^2))
    to avoid cancellation. Returns u and the discriminant (negative = open).
    """
    w = G - geom.E1
    p = dot(w, l)
    c0 = dot(w, w) - geom.l6 ** 2
    disc = p * p - c0
    root = np.sqrt(np.maximum(disc, 0.0))
    with np.errstate(divide='ignore', invalid='ignore'):
        u = np.where(p > 0, c0 / (p + root), p - root)
    return u, disc


def _closure(geom: Geometry, q: np.ndarray) -> tuple[Geometric, dict[str, np.ndarray]]:
    """Positions for poses q (N, 3), and the per-sample validity of each loop."""
    n_samples = q.shape[0]
    G = np.zeros((n_samples, 3))
    G[:, 0] = geom.d2 + geom.d3 + geom.d4 + q[:, 0]
    G[:, 1] = geom.h_G + q[:, 1]
    roll = q[:, 2]

    beta, disc_d = _crank_d_beta(geom, G)
    cb, sb = np.cos(beta), np.sin(beta)
    zeros = np.zeros_like(beta)
    l = np.stack((cb, sb, zeros), axis=-1)
    # platform axes (mechanism.md step 4): t = t0 cos(roll) + (l x t0) sin(roll)
    cr, sr = np.cos(roll), np.sin(roll)
    t = np.stack((sb * sr, -cb * sr, cr), axis=-1)
    n = cross(t, l)
    A3 = G - geom.h * l
    D2 = G - (geom.h - geom.d1) * l
    u, disc_e = _crank_e_u(geom, G, l)
    E2 = G - u[:, None] * l
    B4 = G + 0.5 * geom.b * t
    C4 = G - 0.5 * geom.b * t

    vA = A3 - geom.A1
    vB = B4 - geom.B1
    vC = C4 - geom.C1
    length = np.stack((norm(vA), norm(vB), norm(vC)), axis=-1)
    with np.errstate(divide='ignore', invalid='ignore'):
        dA = vA / length[:, 0:1]
        dB = vB / length[:, 1:2]
        dC = vC / length[:, 2:3]
        hB = np.hypot(dB[:, 0], dB[:, 1])
        hC = np.hypot(dC[:, 0], dC[:, 1])
        e2B = z_cross(dB) / hB[:, None]
        e2C = z_cross(dC) / hC[:, None]
        dD = (D2 - geom.D1) / geom.l5
        dE = (E2 - geom.E1) / geom.l6

    theta_A = np.arctan2(dA[:, 1], dA[:, 0])
    raw = np.stack((
        theta_A,
        length[:, 0] - geom.L0[0],
        beta - theta_A,
        np.arctan2(dB[:, 1], dB[:, 0]),
        -np.arctan2(dB[:, 2], hB),
        length[:, 1] - geom.L0[1],
        np.arctan2(dC[:, 1], dC[:, 0]),
        -np.arctan2(dC[:, 2], hC),
        length[:, 2] - geom.L0[2],
        np.arctan2(dD[:, 1], dD[:, 0]),
        np.arctan2(dE[:, 1], dE[:, 0]),
        (geom.h - geom.d1) - u,          # D2E2; the central value s is removed later
    ), axis=-1)
    data = Geometric(G=G, roll=roll, beta=beta, l=l, t=t, n=n, A3=A3, D2=D2, E2=E2, u=u,
                     B4=B4, C4=C4, length=length, dA=dA, dB=dB, dC=dC, e2B=e2B, e2C=e2C,
                     dD=dD, dE=dE, raw=raw)
    tiny = 1e-9
    valid = {
        'D': disc_d >= 0.0,
        'E': disc_e >= 0.0,
        'E2 on rod': (u >= 0.0) & (u <= geom.h),
        'A': length[:, 0] > tiny,
        'B': (length[:, 1] > tiny) & (hB > tiny),
        'C': (length[:, 2] > tiny) & (hC > tiny),
    }
    return data, valid


_LOOP_REASONS = {
    'D': 'crank D cannot reach the rod (|D2 - D1| = l5 has no solution)',
    'E': 'crank E cannot reach the rod line (|E2 - E1| = l6 has no solution)',
    'E2 on rod': 'slider E2 would leave the rod between A3 and G',
    'A': 'leg A has zero length',
    'B': 'leg B is degenerate (zero length, or along the U-joint axis z0)',
    'C': 'leg C is degenerate (zero length, or along the U-joint axis z0)',
}


def central_configuration(geom: Geometry) -> CentralConfiguration:
    """Solve the loops at q = 0 and fix the zeros of the joint variables
    (the paper's alpha_i, eq. 1-2) and the slider offset s = D2E2 (eq. 8)."""
    data, valid = _closure(geom, np.zeros((1, 3)))
    culprit = {'D': 'l5', 'E': 'l6', 'E2 on rod': 'l6', 'A': 's_A', 'B': 'd5', 'C': 'd5'}
    for loop, ok in valid.items():
        if not bool(ok[0]) or not np.all(np.isfinite(data.raw)):
            raise GeometryError(culprit[loop], _LOOP_REASONS[loop])
    raw = data.raw[0].copy()
    s = float(raw[11])
    zero = raw.copy()
    for i in (1, 5, 8):   # strokes are measured from zero stroke, not from q = 0
        zero[i] = 0.0
    return CentralConfiguration(beta0=float(data.beta[0]), s=s, joint_zero=zero,
                                length=data.length[0].copy())


def inverse_geometry(model: Model, q: np.ndarray) -> Geometric:
    """Inverse geometric problem (eq. 5-8): all 12 joint variables for poses
    q (N, 3) = (surge, heave, roll). Raises :class:`UnreachablePoseError` naming
    the loop of eq. (7) that cannot close and the first sample concerned."""
    data, valid = _closure(model.geometry, q)
    for loop, ok in valid.items():
        if not np.all(ok):
            raise UnreachablePoseError(loop, _LOOP_REASONS[loop], int(np.argmin(ok)))
    data.raw = data.raw - model.central.joint_zero
    for i in (0, 2, 3, 4, 6, 7, 9, 10):
        data.raw[:, i] = _wrap(data.raw[:, i])
    return data


def joint_positions(data: Geometric) -> np.ndarray:
    """The 12 joint variables of eq. (13), measured from the central configuration."""
    return data.raw


# ----------------------------------------------------------------------------
# Velocities: connectivity matrix Q and column P (eq. 11-13)
# ----------------------------------------------------------------------------
def connectivity_matrix(model: Model, g: Geometric) -> tuple[np.ndarray, np.ndarray]:
    """Q (N, 12, 12) and P_q (N, 12, 3), with Q V = P = P_q qd (eq. 11-12).

    Rows: loop A (x0, y0), B (x0, y0, z0), C (x0, y0, z0), D (x0, y0), E (x0, y0),
    i.e. the paper's i = 1, 2 and j = 1, 2, 3. Columns: the joint rates of eq. (13).
    Each entry is the paper's q_ij written in the fixed frame: a revolute joint
    contributes axis x (lever arm), a prismatic joint its axis.
    """
    geom = model.geometry
    N = g.G.shape[0]
    Q = np.zeros((N, 12, 12))
    Pq = np.zeros((N, 12, 3))
    # loop A: A1 + L_A dA + h l = G
    Q[:, 0:2, 0] = z_cross(g.G - geom.A1)[:, :2]          # q_i1^A
    Q[:, 0:2, 1] = g.dA[:, :2]                             # q_i2^A
    Q[:, 0:2, 2] = z_cross(g.G - g.A3)[:, :2]             # q_i3^A
    # loops B, C: B1 + L_B dB = G + r_B (r_B = B4 - G), columns of beta-dot: -z0 x r_B
    for rows, cols, P4, P1, d, e2 in ((slice(2, 5), (3, 4, 5), g.B4, geom.B1, g.dB, g.e2B),
                                      (slice(5, 8), (6, 7, 8), g.C4, geom.C1, g.dC, g.e2C)):
        r = P4 - g.G
        rho = P4 - P1
        Q[:, rows, 0] = -z_cross(r)                        # q_j1^B
        Q[:, rows, 2] = -z_cross(r)                        # q_j3^B
        Q[:, rows, cols[0]] = z_cross(rho)                 # q_j4^B
        Q[:, rows, cols[1]] = cross(e2, rho)               # q_j5^B
        Q[:, rows, cols[2]] = d                            # q_j6^B
        Pq[:, rows, 0] = (1.0, 0.0, 0.0)
        Pq[:, rows, 1] = (0.0, 1.0, 0.0)
        Pq[:, rows, 2] = cross(g.l, r)                     # phi-dot term of p_j^B
    # loop D: D1 + l5 dD = G - (h - d1) l
    Q[:, 8:10, 0] = z_cross(g.G - g.D2)[:, :2]            # q_i1^D
    Q[:, 8:10, 2] = Q[:, 8:10, 0]                          # q_i3^D
    Q[:, 8:10, 9] = z_cross(g.D2 - geom.D1)[:, :2]        # q_i10^D
    # loop E: E1 + l6 dE = G - u l, u = h - d1 - s - lambda
    Q[:, 10:12, 0] = z_cross(g.G - g.E2)[:, :2]           # q_i1^E
    Q[:, 10:12, 2] = Q[:, 10:12, 0]                        # q_i3^E
    Q[:, 10:12, 10] = z_cross(g.E2 - geom.E1)[:, :2]      # q_i11^E
    Q[:, 10:12, 11] = -g.l[:, :2]                          # q_i12^E
    for rows in (slice(0, 2), slice(8, 10), slice(10, 12)):
        Pq[:, rows, 0:2] = np.eye(2)                       # p_i = u_i^T r_0^G-dot
    return Q, Pq


# ----------------------------------------------------------------------------
# Accelerations: column S = P-dot - Q-dot V (eq. 15-17)
# ----------------------------------------------------------------------------
def acceleration_column(model: Model, g: Geometric, V: np.ndarray,
                        qd: np.ndarray, qdd: np.ndarray) -> np.ndarray:
    """S (N, 12) of eq. (16)-(17): Q Gamma = S.

    Each block is the acceleration of the platform side of a loop minus the
    velocity-product (centripetal, Coriolis) terms of the chain side, the
    vector form of the paper's s_i^A, s_j^B, s_j^C, s_i^D, s_i^E.
    """
    geom = model.geometry
    N = g.G.shape[0]
    S = np.zeros((N, 12))
    Gdd = np.zeros((N, 3))
    Gdd[:, 0] = qdd[:, 0]
    Gdd[:, 1] = qdd[:, 1]
    roll_d, roll_dd = qd[:, 2:3], qdd[:, 2:3]
    beta_d = (V[:, 0] + V[:, 2])[:, None]
    zl = z_cross(g.l)
    # loop A
    th, Ld = V[:, 0:1], V[:, 1:2]
    LA = g.length[:, 0:1]
    bias = 2.0 * Ld * th * z_cross(g.dA) - th * th * LA * g.dA - beta_d ** 2 * geom.h * g.l
    S[:, 0:2] = (Gdd - bias)[:, :2]
    # loops B, C
    omega_P = beta_d * Z0 + roll_d * g.l
    eps_P_bias = roll_dd * g.l + beta_d * roll_d * zl          # epsilon_P without beta-ddot
    for rows, k, P4, P1, d, e2 in ((slice(2, 5), 3, g.B4, geom.B1, g.dB, g.e2B),
                                   (slice(5, 8), 6, g.C4, geom.C1, g.dC, g.e2C)):
        r = P4 - g.G
        rho = P4 - P1
        w10, w21, Lr = V[:, k:k + 1], V[:, k + 1:k + 2], V[:, k + 2:k + 3]
        omega = w10 * Z0 + w21 * e2
        platform = Gdd + cross(eps_P_bias, r) + cross(omega_P, cross(omega_P, r))
        chain = (w10 * w21 * cross(z_cross(e2), rho) + cross(omega, cross(omega, rho))
                 + 2.0 * Lr * cross(omega, d))
        S[:, rows] = platform - chain
    # loop D
    thD = V[:, 9:10]
    S[:, 8:10] = (Gdd + beta_d ** 2 * (g.G - g.D2) + thD ** 2 * (g.D2 - geom.D1))[:, :2]
    # loop E
    thE, v = V[:, 10:11], V[:, 11:12]
    S[:, 10:12] = (Gdd + 2.0 * v * beta_d * zl + beta_d ** 2 * (g.G - g.E2)
                   + thE ** 2 * (g.E2 - geom.E1))[:, :2]
    return S
