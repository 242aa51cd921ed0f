"""A machine's pose as a rigid body's, the way ROS messages carry it: the six
components (x, y, z, roll, pitch, yaw) of a Pose, with ZYX angles
(R = Rz(yaw) Ry(pitch) Rx(roll), REP-103), and a Twist's or Accel's angular
part, the platform's angular velocity and acceleration in the base frame,
from the Euler-angle rates and accelerations the solvers take (and back).

(S2) of docs/design/stewart.md: omega = E(pitch, yaw) (roll, pitch, yaw)' with

    E = [ cy cp   -sy   0 ]
        [ sy cp    cy   0 ]        det E = cp: no rates at pitch = +-90 deg
        [ -sp      0    1 ]

(S3): epsilon = omega' = E (roll, pitch, yaw)'' + E' (roll, pitch, yaw)'.
A machine names which component each of its coordinates is
(:attr:`Machine.pose_components`); the components it lacks are 0. Plain
floats: one sample per call, no numpy overhead.
"""
from __future__ import annotations

import math
from typing import Sequence

Vec3 = tuple[float, float, float]

#: The components of a rigid body's pose, in the order of the functions' six-tuples.
COMPONENTS = ('x', 'y', 'z', 'roll', 'pitch', 'yaw')


def six(components: Sequence[str], values: Sequence[float]) -> list[float]:
    """The six components (COMPONENTS order) of a machine's ``values`` (its
    coordinates, their rates or accelerations; ``components`` names each); 0 for
    the others.
    """
    out = [0.0] * 6
    for name, value in zip(components, values):
        out[COMPONENTS.index(name)] = float(value)
    return out


def coordinates(components: Sequence[str], values: Sequence[float]) -> list[float]:
    """A machine's values (``components`` names each) out of six (COMPONENTS order):
    the inverse of :func:`six` on what the machine has.
    """
    return [float(values[COMPONENTS.index(name)]) for name in components]


def angular_velocity(rpy: Sequence[float], rates: Sequence[float]) -> Vec3:
    """The angular velocity in the base frame of the Euler-angle ``rates`` at
    angles ``rpy``: E drpy (S2).
    """
    _, pitch, yaw = rpy
    dr, dp, dy = rates
    cp, sp, cy, sy = math.cos(pitch), math.sin(pitch), math.cos(yaw), math.sin(yaw)
    return (cy * cp * dr - sy * dp, sy * cp * dr + cy * dp, -sp * dr + dy)


def angular_acceleration(rpy: Sequence[float], rates: Sequence[float],
                         accelerations: Sequence[float]) -> Vec3:
    """The angular acceleration in the base frame of the Euler-angle rates and
    ``accelerations`` at angles ``rpy``: E ddrpy + E' drpy (S3).
    """
    _, pitch, yaw = rpy
    dr, dp, dy = rates
    cp, sp, cy, sy = math.cos(pitch), math.sin(pitch), math.cos(yaw), math.sin(yaw)
    ex, ey, ez = angular_velocity(rpy, accelerations)
    return (ex + (-sy * cp * dy - cy * sp * dp) * dr - cy * dy * dp,
            ey + (cy * cp * dy - sy * sp * dp) * dr - sy * dy * dp,
            ez - cp * dp * dr)


def euler_rates(rpy: Sequence[float], omega: Sequence[float]) -> Vec3:
    """The Euler-angle rates of the angular velocity ``omega`` (base frame) at
    angles ``rpy``: (S2) solved, E^-1 omega. Near pitch = +-90 deg they grow
    without bound (det E = cos(pitch), never exactly 0 for a float pitch).
    """
    _, pitch, yaw = rpy
    cp, sp, cy, sy = math.cos(pitch), math.sin(pitch), math.cos(yaw), math.sin(yaw)
    wx, wy, wz = omega
    # Rz(-yaw) omega = (cp dr, dp, -sp dr + dy)
    dr = (cy * wx + sy * wy) / cp
    return (dr, -sy * wx + cy * wy, wz + sp * dr)


def euler_accelerations(rpy: Sequence[float], rates: Sequence[float],
                        epsilon: Sequence[float]) -> Vec3:
    """The Euler-angle accelerations of the angular acceleration ``epsilon``
    (base frame) at angles ``rpy`` and Euler rates ``rates``: (S3) solved,
    E^-1 (epsilon - E' drpy).
    """
    bx, by, bz = angular_acceleration(rpy, rates, (0.0, 0.0, 0.0))    # E' drpy
    return euler_rates(rpy, (epsilon[0] - bx, epsilon[1] - by, epsilon[2] - bz))
