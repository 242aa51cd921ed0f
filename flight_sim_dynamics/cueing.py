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


def motion_cueing(t: np.ndarray | float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """q, qd, qdd (each (N, 3): surge m, heave m, roll rad) of the
    motion-cueing sequence at times ``t`` (s, 0 .. CUEING_DURATION)."""
    t = np.atleast_1d(np.asarray(t, dtype=float))
    q = np.zeros((t.size, 3))
    qd = np.zeros_like(q)
    qdd = np.zeros_like(q)
    for axis, start, duration, change in CUEING_STEPS:
        s, ds, dds = smooth_step((t - start) / duration)
        q[:, axis] += change * s
        qd[:, axis] += change * ds / duration
        qdd[:, axis] += change * dds / duration ** 2
    return q, qd, qdd


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
