"""What a built-in motion is, for every machine: :class:`Motion` (name ->
q, qd, qdd at times t, and a duration), the sample times of a rate, and the
smooth steps most built-in motions are sums of (q, qd, qdd continuous and
exact), and :class:`PlannerSequence`, motions played in turn as the demo
planner streams them. Each machine's registry (``machines/<name>/motions.py``) fills
:attr:`flight_sim_dynamics.core.machine.Machine.motions` with these.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, Mapping, Sequence

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


RETURN_TIME = 1.0  # s, smooth return to neutral after a motion that ends away from it
NEUTRAL_TOLERANCE = 1e-9  # m or rad: a motion ending closer than this to neutral needs no return


class PlannerSequence:
    """Motions ``names`` of ``motions`` (a machine's :attr:`Machine.motions`)
    played one after the other, as a planner would stream them: one that ends
    away from neutral returns to it by a smooth step of ``return_time`` s.
    ``segments`` lists (label, start s, end s).
    """

    def __init__(self, motions: Mapping[str, Motion], names: Sequence[str], *,
                 loop: bool = False, return_time: float = RETURN_TIME) -> None:
        if not names:
            raise ValueError('no motion given')
        unknown = [name for name in names if name not in motions]
        if unknown:
            raise ValueError(f"unknown motion {unknown[0]!r}; choose one of "
                             f"{', '.join(motions)}")
        self.names = tuple(names)
        self.loop = loop
        self._motions = {name: motions[name] for name in self.names}
        self.segments: list[tuple[str, float, float]] = []
        self._parts: list[tuple[str, float, float, np.ndarray | None]] = []
        start = 0.0
        for i, name in enumerate(self.names):
            length = self._motions[name].duration
            self._parts.append((name, start, length, None))
            self.segments.append((name, start, start + length))
            start += length
            end_q = self._motions[name].trajectory(length)[0][0]
            away = bool(np.abs(end_q).max() > NEUTRAL_TOLERANCE)
            if away and (loop or i < len(self.names) - 1):
                self._parts.append(('return', start, return_time, end_q))
                self.segments.append(('return', start, start + return_time))
                start += return_time
        self.period = start

    def finished(self, t: float) -> bool:
        """True once ``t`` is past the end (never when looping)."""
        return not self.loop and t > self.period + 1e-9

    def sample(self, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, str]:
        """q, qd, qdd (one number per coordinate each) and the segment label at
        sequence time ``t``.
        """
        if self.loop:
            t = t % self.period
        t = min(max(t, 0.0), self.period)
        for label, start, length, end_q in reversed(self._parts):
            if t >= start - 1e-12:
                break
        local = min(t - start, length)
        if label == 'return':
            s, ds, dds = smooth_step(np.array([local / length]))
            return (end_q * (1.0 - s[0]), -end_q * ds[0] / length,
                    -end_q * dds[0] / length ** 2, label)
        q, qd, qdd = self._motions[label].trajectory(local)
        return q[0], qd[0], qdd[0], label
