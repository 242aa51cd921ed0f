"""The recursive matrix solver: one call = inverse geometry, velocities,
accelerations and inverse dynamics (paper eq. 5-23) for one pose or a batch.

:func:`solve` (one cycle) and :func:`solve_batch` (N samples) run the compiled
kernel (:mod:`.kernel`) when built, else the Python code below, the reference
(plain floats for one cycle, numpy columns for a batch). Every status comes
from one rule, :func:`.status_rule.sample_status`.

>>> import flight_sim_dynamics as fsd
>>> model = fsd.load_model()
>>> sol = fsd.solve(model, [0, 0, 0], [0, 0, 0], [0, 0, 0])
>>> [round(f, 4) for f in sol.force]
[38.6066, 33.2041, 33.2041]
"""
from __future__ import annotations

import math
import numbers
from dataclasses import dataclass, field
from functools import cached_property
from types import SimpleNamespace
from typing import Sequence

import numpy as np

from . import kernel
from ...core.kernel import Kept
from ...core.status import BY_SEVERITY, SEVERITY, SINGULAR, Status
from ...core.vectors import Scalar, backend
from .dynamics import (actuator_forces, actuator_jacobian, body_states, friction_forces,
                       joint_forces, virtual_velocities)
from .kinematics import (Connectivity, Geometric, acceleration_column, connectivity_matrix,
                         factorize, inverse_geometry, pose_rate_columns, solve_connectivity)
from .model import ACTUATED_JOINTS, Model
from .status_rule import (all_finite, condition_2x2, describe, first_bad_input, first_open_loop,
                          sample_status)

_SCALAR, _ARRAY = backend(False), backend(True)

_A, _B, _C = ACTUATED_JOINTS


@dataclass(frozen=True)
class Solution:
    """Result of a solve (eq. 5-23). Leg quantities are ordered A, B, C. For
    :func:`solve_batch` every field has a leading axis of N samples.
    """

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
    kinematic_condition: np.ndarray | float   # condition of Q from its block factorisation
    jacobian_condition: np.ndarray | float    # condition of the scaled actuator Jacobian
    status: Status | np.ndarray       # ok, limit, near_singular, unreachable, invalid_input
    detail: str | tuple               # why the status is not ok ('' when ok)
    model: Model = field(repr=False, compare=False)
    pose: tuple | np.ndarray = field(repr=False, compare=False)   # the q solved for

    @property
    def _batch(self) -> bool:
        return np.ndim(self.force) == 2

    @cached_property
    def geometric(self) -> Geometric | None:
        """Joint positions (eq. 5-8), recomputed from ``pose`` on first access;
        None for an unreachable pose or invalid input (single solve).
        """
        if not self._batch:
            if SEVERITY[self.status] >= 3:
                return None
            return inverse_geometry(self.model, tuple(self.pose), _SCALAR)
        q = np.where(np.isfinite(self.pose), self.pose, 0.0)
        with np.errstate(all='ignore'):
            return inverse_geometry(self.model, tuple(np.ascontiguousarray(q.T)), _ARRAY,
                                    check=False)

    @cached_property
    def Q(self) -> np.ndarray:
        """The connectivity matrix of eq. (11)-(12), (12, 12) or (N, 12, 12), for
        diagnostics (the solver never forms it); zero where void.
        """
        if self.geometric is None:
            return np.zeros((12, 12))
        with np.errstate(all='ignore'):
            Q = connectivity_matrix(self.model, self.geometric)[0]
        if not self._batch:
            return Q[0]
        Q[np.asarray([SEVERITY[s] >= 3 for s in self.status], dtype=bool)] = 0.0
        return np.where(np.isfinite(Q), Q, 0.0)

    @cached_property
    def cond(self) -> np.ndarray | float:
        """Exact condition number of Q by SVD, on first access only; 0 where void."""
        if self.geometric is None or (not self._batch and SEVERITY[self.status] >= 3):
            return 0.0
        value = np.linalg.cond(self.Q)
        if not self._batch:
            return float(value) if math.isfinite(value) else SINGULAR
        value = np.where(np.isfinite(value), value, SINGULAR)
        return np.where(np.asarray([SEVERITY[s] >= 3 for s in self.status], dtype=bool),
                        0.0, value)


class _KernelSolution(Solution):
    """A :class:`Solution` whose array fields are views of the kernel's output."""


for _name in kernel.OUT:
    if _name in Solution.__dataclass_fields__:
        _kept = Kept(part=kernel.OUT[_name], shape=(3, 3) if _name == 'jacobian' else None)
        _kept.__set_name__(_KernelSolution, _name)
        setattr(_KernelSolution, _name, _kept)
_KernelSolution.__qualname__ = _KernelSolution.__name__ = 'Solution'


def kinematic_condition(g: Geometric, f: Connectivity, xp: SimpleNamespace) -> Scalar:
    """Condition of Q (eq. 11-12) from its block factorisation: the largest
    condition of the pivot blocks (loops A, B, C: orthogonal columns of norms
    L, 1 and L h, L, 1; loops D, E: 2x2), singular exactly when Q is.
    """
    LA, LB, LC = g.length
    one = 1.0
    return xp.maximum(xp.maximum(LA, one) / xp.minimum(LA, one),
                      xp.maximum(LB, one) / xp.minimum(LB * g.hB, one),
                      xp.maximum(LC, one) / xp.minimum(LC * g.hC, one),
                      condition_2x2(f.aD, f.bD, xp), condition_2x2(f.aE, g.l, xp))


def jacobian_condition(model: Model, J: list, Jinv: list, xp: SimpleNamespace) -> Scalar:
    """Frobenius condition number |J_s| |J_s^-1| of the actuator Jacobian dL/dq
    (the actuated rows of eq. 11) with its roll column scaled by c = b/2 (m/rad),
    so that the three columns are lengths: J_s = J diag(1, 1, 1/c). Within a
    factor 3 of the 2-norm one.
    """
    c = 0.5 * model.geometry.b
    nJ = sum(r[0] * r[0] + r[1] * r[1] + (r[2] / c) * (r[2] / c) for r in J)
    nI = sum(Jinv[0][j] * Jinv[0][j] + Jinv[1][j] * Jinv[1][j]
             + (c * Jinv[2][j]) * (c * Jinv[2][j]) for j in range(3))
    return xp.sqrt(nJ * nI)


def _solve(model: Model, g: Geometric, qd: tuple, qdd: tuple, xp: SimpleNamespace) -> dict:
    """The paper's method (eq. 11-23) for the positions g of eq. (5)-(8): raw results."""
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
    Vv, roll_v, Jinv = virtual_velocities(K, J)                          # eq. (14)
    force = actuator_forces(tau, tau_43, Vv, roll_v)                     # eq. (23)
    rate = (V[_A], V[_B], V[_C])
    if effects.friction:
        force = [fi + ff for fi, ff in zip(force, friction_forces(model, rate, xp))]
    return dict(length=g.length, stroke=(g.raw[_A], g.raw[_B], g.raw[_C]), rate=rate,
                acceleration=(Gamma[_A], Gamma[_B], Gamma[_C]), force=force,
                power=[fi * ri for fi, ri in zip(force, rate)], joints=g.raw,
                joint_rates=V, joint_accelerations=Gamma, beta=g.beta, jacobian=J,
                kinematic_condition=kinematic_condition(g, f, xp),
                jacobian_condition=jacobian_condition(model, J, Jinv, xp))


#: Result fields whose finiteness the status rule checks (with the conditions).
_CHECKED = ('length', 'stroke', 'rate', 'acceleration', 'force', 'power', 'joints',
            'joint_rates', 'joint_accelerations')
_CONDITIONS = ('kinematic_condition', 'jacobian_condition')
_STATUS_ARRAY = np.array(BY_SEVERITY, dtype=object)
_KERNEL_STATUS_ARRAY = np.array(kernel.STATUS_BY_CODE if kernel.OUT else (), dtype=object)


def _status(model: Model, r: dict, xp: SimpleNamespace, bad_input: Scalar = -1,
            open_loop: Scalar = -1) -> tuple[Scalar, Scalar]:
    """(code, info) of the results r by the status rule (:func:`.status_rule.sample_status`)."""
    kin, jac = r['kinematic_condition'], r['jacobian_condition']
    finite = all_finite([v for name in _CHECKED for v in r[name]] + [kin, jac], xp)
    return sample_status(model.limits, xp, bad_input, open_loop, finite, kin, jac,
                         r['stroke'], r['rate'], r['force'])


def _clean(fields: dict, code: np.ndarray | int) -> dict:
    """No NaN or infinity (the rule's last step): a void sample's numbers and
    any non-finite number 0, a non-finite condition SINGULAR.
    """
    void = np.asarray(code) >= SEVERITY[Status.UNREACHABLE]
    out = {}
    for name, value in fields.items():
        if name in _CONDITIONS:
            value = np.where(np.isfinite(value), value, SINGULAR)
        mask = np.reshape(void, void.shape + (1,) * (np.ndim(value) - void.ndim))
        out[name] = np.where(mask | ~np.isfinite(value), 0.0, value)
    return out


def _new_solution(**values: object) -> Solution:
    """A Solution without the frozen dataclass's __init__ (2 us of a 10 us
    cycle); with ``_rows`` the array fields are views of it.
    """
    sol = object.__new__(_KernelSolution if '_rows' in values else Solution)
    sol.__dict__.update(values)
    return sol


def _void_solution(model: Model, code: int, info: int, inputs: tuple) -> Solution:
    """A single solve stopped before any result: every number 0."""
    z3, z12 = np.zeros(3), np.zeros(12)
    status = BY_SEVERITY[code]
    return _new_solution(
        length=z3, stroke=z3.copy(), rate=z3.copy(), acceleration=z3.copy(), force=z3.copy(),
        power=z3.copy(), joints=z12, joint_rates=z12.copy(), joint_accelerations=z12.copy(),
        beta=0.0, jacobian=np.zeros((3, 3)), kinematic_condition=0.0, jacobian_condition=0.0,
        status=status, detail=describe(status, info, model.limits, inputs, z3, z3, z3, 0.0, 0.0),
        model=model, pose=inputs[0])


def _pack_batch(values: Sequence[np.ndarray | float]) -> np.ndarray:
    return np.stack(np.broadcast_arrays(*values), axis=-1).astype(float, copy=False)


def solve(model: Model, q: Sequence[float], qd: Sequence[float],
          qdd: Sequence[float]) -> Solution:
    """Solve one control cycle (eq. 5-23): q, qd, qdd are 3 numbers each (surge
    m, heave m, roll rad and their derivatives). Never raises for a bad pose or
    bad numbers (``sol.status``, ``sol.detail``); ValueError only for input
    that is not three numbers per argument.
    """
    q3, qd3, qdd3 = three_numbers('q', q), three_numbers('qd', qd), three_numbers('qdd', qdd)
    if kernel.enabled():
        out, scalars = kernel.solve_row(model, q3, qd3, qdd3)
        return kernel_solution(model, out, scalars, (q3, qd3, qdd3))
    return _solve_floats(model, q3, qd3, qdd3)


def kernel_solution(model: Model, out: np.ndarray, scalars: tuple, inputs: tuple) -> Solution:
    """The Solution of one kernel result row and its scalars."""
    code, info, beta, kin, jac = scalars
    status = kernel.STATUS_BY_CODE[code]
    return _new_solution(   # the array fields are views of `out` (Kept)
        _rows=out, beta=beta, kinematic_condition=kin, jacobian_condition=jac,
        status=status, detail=_kernel_detail(model, status, info, out, inputs),
        model=model, pose=inputs[0])


def _kernel_detail(model: Model, status: Status, info: float, row: np.ndarray,
                   inputs: tuple) -> str:
    """:func:`.status_rule.describe` of one kernel result row."""
    if status is Status.OK:
        return ''
    out = kernel.OUT
    return describe(status, info, model.limits, inputs, row[out['stroke']], row[out['rate']],
                    row[out['force']], row[kernel.O_KIN], row[kernel.O_JAC])


def _solve_floats(model: Model, q: tuple, qd: tuple, qdd: tuple) -> Solution:
    """One cycle on plain floats; a sample where float arithmetic raises (IEEE
    carries on) goes to the array code, so that every path gives one verdict.
    """
    inputs = (q, qd, qdd)
    bad = first_bad_input(q + qd + qdd, _SCALAR)
    if bad >= 0:
        return _void_solution(model, *sample_status(model.limits, _SCALAR, bad_input=bad),
                              inputs)
    try:
        g = inverse_geometry(model, q, _SCALAR, check=False)                # eq. (5)-(8)
        loop = first_open_loop(g.valid, _SCALAR)
        if loop >= 0:
            return _void_solution(
                model, *sample_status(model.limits, _SCALAR, open_loop=loop), inputs)
        r = _solve(model, g, qd, qdd, _SCALAR)
    except (ArithmeticError, ValueError):
        batch = _solve_arrays(model, *(np.array([x], dtype=float) for x in inputs))
        return _new_solution(
            **{name: getattr(batch, name)[0] for name in _CHECKED + ('jacobian',)},
            **{name: float(getattr(batch, name)[0]) for name in ('beta',) + _CONDITIONS},
            status=batch.status[0], detail=batch.detail[0], model=model, pose=q)
    code, info = _status(model, r, _SCALAR)
    fields = {name: np.array(r[name], dtype=float) for name in _CHECKED + ('jacobian',)}
    fields.update({name: r[name] for name in ('beta',) + _CONDITIONS})
    if code >= SEVERITY[Status.NEAR_SINGULAR]:      # the only codes with non-finite results
        fields = _clean(fields, code)
    fields.update({name: float(fields[name]) for name in ('beta',) + _CONDITIONS})
    status = BY_SEVERITY[code]
    detail = '' if status is Status.OK else describe(
        status, info, model.limits, inputs, fields['stroke'], fields['rate'], fields['force'],
        fields['kinematic_condition'], fields['jacobian_condition'])
    return _new_solution(**fields, status=status, detail=detail, model=model, pose=q,
                         geometric=None if code >= SEVERITY[Status.UNREACHABLE] else g)


def solve_batch(model: Model, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> Solution:
    """Inverse kinematics and dynamics (eq. 5-23) of N samples: q, qd, qdd are
    (N, 3); every field gets a leading N axis. A bad sample gets its own
    status; ValueError only for input that is not (N, 3) numbers.
    """
    arrays = _as_batch('q', q, None), None, None
    n = arrays[0].shape[0]
    arrays = (arrays[0], _as_batch('qd', qd, n), _as_batch('qdd', qdd, n))
    if kernel.enabled():
        return batch_from_rows(model, kernel.solve_rows(model, *arrays), arrays)
    return _solve_arrays(model, *arrays)


def batch_from_rows(model: Model, rows: np.ndarray, arrays: tuple) -> Solution:
    """The Solution of a batch from the kernel's result rows (views, no copies)."""
    n = rows.shape[0]
    code = rows[:, kernel.O_STATUS].astype(np.int8)
    info = rows[:, kernel.O_INFO]
    detail = [''] * n
    for i in np.flatnonzero(code):
        detail[i] = _kernel_detail(model, kernel.STATUS_BY_CODE[code[i]], info[i], rows[i],
                                   tuple(a[i].tolist() for a in arrays))
    return _new_solution(_rows=rows, beta=rows[:, kernel.O_BETA],
                         kinematic_condition=rows[:, kernel.O_KIN],
                         jacobian_condition=rows[:, kernel.O_JAC],
                         status=_KERNEL_STATUS_ARRAY[code],
                         detail=tuple(detail), model=model, pose=arrays[0])


def _solve_arrays(model: Model, *arrays: np.ndarray) -> Solution:
    """N samples on numpy columns (IEEE, no exceptions); the rule judges each."""
    n = arrays[0].shape[0]
    columns = [tuple(a.T) for a in arrays]
    bad = np.broadcast_to(first_bad_input(sum(columns, ()), _ARRAY), (n,))
    columns = [tuple(np.ascontiguousarray(np.where(bad[:, None] < 0, a, 0.0).T))
               for a in arrays]
    with np.errstate(all='ignore'):
        g = inverse_geometry(model, columns[0], _ARRAY, check=False)      # eq. (5)-(8)
        r = _solve(model, g, columns[1], columns[2], _ARRAY)
    code, info = _status(model, r, _ARRAY, bad, first_open_loop(g.valid, _ARRAY))
    code = np.broadcast_to(code, (n,)).astype(np.int8)
    info = np.broadcast_to(info, (n,))
    fields = {name: _pack_batch(r[name]) for name in _CHECKED}
    fields['jacobian'] = np.stack([_pack_batch(row) for row in r['jacobian']], axis=-2)
    fields.update({name: np.broadcast_to(r[name], (n,)).astype(float)
                   for name in ('beta',) + _CONDITIONS})
    fields = _clean(fields, code)
    detail = [''] * n
    for i in np.flatnonzero(code):
        detail[i] = describe(BY_SEVERITY[code[i]], info[i], model.limits,
                             tuple(a[i].tolist() for a in arrays), fields['stroke'][i],
                             fields['rate'][i], fields['force'][i],
                             fields['kinematic_condition'][i], fields['jacobian_condition'][i])
    return _new_solution(**fields, status=_STATUS_ARRAY[code], detail=tuple(detail),
                         model=model, pose=arrays[0], geometric=g)


def three_numbers(name: str, value: Sequence[float]) -> tuple[float, float, float]:
    """Three real numbers as floats, or ValueError naming the argument (not
    bools, strings, nested or wrongly sized sequences, ints beyond float
    range); NaN and infinities are numbers (status ``invalid_input``).
    """
    kind = type(value)
    if (kind is tuple or kind is list) and len(value) == 3:     # the usual case, fast
        a, b, c = value
        if type(a) is float and type(b) is float and type(c) is float:
            return (a, b, c)
    elif kind is np.ndarray and value.shape == (3,) and value.dtype == np.float64:
        a, b, c = value.tolist()
        return (a, b, c)
    if (isinstance(value, (str, bytes)) or not isinstance(value, (Sequence, np.ndarray))
            or np.ma.isMaskedArray(value)
            or np.asarray(value, dtype=object).ndim != 1 or len(value) != 3
            or not all(isinstance(v, numbers.Real) and not isinstance(v, bool) for v in value)):
        raise ValueError(f'{name} must be 3 numbers, got {value!r:.200}')
    try:
        return float(value[0]), float(value[1]), float(value[2])
    except OverflowError:
        raise ValueError(f'{name} must be 3 numbers a float can hold, got '
                         f'{value!r:.200}') from None


def _as_batch(name: str, value: object, n: int | None) -> np.ndarray:
    """An (N, 3) float array by the rule of :func:`three_numbers`, masked entries refused."""
    if np.ma.isMaskedArray(value) and np.ma.getmaskarray(value).any():
        raise ValueError(f'{name} has masked entries: fill or drop them first')
    if not isinstance(value, np.ndarray) and any(
            isinstance(v, (bool, np.bool_)) for v in np.asarray(value, dtype=object).flat):
        # numpy would read True as 1.0 in a list of floats
        raise ValueError(f'{name} must be numbers (surge, heave, roll), got a bool in '
                         f'{value!r:.200}')
    try:
        raw = np.asarray(value)
    except ValueError:               # ragged nesting
        raw = None
    if raw is not None and raw.dtype.kind == 'O' and raw.ndim != 2:
        raise ValueError(f'{name} must have shape (N, 3), got {raw.shape}')
    if raw is None or raw.dtype.kind not in 'fiu':
        raise ValueError(f'{name} must be numbers (surge, heave, roll), got {value!r:.200}')
    arr = raw.astype(float)
    if arr.ndim != 2 or arr.shape[1] != 3:
        raise ValueError(f'{name} must have shape (N, 3), got {arr.shape}')
    if n is not None and arr.shape[0] != n:
        raise ValueError(f'{name} has {arr.shape[0]} rows, q has {n}')
    return arr
