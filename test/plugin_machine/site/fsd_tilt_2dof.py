"""A third machine, a plugin of flight_sim_dynamics that lives only under test/:
a 2-DOF pitch-roll platform on a fixed centre post, tilted by two vertical
linear actuators (``fsd_tilt_2dof-0.1.dist-info`` declares :data:`MACHINE`
under the entry-point group ``flight_sim_dynamics.machines``).

Frames: the origin is the post's top, a universal joint whose outer axis is
the base's x and inner axis the platform's y, so R(q) = Rx(roll) Ry(pitch).
Leg 1 joins the base point (a, 0, -h) to the platform point (a, 0, 0), leg 2
(0, a, -h) to (0, a, 0) (spherical ends, massless legs): at home both are
vertical, of length h. The platform is one rigid body (mass, centre of mass
and inertia about it in platform axes). Inverse dynamics by virtual work:
f = J^-T (M(q) qdd + c(q, qd) + g(q)), J = dL/dq, M, c, g of the platform's
Lagrangian (T = 1/2 w^T I_O w, w = E(pitch) qd in platform axes).

It imports numpy and flight_sim_dynamics.core only, as any plugin may.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Mapping

import numpy as np

from flight_sim_dynamics.core.effects import Effects
from flight_sim_dynamics.core.machine import (ActuatorLimits, LimitUsage, Machine, ModelValueError,
                                              check_forward_options, quiet_floating_point,
                                              stroke_usage)
from flight_sim_dynamics.core.motion import Motion
from flight_sim_dynamics.core.parameter_spec import ParamSpec
from flight_sim_dynamics.core.status import BY_SEVERITY, SEVERITY, SINGULAR, Status

NAME = 'tilt_2dof'
COORDINATES = ('roll', 'pitch')
LEG_NAMES = ('leg_1', 'leg_2')
JOINT_NAMES = ('post_roll', 'post_pitch', 'leg_1_length', 'leg_2_length')
#: Above this 2-norm condition of J the status is near_singular.
MAX_CONDITION = 50.0


def _spec(name: str, kind: str, description: str, unit: str = '', minimum: float | None = None,
          exclusive: bool = False, length: int | None = None) -> ParamSpec:
    return ParamSpec(name, kind, None, description, unit, minimum=minimum,
                     exclusive_minimum=exclusive, length=length)


PARAMETER_SPECS = (
    ParamSpec('scene', 'string', 'full', 'effects to simulate: a scene name or file'),
    _spec('gravity', 'double', 'gravitational acceleration (along -z)', 'm/s^2', 0.0),
    _spec('geometry.arm', 'double', 'distance of each leg from the post', 'm', 0.0, True),
    _spec('geometry.depth', 'double', 'depth of the base points below the post top (the '
          'legs at home)', 'm', 0.0, True),
    _spec('platform.mass', 'double', 'mass of the platform', 'kg', 0.0, True),
    _spec('platform.com', 'double_array', 'centre of mass, platform frame', 'm', length=3),
    _spec('platform.inertia', 'double_array', 'inertia about the centre of mass, platform '
          'axes, row-major 3x3', 'kg m^2', length=9),
    _spec('limits.stroke_min', 'double', 'lowest stroke (length - depth)', 'm'),
    _spec('limits.stroke_max', 'double', 'highest stroke', 'm'),
    _spec('limits.max_speed', 'double', 'largest |dL/dt|', 'm/s', 0.0, True),
    _spec('limits.max_force', 'double', 'largest |f|', 'N', 0.0, True),
)
PARAMETER_NAMES = frozenset({'machine'} | {s.name for s in PARAMETER_SPECS})


@dataclass(frozen=True)
class TiltModel:
    """The platform's parameters (SI units) and the scene's effects."""

    name: str
    scene: str
    effects: Effects
    gravity: float
    arm: float
    depth: float
    mass: float
    com: np.ndarray       # (3,)
    inertia: np.ndarray   # (3, 3) about the centre of mass
    stroke_min: float
    stroke_max: float
    max_speed: float
    max_force: float

    @property
    def inertia_at_pivot(self) -> np.ndarray:
        """I_O = I_c + m (|c|^2 1 - c c^T), platform axes (parallel axes)."""
        c = self.com
        return self.inertia + self.mass * (float(c @ c) * np.eye(3) - np.outer(c, c))


def _number(params: Mapping[str, Any], key: str) -> np.ndarray:
    node: Any = params
    for part in key.split('.'):
        if not isinstance(node, Mapping) or part not in node:
            raise ModelValueError(key, 'missing')
        node = node[part]
    if isinstance(node, bool) or not isinstance(node, (int, float, list, tuple)):
        raise ModelValueError(key, f'expected a number, got {node!r:.60}')
    value = np.asarray(node, dtype=float)
    if not np.all(np.isfinite(value)):
        raise ModelValueError(key, 'expected finite numbers')
    return value


def from_params(params: Mapping[str, Any], effects: Effects) -> TiltModel:
    """The model of a file's nested parameters (ModelValueError naming the key)."""
    values = {s.name: _number(params, s.name) for s in PARAMETER_SPECS if s.kind != 'string'}
    for spec in PARAMETER_SPECS:
        if spec.kind == 'string':
            continue
        value, low = values[spec.name], spec.minimum
        if value.shape != (() if spec.length is None else (spec.length,)):
            raise ModelValueError(spec.name, f'expected {spec.length or 1} number(s)')
        if low is not None and np.any(value <= low if spec.exclusive_minimum else value < low):
            raise ModelValueError(spec.name, f"must be {'>' if spec.exclusive_minimum else '>='}"
                                             f' {low:g}')
    if values['limits.stroke_min'] >= values['limits.stroke_max']:
        raise ModelValueError('limits.stroke_max', 'must be above limits.stroke_min')
    inertia = values['platform.inertia'].reshape(3, 3)
    if not np.allclose(inertia, inertia.T):
        raise ModelValueError('platform.inertia', 'must be symmetric')
    return TiltModel(name=str(params['machine']), scene=str(params.get('scene', 'full')),
                     effects=effects, gravity=float(values['gravity']),
                     arm=float(values['geometry.arm']), depth=float(values['geometry.depth']),
                     mass=float(values['platform.mass']), com=values['platform.com'],
                     inertia=inertia, stroke_min=float(values['limits.stroke_min']),
                     stroke_max=float(values['limits.stroke_max']),
                     max_speed=float(values['limits.max_speed']),
                     max_force=float(values['limits.max_force']))


# -- kinematics --------------------------------------------------------------------------
def _rotations(q: np.ndarray) -> dict[str, np.ndarray]:
    """Rx, Ry and their first and second derivatives, each (N, 3, 3)."""
    n = len(q)
    out = {}
    for axis, angle in (('x', q[:, 0]), ('y', q[:, 1])):
        c, s = np.cos(angle), np.sin(angle)
        z, one = np.zeros(n), np.ones(n)
        if axis == 'x':
            m0 = [[one, z, z], [z, c, -s], [z, s, c]]
            m1 = [[z, z, z], [z, -s, -c], [z, c, -s]]
            m2 = [[z, z, z], [z, -c, s], [z, -s, -c]]
        else:
            m0 = [[c, z, s], [z, one, z], [-s, z, c]]
            m1 = [[-s, z, c], [z, z, z], [-c, z, -s]]
            m2 = [[-c, z, -s], [z, z, z], [s, z, -c]]
        for order, m in enumerate((m0, m1, m2)):
            out[f'{axis}{order}'] = np.moveaxis(np.array(m, dtype=float), -1, 0)
    return out


def _points(model: TiltModel) -> tuple[np.ndarray, np.ndarray]:
    a, h = model.arm, model.depth
    platform = np.array([[a, 0.0, 0.0], [0.0, a, 0.0]])
    return platform, platform - np.array([0.0, 0.0, h])


def _kinematics(model: TiltModel, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> dict:
    """Leg lengths, J = dL/dq, rates and accelerations for rows of q, qd, qdd (N, 2)."""
    r = _rotations(q)
    mul = np.matmul
    R = mul(r['x0'], r['y0'])
    dR = (mul(r['x1'], r['y0']), mul(r['x0'], r['y1']))
    ddR = ((mul(r['x2'], r['y0']), mul(r['x1'], r['y1'])),
           (mul(r['x1'], r['y1']), mul(r['x0'], r['y2'])))
    P, B = _points(model)
    w = np.einsum('nij,lj->nli', R, P)                         # (N, legs, 3)
    dw = np.stack([np.einsum('nij,lj->nli', d, P) for d in dR], axis=-1)   # (N, legs, 3, 2)
    d = w - B
    L = np.linalg.norm(d, axis=-1)
    u = d / L[..., None]
    J = np.einsum('nli,nlij->nlj', u, dw)                      # (N, legs, 2)
    wdot = np.einsum('nlij,nj->nli', dw, qd)
    wddot = np.einsum('nlij,nj->nli', dw, qdd)
    for j in range(2):
        for k in range(2):
            wddot += (np.einsum('nab,lb->nla', ddR[j][k], P)
                      * (qd[:, j] * qd[:, k])[:, None, None])
    rate = np.einsum('nlj,nj->nl', J, qd)
    acc = (np.sum(wdot * wdot, -1) + np.sum(d * wddot, -1) - rate ** 2) / L
    return {'R': R, 'dR': dR, 'length': L, 'jacobian': J, 'rate': rate, 'acceleration': acc}


# -- dynamics ----------------------------------------------------------------------------
def _generalized(model: TiltModel, q: np.ndarray, qd: np.ndarray, kin: dict
                 ) -> tuple[np.ndarray, np.ndarray]:
    """M(q) (N, 2, 2) and c + g (N, 2) of the scene's effects."""
    n = len(q)
    e = model.effects
    c, s = np.cos(q[:, 1]), np.sin(q[:, 1])
    z, one = np.zeros(n), np.ones(n)
    E = np.moveaxis(np.array([[c, z], [z, one], [s, z]]), -1, 0)     # w_body = E qd
    dE = np.moveaxis(np.array([[-s, z], [z, z], [c, z]]), -1, 0)     # dE/dpitch
    I_O = model.inertia_at_pivot
    M = np.zeros((n, 2, 2))
    rest = np.zeros((n, 2))
    if e.platform_inertia:
        M = np.einsum('nai,ab,nbj->nij', E, I_O, E)
        if e.velocity_products:
            dM = (np.einsum('nai,ab,nbj->nij', dE, I_O, E)
                  + np.einsum('nai,ab,nbj->nij', E, I_O, dE))
            Mdot_qd = np.einsum('nij,nj->ni', dM, qd) * qd[:, 1:2]
            rest = Mdot_qd.copy()
            rest[:, 1] -= 0.5 * np.einsum('ni,nij,nj->n', qd, dM, qd)
    if e.gravity:
        # V = m g e_z . R c: dV/dq_j = m g e_z . dR_j c
        rest = rest + model.mass * model.gravity * np.stack(
            [(dRj @ model.com)[:, 2] for dRj in kin['dR']], axis=-1)
    return M, rest


@dataclass(frozen=True)
class TiltSolution:
    """A solve; for :func:`solve_batch` every field has a leading axis of N samples."""

    length: np.ndarray               # (2,) m
    stroke: np.ndarray               # (2,) length - depth, m
    rate: np.ndarray                 # (2,) m/s
    acceleration: np.ndarray         # (2,) m/s^2
    force: np.ndarray                # (2,) N, + extends
    power: np.ndarray                # (2,) W
    joints: np.ndarray               # (4,) roll, pitch (rad), leg lengths (m)
    joint_rates: np.ndarray
    joint_accelerations: np.ndarray
    jacobian: np.ndarray             # (2, 2) dL/dq
    jacobian_condition: np.ndarray | float
    status: Status | np.ndarray
    detail: str | tuple
    model: TiltModel = field(repr=False, compare=False)
    pose: np.ndarray = field(repr=False, compare=False)


_FIELDS = ('length', 'stroke', 'rate', 'acceleration', 'force', 'power', 'joints',
           'joint_rates', 'joint_accelerations', 'jacobian')


def _rows(name: str, value: Any) -> np.ndarray:
    array = np.asarray(value, dtype=float)
    if array.ndim != 2 or array.shape[1] != 2:
        raise ValueError(f'{name} must be N rows of 2 numbers (roll, pitch), got shape '
                         f'{array.shape}')
    return array


@quiet_floating_point
def solve_batch(model: TiltModel, Q: Any, Qd: Any, Qdd: Any) -> TiltSolution:
    """N samples; arrays (N, 2). Never raises for bad numbers (the status says)."""
    q, qd, qdd = (_rows(n, v) for n, v in (('q', Q), ('qd', Qd), ('qdd', Qdd)))
    if not (len(q) == len(qd) == len(qdd)):
        raise ValueError('q, qd and qdd must have as many rows')
    n = len(q)
    finite = np.all(np.isfinite(np.hstack([q, qd, qdd])), axis=1)
    safe = [np.where(finite[:, None], v, 0.0) for v in (q, qd, qdd)]
    kin = _kinematics(model, *safe)
    J = kin['jacobian']
    M, rest = _generalized(model, safe[0], safe[1], kin)
    tau = np.einsum('nij,nj->ni', M, safe[2]) + rest
    det = J[:, 0, 0] * J[:, 1, 1] - J[:, 0, 1] * J[:, 1, 0]
    singular = ~(np.abs(det) > 1e-12 * max(model.arm, 1e-300) ** 2)
    cond = np.full(n, SINGULAR)
    ok = ~singular
    if ok.any():
        cond[ok] = np.linalg.cond(J[ok])
    force = np.zeros((n, 2))
    if ok.any():
        force[ok] = np.linalg.solve(np.swapaxes(J[ok], 1, 2), tau[ok][..., None])[..., 0]
    values = {'length': kin['length'], 'stroke': kin['length'] - model.depth,
              'rate': kin['rate'], 'acceleration': kin['acceleration'], 'force': force,
              'power': force * kin['rate'], 'jacobian': J}
    values['joints'] = np.hstack([safe[0], kin['length']])
    values['joint_rates'] = np.hstack([safe[1], kin['rate']])
    values['joint_accelerations'] = np.hstack([safe[2], kin['acceleration']])
    code = np.zeros(n, dtype=int)
    detail = [''] * n
    overflow = ~np.all(np.isfinite(np.hstack([values[k].reshape(n, -1) for k in _FIELDS])),
                       axis=1)
    for i in range(n):
        if not finite[i] or overflow[i]:
            code[i] = SEVERITY[Status.INVALID_INPUT]
            detail[i] = ('a non-finite input' if not finite[i] else 'results not finite')
        elif singular[i] or cond[i] > MAX_CONDITION:
            code[i] = SEVERITY[Status.NEAR_SINGULAR]
            detail[i] = f'jacobian condition {cond[i]:.3g} > {MAX_CONDITION:g}'
        else:
            why = _over_limits(model, values['stroke'][i], values['rate'][i], force[i])
            if why:
                code[i], detail[i] = SEVERITY[Status.LIMIT], why
    void = code >= SEVERITY[Status.INVALID_INPUT]
    for key in _FIELDS:
        values[key] = np.where(void.reshape((n,) + (1,) * (values[key].ndim - 1)), 0.0,
                               values[key])
    values['force'] = np.where(singular[:, None], 0.0, values['force'])
    values['power'] = values['force'] * values['rate']
    status = np.array(BY_SEVERITY, dtype=object)[code]
    return TiltSolution(**values, jacobian_condition=np.where(void, SINGULAR, cond),
                        status=status, detail=tuple(detail), model=model, pose=safe[0])


def _over_limits(model: TiltModel, stroke: np.ndarray, rate: np.ndarray,
                 force: np.ndarray) -> str:
    """Why a valid sample is ``limit`` ('' when within every limit)."""
    for i, leg in enumerate(LEG_NAMES):
        if not model.stroke_min <= stroke[i] <= model.stroke_max:
            return f'{leg} stroke {stroke[i]:.4g} m outside [{model.stroke_min:g}, ' \
                   f'{model.stroke_max:g}]'
        if abs(rate[i]) > model.max_speed:
            return f'{leg} speed {abs(rate[i]):.4g} m/s > {model.max_speed:g}'
        if abs(force[i]) > model.max_force:
            return f'{leg} force {abs(force[i]):.4g} N > {model.max_force:g}'
    return ''


def _two(name: str, value: Any) -> np.ndarray:
    array = np.asarray(value, dtype=float)
    if array.shape != (2,):
        raise ValueError(f'{name} must be 2 numbers, got shape {array.shape}')
    return array


def sample(batch: TiltSolution, i: int) -> TiltSolution:
    """Sample i of a batch, as :func:`solve` gives it."""
    return TiltSolution(**{k: getattr(batch, k)[i] for k in _FIELDS},
                        jacobian_condition=float(batch.jacobian_condition[i]),
                        status=batch.status[i], detail=batch.detail[i], model=batch.model,
                        pose=batch.pose[i])


def solve(model: TiltModel, q: Any, qd: Any, qdd: Any) -> TiltSolution:
    """One sample: q = (roll, pitch), its rates and accelerations."""
    rows = [_two(n, v)[None, :] for n, v in (('q', q), ('qd', qd), ('qdd', qdd))]
    return sample(solve_batch(model, *rows), 0)


# -- forward kinematics and dynamics, simulation ------------------------------------------
@dataclass(frozen=True)
class ForwardSolution:
    """The pose of given leg lengths (Newton's method)."""

    pose: np.ndarray
    status: Status
    residual: float
    iterations: int
    detail: str = ''


@quiet_floating_point
def forward_kinematics(model: TiltModel, lengths: Any, initial: Any = (0.0, 0.0), *,
                       tolerance: float = 1e-10, max_iterations: int = 50) -> ForwardSolution:
    """The pose whose leg lengths are ``lengths`` (Newton from ``initial``)."""
    check_forward_options(tolerance, max_iterations)
    target = _two('lengths', lengths)
    q = _two('initial', initial).copy()
    if not (np.all(np.isfinite(target)) and np.all(np.isfinite(q))):
        return ForwardSolution(np.zeros(2), Status.INVALID_INPUT, math.inf, 0, 'not finite')
    residual = math.inf
    zero = np.zeros((1, 2))
    for iteration in range(1, max_iterations + 1):
        kin = _kinematics(model, q[None, :], zero, zero)
        error = kin['length'][0] - target
        residual = float(np.max(np.abs(error)))
        if residual <= tolerance:
            return ForwardSolution(q, Status.OK, residual, iteration - 1)
        try:
            q = q - np.linalg.solve(kin['jacobian'][0], error)
        except np.linalg.LinAlgError:
            break
    return ForwardSolution(np.zeros(2), Status.NOT_CONVERGED, residual, max_iterations,
                           f'residual {residual:.3g} m after {max_iterations} iterations')


def affine_terms(model: TiltModel, q: Any, qd: Any) -> tuple[np.ndarray, np.ndarray, Any]:
    """(M, b, the solve at qdd = 0) of f = M qdd + b: M = J^-T M(q), b = J^-T (c + g)."""
    base = solve(model, q, qd, np.zeros(2))
    if SEVERITY[base.status] >= SEVERITY[Status.NEAR_SINGULAR]:
        return np.zeros((2, 2)), np.zeros(2), base
    q2 = _two('q', q)[None, :]
    kin = _kinematics(model, q2, np.zeros((1, 2)), np.zeros((1, 2)))
    M, _ = _generalized(model, q2, np.zeros((1, 2)), kin)
    return np.linalg.solve(base.jacobian.T, M[0]), np.array(base.force), base


@dataclass(frozen=True)
class ForwardDynamics:
    """The accelerations of given forces."""

    acceleration: np.ndarray
    status: Status
    detail: str


def forward_dynamics(model: TiltModel, q: Any, qd: Any, force: Any) -> ForwardDynamics:
    """qdd with ``solve(model, q, qd, qdd).force == force``."""
    require_inertia(model)
    M, b, base = affine_terms(model, q, qd)
    if SEVERITY[base.status] >= SEVERITY[Status.NEAR_SINGULAR]:
        return ForwardDynamics(np.zeros(2), base.status, base.detail)
    return ForwardDynamics(np.linalg.solve(M, _two('force', force) - b), Status.OK, '')


def require_inertia(model: TiltModel) -> None:
    """ValueError unless the scene moves the platform (M != 0)."""
    if not model.effects.platform_inertia:
        raise ValueError(f"scene '{model.scene}' computes no inertia, so forces do not "
                         'determine accelerations; use a scene with platform_inertia')


def actuator_limits(model: TiltModel) -> ActuatorLimits:
    """The same limits for both legs."""
    return ActuatorLimits(stroke_min=np.full(2, model.stroke_min),
                          stroke_max=np.full(2, model.stroke_max),
                          max_speed=model.max_speed, max_force=model.max_force)


#: The usages' names (LimitUsage): each leg's stroke, speed, force.
LIMIT_NAMES = tuple(f'{kind} {leg}' for leg in ('1', '2') for kind in ('stroke', 'speed', 'force'))


def limit_usage(model: TiltModel, solution: Any) -> LimitUsage:
    """How much of its stroke, speed and force limits each leg uses (the status
    ``limit``'s rule: a usage above 1).
    """
    columns = [stroke_usage(np.asarray(solution.stroke), model.stroke_min, model.stroke_max),
               np.abs(solution.rate) / model.max_speed, np.abs(solution.force) / model.max_force]
    stacked = np.stack(columns, axis=-1)                     # (..., legs, kinds)
    return LimitUsage(LIMIT_NAMES, stacked.reshape(stacked.shape[:-2] + (len(LIMIT_NAMES),)))


def _wobble(t: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Roll 0.05 (1 - cos pi t), pitch 0.04 (1 - cos 1.5 pi t): from rest."""
    t = np.atleast_1d(np.asarray(t, dtype=float))
    amp, w = np.array([0.05, 0.04]), np.array([math.pi, 1.5 * math.pi])
    phase = t[:, None] * w
    return amp * (1 - np.cos(phase)), amp * w * np.sin(phase), amp * w * w * np.cos(phase)


MOTIONS = {'wobble': Motion('wobble', 4.0, _wobble, 'roll and pitch from rest, two rates')}

#: The 2-DOF tilt platform as flight_sim_dynamics sees it (its entry point's object).
MACHINE = Machine(
    name=NAME, model_type=TiltModel, coordinates=COORDINATES, units=('rad', 'rad'),
    legs=LEG_NAMES, joints=JOINT_NAMES, solve=solve, solve_batch=solve_batch,
    forward_kinematics=forward_kinematics, forward_dynamics=forward_dynamics,
    actuator_limits=actuator_limits, limit_usage=limit_usage, parameters=PARAMETER_NAMES,
    from_params=from_params, title='2-DOF tilt platform', leg_labels=('1', '2'),
    sample_fields=('jacobian_condition',), motions=MOTIONS, examples=tuple(MOTIONS),
    effects=('gravity', 'platform_inertia', 'velocity_products'),
    affine_terms=affine_terms, require_inertia=require_inertia,
    parameter_specs=PARAMETER_SPECS, planner_motions=('wobble',), planner_example='wobble')
