"""The recursive matrix solver: one call = inverse geometry, velocities,
accelerations and inverse dynamics (paper eq. 5-23) for one pose or a batch.

:func:`solve` runs on plain Python floats (one control cycle, no numpy call
overhead); :func:`solve_batch` runs the same code on numpy columns of N
samples. Both return a :class:`Solution`.

>>> import flight_sim_dynamics as fsd
>>> model = fsd.load_model()
>>> sol = fsd.solve(model, [0, 0, 0], [0, 0, 0], [0, 0, 0])
>>> [round(f, 4) for f in sol.force]
[38.6066, 33.2041, 33.2041]
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import cached_property
from typing import Sequence

import numpy as np

from .dynamics import (actuator_forces, actuator_jacobian, body_states, friction_forces,
                       joint_forces, virtual_velocities)
from .kinematics import (Geometric, acceleration_column, connectivity_matrix, factorize,
                         inverse_geometry, pose_rate_columns, solve_connectivity)
from .model import ACTUATED_JOINTS, Model
from .vectors import backend

_A, _B, _C = ACTUATED_JOINTS


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
    jacobian: np.ndarray              # dL/dq (3, 3): leg rates = jacobian @ qd
    model: Model = field(repr=False, compare=False)
    geometric: Geometric = field(repr=False, compare=False)

    @cached_property
    def Q(self) -> np.ndarray:
        """The connectivity matrix of eq. (11)-(12), (12, 12) or (N, 12, 12); the
        solver itself never forms it (see kinematics.Connectivity)."""
        Q = connectivity_matrix(self.model, self.geometric)[0]
        return Q if self.geometric.xp.batch else Q[0]

    @cached_property
    def cond(self) -> np.ndarray | float:
        """2-norm condition number of Q (SVD), computed on first access only: it
        is a diagnostic and costs more than the whole solve."""
        value = np.linalg.cond(self.Q)
        return value if self.geometric.xp.batch else float(value)


def _solve(model: Model, q: tuple, qd: tuple, qdd: tuple, batch: bool) -> Solution:
    xp = backend(batch)
    g = inverse_geometry(model, q, xp)                                   # eq. (5)-(8)
    f = factorize(model, g)                                              # Q, eq. (12)
    K = tuple(solve_connectivity(g, f, P) for P in pose_rate_columns(g))  # Q^-1 P per unit rate
    V = [K[0][j] * qd[0] + K[1][j] * qd[1] + K[2][j] * qd[2] for j in range(12)]  # eq. (11)
    S = acceleration_column(model, g, V, qd, qdd)                        # eq. (17)
    Gamma = solve_connectivity(g, f, S)                                  # eq. (16)
    effects = model.effects
    if effects.velocity_products or not effects.any_inertia:
        Gamma_dyn = Gamma
    else:   # accelerations from rest: Q^-1 (P_q qdd) = K qdd, no velocity products
        Gamma_dyn = [K[0][j] * qdd[0] + K[1][j] * qdd[1] + K[2][j] * qdd[2] for j in range(12)]
    states = body_states(model, g, V, Gamma_dyn, qd, qdd)
    tau, tau_43 = joint_forces(model, g, states)                         # eq. (18)-(22)
    J = actuator_jacobian(K)
    Vv, roll_v = virtual_velocities(K, J)                                # eq. (14)
    force = actuator_forces(tau, tau_43, Vv, roll_v)                     # eq. (23)
    rate = (V[_A], V[_B], V[_C])
    if effects.friction:
        force = [fi + ff for fi, ff in zip(force, friction_forces(model, rate, xp))]
    pack = _pack_batch if batch else _pack_single
    return Solution(
        length=pack(g.length), stroke=pack((g.raw[_A], g.raw[_B], g.raw[_C])),
        rate=pack(rate), acceleration=pack((Gamma[_A], Gamma[_B], Gamma[_C])),
        force=pack(force), power=pack([fi * ri for fi, ri in zip(force, rate)]),
        joints=pack(g.raw), joint_rates=pack(V), joint_accelerations=pack(Gamma),
        beta=g.beta, jacobian=np.stack([pack(row) for row in J], axis=-2),
        model=model, geometric=g)


def _pack_single(values: Sequence[float]) -> np.ndarray:
    return np.array(values, dtype=float)


def _pack_batch(values: Sequence[np.ndarray | float]) -> np.ndarray:
    return np.stack(np.broadcast_arrays(*values), axis=-1).astype(float, copy=False)


def solve(model: Model, q: Sequence[float], qd: Sequence[float],
          qdd: Sequence[float]) -> Solution:
    """Solve one control cycle: q, qd, qdd are 3 floats each (surge m, heave m,
    roll rad, and their derivatives). Leg fields are arrays of 3 (A, B, C), joint
    fields arrays of 12; ``beta`` and ``cond`` are floats. Raises
    :class:`UnreachablePoseError` for a pose whose loops cannot close and
    ValueError for malformed or non-finite input."""
    return _solve(model, _three('q', q), _three('qd', qd), _three('qdd', qdd), batch=False)


def solve_batch(model: Model, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> Solution:
    """Inverse kinematics and dynamics for N samples at once, vectorised.

    q, qd, qdd: (N, 3) arrays of (surge m, heave m, roll rad) and their first and
    second time derivatives. Fields of the result have a leading N axis.
    """
    q = _as_batch('q', q, None)
    qd = _as_batch('qd', qd, len(q[0]))
    qdd = _as_batch('qdd', qdd, len(q[0]))
    return _solve(model, q, qd, qdd, batch=True)


def _three(name: str, value: Sequence[float]) -> tuple[float, float, float]:
    if isinstance(value, (str, bytes)) or np.ndim(value) != 1 or len(value) != 3:
        raise ValueError(f'{name} must be 3 numbers (surge, heave, roll), got {value!r}')
    try:
        out = tuple(float(v) for v in value)
    except (TypeError, ValueError):
        raise ValueError(f'{name} must be numbers (surge, heave, roll), got {value!r}') from None
    for i, v in enumerate(out):
        if not math.isfinite(v):
            raise ValueError(f'{name}[{i}] is not finite ({v})')
    return out  # type: ignore[return-value]


def _as_batch(name: str, value: object, n: int | None) -> tuple[np.ndarray, ...]:
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
    columns = np.ascontiguousarray(arr.T)
    return columns[0], columns[1], columns[2]
