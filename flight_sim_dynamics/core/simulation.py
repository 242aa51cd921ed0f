"""Simulation, the digital twin of any machine (:class:`.machine.Machine`): the
plant under its actuator forces, RK4 at a fixed step, each stage solving the
forward dynamics f = M qdd + b (the machine's ``affine_terms``, its equations in
its own module; :func:`.forward_dynamics.solve_accelerations`),
in C when the machine's kernel loop is enabled (``Machine.integrate_rows``).
Open loop (``forces=``, a :class:`ForceHistory`; unstable: for short runs) or
closed loop (``reference=``): the servo law of :mod:`.servo`, f_ff the
``feedforward`` model's inverse dynamics. A run stops (``outcome``) at a stage
state that is unreachable, near a singularity or not finite. Never a NaN.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Callable

import numpy as np

from .forward_dynamics import solve_accelerations
from .interpolation import ForceHistory, MotionLike, Reference, finite_rows
from .machine import Machine
from .servo import Servo, TabulatedLaw
from .status import SEVERITY, Status

DEFAULT_STEP = 1e-3              # s: RK4 at 1 kHz
MAX_STEPS = 10_000_000


@dataclass(frozen=True)
class Simulation:
    """Result of :func:`simulate`: one row per step (t = start + k h) up to the
    end or to the last state reached. Pose columns in the order of the machine's
    ``coordinates``, leg columns in the order of its ``legs``.
    """

    t: np.ndarray            # (N,) s
    q: np.ndarray            # (N, dof) pose (m, rad)
    qd: np.ndarray           # (N, dof) its rates
    qdd: np.ndarray          # (N, dof) its accelerations (zeros on a last row that stopped)
    length: np.ndarray       # (N, legs) leg lengths, m
    rate: np.ndarray         # (N, legs) leg rates, m/s
    force: np.ndarray        # (N, legs) delivered actuator forces, N
    status: np.ndarray       # (N,) Status of each row (solve's rules: ok, limit, ...)
    detail: tuple            # (N,) why a row's status is not ok ('' when ok)
    outcome: Status          # ok when the run reached its end, else why it stopped
    outcome_detail: str      # when and why it stopped ('' when ok)
    pose_error: np.ndarray | None = None     # (N, dof) q - q_ref (closed loop)
    length_error: np.ndarray | None = None   # (N, legs) L - L_ref (closed loop)
    coordinates: tuple[str, ...] = ()        # the machine's pose coordinates

    def tracking(self) -> dict[str, float]:
        """Max and RMS over the rows of the tracking errors: pose per coordinate
        (m or rad) and leg lengths over all legs (m).
        """
        if self.pose_error is None or self.length_error is None:
            raise ValueError('an open-loop simulation has no tracking error')
        out: dict[str, float] = {}
        for i, name in enumerate(self.coordinates):
            e = self.pose_error[:, i]
            out[f'{name}_max'] = float(np.max(np.abs(e)))
            out[f'{name}_rms'] = float(np.sqrt(np.mean(e * e)))
        e = self.length_error
        out['length_max'] = float(np.max(np.abs(e)))
        out['length_rms'] = float(np.sqrt(np.mean(e * e)))
        return out


#: A force law of one stage: (half-step index, the plant's solve at the stage
#: state with zero acceleration) -> forces to apply (legs,).
ForceLaw = Callable[[int, Any], np.ndarray]


def stage(machine: Machine, plant: Any, q: np.ndarray, qd: np.ndarray, law: ForceLaw,
          j: int) -> tuple[np.ndarray, np.ndarray, Status, str]:
    """Qdd and the applied force at one stage state, or the status that stops."""
    M, b, base = machine.affine_terms(plant, q, qd)
    if SEVERITY[base.status] >= SEVERITY[Status.NEAR_SINGULAR]:
        rest = np.zeros(len(q))
        return rest, np.zeros(len(b)), base.status, base.detail
    force = law(j, base)
    qdd, status, detail = solve_accelerations(M, b, force)
    return qdd, force, status, detail


def rk4_step(machine: Machine, plant: Any, q: np.ndarray, qd: np.ndarray, a1: np.ndarray,
             law: ForceLaw, j: int, h: float) -> tuple[np.ndarray, np.ndarray, Status, str]:
    """The rest of one RK4 step from (q, qd) whose first stage gave a1 (half-step
    index j): the new (q, qd), ok; or the status and detail of a stage that stops.
    """
    q2, v2 = q + 0.5 * h * qd, qd + 0.5 * h * a1
    a2, _, status, detail = stage(machine, plant, q2, v2, law, j + 1)
    if status == Status.OK:
        q3, v3 = q + 0.5 * h * v2, qd + 0.5 * h * a2
        a3, _, status, detail = stage(machine, plant, q3, v3, law, j + 1)
    if status == Status.OK:
        q4, v4 = q + h * v3, qd + h * a3
        a4, _, status, detail = stage(machine, plant, q4, v4, law, j + 2)
    if status == Status.OK:
        q = q + (h / 6.0) * (qd + 2.0 * (v2 + v3) + v4)
        qd = qd + (h / 6.0) * (a1 + 2.0 * (a2 + a3) + a4)
        if not (np.all(np.isfinite(q)) and np.all(np.isfinite(qd))):
            status, detail = Status.INVALID_INPUT, 'state not finite: forces too large'
    return q, qd, status, detail


def kernel_loop(machine: Machine) -> Callable[..., int] | None:
    """The machine's compiled RK4 loop when it has one and it is enabled, else None."""
    if machine.integrate_rows is not None and machine.kernel_enabled():
        return machine.integrate_rows
    return None


def integrate(machine: Machine, plant: Any, t0: float, step: float, steps: int,
              q0: np.ndarray, qd0: np.ndarray, law: ForceLaw) -> tuple:
    """RK4 of (q, qd) from (q0, qd0) at t0 over ``steps`` steps, the force law
    evaluated at half-step index j. Returns t, q, qd, qdd, force (the rows
    reached), outcome, outcome detail. A :class:`.servo.TabulatedLaw` runs in
    the machine's kernel when enabled; a step the kernel cannot finish is taken here.
    """
    h = step
    dof, legs = machine.dof, len(machine.legs)
    rq, rqd, rqdd, rf = rows = (np.zeros((steps + 1, dof)), np.zeros((steps + 1, dof)),
                                np.zeros((steps + 1, dof)), np.zeros((steps + 1, legs)))
    loop = kernel_loop(machine)
    tables = None
    if isinstance(law, TabulatedLaw) and len(law.ff) == 2 * steps + 1 and loop is not None:
        tables = law.tables()
    q, qd = np.asarray(q0, dtype=float), np.asarray(qd0, dtype=float)
    k, n = 0, steps + 1
    outcome, why = Status.OK, ''
    while k <= steps:
        if tables is not None:
            rq[k], rqd[k] = q, qd
            k = loop(plant, tables, h, k, steps, rows)
            if k > steps:
                break
            q, qd = rq[k].copy(), rqd[k].copy()
        rq[k], rqd[k] = q, qd
        a1, f1, status, detail = stage(machine, plant, q, qd, law, 2 * k)
        rqdd[k], rf[k] = a1, f1
        if status != Status.OK:
            outcome, why, n = status, f't = {t0 + k * h:.6g} s: {detail}', k + 1
            break
        if k == steps:
            break
        q, qd, status, detail = rk4_step(machine, plant, q, qd, a1, law, 2 * k, h)
        if status != Status.OK:
            outcome, why, n = status, (f'step from t = {t0 + k * h:.6g} s: {detail}'), k + 1
            break
        k += 1
    return (t0 + h * np.arange(n), rq[:n], rqd[:n], rqdd[:n], rf[:n], outcome, why)


def reference_tables(machine: Machine, model: Any, q: np.ndarray, qd: np.ndarray,
                     qdd: np.ndarray, times: np.ndarray, what: str
                     ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Leg lengths, rates and forces of ``model`` on the reference (its inverse
    dynamics); ValueError at the first sample that cannot be tracked.
    """
    sol = machine.solve_batch(model, q, qd, qdd)
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


def _state(machine: Machine, initial: tuple | None, default: tuple[np.ndarray, np.ndarray]
           ) -> tuple[np.ndarray, np.ndarray]:
    if initial is None:
        return default
    dof = machine.dof
    try:
        q0, qd0 = initial
    except (TypeError, ValueError):
        raise ValueError(f'initial must be (q, qd): two vectors of {dof} numbers') from None
    q0 = finite_rows('initial q', [q0], columns=dof)[0]
    qd0 = finite_rows('initial qd', [qd0], columns=dof)[0]
    return q0, qd0


def _reference_motion(machine: Machine, reference: Reference, times: np.ndarray
                      ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """q, qd, qdd of the reference at ``times``, each (N, dof), or ValueError
    (numbers that are not finite are the solve's to report, with their time).
    """
    out = []
    for name, value in zip(('q', 'qd', 'qdd'), reference.motion(times)):
        arr = np.asarray(value, dtype=float)
        if arr.shape != (times.size, machine.dof):
            raise ValueError(f"the reference motion's {name} has shape {arr.shape}, the "
                             f'machine {machine.dof} coordinates '
                             f'({", ".join(machine.coordinates)})')
        out.append(arr)
    return out[0], out[1], out[2]


def simulate(machine: Machine, plant: Any, *, forces: ForceHistory | tuple | None = None,
             reference: Reference | MotionLike | None = None, feedforward: Any | None = None,
             servo: Servo | None = None, initial: tuple | None = None,
             step: float = DEFAULT_STEP) -> Simulation:
    """Simulate the plant (a model of ``machine``) with RK4 at a fixed ``step`` (s).

    Open loop: ``forces`` (a :class:`ForceHistory` or its (t, force), one
    column per leg); ``initial`` = (q, qd), default rest at home. Closed loop:
    ``reference`` (a :class:`Reference` or a motion with ``trajectory`` and
    ``duration``) tracked by ``servo`` (default :meth:`.Servo.for_bandwidth`)
    with the feed-forward of ``feedforward`` (None: none); ``initial`` defaults
    to the reference's start. ValueError for bad arguments (sizes, values that
    are not finite, a scene without inertia, a reference the plant cannot follow).
    """
    machine.require_inertia(plant)
    dof, legs = machine.dof, len(machine.legs)
    rest = np.zeros(dof)
    if (forces is None) == (reference is None):
        raise ValueError('give either forces (open loop) or reference (closed loop)')
    if forces is not None:
        if not isinstance(forces, ForceHistory):
            try:
                t_forces, force_rows = forces
            except (TypeError, ValueError):
                raise ValueError('forces must be a ForceHistory or (t, force)') from None
            forces = ForceHistory(t_forces, force_rows, legs)
        elif forces.force.shape[1] != legs:
            raise ValueError(f'the force history has {forces.force.shape[1]} columns, the '
                             f'machine {legs} legs ({", ".join(machine.legs)})')
        if feedforward is not None or servo is not None:
            raise ValueError('feedforward and servo apply to closed loop (reference) only')
        steps = step_count(forces.start, forces.end, step)
        stage_force = forces(forces.start + 0.5 * step * np.arange(2 * steps + 1))
        q0, qd0 = _state(machine, initial, (rest, rest))
        no_gain = np.zeros(legs)
        t, q, qd, qdd, force, outcome, why = integrate(
            machine, plant, forces.start, step, steps, q0, qd0,
            TabulatedLaw(stage_force, stage_force, stage_force, no_gain, no_gain))
        return _result(machine, plant, t, q, qd, qdd, force, outcome, why)
    if not isinstance(reference, Reference):
        reference = Reference.from_motion(reference)
    steps = step_count(reference.start, reference.end, step)
    times = reference.start + 0.5 * step * np.arange(2 * steps + 1)
    q_ref, qd_ref, qdd_ref = _reference_motion(machine, reference, times)
    if servo is None:
        servo = Servo.for_bandwidth(machine, plant)
    servo.check(machine)
    q0, qd0 = _state(machine, initial, (q_ref[0], qd_ref[0]))
    length_ref, rate_ref, plant_force = reference_tables(machine, plant, q_ref, qd_ref, qdd_ref,
                                                         times, 'the reference motion')
    if feedforward is plant:         # the plant's own model: the same batch
        ff = plant_force
    elif feedforward is not None:
        if not isinstance(feedforward, machine.model_type):
            raise ValueError(f'the feed-forward model is a {type(feedforward).__name__}, the '
                             f'plant a {type(plant).__name__}: both must be of one machine')
        ff = reference_tables(machine, feedforward, q_ref, qd_ref, qdd_ref, times,
                              'the feed-forward model')[2]
    else:
        ff = np.zeros_like(length_ref)
    law = TabulatedLaw.servo_law(machine, plant, servo, ff, length_ref, rate_ref)
    t, q, qd, qdd, force, outcome, why = integrate(machine, plant, reference.start, step, steps,
                                                   q0, qd0, law)
    rows = slice(0, 2 * len(t), 2)
    return _result(machine, plant, t, q, qd, qdd, force, outcome, why,
                   q - q_ref[rows], length_ref[rows])


def _result(machine: Machine, plant: Any, t: np.ndarray, q: np.ndarray, qd: np.ndarray,
            qdd: np.ndarray, force: np.ndarray, outcome: Status, why: str,
            pose_error: np.ndarray | None = None,
            length_ref: np.ndarray | None = None) -> Simulation:
    """The rows of a run, with lengths, rates and statuses from one batch solve
    (its forces are the delivered ones, to rounding: f = M qdd + b).
    """
    sol = machine.solve_batch(plant, q, qd, qdd)
    length = np.array(sol.length)
    return Simulation(t=t, q=q, qd=qd, qdd=qdd, length=length, rate=np.array(sol.rate),
                      force=force, status=np.asarray(sol.status), detail=tuple(sol.detail),
                      outcome=outcome, outcome_detail=why, pose_error=pose_error,
                      length_error=None if length_ref is None else length - length_ref,
                      coordinates=machine.coordinates)
