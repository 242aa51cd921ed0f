"""Euler-angle rates and accelerations of an angular velocity and acceleration.

ZYX Euler angles (roll phi, pitch theta, yaw psi; ``R = Rz(psi) Ry(theta)
Rx(phi)``, REP-103) and a body's angular velocity and acceleration in the base
frame, as a ROS twist carries them (docs/design/stewart.md, (S2)-(S3)):

    omega = E(theta, psi) phidot,             phidot = E^-1 omega
    eps = E phiddot + Edot phidot,            phiddot = E^-1 (eps - Edot phidot)

with ``E^-1 omega = ((c_psi w_x + s_psi w_y) / c_theta, -s_psi w_x + c_psi w_y,
w_z + s_theta phidot_roll)``. Undefined at pitch +-90 deg (det E = c_theta).
Plain floats: the node converts one setpoint at a time.
"""
from __future__ import annotations

import math

Vec3 = tuple[float, float, float]


class EulerSingularity(ValueError):
    """The pitch is +-90 deg to working precision: Euler rates are undefined."""


def _inverse(theta: float, psi: float, x: float, y: float, z: float) -> Vec3:
    """``E(theta, psi)^-1 (x, y, z)``."""
    ct = math.cos(theta)
    if abs(ct) < 1e-12:
        raise EulerSingularity(f'pitch {theta:.6g} rad is +-90 deg: the Euler-angle rates '
                               'of an angular velocity are undefined there')
    cp, sp = math.cos(psi), math.sin(psi)
    roll = (cp * x + sp * y) / ct
    return roll, -sp * x + cp * y, z + math.sin(theta) * roll


def euler_rates(angles: Vec3, omega: Vec3) -> Vec3:
    """The rates (roll, pitch, yaw)' of the angular velocity ``omega`` (base
    frame) at ``angles`` (roll, pitch, yaw): E^-1 omega (S2). At zero pitch and
    yaw, E is the identity and ``omega`` is returned as it is.
    """
    _, theta, psi = angles
    if theta == 0.0 and psi == 0.0:
        return tuple(omega)
    return _inverse(theta, psi, *omega)


def euler_accelerations(angles: Vec3, rates: Vec3, epsilon: Vec3) -> Vec3:
    """The accelerations (roll, pitch, yaw)'' of the angular acceleration
    ``epsilon`` (base frame) at ``angles`` with the Euler-angle ``rates``:
    E^-1 (epsilon - Edot rates) (S3). At zero pitch, yaw and pitch and yaw
    rates, E is the identity, Edot rates zero and ``epsilon`` is returned as it is.
    """
    _, theta, psi = angles
    droll, dtheta, dpsi = rates
    if theta == 0.0 and psi == 0.0 and dtheta == 0.0 and dpsi == 0.0:
        return tuple(epsilon)
    ct, st = math.cos(theta), math.sin(theta)
    cp, sp = math.cos(psi), math.sin(psi)
    # Edot rates, (S3)'s Edot times (roll, pitch, yaw)'
    ex = (-sp * ct * dpsi - cp * st * dtheta) * droll - cp * dpsi * dtheta
    ey = (cp * ct * dpsi - sp * st * dtheta) * droll - sp * dpsi * dtheta
    ez = -ct * dtheta * droll
    return _inverse(theta, psi, epsilon[0] - ex, epsilon[1] - ey, epsilon[2] - ez)
