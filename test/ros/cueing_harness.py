"""What the motion-cueing tests share: a vehicle's motion (:func:`vehicle`) and
its log as the demo and ``cue`` read it (:func:`write_vehicle_log`).
"""
from __future__ import annotations

import math
from pathlib import Path

G = 9.80665     # m/s^2, the specific force of a vehicle at rest and level


def vehicle(t: float) -> tuple[tuple[float, float, float], tuple[float, float, float]]:
    """A vehicle's specific force and angular velocity at ``t`` s: at rest, then
    accelerating (surge) and climbing (heave), then a turn (sway and yaw) with
    a roll rate, smooth (raised-cosine) edges; at rest again after 2.5 s.
    """
    def pulse(start: float, end: float, edge: float = 0.2) -> float:
        if t <= start or t >= end:
            return 0.0
        rise = min(1.0, (t - start) / edge, (end - t) / edge)
        return 0.5 - 0.5 * math.cos(math.pi * rise)
    accelerate, turn = pulse(0.2, 1.4), pulse(1.0, 2.5)
    f = (2.0 * accelerate, 1.5 * turn, G + 1.0 * pulse(0.3, 0.9))
    omega = (0.15 * pulse(1.0, 1.6), 0.05 * accelerate, 0.3 * turn)
    return f, omega


def write_vehicle_log(path: Path, duration: float = 2.0, rate: float = 100.0) -> None:
    """:func:`vehicle` from 0 to ``duration`` s at ``rate``, as a CSV log
    (``t, f_x, f_y, f_z, omega_x, omega_y, omega_z``).
    """
    rows = ['t,f_x,f_y,f_z,omega_x,omega_y,omega_z']
    for k in range(int(round(duration * rate)) + 1):
        f, omega = vehicle(k / rate)
        rows.append(','.join(repr(v) for v in (k / rate, *f, *omega)))
    path.write_text('\n'.join(rows) + '\n')
