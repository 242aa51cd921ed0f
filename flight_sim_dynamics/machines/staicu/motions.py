"""The reference motions, one registry (name -> q, qd, qdd at times t, duration):
the paper's three examples (eq. 6), ``cueing`` and ``violent`` (``cueing``
compressed, a harsh test), sums of quintic steps (q, qd, qdd continuous and
exact).
"""
from __future__ import annotations

from functools import partial
import numpy as np

from ...core.motion import Motion, Step, Trajectory, step_sequence
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
