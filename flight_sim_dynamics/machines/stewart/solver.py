"""The hexapod's solve: inverse kinematics and dynamics of one sample or a
batch (docs/design/stewart.md, (S1)-(S23)), judged by the status rule of
:mod:`flight_sim_dynamics.core.status` (never a NaN, never an exception for
a bad pose or bad numbers).

:func:`solve` (one sample) and :func:`solve_batch` (N samples) run the
compiled kernel (:mod:`.kernel`, ``kernel.c``) when it is built, else the numpy
code below, the reference: :func:`solve_batch` on arrays (N, 6), :func:`solve`
its batch of one::

    sol = solve(model, q, qd, qdd)       # six numbers each
    sol.force, sol.status, sol.detail    # six forces (N), ok ... invalid_input, why
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from types import SimpleNamespace

import numpy as np

from ...core.kernel import Kept, row_view
from ...core.status import BY_SEVERITY, RESULTS_NOT_FINITE, SEVERITY, Status
from . import kernel, limits
from .dynamics import actuator_forces, friction_forces, generalised_wrench, has_inertia
from .kinematics import (actuator_jacobian, degenerate_legs, has_bool, jacobian_condition,
                         leg_accelerations, leg_positions, leg_velocities, platform_motion,
                         pose_jacobian, six_numbers, spherical_joint_angles)
from .model import MAX_SOLVED_CONDITION, MIN_LENGTH, UNREACHABLE_REASONS, StewartModel

#: The pose coordinates, in the order of q, qd, qdd.
COORDINATES = ('surge', 'sway', 'heave', 'roll', 'pitch', 'yaw')
_INPUTS = ('q', 'qd', 'qdd')


@dataclass(frozen=True)
class StewartSolution:
    """Result of a solve (S1)-(S23). Leg quantities are ordered 1-6; for
    :func:`solve_batch` every field has a leading axis of N samples.
    """

    length: np.ndarray               # (6,) leg length, joint centre to joint centre, m
    stroke: np.ndarray               # (6,) L - L_home, m
    rate: np.ndarray                 # (6,) dL/dt, m/s
    acceleration: np.ndarray         # (6,) d2L/dt2, m/s^2
    force: np.ndarray                # (6,) actuator force along the leg, + extends, N
    power: np.ndarray                # (6,) force x rate, W
    joints: np.ndarray               # (6, 3) per leg theta_1, theta_2 (rad), L (m) (S5)
    joint_rates: np.ndarray          # (6, 3) their rates (S7)-(S8)
    joint_accelerations: np.ndarray  # (6, 3) their accelerations (S11)-(S12)
    spherical_angles: np.ndarray     # (6,) angle of each leg from the platform's z axis, rad
    jacobian: np.ndarray             # (6, 6) dL/dq: leg rates = jacobian @ qd (S22)
    twist_jacobian: np.ndarray       # (6, 6) J: leg rates = J @ (v, omega) (S21)
    jacobian_condition: np.ndarray | float  # 2-norm condition of J
    status: Status | np.ndarray      # ok, limit, near_singular, unreachable, invalid_input
    detail: str | tuple              # why the status is not ok ('' when ok)
    model: StewartModel = field(repr=False, compare=False)
    pose: np.ndarray = field(repr=False, compare=False)   # the q solved for


#: Fields that are zero for a void sample and checked for finiteness.
_FIELDS = ('length', 'stroke', 'rate', 'acceleration', 'force', 'power', 'joints',
           'joint_rates', 'joint_accelerations', 'spherical_angles', 'jacobian',
           'twist_jacobian')
_STATUS_ARRAY = np.array(BY_SEVERITY, dtype=object)


def _evaluate(model: StewartModel, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> dict:
    """Every result of (S1)-(S23) for finite inputs (IEEE values where degenerate)."""
    platform = platform_motion(model, q, qd, qdd)                    # (S1)-(S3)
    legs = leg_positions(model, platform.p, platform.R)              # (S4)-(S5)
    rates = leg_velocities(model, legs, platform)                    # (S6)-(S9)
    acc = leg_accelerations(model, legs, rates, platform)            # (S10)-(S13)
    J = actuator_jacobian(legs)                                      # (S21)
    condition = jacobian_condition(J)
    degenerate = degenerate_legs(legs)
    effects = model.effects
    if not effects.velocity_products and has_inertia(model):
        # the forces of the same accelerations from rest: no velocity products
        dyn_platform = platform_motion(model, q, np.zeros_like(qd), qdd)
        dyn_rates = leg_velocities(model, legs, dyn_platform)
        dyn_acc = leg_accelerations(model, legs, dyn_rates, dyn_platform)
    else:
        dyn_platform, dyn_rates, dyn_acc = platform, rates, acc
    wrench = generalised_wrench(model, dyn_platform, legs, dyn_rates, dyn_acc)  # (S14)-(S20)
    solvable = ~degenerate.any(axis=1) & (condition < MAX_SOLVED_CONDITION)
    force = actuator_forces(np.where(solvable[:, None, None], J, np.eye(6)), wrench)  # (S21)
    force = np.where(solvable[:, None], force, np.nan)   # no forces through a singular J
    if effects.friction:
        force = force + friction_forces(model, rates.Ld)             # (S23)
    return dict(
        length=legs.L, stroke=legs.L - model.home_lengths, rate=rates.Ld,
        acceleration=acc.Ldd, force=force, power=force * rates.Ld,
        joints=np.stack([legs.theta1, legs.theta2, legs.L], axis=-1),
        joint_rates=np.stack([rates.theta1d, rates.theta2d, rates.Ld], axis=-1),
        joint_accelerations=np.stack([acc.theta1dd, acc.theta2dd, acc.Ldd], axis=-1),
        spherical_angles=spherical_joint_angles(platform.R, legs.u),
        jacobian=pose_jacobian(J, platform.E), twist_jacobian=J,
        jacobian_condition=condition, degenerate=degenerate, solvable=solvable)


def _first_bad_input(arrays: tuple) -> np.ndarray:
    """(N,) index 0-17 of the first non-finite component of (q, qd, qdd), or -1."""
    finite = np.isfinite(np.concatenate(arrays, axis=1))
    return np.where(finite.all(axis=1), -1, np.argmin(finite, axis=1))


def _limit_reasons(model: StewartModel, sol: SimpleNamespace) -> list[str]:
    """What one sample's values exceed (stewart.md, "Actuators, limits, effects"),
    or nothing: its usages above 1 (:mod:`.limits`), named with their values.
    """
    lim = model.limits
    kinds = limits.kinds(lim)
    used = limits.usages(lim, sol.length, sol.rate, sol.force, sol.joints,
                         sol.spherical_angles).reshape(6, len(kinds))
    out = []
    for k in range(6):
        for kind, usage in zip(kinds, used[k].tolist()):
            if not usage > 1.0:
                continue
            if kind == 'stroke':
                out.append(f'leg {k + 1} length {sol.length[k]:.4g} m outside '
                           f'[{lim.length_min:g}, {lim.length_max:g}] m')
            elif kind == 'speed':
                out.append(f'leg {k + 1} speed {abs(sol.rate[k]):.4g} m/s > '
                           f'{lim.max_speed:g} m/s')
            elif kind == 'force':
                out.append(f'leg {k + 1} force {abs(sol.force[k]):.4g} N > '
                           f'{lim.max_force:g} N')
            elif kind == 'u_joint':
                angle = np.abs(sol.joints[k, :2]).max()
                out.append(f'leg {k + 1} U-joint angle {math.degrees(angle):.4g} deg > '
                           f'{math.degrees(lim.u_joint_max_angle):g} deg')
            else:
                out.append(f'leg {k + 1} spherical joint angle '
                           f'{math.degrees(sol.spherical_angles[k]):.4g} deg > '
                           f'{math.degrees(lim.spherical_joint_max_angle):g} deg')
    return out


def _over_limits(model: StewartModel, r: dict) -> np.ndarray:
    """(N,) True where a usage of :mod:`.limits` is above 1: a length, speed,
    force or enabled joint-angle limit exceeded.
    """
    used = limits.usages(model.limits, r['length'], r['rate'], r['force'], r['joints'],
                         r['spherical_angles'])
    return (used > 1.0).any(axis=-1)


def _detail(model: StewartModel, code: int, info: int, sol: SimpleNamespace,
            inputs: tuple) -> str:
    """Why a sample has status ``code`` ('' for ok): ``sol`` its cleaned values
    (length, rate, force, joints, spherical_angles, jacobian_condition),
    ``inputs`` its (q, qd, qdd).
    """
    status = BY_SEVERITY[code]
    if status is Status.INVALID_INPUT:
        if info == RESULTS_NOT_FINITE:
            return 'results are not finite: input too large'
        value = inputs[info // 6][info % 6]
        return (f'{_INPUTS[info // 6]}[{info % 6}] ({COORDINATES[info % 6]}) '
                f'is not finite ({value})')
    if status is Status.UNREACHABLE:
        leg, reason = info % 6 + 1, UNREACHABLE_REASONS[info // 6]
        if reason == 'degenerate_length':
            return f'leg {leg}: degenerate length (<= {MIN_LENGTH:g} m)'
        if reason == 'not_finite':
            return f'leg {leg}: position not finite (pose too large)'
        return f'leg {leg}: along its U-joint\'s first axis (theta_2 = +-90 deg, singular joint)'
    if status is Status.NEAR_SINGULAR:
        if not info:
            return 'exact singularity: the actuator Jacobian is singular, forces set to 0'
        return (f'actuator Jacobian condition {sol.jacobian_condition:.3g} > '
                f'{model.limits.max_jacobian_condition:g}')
    if status is Status.LIMIT:
        return '; '.join(_limit_reasons(model, sol))
    return ''


def _unreachable_info(r: dict) -> np.ndarray:
    """(N,) info of an unreachable sample: its first degenerate leg + 6 x the
    reason (UNREACHABLE_REASONS): a length <= MIN_LENGTH, a position not
    finite, else a U-joint along its first axis.
    """
    leg = np.argmax(r['degenerate'], axis=1)
    rows = np.arange(leg.size)
    L, joints = r['length'][rows, leg], r['joints'][rows, leg]
    reason = np.where(np.isfinite(L) & (L <= MIN_LENGTH), 0,
                      np.where(np.isfinite(joints).all(axis=1), 2, 1))
    return leg + 6 * reason


def _status(model: StewartModel, r: dict, bad: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(code, info) per sample by the rule of core.status, worst first:
    invalid_input (input) > unreachable > near_singular > invalid_input
    (results overflow) > limit > ok.
    """
    cond = r['jacobian_condition']
    finite = np.ones(bad.shape, dtype=bool)
    for name in _FIELDS:
        v = r[name]
        finite &= np.isfinite(v).all(axis=tuple(range(1, v.ndim)))
    code = np.where(_over_limits(model, r), SEVERITY[Status.LIMIT], SEVERITY[Status.OK])
    info = np.zeros(bad.shape, dtype=int)
    code = np.where(finite, code, SEVERITY[Status.INVALID_INPUT])
    info = np.where(finite, info, RESULTS_NOT_FINITE)
    near = ~(cond <= model.limits.max_jacobian_condition)
    code = np.where(near, SEVERITY[Status.NEAR_SINGULAR], code)
    info = np.where(near, np.where(r['solvable'] & finite, 1, 0), info)
    degenerate = r['degenerate'].any(axis=1)
    code = np.where(degenerate, SEVERITY[Status.UNREACHABLE], code)
    info = np.where(degenerate, _unreachable_info(r), info)
    code = np.where(bad >= 0, SEVERITY[Status.INVALID_INPUT], code)
    info = np.where(bad >= 0, bad, info)
    return code.astype(np.int8), info


def _clean(r: dict, code: np.ndarray) -> dict:
    """No NaN or infinity: a void sample's numbers (unreachable, invalid input)
    and any non-finite number 0.
    """
    void = code >= SEVERITY[Status.UNREACHABLE]
    out = {}
    for name in _FIELDS + ('jacobian_condition',):
        v = r[name]
        mask = void.reshape(void.shape + (1,) * (v.ndim - 1))
        out[name] = np.where(mask | ~np.isfinite(v), 0.0, v)
    return out


def solve_batch(model: StewartModel, q: np.ndarray, qd: np.ndarray,
                qdd: np.ndarray) -> StewartSolution:
    """Inverse kinematics and dynamics (S1)-(S23) of N samples: q, qd, qdd are
    (N, 6) (surge, sway, heave in m, roll, pitch, yaw in rad, their rates and
    accelerations); every field gets a leading N axis. A bad sample gets its
    own status; ValueError only for input that is not (N, 6) numbers.
    """
    Q = _as_batch('q', q, None)
    n = Q.shape[0]
    arrays = (Q, _as_batch('qd', qd, n), _as_batch('qdd', qdd, n))
    if kernel.enabled():
        rows = kernel.solve_rows(model, *arrays)
        code = rows[:, kernel.O_STATUS].astype(np.intp)
        # the detail's inputs: copies of the invalid samples' (which it names)
        invalid = np.flatnonzero(code == SEVERITY[Status.INVALID_INPUT])
        return _new_kernel_solution(_rows=rows, model=model,
                                    _inputs=(invalid, *(a[invalid] for a in arrays)),
                                    status=_KERNEL_STATUS_ARRAY[code])
    return _solve_arrays(model, *(a.copy() for a in arrays))   # its pose: a copy of q


def _solve_arrays(model: StewartModel, *arrays: np.ndarray) -> StewartSolution:
    """N samples on numpy arrays (IEEE, no exceptions); the rule judges each."""
    n = arrays[0].shape[0]
    bad = _first_bad_input(arrays)
    clean = tuple(np.where(bad[:, None] < 0, a, 0.0) for a in arrays)
    with np.errstate(all='ignore'):
        r = _evaluate(model, *clean)
        code, info = _status(model, r, bad)
    fields = _clean(r, code)
    detail = [''] * n
    for i in np.flatnonzero(code):
        values = SimpleNamespace(**{name: value[i] for name, value in fields.items()})
        detail[i] = _detail(model, int(code[i]), int(info[i]), values,
                            tuple(a[i] for a in arrays))
    return StewartSolution(**fields, status=_STATUS_ARRAY[code], detail=tuple(detail),
                           model=model, pose=arrays[0])


def solve(model: StewartModel, q, qd, qdd) -> StewartSolution:
    """One sample (S1)-(S23): q, qd, qdd are six numbers each. Never raises
    for a bad pose or bad numbers (``sol.status``, ``sol.detail``); ValueError
    only for an argument that is not six numbers.
    """
    if kernel.enabled():
        params, bits = kernel.prepared(model)
        out = np.empty(kernel.OUT_SIZE)
        # the kernel reads lists and tuples of six floats (an array's tolist())
        if type(q) is np.ndarray:
            q = q.tolist()
        if type(qd) is np.ndarray:
            qd = qd.tolist()
        if type(qdd) is np.ndarray:
            qdd = qdd.tolist()
        try:
            code, info, cond = kernel.solve_one(params, bits, out, q, qd, qdd)
        except TypeError:   # anything else: six numbers as floats, or ValueError
            q, qd, qdd = (tuple(six_numbers(name, v).tolist())
                          for name, v in zip(_INPUTS, (q, qd, qdd)))
            code, info, cond = kernel.solve_one(params, bits, out, q, qd, qdd)
        sol = object.__new__(_KernelSolution)      # its fields come from the row
        values = sol.__dict__
        values['_rows'], values['_info'] = out, info
        if cond != kernel.NOT_COMPUTED:     # else computed on first access
            values['jacobian_condition'] = cond
        values['status'], values['model'] = kernel.STATUS_BY_CODE[code], model
        if code:    # the detail's inputs, copied (the caller may reuse its lists)
            values['_inputs'] = (tuple(q), tuple(qd), tuple(qdd))
        return sol
    rows = [six_numbers(name, v)[None, :] for name, v in zip(_INPUTS, (q, qd, qdd))]
    return sample(_solve_arrays(model, *rows), 0)


def sample(batch: StewartSolution, i: int) -> StewartSolution:
    """Sample i of a batch's solution, as :func:`solve` gives it."""
    values = {name: getattr(batch, name)[i] for name in _FIELDS}
    return StewartSolution(**values, jacobian_condition=float(batch.jacobian_condition[i]),
                           status=batch.status[i], detail=batch.detail[i], model=batch.model,
                           pose=batch.pose[i])


# ---------------------------------------------------------------------------
# The kernel's solutions: fields made from its result rows on first access
# ---------------------------------------------------------------------------

def _layout(name: str) -> tuple[slice, tuple[int, ...]]:
    """Where the field ``name`` is in a result row, and its shape."""
    offset, size = kernel.OUT[name]
    shape = {'joints': (6, 3), 'joint_rates': (6, 3), 'joint_accelerations': (6, 3),
             'jacobian': (6, 6), 'twist_jacobian': (6, 6)}.get(name, (size,) if size > 1 else ())
    return slice(offset, offset + size), shape


def _row_view(name: str):
    """The field ``name`` as a view of the result row(s), in its shape."""
    part, shape = _layout(name)

    def view(sol: StewartSolution) -> np.ndarray:
        return row_view(sol.__dict__['_rows'], part, shape)
    return view


def _angle_view(name: str):
    """``joints`` or ``spherical_angles``: the row view, once the kernel has filled
    the joint angles that solve left (:func:`kernel.joint_angles`).
    """
    view = _row_view(name)

    def angles(sol: StewartSolution) -> np.ndarray:
        if not sol.__dict__.get('_angles_filled'):
            kernel.joint_angles(sol.model, sol.__dict__['_rows'])
            sol.__dict__['_angles_filled'] = True
        return view(sol)
    return angles


def _kernel_detail(sol: StewartSolution) -> str | tuple:
    """The detail of a kernel solution: one string, or one per sample of a batch."""
    rows = sol.__dict__['_rows']
    if rows.ndim == 1:
        if sol.status is Status.OK:
            return ''
        return _detail(sol.model, SEVERITY[sol.status], sol.__dict__['_info'], sol,
                       sol.__dict__['_inputs'])
    code = rows[:, kernel.O_STATUS].astype(np.intp)
    info = rows[:, kernel.O_INFO].astype(np.intp)
    detail = [''] * len(rows)
    invalid, *inputs = sol.__dict__['_inputs']      # the invalid samples' only
    # the rows as they are, nothing deferred computed for every row: a detail
    # reads the joint angles only where a joint-angle limit is set and the
    # condition only where it is beyond its limit, and solve_batch computed them
    # there
    raw = {name: _row_view(name)(sol) for name in ('length', 'rate', 'force', 'joints',
                                                   'spherical_angles', 'jacobian_condition')}
    for i in np.flatnonzero(code):
        values = SimpleNamespace(**{name: view[i] for name, view in raw.items()})
        j = np.searchsorted(invalid, i)
        detail[i] = _detail(sol.model, int(code[i]), int(info[i]), values,
                            tuple(a[j] for a in inputs) if j < invalid.size and invalid[j] == i
                            else ())
    return tuple(detail)


def _kernel_condition(sol: StewartSolution) -> float | np.ndarray:
    """The condition of J: the kernel's solve leaves it where the status does
    not need it (kernel.conditions).
    """
    cond = kernel.conditions(sol.__dict__['_rows'])
    return float(cond) if cond.ndim == 0 else cond


class _KernelSolution(StewartSolution):
    """A :class:`StewartSolution` whose arrays are views of the kernel's result
    row(s), made on first access, as are its detail and condition.
    """

    detail = Kept(_kernel_detail)
    jacobian_condition = Kept(_kernel_condition)


if kernel.OUT:
    for _name in set(kernel.ROW_FIELDS) - {'status', 'info', 'jacobian_condition'}:
        _part, _shape = _layout(_name)
        _kept = (Kept(_angle_view(_name)) if _name in ('joints', 'spherical_angles')
                 else Kept(part=_part, shape=_shape))
        _kept.__set_name__(_KernelSolution, _name)
        setattr(_KernelSolution, _name, _kept)
_KernelSolution.__qualname__ = _KernelSolution.__name__ = 'StewartSolution'
_KERNEL_STATUS_ARRAY = np.array(kernel.STATUS_BY_CODE if kernel.OUT else (), dtype=object)


def _new_kernel_solution(**values: object) -> StewartSolution:
    """A solution without the frozen dataclass's __init__: the rest of its
    fields come from ``_rows`` on first access.
    """
    sol = object.__new__(_KernelSolution)
    sol.__dict__.update(values)
    return sol


def _as_batch(name: str, value: object, n: int | None) -> np.ndarray:
    """An (N, 6) float array, or ValueError naming the argument (bools,
    strings, masked entries and wrong shapes refused; NaN and infinities are
    numbers, judged by the status).
    """
    if np.ma.isMaskedArray(value) and np.ma.getmaskarray(value).any():
        raise ValueError(f'{name} has masked entries: fill or drop them first')
    if not isinstance(value, np.ndarray) and has_bool(value):
        raise ValueError(f'{name} must be numbers, got a bool in {value!r:.200}')
    try:
        arr = np.asarray(value)
    except (ValueError, TypeError):
        raise ValueError(f'{name} must be an (N, 6) array of numbers, got {value!r:.200}') \
            from None
    if arr.dtype.kind not in 'fiu':
        raise ValueError(f'{name} must be numbers ({", ".join(COORDINATES)}), '
                         f'got {value!r:.200}')
    if arr.ndim != 2 or arr.shape[1] != 6:
        raise ValueError(f'{name} must have shape (N, 6), got {arr.shape}')
    if n is not None and arr.shape[0] != n:
        raise ValueError(f'{name} has {arr.shape[0]} rows, q has {n}')
    return np.ascontiguousarray(arr, dtype=float)     # the caller's own array if it is one
