"""Simulation: the platform driven by its actuators, integrated in time (a
digital twin of the machine). Numpy only.

The state (q, qd) is integrated by the classical fourth-order Runge-Kutta
method at a fixed step h; each stage evaluates the forward dynamics
(:mod:`.forward_dynamics`: qdd from f = M qdd + b, eq. 14, 18-23) of the
*plant* model.

Open loop (``forces=``): a :class:`ForceHistory` of actuator forces at given
times, interpolated between its rows by a cubic Hermite spline whose node
slopes are the derivatives of the polynomial through the five nearest rows
(fewer when there are fewer rows): the spline reproduces cubics exactly, so
its error is O(dt^4) for smooth forces (a Catmull-Rom spline, whose
three-point slopes are exact for quadratics only, is O(dt^3)). The platform
under prescribed forces is unstable (no feedback holds it on a path), so open
loop is for short horizons and checks.

Closed loop (``reference=``): each actuator is a servo on its leg length and
rate, as the machine runs:

    command = f_ff + kp (L_ref - L) + kd (Ldot_ref - Ldot)

with gains per actuator (:class:`Servo`), L_ref and Ldot_ref from the
plant's inverse kinematics of the reference motion (the geometry is taken as
calibrated), and f_ff the inverse dynamics of the reference motion computed
with the ``feedforward`` model (any scene or parameter file; None: no
feed-forward). The delivered force is the command saturated by the plant's
actuator (:func:`deliver`): at most ``limits.max_force``, and in the
direction of the leg's motion at most max_force (1 - |Ldot| / max_speed), the
force-speed line of a drive whose no-load speed is ``limits.max_speed`` (it
cannot drive a leg faster; it can always brake with the full force).

A simulation stops, with the status and the time in ``outcome`` and
``outcome_detail``, when a stage state is unreachable, near a singularity
(the solver's thresholds, or M too ill-conditioned) or not finite; its rows
end at the last state reached. Never a NaN.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, Protocol, Sequence

import numpy as np

from .forward_dynamics import affine_terms, require_inertia, solve_accelerations
from .model import Model
from .solver import Solution, solve_batch
from .status import SEVERITY, Status

Trajectory = tuple[np.ndarray, np.ndarray, np.ndarray]


class MotionLike(Protocol):
    """What :class:`.motions.Motion` offers (not imported here: ``import
    flight_sim_dynamics`` stays free of the motion registry).
    """

    duration: float

    def trajectory(self, t: np.ndarray) -> Trajectory: ...


DEFAULT_STEP = 1e-3              # s: RK4 at 1 kHz
#: Servo bandwidth of the default gains (Hz) and their damping ratio: a
#: critically damped leg of the platform's leg-space mass at the centre.
DEFAULT_BANDWIDTH_HZ = 5.0
DEFAULT_DAMPING = 1.0
MAX_STEPS = 10_000_000
_REST = np.zeros(3)


def _rows(name: str, value: object, n: int | None = None) -> np.ndarray:
    """An (N, 3) array of finite numbers, or ValueError naming ``name``."""
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f'{name} must be numbers, got {value!r:.100}') from None
    if arr.ndim != 2 or arr.shape[1] != 3 or (n is not None and arr.shape[0] != n):
        raise ValueError(f'{name} must have shape ({n if n is not None else "N"}, 3), '
                         f'got {arr.shape}')
    bad = np.argwhere(~np.isfinite(arr))
    if bad.size:
        i, j = bad[0]
        raise ValueError(f'{name}[{i}, {j}] is not finite ({arr[i, j]})')
    return arr


def _times(t: object) -> np.ndarray:
    """Strictly increasing finite sample times (at least two), or ValueError."""
    arr = np.asarray(t, dtype=float)
    if arr.ndim != 1 or arr.size < 2:
        raise ValueError(f'times must be a list of at least 2 numbers, got shape {arr.shape}')
    if not np.all(np.isfinite(arr)):
        raise ValueError(f't[{int(np.argmin(np.isfinite(arr)))}] is not finite')
    steps = np.diff(arr)
    if not np.all(steps > 0):
        i = int(np.argmin(steps > 0))
        raise ValueError(f'times must increase strictly: t[{i + 1}] = {arr[i + 1]!r} '
                         f'after t[{i}] = {arr[i]!r}')
    return arr


def node_slopes(t: np.ndarray, y: np.ndarray) -> np.ndarray:
    """dy/dt at every node: the derivative of the interpolating polynomial
    through the five nearest nodes (window kept inside the data; all nodes
    when fewer than five), i.e. sum_j L_j'(t_i) y_j with the Lagrange basis
    L_j. Exact for polynomials of degree <= 4 (and <= n - 1).
    """
    n = t.size
    width = min(5, n)
    first = np.clip(np.arange(n) - width // 2, 0, n - width)
    nodes = first[:, None] + np.arange(width)           # (n, width) window of each node
    tw = t[nodes]
    ti = t[:, None]
    slopes = np.zeros_like(y)
    for j in range(width):
        others = [k for k in range(width) if k != j]
        dj = tw[:, j:j + 1] - tw[:, others]                          # t_j - t_k
        is_self = nodes[:, j] == np.arange(n)
        # L_j'(t_i) for j != i: prod_{k != i, j}(t_i - t_k) / prod_{k != j}(t_j - t_k)
        num = np.prod(np.where(nodes[:, others] == np.arange(n)[:, None], 1.0,
                               ti - tw[:, others]), axis=1)
        w = num / np.prod(dj, axis=1)
        # L_i'(t_i) = sum_{k != i} 1 / (t_i - t_k)
        w_self = np.sum(1.0 / dj, axis=1)
        w = np.where(is_self, w_self, w)
        slopes += w[:, None] * y[nodes[:, j]]
    return slopes


class ForceHistory:
    """Actuator forces (legs A, B, C, N) at times ``t`` (s, strictly
    increasing), interpolated by the cubic Hermite spline of the module's
    docstring (O(dt^4); linear for two rows).
    """

    def __init__(self, t: Sequence[float], force: object) -> None:
        self.t = _times(t)
        self.force = _rows('force', force, self.t.size)
        self.slope = node_slopes(self.t, self.force)

    @property
    def start(self) -> float:
        return float(self.t[0])

    @property
    def end(self) -> float:
        return float(self.t[-1])

    def __call__(self, times: np.ndarray) -> np.ndarray:
        """Forces (N, 3) at ``times`` (within [start, end], else ValueError)."""
        times = np.atleast_1d(np.asarray(times, dtype=float))
        if times.min() < self.start or times.max() > self.end:
            raise ValueError(f'force history spans [{self.start:g}, {self.end:g}] s; '
                             f'asked for [{times.min():g}, {times.max():g}] s')
        i = np.clip(np.searchsorted(self.t, times, side='right') - 1, 0, self.t.size - 2)
        dt = (self.t[i + 1] - self.t[i])[:, None]
        u = (times[:, None] - self.t[i][:, None]) / dt
        h00, h10 = (1 + 2 * u) * (1 - u) ** 2, u * (1 - u) ** 2
        h01, h11 = u * u * (3 - 2 * u), u * u * (u - 1)
        return (h00 * self.force[i] + h10 * dt * self.slope[i]
                + h01 * self.force[i + 1] + h11 * dt * self.slope[i + 1])


#: Quintic Hermite basis on [0, 1] (rows: value, slope, second derivative at 0,
#: then second derivative, slope, value at 1; columns: coefficients of u^0..u^5).
_QUINTIC = np.array([[1, 0, 0, -10, 15, -6], [0, 1, 0, -6, 8, -3],
                     [0, 0, 0.5, -1.5, 1.5, -0.5], [0, 0, 0, 0.5, -1, 0.5],
                     [0, 0, 0, -4, 7, -3], [0, 0, 0, 10, -15, 6]], dtype=float)


@dataclass(frozen=True)
class Reference:
    """A reference motion: ``motion(times)`` gives q, qd, qdd (each (N, 3)) at
    times in [start, end] (s).
    """

    motion: Callable[[np.ndarray], Trajectory]
    start: float
    end: float

    @classmethod
    def from_motion(cls, motion: MotionLike) -> 'Reference':
        """A motion of the registry (:class:`.motions.Motion`, or anything with
        its ``trajectory(t)`` and ``duration``), from 0 to its duration: exact.
        """
        try:
            return cls(motion.trajectory, 0.0, float(motion.duration))
        except AttributeError:
            raise ValueError(f'reference must be a Reference or a motion with trajectory and '
                             f'duration, got {motion!r:.100}') from None

    @classmethod
    def from_samples(cls, t: Sequence[float], q: object, qd: object, qdd: object
                     ) -> 'Reference':
        """Samples (e.g. the rows of a trajectory CSV), interpolated by quintic
        Hermite polynomials matching q, qd and qdd at both ends of every
        interval (exact at the rows, C2 in between).
        """
        times = _times(t)
        n = times.size
        values = np.stack([_rows('q', q, n), _rows('qd', qd, n), _rows('qdd', qdd, n)])

        def motion(at: np.ndarray) -> Trajectory:
            at = np.atleast_1d(np.asarray(at, dtype=float))
            i = np.clip(np.searchsorted(times, at, side='right') - 1, 0, n - 2)
            dt = (times[i + 1] - times[i])[:, None]
            u = (at[:, None] - times[i][:, None]) / dt
            powers = u[..., None] ** np.arange(6)                     # (N, 1, 6)
            d1 = np.concatenate([np.zeros_like(u)[..., None],
                                 np.arange(1, 6) * u[..., None] ** np.arange(5)], axis=-1)
            d2 = np.concatenate([np.zeros_like(u)[..., None].repeat(2, -1),
                                 np.arange(2, 6) * np.arange(1, 5) * u[..., None]
                                 ** np.arange(4)], axis=-1)
            ends = (values[0][i], dt * values[1][i], dt * dt * values[2][i],
                    dt * dt * values[2][i + 1], dt * values[1][i + 1], values[0][i + 1])
            out = []
            for k, basis_powers in enumerate((powers, d1, d2)):
                basis = basis_powers[:, 0, :] @ _QUINTIC.T                # (N, 6)
                out.append(sum(basis[:, m:m + 1] * ends[m] for m in range(6)) / dt ** k)
            return out[0], out[1], out[2]

        return cls(motion, float(times[0]), float(times[-1]))


@dataclass(frozen=True)
class Servo:
    """PD gains of the three actuator servos (legs A, B, C): kp in N/m, kd in
    N s/m, each >= 0.
    """

    kp: tuple[float, float, float]
    kd: tuple[float, float, float]

    def __post_init__(self) -> None:
        for name in ('kp', 'kd'):
            value = tuple(float(v) for v in getattr(self, name))
            if len(value) != 3 or not all(math.isfinite(v) and v >= 0 for v in value):
                raise ValueError(f'servo {name} must be 3 finite numbers >= 0 (legs A, B, C), '
                                 f'got {getattr(self, name)!r}')
            object.__setattr__(self, name, value)

    @classmethod
    def for_bandwidth(cls, model: Model, hz: float = DEFAULT_BANDWIDTH_HZ,
                      damping: float = DEFAULT_DAMPING) -> 'Servo':
        """Gains of a leg of mass m_i with natural frequency 2 pi hz and damping
        ratio ``damping``: kp = m_i w^2, kd = 2 damping m_i w, with m_i the
        diagonal of the model's leg-space mass matrix M J^-1 at rest at the
        central configuration (J = dL/dq).
        """
        if not (math.isfinite(hz) and hz > 0 and math.isfinite(damping) and damping >= 0):
            raise ValueError(f'servo bandwidth must be > 0 Hz and damping >= 0, '
                             f'got {hz!r} Hz, {damping!r}')
        require_inertia(model)
        M, _, base = affine_terms(model, _REST, _REST)
        mass = np.diag(np.linalg.solve(base.jacobian.T, M.T).T)
        w = 2.0 * math.pi * hz
        return cls(tuple(mass * w * w), tuple(2.0 * damping * mass * w))


def deliver(command: np.ndarray, rate: np.ndarray, max_force: float,
            max_speed: float) -> np.ndarray:
    """The force an actuator delivers for a commanded force at leg rate
    ``rate``: within +-max_force, and in the direction of motion at most
    max_force (1 - |rate| / max_speed) (zero at and beyond max_speed).
    """
    force = np.clip(command, -max_force, max_force)
    drive = max_force * np.maximum(0.0, 1.0 - np.abs(rate) / max_speed)
    return np.where(force * rate > 0.0, np.sign(force) * np.minimum(np.abs(force), drive),
                    force)


@dataclass(frozen=True)
class Simulation:
    """Result of :func:`simulate`: one row per step (t = start + k h) up to the
    end or to the last state reached. Leg quantities are ordered A, B, C.
    """

    t: np.ndarray            # (N,) s
    q: np.ndarray            # (N, 3) surge m, heave m, roll rad
    qd: np.ndarray           # (N, 3) their rates
    qdd: np.ndarray          # (N, 3) their accelerations (zeros on a last row that stopped)
    length: np.ndarray       # (N, 3) leg lengths, m
    rate: np.ndarray         # (N, 3) leg rates, m/s
    force: np.ndarray        # (N, 3) delivered actuator forces, N
    status: np.ndarray       # (N,) Status of each row (solve's rules: ok, limit, ...)
    detail: tuple            # (N,) why a row's status is not ok
    outcome: Status          # ok when the run reached its end, else why it stopped
    outcome_detail: str      # when and why it stopped ('' when ok)
    pose_error: np.ndarray | None = None     # (N, 3) q - q_ref (closed loop)
    length_error: np.ndarray | None = None   # (N, 3) L - L_ref (closed loop)

    def tracking(self) -> dict[str, float]:
        """Max and RMS over the rows of the tracking errors: pose per coordinate
        (surge, heave m; roll rad) and leg lengths over the three legs (m).
        """
        if self.pose_error is None or self.length_error is None:
            raise ValueError('an open-loop simulation has no tracking error')
        out: dict[str, float] = {}
        for i, name in enumerate(('surge', 'heave', 'roll')):
            e = self.pose_error[:, i]
            out[f'{name}_max'] = float(np.max(np.abs(e)))
            out[f'{name}_rms'] = float(np.sqrt(np.mean(e * e)))
        e = self.length_error
        out['length_max'] = float(np.max(np.abs(e)))
        out['length_rms'] = float(np.sqrt(np.mean(e * e)))
        return out


#: A force law of one stage: (half-step index, the plant's solve at the stage
#: state with zero acceleration) -> forces to apply (3,).
ForceLaw = Callable[[int, Solution], np.ndarray]


def _stage(plant: Model, q: np.ndarray, qd: np.ndarray, law: ForceLaw, j: int
           ) -> tuple[np.ndarray, np.ndarray, Status, str]:
    """Qdd and the applied force at one stage state, or the status that stops."""
    M, b, base = affine_terms(plant, q, qd)
    if SEVERITY[base.status] >= SEVERITY[Status.NEAR_SINGULAR]:
        return _REST, _REST, base.status, base.detail
    force = law(j, base)
    qdd, status, detail = solve_accelerations(M, b, force)
    return qdd, force, status, detail


def integrate(plant: Model, t0: float, step: float, steps: int, q0: np.ndarray,
              qd0: np.ndarray, law: ForceLaw) -> tuple:
    """RK4 of (q, qd) from (q0, qd0) at t0 over ``steps`` steps; the force law
    is evaluated at half-step index j (time t0 + j step / 2). Returns t, q, qd,
    qdd, force (arrays of the rows reached), outcome, outcome detail.
    """
    h = step
    q, qd = q0, qd0
    rows_q, rows_qd, rows_qdd, rows_f = [], [], [], []
    outcome, why = Status.OK, ''
    for k in range(steps + 1):
        rows_q.append(q)
        rows_qd.append(qd)
        a1, f1, status, detail = _stage(plant, q, qd, law, 2 * k)
        rows_qdd.append(a1)
        rows_f.append(f1)
        if status != Status.OK:
            outcome, why = status, f't = {t0 + k * h:.6g} s: {detail}'
            break
        if k == steps:
            break
        q2, v2 = q + 0.5 * h * qd, qd + 0.5 * h * a1
        a2, _, status, detail = _stage(plant, q2, v2, law, 2 * k + 1)
        if status == Status.OK:
            q3, v3 = q + 0.5 * h * v2, qd + 0.5 * h * a2
            a3, _, status, detail = _stage(plant, q3, v3, law, 2 * k + 1)
        if status == Status.OK:
            q4, v4 = q + h * v3, qd + h * a3
            a4, _, status, detail = _stage(plant, q4, v4, law, 2 * k + 2)
        if status == Status.OK:
            q = q + (h / 6.0) * (qd + 2.0 * (v2 + v3) + v4)
            qd = qd + (h / 6.0) * (a1 + 2.0 * (a2 + a3) + a4)
            if not (np.all(np.isfinite(q)) and np.all(np.isfinite(qd))):
                status, detail = Status.INVALID_INPUT, 'state not finite: forces too large'
        if status != Status.OK:
            outcome, why = status, (f'step from t = {t0 + k * h:.6g} s: {detail}')
            break
    n = len(rows_q)
    return (t0 + h * np.arange(n), np.array(rows_q), np.array(rows_qd), np.array(rows_qdd),
            np.array(rows_f), outcome, why)


def _grid(start: float, end: float, step: float) -> int:
    """Number of whole steps from start to end (validated step)."""
    if not (math.isfinite(step) and step > 0):
        raise ValueError(f'step must be a positive number of seconds, got {step!r}')
    steps = int(math.floor((end - start) / step + 1e-9))
    if steps < 1:
        raise ValueError(f'the motion lasts {end - start:g} s, less than one step of {step:g} s')
    if steps > MAX_STEPS:
        raise ValueError(f'{steps} steps of {step:g} s: more than {MAX_STEPS}')
    return steps


def _state(initial: tuple | None, default: tuple[np.ndarray, np.ndarray]
           ) -> tuple[np.ndarray, np.ndarray]:
    if initial is None:
        return default
    try:
        q0, qd0 = initial
    except (TypeError, ValueError):
        raise ValueError('initial must be (q, qd): two triples') from None
    q0, qd0 = _rows('initial q', [q0])[0], _rows('initial qd', [qd0])[0]
    return q0, qd0


def _reference_problem(sol: Solution, times: np.ndarray, what: str) -> None:
    """ValueError at the first reference sample that cannot be tracked."""
    code = np.array([SEVERITY[s] for s in sol.status])
    bad = np.flatnonzero(code >= SEVERITY[Status.NEAR_SINGULAR])
    if bad.size:
        i = int(bad[0])
        raise ValueError(f'{what} at t = {times[i]:.6g} s: {sol.status[i]}: {sol.detail[i]} '
                         f'({bad.size} of {times.size} samples cannot be tracked)')


def simulate(plant: Model, *, forces: ForceHistory | tuple | None = None,
             reference: Reference | MotionLike | None = None,
             feedforward: Model | None = None,
             servo: Servo | None = None, initial: tuple | None = None,
             step: float = DEFAULT_STEP) -> Simulation:
    """Simulate the plant model with RK4 at a fixed ``step`` (s).

    Open loop: ``forces`` (a :class:`ForceHistory`, or its arguments (t,
    force)), from its first time to its last; ``initial`` = (q, qd), default
    rest at the central configuration. Closed loop: ``reference`` (a
    :class:`Reference`, or a motion of the registry :mod:`.motions`) tracked
    by the servos (``servo``, default :meth:`Servo.for_bandwidth` of the
    plant) with the feed-forward of the ``feedforward`` model (None: none);
    ``initial`` defaults to the reference's state at its start. ValueError
    for bad arguments (a scene without inertia, a reference the plant cannot
    follow: unreachable or near a singularity).
    See the module's docstring for the models.
    """
    require_inertia(plant)
    if (forces is None) == (reference is None):
        raise ValueError('give either forces (open loop) or reference (closed loop)')
    if forces is not None:
        if not isinstance(forces, ForceHistory):
            forces = ForceHistory(*forces)
        if feedforward is not None or servo is not None:
            raise ValueError('feedforward and servo apply to closed loop (reference) only')
        steps = _grid(forces.start, forces.end, step)
        stage_force = forces(forces.start + 0.5 * step * np.arange(2 * steps + 1))
        q0, qd0 = _state(initial, (_REST, _REST))
        t, q, qd, qdd, force, outcome, why = integrate(
            plant, forces.start, step, steps, q0, qd0, lambda j, base: stage_force[j])
        return _result(plant, t, q, qd, qdd, force, outcome, why)
    if not isinstance(reference, Reference):
        reference = Reference.from_motion(reference)
    steps = _grid(reference.start, reference.end, step)
    times = reference.start + 0.5 * step * np.arange(2 * steps + 1)
    q_ref, qd_ref, qdd_ref = reference.motion(times)
    kinematics = solve_batch(plant, q_ref, qd_ref, qdd_ref)
    _reference_problem(kinematics, times, 'the reference motion')
    length_ref, rate_ref = np.array(kinematics.length), np.array(kinematics.rate)
    if feedforward is not None:
        ff_sol = solve_batch(feedforward, q_ref, qd_ref, qdd_ref)
        _reference_problem(ff_sol, times, 'the feed-forward model')
        ff = np.array(ff_sol.force)
    else:
        ff = np.zeros_like(length_ref)
    servo = servo if servo is not None else Servo.for_bandwidth(plant)
    kp, kd = np.array(servo.kp), np.array(servo.kd)
    max_force, max_speed = plant.limits.max_force, plant.limits.max_speed

    def law(j: int, base: Solution) -> np.ndarray:
        command = ff[j] + kp * (length_ref[j] - base.length) + kd * (rate_ref[j] - base.rate)
        return deliver(command, base.rate, max_force, max_speed)

    q0, qd0 = _state(initial, (q_ref[0], qd_ref[0]))
    t, q, qd, qdd, force, outcome, why = integrate(plant, reference.start, step, steps,
                                                   q0, qd0, law)
    rows = slice(0, 2 * len(t), 2)
    return _result(plant, t, q, qd, qdd, force, outcome, why,
                   q - q_ref[rows], length_ref[rows])


def _result(plant: Model, t: np.ndarray, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray,
            force: np.ndarray, outcome: Status, why: str, pose_error: np.ndarray | None = None,
            length_ref: np.ndarray | None = None) -> Simulation:
    """The rows of a run, with lengths, rates and statuses from one batch solve
    (its forces are the delivered ones, to rounding: f = M qdd + b).
    """
    sol = solve_batch(plant, q, qd, qdd)
    length = np.array(sol.length)
    return Simulation(t=t, q=q, qd=qd, qdd=qdd, length=length, rate=np.array(sol.rate),
                      force=force, status=np.asarray(sol.status), detail=tuple(sol.detail),
                      outcome=outcome, outcome_detail=why, pose_error=pose_error,
                      length_error=None if length_ref is None else length - length_ref)
