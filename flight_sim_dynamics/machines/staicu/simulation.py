"""Simulation, the digital twin: the plant under its actuator forces, RK4 at a
fixed step, each stage solving the forward dynamics f = M qdd + b (eq. 14,
18-23; :mod:`.forward_dynamics`; in C with the kernel, :func:`integrate`).
Open loop (``forces=``, a :class:`ForceHistory`; unstable: for short runs) or
closed loop (``reference=``): per actuator ``command = f_ff + kp (L_ref - L) +
kd (Ldot_ref - Ldot)`` (:class:`Servo`), f_ff the ``feedforward`` model's
inverse dynamics, saturated by :func:`deliver`. A run stops (``outcome``) at a
stage state that is unreachable, near a singularity or not finite. Never a NaN.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np

from . import kernel
from ...core.interpolation import ForceHistory, MotionLike, Reference, finite_rows
from .forward_dynamics import affine_terms, require_inertia, solve_accelerations

from ...core.status import SEVERITY, Status
from .model import Model
from .solver import Solution, solve_batch

DEFAULT_STEP = 1e-3              # s: RK4 at 1 kHz
#: Bandwidth (Hz) and damping ratio of the default servo gains.
DEFAULT_BANDWIDTH_HZ = 5.0
DEFAULT_DAMPING = 1.0
MAX_STEPS = 10_000_000
_REST = np.zeros(3)


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
                                 f'got {value}')
            object.__setattr__(self, name, value)

    @classmethod
    def for_bandwidth(cls, model: Model, hz: float = DEFAULT_BANDWIDTH_HZ,
                      damping: float = DEFAULT_DAMPING) -> 'Servo':
        """Gains kp = m_i w^2, kd = 2 damping m_i w (w = 2 pi hz), m_i the diagonal of
        the leg-space mass matrix M J^-1 at the central configuration (J = dL/dq).
        """
        if not (math.isfinite(hz) and hz > 0 and math.isfinite(damping) and damping >= 0):
            raise ValueError(f'servo bandwidth must be > 0 Hz and damping >= 0, '
                             f'got {hz!r} Hz, {damping!r}')
        require_inertia(model)
        M, _, base = affine_terms(model, _REST, _REST)
        mass = np.diag(np.linalg.solve(base.jacobian.T, M.T).T).tolist()
        w = 2.0 * math.pi * hz          # Python floats: an overflow is inf, refused, no warning
        return cls(tuple(m * w * w for m in mass), tuple(2.0 * damping * m * w for m in mass))


def deliver(command: np.ndarray, rate: np.ndarray, max_force: float,
            max_speed: float) -> np.ndarray:
    """The delivered force: within +-max_force, and in the direction of the leg's
    motion at most max_force (1 - |rate| / max_speed).
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


@dataclass(frozen=True)
class TabulatedLaw:
    """The force laws of :func:`simulate` as data the kernel integrates, over the
    half-step index j: ``ff[j]``, or (``servo``) ``deliver(ff[j] + kp
    (length_ref[j] - L) + kd (rate_ref[j] - Ldot))``.
    """

    ff: np.ndarray              # (2 steps + 1, 3) feed-forward (open loop: applied) forces, N
    length_ref: np.ndarray      # (2 steps + 1, 3) reference leg lengths, m (servo only)
    rate_ref: np.ndarray        # (2 steps + 1, 3) reference leg rates, m/s (servo only)
    kp: np.ndarray              # (3,) N/m
    kd: np.ndarray              # (3,) N s/m
    max_force: float = math.inf     # N
    max_speed: float = math.inf     # m/s
    servo: bool = False

    def __post_init__(self) -> None:
        for name in ('ff', 'length_ref', 'rate_ref', 'kp', 'kd'):
            value = np.ascontiguousarray(getattr(self, name), dtype=np.float64)
            if value.shape != ((3,) if name in ('kp', 'kd') else (len(self.ff), 3)):
                raise ValueError(f'{name} has shape {value.shape}')
            object.__setattr__(self, name, value)

    @classmethod
    def servo_law(cls, plant: Model, servo: Servo, ff: np.ndarray, length_ref: np.ndarray,
                  rate_ref: np.ndarray) -> 'TabulatedLaw':
        """The closed loop's law: ``servo``'s gains, the plant's actuator limits."""
        return cls(ff, length_ref, rate_ref, np.array(servo.kp), np.array(servo.kd),
                   plant.limits.max_force, plant.limits.max_speed, True)

    def __call__(self, j: int, base: Solution) -> np.ndarray:
        if not self.servo:
            return self.ff[j]
        command = (self.ff[j] + self.kp * (self.length_ref[j] - base.length)
                   + self.kd * (self.rate_ref[j] - base.rate))
        return deliver(command, base.rate, self.max_force, self.max_speed)


def _stage(plant: Model, q: np.ndarray, qd: np.ndarray, law: ForceLaw, j: int
           ) -> tuple[np.ndarray, np.ndarray, Status, str]:
    """Qdd and the applied force at one stage state, or the status that stops."""
    M, b, base = affine_terms(plant, q, qd)
    if SEVERITY[base.status] >= SEVERITY[Status.NEAR_SINGULAR]:
        return _REST, _REST, base.status, base.detail
    force = law(j, base)
    qdd, status, detail = solve_accelerations(M, b, force)
    return qdd, force, status, detail


def rk4_step(plant: Model, q: np.ndarray, qd: np.ndarray, a1: np.ndarray, law: ForceLaw,
             j: int, h: float) -> tuple[np.ndarray, np.ndarray, Status, str]:
    """The rest of one RK4 step from (q, qd) whose first stage gave a1 (half-step
    index j): the new (q, qd), ok; or the status and detail of a stage that stops.
    """
    q2, v2 = q + 0.5 * h * qd, qd + 0.5 * h * a1
    a2, _, status, detail = _stage(plant, q2, v2, law, j + 1)
    if status == Status.OK:
        q3, v3 = q + 0.5 * h * v2, qd + 0.5 * h * a2
        a3, _, status, detail = _stage(plant, q3, v3, law, j + 1)
    if status == Status.OK:
        q4, v4 = q + h * v3, qd + h * a3
        a4, _, status, detail = _stage(plant, q4, v4, law, j + 2)
    if status == Status.OK:
        q = q + (h / 6.0) * (qd + 2.0 * (v2 + v3) + v4)
        qd = qd + (h / 6.0) * (a1 + 2.0 * (a2 + a3) + a4)
        if not (np.all(np.isfinite(q)) and np.all(np.isfinite(qd))):
            status, detail = Status.INVALID_INPUT, 'state not finite: forces too large'
    return q, qd, status, detail


def integrate(plant: Model, t0: float, step: float, steps: int, q0: np.ndarray,
              qd0: np.ndarray, law: ForceLaw) -> tuple:
    """RK4 of (q, qd) from (q0, qd0) at t0 over ``steps`` steps, the force law
    evaluated at half-step index j. Returns t, q, qd, qdd, force (the rows
    reached), outcome, outcome detail. A :class:`TabulatedLaw` runs in the
    kernel when enabled; a step the kernel cannot finish is taken here.
    """
    h = step
    rows = tuple(np.zeros((steps + 1, 3)) for _ in range(4))
    rq, rqd, rqdd, rf = rows
    tables = None
    if isinstance(law, TabulatedLaw) and len(law.ff) == 2 * steps + 1 and kernel.enabled():
        tables = (law.ff, law.length_ref, law.rate_ref, law.kp, law.kd, float(law.max_force),
                  float(law.max_speed), bool(law.servo))
    q, qd = np.asarray(q0, dtype=float), np.asarray(qd0, dtype=float)
    k, n = 0, steps + 1
    outcome, why = Status.OK, ''
    while k <= steps:
        if tables is not None:
            rq[k], rqd[k] = q, qd
            k = kernel.integrate_rows(plant, tables, h, k, steps, rows)
            if k > steps:
                break
            q, qd = rq[k].copy(), rqd[k].copy()
        rq[k], rqd[k] = q, qd
        a1, f1, status, detail = _stage(plant, q, qd, law, 2 * k)
        rqdd[k], rf[k] = a1, f1
        if status != Status.OK:
            outcome, why, n = status, f't = {t0 + k * h:.6g} s: {detail}', k + 1
            break
        if k == steps:
            break
        q, qd, status, detail = rk4_step(plant, q, qd, a1, law, 2 * k, h)
        if status != Status.OK:
            outcome, why, n = status, (f'step from t = {t0 + k * h:.6g} s: {detail}'), k + 1
            break
        k += 1
    return (t0 + h * np.arange(n), rq[:n], rqd[:n], rqdd[:n], rf[:n], outcome, why)


def reference_tables(model: Model, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray,
                     times: np.ndarray, what: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Leg lengths, rates and forces of ``model`` on the reference (eq. 5-23);
    ValueError at the first sample that cannot be tracked.
    """
    sol = solve_batch(model, q, qd, qdd)
    bad = [i for i, s in enumerate(sol.status) if SEVERITY[s] >= SEVERITY[Status.NEAR_SINGULAR]]
    if bad:
        i = bad[0]
        raise ValueError(f'{what} at t = {times[i]:.6g} s: {sol.status[i]}: {sol.detail[i]} '
                         f'({len(bad)} of {times.size} samples cannot be tracked)')
    return np.array(sol.length), np.array(sol.rate), np.array(sol.force)


def step_count(start: float, end: float, step: float) -> int:
    """Number of whole steps from start to end (validated step)."""
    if not (math.isfinite(step) and step > 0):
        raise ValueError(f'step must be a positive number of seconds, got {step!r}')
    count = (end - start) / step + 1e-9         # a float: may be huge, or inf
    if count < 1:
        raise ValueError(f'the motion lasts {end - start:g} s, less than one step of {step:g} s')
    if count >= MAX_STEPS + 1:
        raise ValueError(f'{count:.3g} steps of {step:g} s: more than {MAX_STEPS}')
    return int(count)


def _state(initial: tuple | None, default: tuple[np.ndarray, np.ndarray]
           ) -> tuple[np.ndarray, np.ndarray]:
    if initial is None:
        return default
    try:
        q0, qd0 = initial
    except (TypeError, ValueError):
        raise ValueError('initial must be (q, qd): two triples') from None
    q0, qd0 = finite_rows('initial q', [q0])[0], finite_rows('initial qd', [qd0])[0]
    return q0, qd0


def simulate(plant: Model, *, forces: ForceHistory | tuple | None = None,
             reference: Reference | MotionLike | None = None,
             feedforward: Model | None = None,
             servo: Servo | None = None, initial: tuple | None = None,
             step: float = DEFAULT_STEP) -> Simulation:
    """Simulate the plant with RK4 at a fixed ``step`` (s).

    Open loop: ``forces`` (a :class:`ForceHistory` or its (t, force));
    ``initial`` = (q, qd), default rest at the central configuration. Closed
    loop: ``reference`` (a :class:`Reference` or a motion name of
    :mod:`.motions`) tracked by ``servo`` (default :meth:`Servo.for_bandwidth`)
    with the feed-forward of ``feedforward`` (None: none); ``initial`` defaults
    to the reference's start. ValueError for bad arguments (a scene without
    inertia, a reference the plant cannot follow).
    """
    require_inertia(plant)
    if (forces is None) == (reference is None):
        raise ValueError('give either forces (open loop) or reference (closed loop)')
    if forces is not None:
        if not isinstance(forces, ForceHistory):
            forces = ForceHistory(*forces)
        if feedforward is not None or servo is not None:
            raise ValueError('feedforward and servo apply to closed loop (reference) only')
        steps = step_count(forces.start, forces.end, step)
        stage_force = forces(forces.start + 0.5 * step * np.arange(2 * steps + 1))
        q0, qd0 = _state(initial, (_REST, _REST))
        t, q, qd, qdd, force, outcome, why = integrate(
            plant, forces.start, step, steps, q0, qd0,
            TabulatedLaw(stage_force, stage_force, stage_force, _REST, _REST))
        return _result(plant, t, q, qd, qdd, force, outcome, why)
    if not isinstance(reference, Reference):
        reference = Reference.from_motion(reference)
    steps = step_count(reference.start, reference.end, step)
    times = reference.start + 0.5 * step * np.arange(2 * steps + 1)
    q_ref, qd_ref, qdd_ref = reference.motion(times)
    servo = servo if servo is not None else Servo.for_bandwidth(plant)
    q0, qd0 = _state(initial, (q_ref[0], qd_ref[0]))
    length_ref, rate_ref, plant_force = reference_tables(plant, q_ref, qd_ref, qdd_ref, times,
                                                         'the reference motion')
    if feedforward is plant:         # the plant's own model: the same batch
        ff = plant_force
    elif feedforward is not None:
        ff = reference_tables(feedforward, q_ref, qd_ref, qdd_ref, times,
                              'the feed-forward model')[2]
    else:
        ff = np.zeros_like(length_ref)
    law = TabulatedLaw.servo_law(plant, servo, ff, length_ref, rate_ref)
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
