"""The hexapod's built-in motions, one registry of name -> motion.

Each is a :class:`flight_sim_dynamics.core.motion.Motion` (q, qd, qdd at
times t; a duration), poses measured from home (q = (surge, sway, heave, roll,
pitch, yaw), ZYX angles, qd the Euler-angle rates; docs/design/stewart.md):

- ``gentle``: a slow tour of the six coordinates, each out and back;
- ``cueing``: motion cueing: a surge onset held by tilt coordination (pitch),
  a heave bump, a coordinated yaw turn (yaw, roll, sway), each washed out;
- ``violent``: short overlapping onset cues in all six coordinates near the
  default machine's speed limit (legs at up to 1.36 of 1.5 m/s; about 1 g and
  12 rad/s^2), rest to rest;
- ``tsai_1`` ... ``tsai_4``: the four motions of Tsai's benchmark (stewart.md,
  "A second, public hexapod"), omega = 3 rad/s over one period.

``gentle``, ``cueing`` and ``violent`` are sums of quintic smooth steps, so
q, qd, qdd are continuous and exact, and start and end at rest at home.
"""
from __future__ import annotations

import math
from functools import partial

import numpy as np

from ...core.motion import Motion, Step, Trajectory, step_sequence

DOF = 6
SURGE, SWAY, HEAVE, ROLL, PITCH, YAW = range(DOF)

#: The steps of ``gentle``: about 0.1 m and 0.1 rad, 0.1 m/s and 0.1 rad/s at most.
GENTLE_STEPS: tuple[Step, ...] = (
    (SURGE, 0.0, 2.5, +0.10), (SURGE, 2.5, 2.5, -0.10),
    (SWAY, 1.0, 2.5, +0.10), (SWAY, 3.5, 2.5, -0.10),
    (HEAVE, 2.0, 2.5, +0.08), (HEAVE, 4.5, 2.5, -0.08),
    (ROLL, 4.0, 2.5, +0.10), (ROLL, 6.5, 2.5, -0.10),
    (PITCH, 5.0, 2.5, +0.10), (PITCH, 7.5, 2.5, -0.10),
    (YAW, 6.0, 2.5, +0.15), (YAW, 8.5, 2.5, -0.15),
)
GENTLE_DURATION = 12.0  # s; at rest at home from 11.0 s on

#: The steps of ``cueing``. A forward acceleration is held by pitching nose
#: up (negative pitch: gravity along the seat back) at about 3 deg/s, below
#: the perception threshold of rotation; every cue is washed back to neutral.
CUEING_STEPS: tuple[Step, ...] = (
    (SURGE, 0.0, 0.6, +0.12),    # surge onset (acceleration cue, 3.8 m/s^2) ...
    (SURGE, 0.6, 3.0, -0.12),    # ... slow washout
    (PITCH, 0.3, 2.5, -0.08),    # tilt coordination: nose up, sustained ...
    (PITCH, 4.0, 2.5, +0.08),    # ... and back
    (HEAVE, 1.5, 0.4, +0.05),    # heave bump up
    (HEAVE, 1.9, 0.8, -0.05),    # back to neutral
    (YAW, 3.0, 1.0, +0.20),      # yaw turn onset ...
    (YAW, 4.0, 3.0, -0.20),      # ... washout
    (ROLL, 3.0, 1.5, +0.06),     # bank into the turn ...
    (ROLL, 5.0, 2.0, -0.06),     # ... and back
    (SWAY, 3.0, 0.6, +0.06),     # lateral cue of the turn ...
    (SWAY, 3.6, 2.4, -0.06),     # ... washout
)
CUEING_DURATION = 7.5  # s; at rest at home from 7.0 s on

#: The steps of ``violent`` (peak speed 1.875 change / duration, peak
#: acceleration 5.77 change / duration^2), rest to rest.
VIOLENT_STEPS: tuple[Step, ...] = (
    (HEAVE, 0.00, 0.26, +0.09),    # heave up, 7.7 m/s^2
    (SURGE, 0.08, 0.22, +0.055),   # surge onset, 6.6 m/s^2
    (PITCH, 0.17, 0.26, -0.11),    # pitch kick, 9.4 rad/s^2
    (SURGE, 0.34, 0.26, -0.11),    # surge reversal
    (HEAVE, 0.38, 0.30, -0.16),    # heave down through home, 10 m/s^2
    (PITCH, 0.47, 0.30, +0.18),    # pitch reversal, 11.5 rad/s^2
    (YAW, 0.51, 0.26, +0.135),     # yaw kick, 11.5 rad/s^2
    (ROLL, 0.60, 0.26, +0.09),     # roll kick
    (SWAY, 0.68, 0.22, +0.055),    # sway jolt
    (YAW, 0.81, 0.34, -0.135),     # washouts back to home
    (ROLL, 0.85, 0.34, -0.09),
    (SWAY, 0.89, 0.34, -0.055),
    (SURGE, 0.94, 0.34, +0.055),
    (HEAVE, 0.94, 0.34, +0.07),
    (PITCH, 0.94, 0.34, -0.07),
)
VIOLENT_DURATION = 1.5  # s; at rest at home from 1.28 s on

TSAI_OMEGA = 3.0                             # rad/s
TSAI_DURATION = 2.0 * math.pi / TSAI_OMEGA   # s, one period
#: Amplitudes (m, m, m, rad, rad, rad) of Tsai's motions q = a sin(omega t);
#: (4) is at rest at home.
TSAI_AMPLITUDES: dict[str, tuple[float, ...]] = {
    'tsai_1': (0.2, 0.2, 0.2, 0.0, 0.0, 0.0),
    'tsai_2': (0.0, 0.0, 0.0, 0.0, 0.0, math.pi / 6),
    'tsai_3': (0.2, 0.0, 0.0, 0.0, 0.0, 0.0),
    'tsai_4': (0.0, 0.0, 0.0, 0.0, 0.0, 0.0),
}


def sinusoid(amplitude: tuple[float, ...], omega: float, t: np.ndarray | float) -> Trajectory:
    """The pose a sin(omega t), its rates and accelerations (each (N, 6)) at times ``t``."""
    t = np.atleast_1d(np.asarray(t, dtype=float))[:, None]
    a = np.asarray(amplitude, dtype=float)
    s, c = np.sin(omega * t), np.cos(omega * t)
    return a * s, a * omega * c, -a * omega * omega * s


#: The registry, by name.
MOTIONS: dict[str, Motion] = {
    'gentle': Motion('gentle', GENTLE_DURATION, partial(step_sequence, GENTLE_STEPS, dof=DOF),
                     'a slow tour: each coordinate out and back in turn '
                     '(0.1 m and 0.1 rad, about 0.1 m/s and 0.1 rad/s)'),
    'cueing': Motion('cueing', CUEING_DURATION, partial(step_sequence, CUEING_STEPS, dof=DOF),
                     'motion cueing: surge onset with tilt coordination, heave bump, '
                     'coordinated yaw turn, each washed out'),
    'violent': Motion('violent', VIOLENT_DURATION,
                      partial(step_sequence, VIOLENT_STEPS, dof=DOF),
                      'short overlapping onset cues in all six coordinates near the default '
                      "machine's speed limit (about 1 g, 12 rad/s^2)"),
    **{name: Motion(name, TSAI_DURATION, partial(sinusoid, amplitude, TSAI_OMEGA),
                    f"Tsai's motion ({name[-1]}): " + description)
       for (name, amplitude), description in zip(TSAI_AMPLITUDES.items(), (
           'surge = sway = heave = 0.2 sin 3t (m)', 'yaw = (pi/6) sin 3t (rad)',
           'surge = 0.2 sin 3t (m)', 'at rest at home'))},
}
