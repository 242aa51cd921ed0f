"""The recursive matrix solver: one call = inverse geometry, velocities,
accelerations and inverse dynamics (paper eq. 5-23) for one pose or a batch.

>>> import flight_sim_dynamics as fsd
>>> model = fsd.load_model()
>>> sol = fsd.solve(model, [0, 0, 0], [0, 0, 0], [0, 0, 0])
>>> [round(f, 4) for f in sol.force]
[38.6066, 33.2041, 33.2041]
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np

from .dynamics import actuator_forces, body_motions, joint_forces, virtual_velocities
from .kinematics import acceleration_column, connectivity_matrix, inverse_geometry
from .model import ACTUATED_JOINTS, Model


@dataclass(frozen=True)
class Solution:
    """Result of a solve. Leg quantities are ordered A, B, C. For
    :func:`solve_batch` every field has a leading axis of N samples."""

    length: np.ndarray                # leg length, joint centre to joint centre, m
    stroke: np.ndarray                # lambda = L - L0, m
    rate: np.ndarray                  # dL/dt, m/s
    acceleration: np.ndarray          # d2L/dt2, m/s^2
    force: np.ndarray                 # actuator force along the leg, + extends, N
    power: np.ndarray                 # force x rate, W
    joints: np.ndarray                # the 12 joint variables of eq. (13), rad or m
    joint_rates: np.ndarray           # V of eq. (13)
    joint_accelerations: np.ndarray   # Gamma of eq. (15)
    beta: np.ndarray | float          # parasitic pitch (rod angle about z0), rad
    cond: np.ndarray | float          # 2-norm condition number of Q
    jacobian: np.ndarray              # d(L)/d(q), (3, 3): actuator rates = jacobian @ qd


def _as_batch(name: str, value: object, n: int | None) -> np.ndarray:
    try:
        arr = np.array(value, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f'{name} must be numbers (surge, heave, roll), got {value!r}') from None
    if arr.ndim != 2 or arr.shape[1] != 3:
        raise ValueError(f'{name} must have shape (N, 3), got {arr.shape}')
    if n is not None and arr.shape[0] != n:
        raise ValueError(f'{name} has {arr.shape[0]} rows, q has {n}')
    bad = ~np.isfinite(arr)
    if bad.any():
        row, col = np.argwhere(bad)[0]
        raise ValueError(f'{name}[{row}, {col}] is not finite ({arr[row, col]})')
    return arr


def solve_batch(model: Model, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> Solution:
    """Inverse kinematics and dynamics for N samples at once.

    q, qd, qdd: (N, 3) arrays of (surge m, heave m, roll rad) and their first and
    second time derivatives. Raises :class:`UnreachablePoseError` for a pose whose
    loops cannot close and ValueError for malformed or non-finite input.
    """
    q = _as_batch('q', q, None)
    qd = _as_batch('qd', qd, q.shape[0])
    qdd = _as_batch('qdd', qdd, q.shape[0])
    g = inverse_geometry(model, q)                           # eq. (5)-(8)
    Q, Pq = connectivity_matrix(model, g)                    # eq. (11)-(12)
    K = np.linalg.solve(Q, Pq)                               # V = Q^-1 P, per unit pose rate
    V = np.einsum('nij,nj->ni', K, qd)                       # eq. (11), (13)
    S = acceleration_column(model, g, V, qd, qdd)            # eq. (17)
    Gamma = np.linalg.solve(Q, S[..., None])[..., 0]         # eq. (16)
    motions = body_motions(model, g, V, Gamma, qd, qdd)
    tau, tau_43 = joint_forces(model, g, motions)            # eq. (18)-(22)
    J, V_virtual, roll_virtual = virtual_velocities(K)       # eq. (14)
    force = actuator_forces(tau, tau_43, V_virtual, roll_virtual)   # eq. (23)
    idx = list(ACTUATED_JOINTS)
    rate = V[:, idx]
    return Solution(length=g.length, stroke=g.raw[:, idx], rate=rate,
                    acceleration=Gamma[:, idx], force=force, power=force * rate,
                    joints=g.raw, joint_rates=V, joint_accelerations=Gamma,
                    beta=g.beta, cond=np.linalg.cond(Q), jacobian=J)


def solve(model: Model, q: Sequence[float], qd: Sequence[float],
          qdd: Sequence[float]) -> Solution:
    """Solve one control cycle: q, qd, qdd are 3 floats each (surge m, heave m,
    roll rad, and their derivatives). Fields are arrays of 3 (legs A, B, C) or
    12 (joints); ``beta`` and ``cond`` are floats."""
    batch = solve_batch(model, [_three('q', q)], [_three('qd', qd)], [_three('qdd', qdd)])
    return Solution(**{name: (float(value[0]) if name in ('beta', 'cond') else value[0])
                       for name, value in batch.__dict__.items()})


def _three(name: str, value: Sequence[float]) -> Sequence[float]:
    if isinstance(value, (str, bytes)) or np.ndim(value) != 1 or len(value) != 3:
        raise ValueError(f'{name} must be 3 numbers (surge, heave, roll), got {value!r}')
    return value
