"""What a built-in motion is, for every machine: :class:`Motion` (name ->
q, qd, qdd at times t, and a duration), the sample times of a rate, and the
smooth steps most built-in motions are sums of (q, qd, qdd continuous and
exact). Each machine's registry (``machines/<name>/motions.py``) fills
:attr:`flight_sim_dynamics.core.machine.Machine.motions` with these.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, Sequence

import numpy as np

#: q, qd, qdd, each (N, coordinates).
Trajectory = tuple[np.ndarray, np.ndarray, np.ndarray]
#: (coordinate index in q, start s, duration s, change in m or rad) of one smooth step.
Step = tuple[int, float, float, float]


def sample_times(rate_hz: float, duration: float) -> np.ndarray:
    """Sample times 0, 1/rate, ..., duration (inclusive when it falls on the grid)."""
    if not (rate_hz > 0 and math.isfinite(rate_hz)):
        raise ValueError(f'rate must be a positive finite number of Hz, got {rate_hz!r}')
    n = int(math.floor(duration * rate_hz + 1e-9)) + 1
    return np.arange(n) / rate_hz


@dataclass(frozen=True)
class Motion:
    """One built-in motion: ``trajectory(t)`` gives q, qd, qdd (each (N, dof))
    at times ``t`` in [0, duration] s (qd, qdd: the coordinates' time derivatives).
    """

    name: str
    duration: float
    trajectory: Callable[[np.ndarray | float], Trajectory]
    description: str

    def sampled(self, rate_hz: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """t, q, qd, qdd at 0, 1/rate, ..., duration."""
        t = sample_times(rate_hz, self.duration)
        return (t, *self.trajectory(t))


def smooth_step(u: np.ndarray) -> Trajectory:
    """Quintic step s(u) = 10u^3 - 15u^4 + 6u^5 (clamped to [0, 1]), s' and s''."""
    u = np.clip(u, 0.0, 1.0)
    s = u ** 3 * (10.0 - 15.0 * u + 6.0 * u * u)
    ds = 30.0 * u * u * (1.0 - u) ** 2
    dds = 60.0 * u * (1.0 - u) * (1.0 - 2.0 * u)
    return s, ds, dds


def step_sequence(steps: Sequence[Step], t: np.ndarray | float, dof: int = 3) -> Trajectory:
    """q, qd, qdd (each (N, dof)) at times ``t`` of a sum of smooth steps."""
    t = np.atleast_1d(np.asarray(t, dtype=float))
    q = np.zeros((t.size, dof))
    qd = np.zeros_like(q)
    qdd = np.zeros_like(q)
    for axis, start, duration, change in steps:
        s, ds, dds = smooth_step((t - start) / duration)
        q[:, axis] += change * s
        qd[:, axis] += change * ds / duration
        qdd[:, axis] += change * dds / duration ** 2
    return q, qd, qdd
