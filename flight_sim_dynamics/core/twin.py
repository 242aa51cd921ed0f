"""The digital twin in real time (the ``platform_sim`` node), for any machine
(:class:`.machine.Machine`): the plant under its actuator servos, the last
command held, advanced by the RK4 of :func:`.simulation.integrate` (forward
dynamics M(q) qdd = f - b(q, qd), the machine's ``affine_terms`` (its equations
in its own module); in C when the machine's kernel loop is enabled). A stage
state that cannot be simulated stops the stepper (:attr:`TwinStepper.outcome`)
at the last state reached, at rest: never a NaN.
"""
from __future__ import annotations

import math
from typing import Any, Sequence

import numpy as np

from .machine import Machine
from .servo import Servo, deliver
from .simulation import kernel_loop, rk4_step, stage
from .status import Status

Solution = Any      # the machine's solve at a stage state (length, rate, status, detail)


class TwinStepper:
    """The plant (a model of ``machine``) under servos of gains ``servo``, RK4
    at ``step`` s from rest at ``q0``; the servos push nothing until the first
    :meth:`command`.
    """

    def __init__(self, machine: Machine, plant: Any, servo: Servo, step: float,
                 q0: Sequence[float] | None = None) -> None:
        if not (math.isfinite(step) and step > 0):
            raise ValueError(f'step must be a positive number of seconds, got {step!r}')
        servo.check(machine)
        self.machine, self.plant = machine, plant
        self.step = float(step)
        self._dof, self._legs = machine.dof, len(machine.legs)
        self._kp, self._kd = np.array(servo.kp), np.array(servo.kd)
        limits = machine.actuator_limits(plant)
        self._max_force, self._max_speed = limits.max_force, limits.max_speed
        q = np.zeros(self._dof) if q0 is None else np.asarray(q0, dtype=float)
        if q.shape != (self._dof,) or not np.all(np.isfinite(q)):
            raise ValueError(f'q0 must be {self._dof} finite numbers '
                             f'({", ".join(machine.coordinates)}), got {q0!r}')
        self.q, self.qd = q.copy(), np.zeros(self._dof)
        self.time = 0.0                      # s of simulated time
        self.steps = 0
        self._length_ref, self._rate_ref, self._ff = (np.zeros(self._legs)
                                                      for _ in range(3))  # command
        self.outcome = Status.OK             # ok while running, else why it stopped
        self.detail = ''
        # (qdd, delivered force, solve) of the current state's first stage; None: to evaluate
        self._first: tuple[np.ndarray, np.ndarray, Solution] | None = None
        self._base: Solution | None = None
        self._held: Solution | None = None       # the solve of the last good state
        self._tables: tuple | None = None        # (steps, the kernel's law) of the command
        self._rows = self._kernel_rows(0)    # the kernel's q, qd, qdd, f
        self._evaluate_first()

    # -- the command ------------------------------------------------------------------
    def command(self, length: Sequence[float], rate: Sequence[float],
                force: Sequence[float]) -> None:
        """Hold a new command: leg lengths, rates (m, m/s) and feed-forward forces
        (N), each one finite number per leg (else ValueError).
        """
        values = []
        for name, v in (('length', length), ('rate', rate), ('force', force)):
            arr = np.asarray(v, dtype=float)
            if arr.shape != (self._legs,) or not np.all(np.isfinite(arr)):
                raise ValueError(f'{name} must be {self._legs} finite numbers (legs '
                                 f'{", ".join(self.machine.legs)}), got {v!r}')
            values.append(arr)
        self._length_ref, self._rate_ref, self._ff = values
        self._first = None
        self._tables = None
        if self.outcome is Status.OK:
            self._evaluate_first()

    def _law(self, j: int, base: Solution) -> np.ndarray:
        """The delivered force of the servo law (``j`` unused: the command is held)."""
        self._base = base
        command = (self._ff + self._kp * (self._length_ref - base.length)
                   + self._kd * (self._rate_ref - base.rate))
        return deliver(command, base.rate, self._max_force, self._max_speed)

    def _evaluate_first(self) -> bool:
        """Evaluate the first stage at the current state; False (stopped) when
        the state cannot be simulated.
        """
        self._base = None
        qdd, force, status, detail = stage(self.machine, self.plant, self.q, self.qd,
                                           self._law, 0)
        if status is not Status.OK:
            self._stop(status, f't = {self.time:.6g} s: {detail}')
            return False
        self._first = (qdd, force, self._base)
        self._held = self._base
        return True

    def _stop(self, status: Status, detail: str) -> None:
        self.outcome, self.detail = status, detail
        self.qd = np.zeros(self._dof)
        self._first = None

    # -- stepping -----------------------------------------------------------------------
    def advance(self, steps: int = 1) -> int:
        """Advance by ``steps`` RK4 steps (fewer when it stops); returns the
        number of steps made.
        """
        done = 0
        loop = kernel_loop(self.machine)
        if steps > 0 and self.outcome is Status.OK and loop is not None:
            done = self._advance_compiled(loop, steps)
        while done < steps and self.outcome is Status.OK:
            if not self._python_step():
                break
            done += 1
        return done

    def _kernel_rows(self, n: int) -> tuple[np.ndarray, ...]:
        """Rows of q, qd, qdd (dof columns) and force (legs columns) for the kernel."""
        return (np.empty((n, self._dof)), np.empty((n, self._dof)), np.empty((n, self._dof)),
                np.empty((n, self._legs)))

    def _advance_compiled(self, loop, steps: int) -> int:
        """Up to ``steps`` steps in the kernel's loop; the steps made."""
        if self._tables is None or self._tables[0] != steps:
            # the held command as the kernel's tables; kept until the next command
            n = 2 * steps + 1
            self._tables = (steps, (
                np.tile(self._ff, (n, 1)), np.tile(self._length_ref, (n, 1)),
                np.tile(self._rate_ref, (n, 1)), self._kp, self._kd, float(self._max_force),
                float(self._max_speed), True))
        law = self._tables[1]
        if len(self._rows[0]) < steps + 1:      # grown once, reused every tick
            self._rows = self._kernel_rows(steps + 1)
        rows = tuple(r[:steps + 1] for r in self._rows)
        rows[0][0], rows[1][0] = self.q, self.qd
        reached = min(loop(self.plant, law, self.step, 0, steps, rows), steps)
        if reached == 0:
            return 0                         # the Python loop takes this step
        self.q, self.qd = rows[0][reached].copy(), rows[1][reached].copy()
        self._set_steps(self.steps + reached)
        if self._evaluate_first():
            return reached
        # hold the last state that could be simulated, as the Python loop does
        self.q = rows[0][reached - 1].copy()
        self._set_steps(self.steps - 1)
        self._base = None
        stage(self.machine, self.plant, self.q, rows[1][reached - 1], self._law, 0)
        self._held = self._base
        return reached - 1

    def _set_steps(self, steps: int) -> None:
        self.steps = steps
        self.time = steps * self.step

    def _python_step(self) -> bool:
        """One RK4 step in Python; False when the stepper stopped instead."""
        if self._first is None and not self._evaluate_first():
            return False
        q = self.q
        q_new, qd_new, status, detail = rk4_step(self.machine, self.plant, q, self.qd,
                                                 self._first[0], self._law, 0, self.step)
        if status is not Status.OK:
            self._stop(status, f'step from t = {self.time:.6g} s: {detail}')
            return False
        self.q, self.qd = q_new, qd_new
        self._set_steps(self.steps + 1)
        if not self._evaluate_first():
            self.q = q                       # hold the last state that could be simulated
            self._set_steps(self.steps - 1)
            return False
        return True

    # -- the measured state ----------------------------------------------------------------
    @property
    def running(self) -> bool:
        return self.outcome is Status.OK

    @property
    def acceleration(self) -> np.ndarray:
        """Qdd at the current state (zeros once stopped)."""
        return self._first[0] if self._first is not None else np.zeros(self._dof)

    @property
    def force(self) -> np.ndarray:
        """Delivered actuator forces at the current state, N (zeros once stopped)."""
        return self._first[1] if self._first is not None else np.zeros(self._legs)

    @property
    def length(self) -> np.ndarray:
        """Leg lengths at the current state, m (once stopped: where it is held)."""
        return self._held.length if self._held is not None else np.zeros(self._legs)

    @property
    def rate(self) -> np.ndarray:
        """Leg rates at the current state, m/s (zeros once stopped: held at rest)."""
        return self._first[2].rate if self._first is not None else np.zeros(self._legs)

    @property
    def status(self) -> Status:
        """The plant's status at the current state (``limit`` beyond a stroke,
        speed or force limit), or why the stepper stopped.
        """
        if self._first is None:
            return self.outcome if self.outcome is not Status.OK else Status.INVALID_INPUT
        return self._first[2].status

    @property
    def status_detail(self) -> str:
        return self._first[2].detail if self._first is not None else self.detail
