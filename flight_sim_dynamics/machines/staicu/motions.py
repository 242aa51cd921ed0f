"""The reference motions, one registry (name -> q, qd, qdd at times t, duration):
the paper's three examples (eq. 6), ``cueing`` and ``violent`` (``cueing``
compressed, a harsh test), sums of quintic steps (q, qd, qdd continuous and
exact). :class:`PlannerSequence` plays motions in turn, as the demo planner does.
"""
from __future__ import annotations

from functools import partial
from typing import Sequence

import numpy as np

from ...core.motion import Motion, Step, Trajectory, smooth_step, step_sequence
from .trajectories import DURATION as PAPER_DURATION
from .trajectories import PAPER_EXAMPLES, paper_example
from .trajectories import sample_times  # noqa: F401 - the one sample_times, offered here too

# Steps' coordinates: 0 = surge (m), 1 = heave (m), 2 = roll (rad).

#: The steps of ``cueing``. Each pulse is washed out.
CUEING_STEPS: tuple[Step, ...] = (
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

#: The steps of ``violent`` (peak acceleration 5.77 change / duration^2), rest to rest.
VIOLENT_STEPS: tuple[Step, ...] = (
    (0, 0.00, 0.20, +0.08),   # surge onset, 11.5 m/s^2
    (2, 0.10, 0.26, +0.25),   # roll onset, 21 rad/s^2
    (1, 0.30, 0.18, +0.06),   # heave bump up, 10.7 m/s^2
    (0, 0.40, 0.60, -0.08),   # surge washout
    (1, 0.48, 0.25, -0.12),   # ... and straight down through neutral, 11 m/s^2
    (2, 0.60, 0.35, -0.45),   # roll reversal to -0.2 rad, 21 rad/s^2
    (1, 0.90, 0.40, +0.06),   # heave back to neutral
    (0, 1.20, 0.16, -0.05),   # surge braking jolt, 11 m/s^2
    (2, 1.20, 0.60, +0.20),   # roll washout to level
    (1, 1.40, 0.13, +0.03),   # runway bump up, 10 m/s^2 ...
    (1, 1.53, 0.13, -0.03),   # ... and down
    (0, 1.50, 1.00, +0.05),   # surge washout
    (2, 2.00, 0.20, -0.15),   # roll kick, 21 rad/s^2 ...
    (2, 2.20, 0.60, +0.15),   # ... washed out
)
VIOLENT_DURATION = 3.0  # s; at rest in the central configuration from 2.8 s on


#: q, qd, qdd (each (N, 3)) of ``cueing`` and ``violent`` at times ``t`` (s).
motion_cueing = partial(step_sequence, CUEING_STEPS)
violent_motion = partial(step_sequence, VIOLENT_STEPS)


#: The registry, by name.
MOTIONS: dict[str, Motion] = {
    **{name: Motion(name, PAPER_DURATION, partial(paper_example, name),
                    f"the paper's {name} example (eq. 6)") for name in PAPER_EXAMPLES},
    'cueing': Motion('cueing', CUEING_DURATION, motion_cueing,
                     'motion-cueing sequence: surge and heave pulses and a roll tilt, '
                     'each washed back to neutral'),
    'violent': Motion('violent', VIOLENT_DURATION, violent_motion,
                      'the cueing sequence compressed into short, overlapping onset cues '
                      '(about 1.2 g and 21 rad/s^2)'),
}
#: What the demo planner plays: the paper's examples and the cueing sequence.
PLANNER_MOTIONS: tuple[str, ...] = (*PAPER_EXAMPLES, 'cueing')
#: What the bench measures force errors on: the paper's examples and ``violent``.
TEST_MOTIONS: tuple[str, ...] = (*PAPER_EXAMPLES, 'violent')


def get(name: str) -> Motion:
    """The registered motion ``name`` (ValueError naming the choices otherwise)."""
    try:
        return MOTIONS[name]
    except KeyError:
        raise ValueError(f"unknown motion {name!r}; choose one of {', '.join(MOTIONS)}") from None


def motion(name: str, t: np.ndarray | float) -> Trajectory:
    """q, qd, qdd of motion ``name`` at times ``t`` (s)."""
    return get(name).trajectory(t)


def duration(name: str) -> float:
    """Length of motion ``name``, s."""
    return get(name).duration


RETURN_TIME = 1.0  # s, smooth return to neutral after a motion that ends away from it
NEUTRAL_TOLERANCE = 1e-9  # m or rad: a motion ending closer than this to neutral needs no return


class PlannerSequence:
    """Motions played one after the other, as a planner would stream them: one
    that ends away from neutral returns to it by a smooth step of
    ``return_time`` s. ``segments`` lists (label, start s, end s).
    """

    def __init__(self, names: Sequence[str], *, loop: bool = False,
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
            end_q = motion(name, length)[0][0]
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
