"""Reference motions: the paper's three examples (eq. 6).

``surge = x*(1 - cos(pi t / T))``, ``heave = y*(1 - cos(pi t / T))``,
``roll = phi*(1 - cos(pi t / T))`` with ``T = 3 s``, starting at rest in the
central configuration (mechanism.md, table of the three examples).
"""
from __future__ import annotations

import math

import numpy as np

from ...core import motion

DURATION = 3.0  # s, the paper's Delta t

#: (x*, y*, phi*) of eq. (6) for each example: m, m, rad.
PAPER_EXAMPLES: dict[str, tuple[float, float, float]] = {
    'vertical': (0.0, 0.1, 0.0),
    'rectilinear': (0.05, 0.1, 0.0),
    'general': (0.05, 0.1, math.pi / 12),
}


def paper_example(name: str, t: np.ndarray | float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """q, qd, qdd (each (N, 3): surge m, heave m, roll rad) of example ``name`` (eq. 6)."""
    try:
        amplitude = np.array(PAPER_EXAMPLES[name])
    except KeyError:
        raise ValueError(f"unknown example {name!r}; choose one of "
                         f"{', '.join(PAPER_EXAMPLES)}") from None
    t = np.atleast_1d(np.asarray(t, dtype=float))[:, None]
    w = math.pi / DURATION
    q = amplitude * (1.0 - np.cos(w * t))
    qd = amplitude * w * np.sin(w * t)
    qdd = amplitude * w * w * np.cos(w * t)
    return q, qd, qdd


def sample_times(rate_hz: float, duration: float = DURATION) -> np.ndarray:
    """Sample times 0, 1/rate, ..., duration (default the paper's 3 s)."""
    return motion.sample_times(rate_hz, duration)
