"""Vehicle motions to cue (tests, the demo, the benchmark, ``cue --example``):
the specific force ``f`` (m/s²) and angular velocity ``omega`` (rad/s) of a
vehicle in its body axes (REP-103: x forward, y left, z up; at rest and level
``f = (0, 0, g)``), as an IMU at its reference point reads them. numpy, no I/O.

- ``takeoff``: an airliner's take-off roll (thrust onset, runway rumble),
  rotation and initial climb;
- ``braking``: a car cruising, braking hard to a stop (the pitch of the body
  and its rebound), pulling away again;
- ``turbulence``: an aircraft in moderate turbulence (band-limited random
  specific force and rates, seeded: the same log every time);
- ``violent``: multi-g manoeuvre spikes and a crash (a 10 g deceleration
  spike for 50 ms), rates up to 3 rad/s: what the limiter must survive.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np

from ..config.cueing import G


@dataclass(frozen=True)
class VehicleLog:
    """Times ``t`` (N,) s, specific force ``f`` (N, 3) m/s², angular velocity
    ``omega`` (N, 3) rad/s.
    """

    t: np.ndarray
    f: np.ndarray
    omega: np.ndarray


def _smoothstep(t: np.ndarray, start: float, duration: float) -> np.ndarray:
    """0 before ``start``, 1 after ``start + duration``, a C1 cubic between."""
    x = np.clip((t - start) / duration, 0.0, 1.0)
    return x * x * (3.0 - 2.0 * x)


def _pulse(t: np.ndarray, start: float, rise: float, hold: float) -> np.ndarray:
    """0 -> 1 in ``rise`` s from ``start``, held ``hold`` s, back to 0 in ``rise`` s."""
    return _smoothstep(t, start, rise) - _smoothstep(t, start + rise + hold, rise)


def _band_noise(t: np.ndarray, rng: np.random.Generator, low: float, high: float,
                terms: int = 24) -> np.ndarray:
    """Unit-RMS noise: a sum of sines of random frequencies in [low, high] Hz."""
    hz = rng.uniform(low, high, terms)
    phase = rng.uniform(0.0, 2.0 * math.pi, terms)
    out = np.zeros_like(t)
    for f, p in zip(hz, phase):
        out += np.sin(2.0 * math.pi * f * t + p)
    return out * math.sqrt(2.0 / terms)


def takeoff(t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Thrust at 2 s (3 m/s² along x, falling as drag grows), runway rumble,
    rotation at 30 s (nose up 8 deg at 3 deg/s), climb.
    """
    rng = np.random.default_rng(1)
    thrust = 3.0 * _smoothstep(t, 2.0, 1.5) * (1.0 - 0.3 * _smoothstep(t, 3.5, 26.0))
    on_ground = 1.0 - _smoothstep(t, 30.0, 3.0)
    rumble = 0.25 * _band_noise(t, rng, 4.0, 12.0) * _smoothstep(t, 2.0, 5.0) * on_ground
    # nose-up pitch (REP-103: a negative rate about y) at 3 deg/s from 30 s, to 8 deg
    rate = -math.radians(3.0) * _pulse(t, 30.0, 0.3, 8.0 / 3.0 - 0.3)
    nose_up = -np.cumsum(rate) * (t[1] - t[0] if len(t) > 1 else 0.0)
    lift = 0.8 * _pulse(t, 30.0, 1.0, 2.0)                # the rotation's load factor
    # body axes: gravity's share moves from z to x as the nose comes up (felt as a push back)
    f = np.column_stack([thrust + G * np.sin(nose_up), np.zeros_like(t),
                         G * np.cos(nose_up) + lift + rumble])
    omega = np.column_stack([np.zeros_like(t), rate, np.zeros_like(t)])
    return f, omega


def braking(t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Cruise, brake at 3 s (-7 m/s² for 2.5 s), the stop's jolt and the body's
    pitch rebound, pull away at 9 s (+3 m/s²).
    """
    brake = -7.0 * _pulse(t, 3.0, 0.3, 2.5)
    go = 3.0 * _pulse(t, 9.0, 0.5, 2.5)
    # the body pitches nose-down (positive) under braking and rebounds at the stop
    stop = np.where(t > 6.1, np.exp(-(t - 6.1) / 0.4) * np.sin(2 * math.pi * 1.2 * (t - 6.1)), 0.0)
    pitch_rate = (0.05 * np.gradient(_pulse(t, 3.0, 0.3, 2.5), t) - 0.08 * stop
                  - 0.02 * np.gradient(_pulse(t, 9.0, 0.5, 2.5), t))
    f = np.column_stack([brake + go, np.zeros_like(t), np.full_like(t, G)])
    omega = np.column_stack([np.zeros_like(t), pitch_rate, np.zeros_like(t)])
    return f, omega


def turbulence(t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Moderate turbulence after a 2 s onset: vertical 1.2 m/s² RMS, lateral
    0.5, longitudinal 0.3 (0.1-3 Hz); rates 0.05-0.1 rad/s RMS (0.1-2 Hz).
    """
    rng = np.random.default_rng(7)
    onset = _smoothstep(t, 0.0, 2.0)         # from rest: the first sample is the reference
    f = np.column_stack([0.3 * _band_noise(t, rng, 0.1, 3.0),
                         0.5 * _band_noise(t, rng, 0.1, 3.0),
                         1.2 * _band_noise(t, rng, 0.1, 3.0)]) * onset[:, None]
    f[:, 2] += G
    omega = np.column_stack([0.1 * _band_noise(t, rng, 0.1, 2.0),
                             0.06 * _band_noise(t, rng, 0.1, 2.0),
                             0.05 * _band_noise(t, rng, 0.1, 2.0)]) * onset[:, None]
    return f, omega


def violent(t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Multi-g spikes (3 g along x, -2/+4 g along z, 3 g along y, 0.1-0.3 s),
    rate spikes up to 3 rad/s, and a crash at 15 s: -10 g along x for 50 ms.
    """
    f = np.tile([0.0, 0.0, G], (len(t), 1))
    spikes = ((0, 2.0, 0.05, 0.2, 3.0 * G), (2, 4.0, 0.05, 0.1, -2.0 * G),
              (2, 5.0, 0.05, 0.3, 4.0 * G), (1, 7.0, 0.03, 0.2, 3.0 * G),
              (0, 9.0, 0.02, 0.1, -4.0 * G), (0, 15.0, 0.005, 0.05, -10.0 * G))
    for axis, start, rise, hold, size in spikes:
        f[:, axis] += size * _pulse(t, start, rise, hold)
    omega = np.zeros((len(t), 3))
    for axis, start, size in ((0, 6.0, 3.0), (1, 8.0, -2.0), (2, 11.0, 2.5), (0, 15.02, -3.0)):
        omega[:, axis] += size * _pulse(t, start, 0.05, 0.2)
    return f, omega


#: name -> (generator f(t) -> (f, omega), default duration s)
VEHICLES: dict[str, tuple[Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]], float]] = {
    'takeoff': (takeoff, 45.0),
    'braking': (braking, 14.0),
    'turbulence': (turbulence, 60.0),
    'violent': (violent, 20.0),
}


def vehicle_log(name: str, rate: float = 1000.0, duration: float | None = None) -> VehicleLog:
    """The vehicle motion ``name`` (:data:`VEHICLES`) sampled at ``rate`` Hz for
    ``duration`` s (None: its own); ValueError for an unknown name.
    """
    if name not in VEHICLES:
        raise ValueError(f'unknown vehicle motion {name!r}; one of {", ".join(VEHICLES)}')
    generate, default = VEHICLES[name]
    n = int(round((default if duration is None else duration) * rate)) + 1
    t = np.arange(n) / rate
    f, omega = generate(t)
    return VehicleLog(t, f, omega)
