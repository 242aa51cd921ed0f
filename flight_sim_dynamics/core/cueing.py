"""Planner motions for the demo planner (no ROS here).

* the paper's three examples (:func:`flight_sim_dynamics.trajectories.paper_example`);
* a motion-cueing-style sequence (:func:`motion_cueing`): short surge and heave
  onset pulses and a sustained roll tilt, each washed back to the neutral
  (central) configuration, as a washout filter would do. Every segment is a
  quintic smooth step, so position, rate and acceleration are continuous and
  exact (no finite differences).
"""
from __future__ import annotations

import numpy as np

from .trajectories import DURATION as PAPER_DURATION
from .trajectories import PAPER_EXAMPLES, paper_example

#: (coordinate index, start s, duration s, change) of each smooth step:
#: 0 = surge (m), 1 = heave (m), 2 = roll (rad). Each pulse is washed out.
CUEING_STEPS: tuple[tuple[int, float, float, float], ...] = (
    (0, 0.0, 0.5, +0.04),   # surge onset (acceleration cue) ...
    (0, 0.5, 2.5, -0.04),   # ... slow washout below the perception threshold
    (1, 1.0, 0.4, +0.05),   # heave bump up
    (1, 1.4, 0.8, -0.05),   # back to neutral
    (2, 2.0, 1.0, +0.12),   # roll tilt (sustained lateral cue) ...
    (1, 3.0, 0.4, -0.03),   # heave dip
    (1, 3.4, 0.8, +0.03),   # back
    (2, 3.5, 2.5, -0.12),   # ... roll washout
    (0, 4.0, 0.5, -0.03),   # surge braking cue
    (0, 4.5, 1.5, +0.03),   # washout
)
CUEING_DURATION = 6.5  # s; neutral and at rest from 6.0 s on

MOTIONS = (*PAPER_EXAMPLES, 'cueing')


def smooth_step(u: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Quintic 0 -> 1 step s(u) = 10u^3 - 15u^4 + 6u^5 on [0, 1] (clamped
    outside) and its first two derivatives with respect to u."""
    u = np.clip(u, 0.0, 1.0)
    s = u ** 3 * (10.0 - 15.0 * u + 6.0 * u * u)
    ds = 30.0 * u * u * (1.0 - u) ** 2
    dds = 60.0 * u * (1.0 - u) * (1.0 - 2.0 * u)
    return s, ds, dds


def step_sequence(steps, t: np.ndarray | float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """q, qd, qdd (each (N, 3)) at times ``t`` (s) of a sum of smooth steps
    ``(coordinate, start s, duration s, change)``, with exact derivatives."""
    t = np.atleast_1d(np.asarray(t, dtype=float))
    q = np.zeros((t.size, 3))
    qd = np.zeros_like(q)
    qdd = np.zeros_like(q)
    for axis, start, duration, change in steps:
        s, ds, dds = smooth_step((t - start) / duration)
        q[:, axis] += change * s
        qd[:, axis] += change * ds / duration
        qdd[:, axis] += change * dds / duration ** 2
    return q, qd, qdd


def motion_cueing(t: np.ndarray | float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """q, qd, qdd (each (N, 3): surge m, heave m, roll rad) of the
    motion-cueing sequence at times ``t`` (s, 0 .. CUEING_DURATION)."""
    return step_sequence(CUEING_STEPS, t)


def motion(name: str, t: np.ndarray | float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """q, qd, qdd of one planner motion: a paper example or ``cueing``."""
    if name == 'cueing':
        return motion_cueing(t)
    return paper_example(name, t)


def duration(name: str) -> float:
    """Length of a motion, s."""
    if name == 'cueing':
        return CUEING_DURATION
    if name not in PAPER_EXAMPLES:
        raise ValueError(f"unknown motion {name!r}; choose one of {', '.join(MOTIONS)}")
    return PAPER_DURATION


# ----------------------------------------------------------------------------
# Planner sequences: motions one after the other, each washed back to neutral
# ----------------------------------------------------------------------------
RETURN_TIME = 1.0  # s, smooth return to neutral after a paper example


class PlannerSequence:
    """Motions played one after the other, as a planner would stream them.

    A paper example ends away from neutral (at twice its amplitude); before the
    next motion (or the next loop) it is brought back to the central
    configuration by a quintic smooth step of ``return_time`` seconds, so the
    stream is continuous in position, rate and acceleration.
    ``segments`` lists (label, start s, end s).
    """

    def __init__(self, names: list[str] | tuple[str, ...], *, loop: bool = False,
                 return_time: float = RETURN_TIME) -> None:
        if not names:
            raise ValueError('no motion given')
        self.names = tuple(names)
        self.loop = loop
        self.segments: list[tuple[str, float, float]] = []
        self._parts: list[tuple[str, float, float, np.ndarray | None]] = []
        start = 0.0
        for i, name in enumerate(self.names):
            length = duration(name)
            self._parts.append((name, start, length, None))
            self.segments.append((name, start, start + length))
            start += length
            if name != 'cueing' and (loop or i < len(self.names) - 1):
                end_q = motion(name, length)[0][0]
                self._parts.append(('return', start, return_time, end_q))
                self.segments.append(('return', start, start + return_time))
                start += return_time
        self.period = start

    def finished(self, t: float) -> bool:
        """True once ``t`` is past the end (never when looping)."""
        return not self.loop and t > self.period + 1e-9

    def sample(self, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, str]:
        """q, qd, qdd (3 each) and the segment label at sequence time ``t``."""
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
        q, qd, qdd = motion(label, local)
        return q[0], qd[0], qdd[0], label
