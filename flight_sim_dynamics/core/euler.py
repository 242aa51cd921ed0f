"""Euler-angle rates and accelerations of an angular velocity and acceleration,
and back.

ZYX Euler angles (roll phi, pitch theta, yaw psi; ``R = Rz(psi) Ry(theta)
Rx(phi)``, REP-103) and a body's angular velocity and acceleration in the base
frame, as a ROS twist carries them:

    omega = E(theta, psi) phidot,             phidot = E^-1 omega
    eps = E phiddot + Edot phidot,            phiddot = E^-1 (eps - Edot phidot)

with ``E^-1 omega = ((c_psi w_x + s_psi w_y) / c_theta, -s_psi w_x + c_psi w_y,
w_z + s_theta phidot_roll)``. Undefined at pitch +-90 deg (det E = c_theta).
Plain floats: the node converts one setpoint at a time; the batch forms
(:func:`rotation`, :func:`euler_rate_matrix`, :func:`euler_rate_matrix_derivative`:
arrays (N, 3, 3) of poses (N, 6)) serve a machine's solver and the cue metrics.
"""
from __future__ import annotations

import math

import numpy as np

Vec3 = tuple[float, float, float]


class EulerSingularity(ValueError):
    """The pitch is +-90 deg to working precision: Euler rates are undefined."""


def angular_velocity(angles: Vec3, rates: Vec3) -> Vec3:
    """The angular velocity in the base frame of the Euler-angle ``rates`` at
    ``angles`` (roll, pitch, yaw): E rates (S2). At zero pitch and yaw, E is
    the identity and ``rates`` are returned as they are.
    """
    _, theta, psi = angles
    if theta == 0.0 and psi == 0.0:
        return tuple(rates)
    droll, dtheta, dpsi = rates
    ct, st, cp, sp = math.cos(theta), math.sin(theta), math.cos(psi), math.sin(psi)
    return (cp * ct * droll - sp * dtheta, sp * ct * droll + cp * dtheta, -st * droll + dpsi)


def angular_acceleration(angles: Vec3, rates: Vec3, accelerations: Vec3) -> Vec3:
    """The angular acceleration in the base frame of the Euler-angle ``rates``
    and ``accelerations`` at ``angles``: E accelerations + Edot rates (S3).
    """
    ex, ey, ez = _e_dot_rates(angles, rates)
    ax, ay, az = angular_velocity(angles, accelerations)
    return (ax + ex, ay + ey, az + ez)


def _e_dot_rates(angles: Vec3, rates: Vec3) -> Vec3:
    """(S3)'s Edot times the Euler-angle ``rates``."""
    _, theta, psi = angles
    droll, dtheta, dpsi = rates
    if dtheta == 0.0 and dpsi == 0.0:
        return (0.0, 0.0, 0.0)
    ct, st = math.cos(theta), math.sin(theta)
    cp, sp = math.cos(psi), math.sin(psi)
    return ((-sp * ct * dpsi - cp * st * dtheta) * droll - cp * dpsi * dtheta,
            (cp * ct * dpsi - sp * st * dtheta) * droll - sp * dpsi * dtheta,
            -ct * dtheta * droll)


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
    _, dtheta, dpsi = rates
    if theta == 0.0 and psi == 0.0 and dtheta == 0.0 and dpsi == 0.0:
        return tuple(epsilon)
    ex, ey, ez = _e_dot_rates(angles, rates)
    return _inverse(theta, psi, epsilon[0] - ex, epsilon[1] - ey, epsilon[2] - ez)


# -- batch forms: q (N, 6) = (surge, sway, heave, roll, pitch, yaw) ---------------
def rotation(q: np.ndarray) -> np.ndarray:
    """R = Rz(yaw) Ry(pitch) Rx(roll) (S1), (N, 3, 3)."""
    cr, sr = np.cos(q[:, 3]), np.sin(q[:, 3])
    cp, sp = np.cos(q[:, 4]), np.sin(q[:, 4])
    cy, sy = np.cos(q[:, 5]), np.sin(q[:, 5])
    return np.stack([
        np.stack([cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr], axis=-1),
        np.stack([sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr], axis=-1),
        np.stack([-sp, cp * sr, cp * cr], axis=-1)], axis=-2)


def euler_rate_matrix(q: np.ndarray) -> np.ndarray:
    """E(theta, psi) of (S2): omega = E (roll, pitch, yaw) rates, base frame, (N, 3, 3)."""
    cp, sp = np.cos(q[:, 4]), np.sin(q[:, 4])
    cy, sy = np.cos(q[:, 5]), np.sin(q[:, 5])
    zero, one = np.zeros_like(cp), np.ones_like(cp)
    return np.stack([np.stack([cy * cp, -sy, zero], axis=-1),
                     np.stack([sy * cp, cy, zero], axis=-1),
                     np.stack([-sp, zero, one], axis=-1)], axis=-2)


def euler_rate_matrix_derivative(q: np.ndarray, qd: np.ndarray) -> np.ndarray:
    """dE/dt of (S3), (N, 3, 3)."""
    cp, sp = np.cos(q[:, 4]), np.sin(q[:, 4])
    cy, sy = np.cos(q[:, 5]), np.sin(q[:, 5])
    pd, yd = qd[:, 4], qd[:, 5]
    zero = np.zeros_like(cp)
    return np.stack([np.stack([-sy * cp * yd - cy * sp * pd, -cy * yd, zero], axis=-1),
                     np.stack([cy * cp * yd - sy * sp * pd, -sy * yd, zero], axis=-1),
                     np.stack([-cp * pd, zero, zero], axis=-1)], axis=-2)
