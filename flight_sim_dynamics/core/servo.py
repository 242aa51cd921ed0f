"""The actuator servos of the twin, one per leg: ``command = f_ff + kp (L_ref
- L) + kd (Ldot_ref - Ldot)`` (:class:`Servo`), saturated by :func:`deliver`;
:class:`TabulatedLaw`, the force law of a run as tables the machines' kernels
integrate. Written against :class:`.machine.Machine`, for any number of legs.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from .machine import Machine

#: Bandwidth (Hz) and damping ratio of the default servo gains.
DEFAULT_BANDWIDTH_HZ = 5.0
DEFAULT_DAMPING = 1.0


@dataclass(frozen=True)
class Servo:
    """PD gains of the actuator servos, one per leg in the machine's order: kp
    in N/m, kd in N s/m, each >= 0 (as many as the machine has legs).
    """

    kp: tuple[float, ...]
    kd: tuple[float, ...]

    def __post_init__(self) -> None:
        n = None
        for name in ('kp', 'kd'):
            try:
                value = tuple(float(v) for v in getattr(self, name))
            except (TypeError, ValueError):
                raise ValueError(f'servo {name} must be numbers, got '
                                 f'{getattr(self, name)!r:.100}') from None
            if not value or not all(math.isfinite(v) and v >= 0 for v in value):
                raise ValueError(f'servo {name} must be {len(value) or "some"} finite numbers '
                                 f'>= 0 (one per leg), got {value}')
            if n is not None and len(value) != n:
                raise ValueError(f'servo kp and kd must have one gain per leg each, got '
                                 f'{n} and {len(value)}')
            n = len(value)
            object.__setattr__(self, name, value)

    @classmethod
    def for_bandwidth(cls, machine: Machine, model: Any, hz: float = DEFAULT_BANDWIDTH_HZ,
                      damping: float = DEFAULT_DAMPING) -> 'Servo':
        """Gains kp = m_i w^2, kd = 2 damping m_i w (w = 2 pi hz), m_i the diagonal of
        the leg-space mass matrix M J^-1 at home (J = dL/dq; M of the machine's
        ``affine_terms``).
        """
        if not (math.isfinite(hz) and hz > 0 and math.isfinite(damping) and damping >= 0):
            raise ValueError(f'servo bandwidth must be > 0 Hz and damping >= 0, '
                             f'got {hz!r} Hz, {damping!r}')
        machine.require_inertia(model)
        rest = np.zeros(machine.dof)
        M, _, base = machine.affine_terms(model, rest, rest)
        mass = np.diag(np.linalg.solve(base.jacobian.T, M.T).T).tolist()
        w = 2.0 * math.pi * hz          # Python floats: an overflow is inf, refused, no warning
        return cls(tuple(m * w * w for m in mass), tuple(2.0 * damping * m * w for m in mass))

    def check(self, machine: Machine) -> None:
        """ValueError unless there is one gain per leg of ``machine``."""
        if len(self.kp) != len(machine.legs):
            raise ValueError(f'servo has {len(self.kp)} gains per kind, the machine '
                             f'{len(machine.legs)} legs ({", ".join(machine.legs)})')


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
class TabulatedLaw:
    """The force laws of :func:`.simulation.simulate` as data the kernels
    integrate, over the half-step index j: ``ff[j]``, or (``servo``)
    ``deliver(ff[j] + kp (length_ref[j] - L) + kd (rate_ref[j] - Ldot))``.
    """

    ff: np.ndarray              # (2 steps + 1, legs) feed-forward (open loop: applied) forces, N
    length_ref: np.ndarray      # (2 steps + 1, legs) reference leg lengths, m (servo only)
    rate_ref: np.ndarray        # (2 steps + 1, legs) reference leg rates, m/s (servo only)
    kp: np.ndarray              # (legs,) N/m
    kd: np.ndarray              # (legs,) N s/m
    max_force: float = math.inf     # N
    max_speed: float = math.inf     # m/s
    servo: bool = False

    def __post_init__(self) -> None:
        legs = np.shape(self.ff)[1] if np.ndim(self.ff) == 2 else -1
        for name in ('ff', 'length_ref', 'rate_ref', 'kp', 'kd'):
            value = np.ascontiguousarray(getattr(self, name), dtype=np.float64)
            if value.shape != ((legs,) if name in ('kp', 'kd') else (len(self.ff), legs)):
                raise ValueError(f'{name} has shape {value.shape}')
            object.__setattr__(self, name, value)

    @classmethod
    def servo_law(cls, machine: Machine, plant: Any, servo: Servo, ff: np.ndarray,
                  length_ref: np.ndarray, rate_ref: np.ndarray) -> 'TabulatedLaw':
        """The closed loop's law: ``servo``'s gains, the plant's actuator limits."""
        limits = machine.actuator_limits(plant)
        return cls(ff, length_ref, rate_ref, np.array(servo.kp), np.array(servo.kd),
                   limits.max_force, limits.max_speed, True)

    def tables(self) -> tuple:
        """The law as the kernels' ``integrate_rows`` read it."""
        return (self.ff, self.length_ref, self.rate_ref, self.kp, self.kd,
                float(self.max_force), float(self.max_speed), bool(self.servo))

    def __call__(self, j: int, base: Any) -> np.ndarray:
        if not self.servo:
            return self.ff[j]
        command = (self.ff[j] + self.kp * (self.length_ref[j] - base.length)
                   + self.kd * (self.rate_ref[j] - base.rate))
        return deliver(command, base.rate, self.max_force, self.max_speed)
