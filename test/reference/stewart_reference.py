"""Independent reference of the 6-UPS Stewart-Gough hexapod (docs/design/stewart.md).

This module is written from ``docs/design/stewart.md`` only and shares no
code with ``flight_sim_dynamics`` (it imports numpy, pinocchio and yaml,
nothing else).  It gives the actuator forces of the hexapod for a motion
``q(t) = (surge, sway, heave, roll, pitch, yaw)`` by two formulations that
have nothing in common but the geometry of the machine.

Machine and conventions (stewart.md)
------------------------------------
Base frame z up, gravity ``-g z``.  Platform origin ``p = home + (surge, sway,
heave)``, orientation ``R = Rz(yaw) Ry(pitch) Rx(roll)``.  Leg i joins the base
joint ``B_i`` (universal joint, first axis ``a1_i`` fixed in the base, second
axis ``a2_i`` perpendicular to ``a1_i`` and to the leg) to the platform joint
``P_i = p + R p_i`` (spherical joint).  ``d_i = P_i - B_i``, ``L_i = |d_i|``,
``u_i = d_i / L_i``.  The cylinder turns with the U-joint's second body, its
centre of mass ``c_cyl`` from ``B_i`` along ``u_i``; the rod slides in it along
``u_i``, its centre of mass ``c_rod`` from ``P_i`` towards ``B_i``.  Both are
axisymmetric about ``u_i`` (inertias ``across`` and ``along``).  ``f_i`` pushes
``B_i`` and ``P_i`` apart.

The U-joint angles use a per-leg base frame ``C_i = [e1 e2 e3]`` with
``e1 = a1_i``, ``e3`` the base z axis made perpendicular to ``a1_i`` (x if
``a1_i`` is vertical) and ``e2 = e3 x e1``; the leg's frame is
``C_i Rx(theta1) Ry(theta2)``, its z axis is ``u_i``.  So in ``C_i``
coordinates ``u = (sin t2, -sin t1 cos t2, cos t1 cos t2)``:
``t2 = asin(u.e1)``, ``t1 = atan2(-u.e2, u.e3)``, singular where
``u_i`` is parallel to ``a1_i`` (cos t2 = 0).

(a) Pinocchio: the closed chain as a tree plus loop closures
------------------------------------------------------------
The tree: the platform on a free-flyer joint (with the payload's inertia
added to its body), and per leg three joints from the base: RX at
``SE3(C_i, B_i)`` (``theta1`` about ``a1_i``), RY (``theta2``, the cylinder's
body), PZ (``L_i``, the rod's body, whose origin is the rod's end ``P_i``).
The six spherical joints are the loop closures ``tip_i = P_i``.

For a platform motion, the free-flyer's configuration ``(p, R)``, its body
twist ``nu = (R^T dp/dt, R^T omega)`` and its spatial acceleration
``dnu/dt = (R^T d2p/dt2 - omega_b x v_b, R^T domega/dt)`` come from
pinocchio's roll-pitch-yaw Jacobian and its time derivative.  The legs'
joint positions come from the closed form above; their velocities and
accelerations from the closure, with pinocchio's frame Jacobians and
classical accelerations (LOCAL_WORLD_ALIGNED, linear part):

    J_tip,i qd_leg,i          = J_P,i nu                    (closure, velocity)
    J_tip,i qdd_leg,i + g_tip = J_P,i dnu/dt + g_P          (closure, acceleration)

``g_tip``, ``g_P`` the classical accelerations of the two points with zero
joint accelerations of their own chains.  So every tree velocity is
``v = W nu``, with ``W`` stacking ``A_i = J_tip,i^-1 J_P,i`` and the identity
on the free-flyer.  ``tau = rnea(q, v, dv/dt)`` (gravity included) is the
tree's joint-space inverse dynamics.  The actual machine is the tree loaded
by the actuator forces ``S^T f`` (f_i on the prismatic joint i) and by the
spherical joints' constraint forces, which do no work on any ``v = W nu``;
virtual work over the admissible motions gives

    W^T tau = J^T f,    J = S W = d(dL/dt)/d nu     (6 x 6 actuator Jacobian)
    f = J^-T W^T tau.

(b) Lagrange by energy
----------------------
``T(q, qd)`` and ``V(q)`` of every body (six cylinders, six rods, platform,
payload) are written in closed form from the geometry: ``omega = E(q) qd`` with
``E``'s columns ``Rz Ry x, Rz y, z`` (stewart.md); ``dP_i/dt = dp/dt +
omega x R p_i``; ``dL/dt = u . dP/dt``; ``du/dt = (dP/dt - dL/dt u) / L``; the
leg's angular velocity, in the span of the two U axes,
``omega_leg = u x du/dt + (a1 . u) theta1_dot u`` with
``theta1_dot = (a1 x u) . du/dt / |a1 x u|^2`` (the spin about ``u`` that the
U-joint imposes); centres of mass ``B + c_cyl u`` and ``P - c_rod u``.  With
``p_j = dT/dqd_j`` the Lagrange equations give the generalised forces

    Q_j = d/dt dT/dqd_j - dT/dq_j + dV/dq_j = sum_i f_i dL_i/dq_j,
    f = (dL/dq)^-T Q.

Derivatives without truncation error: ``T`` is quadratic in ``qd``, so
``dT/dqd_j = (T(qd + e_j) - T(qd - e_j)) / 2`` exactly; every first derivative
in ``q`` or along the motion ``(q, qd) -> (qd, qdd)`` is a complex step
``Im F(x + i h dx) / h`` with ``h = 1e-30`` (every formula above is analytic;
no conjugates, no abs).  ``d(T + V)/dt`` along the motion comes out the same
way, for the power balance ``sum f_i dL_i/dt = d(T + V)/dt``.

Parameters
----------
``default_machine()`` and ``tsai_2000()`` return the machines as plain dicts
in the parameter-file layout of stewart.md (``{"/**/flight_sim_dynamics":
{"ros__parameters": {...}}}``, joints as 18 explicit numbers);
``machine_from_dict(d)`` turns such a dict (or the ``ros__parameters`` part)
into numpy arrays.  ``docs/design/stewart.md`` prints the same dicts as YAML.
The reference has no scenes: gravity and every body's inertia always act, the
payload whenever its mass is not zero, friction never; ``scene``, ``friction``
and ``limits`` are carried in the dicts for the parameter files only.

Public API
----------
``default_machine()``, ``tsai_2000()``   -> parameter-file dicts
``machine_yaml(d)``, ``load_machine(path)``  -> the same as YAML text / from a file
``machine_from_dict(d)``, ``with_payload(d, mass, com, inertia)``
``leg_lengths(m, q)``, ``leg_rates(m, q, qd)``
``forces_pinocchio(m, q, qd, qdd)``  -> (N, 6)        formulation (a)
``forces_lagrange(m, q, qd, qdd)``   -> (N, 6)        formulation (b)
``energy(m, q, qd)``                 -> (T, V)
``energy_rate(m, q, qd, qdd)``       -> d(T + V)/dt
``energy_pinocchio(m, q, qd)``       -> (T, V) of the tree, pinocchio's
``tsai_motion(k, t)``                -> (q, qd, qdd) of Tsai's motion k = 1..4
"""

from __future__ import annotations

import copy

import numpy as np
import pinocchio as pin
import yaml

_H = 1e-30  # complex step: exact first derivatives for analytic formulas

# ---------------------------------------------------------------------------
# The machines, in the parameter-file layout of stewart.md
# ---------------------------------------------------------------------------

_DEFAULT_TABLE = {
    "r_b": 1.2,
    "theta_b": (350.0, 10.0, 110.0, 130.0, 230.0, 250.0),
    "r_p": 0.8,
    "theta_p": (315.0, 45.0, 75.0, 165.0, 195.0, 285.0),
    "h_0": 1.0,
}


def _flat(points) -> list[float]:
    return [float(x) for x in np.asarray(points, dtype=float).reshape(-1)]


#: the packaged files' section: the node of that name in any namespace
SECTION = "/**/flight_sim_dynamics"


def _file(params: dict) -> dict:
    return {SECTION: {"ros__parameters": params}}


def _params(d: dict) -> dict:
    """The ``ros__parameters`` of a parameter-file dict (a section
    ``flight_sim_dynamics`` or ``/**/flight_sim_dynamics``), or ``d`` itself."""
    for section in ("flight_sim_dynamics", SECTION):
        if section in d:
            return d[section]["ros__parameters"]
    return d


def default_machine() -> dict:
    """The default 6-DOF machine of stewart.md as a parameter-file dict."""
    t = _DEFAULT_TABLE
    tb = np.radians(t["theta_b"])
    tp = np.radians(t["theta_p"])
    zero = np.zeros(6)
    base = np.stack([t["r_b"] * np.cos(tb), t["r_b"] * np.sin(tb), zero], axis=1)
    plat = np.stack([t["r_p"] * np.cos(tp), t["r_p"] * np.sin(tp), zero], axis=1)
    axes = np.stack([-np.sin(tb), np.cos(tb), zero], axis=1)  # tangent to the base circle
    return _file({
        "machine": "stewart_6dof",
        "gravity": 9.81,
        "scene": "full",
        "geometry": {
            "base_joints": _flat(base),
            "platform_joints": _flat(plat),
            "base_axes": _flat(axes),
            "home": [0.0, 0.0, t["h_0"]],
        },
        "bodies": {
            "platform": {"mass": 150.0, "com": [0.05, 0.0, 0.3],
                         "inertia": [40.0, 0.0, -2.0, 0.0, 45.0, 0.0, -2.0, 0.0, 60.0]},
            "cylinder": {"mass": 12.0, "com_distance": 0.35,
                         "inertia_across": 0.6, "inertia_along": 0.03},
            "rod": {"mass": 6.0, "com_distance": 0.40,
                    "inertia_across": 0.3, "inertia_along": 0.01},
        },
        "payload": {"mass": 0.0, "com": [0.0, 0.0, 0.5], "inertia": [0.0] * 9},
        "friction": {"viscous": [0.0] * 6, "coulomb": [0.0] * 6,
                     "smoothing_velocity": 0.001},
        "limits": {"length_min": 0.95, "length_max": 1.55,
                   "max_speed": 1.5, "max_force": 8000.0},
    })


_TSAI_PLATFORM = ((0.17, 0.595, -0.4), (-0.6, 0.15, -0.4), (-0.6, -0.15, -0.4),
                  (0.17, -0.595, -0.4), (0.43, -0.445, -0.4), (0.43, 0.445, -0.4))
_TSAI_BASE = ((-2.12, 1.374, 0.0), (-2.38, 1.224, 0.0), (-2.38, -1.224, 0.0),
              (-2.12, -1.374, 0.0), (0.0, -0.15, 0.0), (0.0, 0.15, 0.0))
_TSAI_HOME = (-1.5, 0.0, 1.0)


def tsai_2000() -> dict:
    """Tsai's benchmark hexapod (stewart.md, "A second, public hexapod")."""
    base = np.array(_TSAI_BASE)
    plat = np.array(_TSAI_PLATFORM)
    legs = np.array(_TSAI_HOME) + plat - base
    # horizontal, across each leg's horizontal direction at home: z x (leg)
    axes = np.stack([-legs[:, 1], legs[:, 0], np.zeros(6)], axis=1)
    axes /= np.linalg.norm(axes, axis=1, keepdims=True)
    leg = {"mass": 0.1, "com_distance": 0.5, "inertia_across": 1.0 / 160.0, "inertia_along": 0.0}
    return _file({
        "machine": "stewart_tsai2000",
        "gravity": 9.80665,
        "scene": "full",
        "geometry": {
            "base_joints": _flat(base),
            "platform_joints": _flat(plat),
            "base_axes": _flat(axes),
            "home": list(_TSAI_HOME),
        },
        "bodies": {
            "platform": {"mass": 1.5, "com": [0.0, 0.0, 0.0],
                         "inertia": [0.08, 0.0, 0.0, 0.0, 0.08, 0.0, 0.0, 0.0, 0.08]},
            "cylinder": dict(leg),
            "rod": dict(leg),
        },
        "payload": {"mass": 0.0, "com": [0.0, 0.0, 0.0], "inertia": [0.0] * 9},
        "friction": {"viscous": [0.0] * 6, "coulomb": [0.0] * 6,
                     "smoothing_velocity": 0.001},
        # not in the source: round values that cover the four motions
        "limits": {"length_min": 0.8, "length_max": 1.8,
                   "max_speed": 2.0, "max_force": 100.0},
    })


def with_payload(d: dict, mass: float, com, inertia=(0.0,) * 9) -> dict:
    """A copy of the machine dict ``d`` carrying the given payload."""
    d = copy.deepcopy(d)
    params = _params(d)
    params["payload"] = {"mass": float(mass), "com": [float(c) for c in com],
                         "inertia": [float(x) for x in inertia]}
    return d


def _scalar(x) -> str:
    if isinstance(x, str):
        return x
    text = repr(float(x))
    if "e" in text and "." not in text.split("e")[0]:  # YAML 1.1 floats need a dot
        mantissa, exponent = text.split("e")
        text = f"{mantissa}.0e{exponent}"
    return text


def machine_yaml(d: dict) -> str:
    """The parameter file of a machine dict as YAML text (joints three numbers a line)."""
    lines: list[str] = []

    def emit(key, value, indent):
        pad = " " * indent
        if isinstance(value, dict):
            lines.append(f"{pad}{key}:")
            for k, v in value.items():
                emit(k, v, indent + 2)
        elif isinstance(value, list):
            items = [_scalar(x) for x in value]
            rows = [items[i:i + 3] for i in range(0, len(items), 3)] if len(items) > 3 else [items]
            head = f"{pad}{key}: ["
            sep = ",\n" + " " * len(head)
            lines.extend((head + sep.join(", ".join(r) for r in rows) + "]").split("\n"))
        else:
            lines.append(f"{pad}{key}: {_scalar(value)}")

    for k, v in d.items():
        emit(k, v, 0)
    return "\n".join(lines) + "\n"


def load_machine(path) -> dict:
    """Read a parameter file (YAML) into the dict layout of ``default_machine()``."""
    with open(path, encoding="utf-8") as stream:
        return yaml.safe_load(stream)


def machine_from_dict(d: dict) -> dict:
    """Numpy arrays of a machine given as a parameter-file dict or its ros__parameters."""
    d = _params(d)
    geo, bodies = d["geometry"], d["bodies"]

    def points(key):
        a = np.asarray(geo[key], dtype=float)
        if a.shape != (18,):
            raise ValueError(f"geometry.{key}: 18 numbers expected, got shape {a.shape}")
        return a.reshape(6, 3)

    axes = points("base_axes")
    axes = axes / np.linalg.norm(axes, axis=1, keepdims=True)

    def rigid(b):
        return {"mass": float(b["mass"]), "com": np.asarray(b["com"], dtype=float),
                "inertia": np.asarray(b["inertia"], dtype=float).reshape(3, 3)}

    def leg_body(b):
        return {k: float(b[k]) for k in ("mass", "com_distance", "inertia_across", "inertia_along")}

    payload = d.get("payload", {"mass": 0.0, "com": [0.0] * 3, "inertia": [0.0] * 9})
    return {
        "g": float(d["gravity"]),
        "B": points("base_joints"),
        "p": points("platform_joints"),
        "a1": axes,
        "home": np.asarray(geo["home"], dtype=float),
        "platform": rigid(bodies["platform"]),
        "payload": rigid(payload),
        "cylinder": leg_body(bodies["cylinder"]),
        "rod": leg_body(bodies["rod"]),
    }


def _machine(m) -> dict:
    return m if "B" in m else machine_from_dict(m)


def _batch(*arrays):
    out = [np.atleast_2d(np.asarray(a)) for a in arrays]
    return out


# ---------------------------------------------------------------------------
# Closed-form geometry (complex-safe: used by (b) with complex steps)
# ---------------------------------------------------------------------------

def _dot(a, b):
    return (a * b).sum(axis=-1)


def _cross(a, b):
    return np.stack([a[..., 1] * b[..., 2] - a[..., 2] * b[..., 1],
                     a[..., 2] * b[..., 0] - a[..., 0] * b[..., 2],
                     a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]], axis=-1)


def _rotation(q):
    """R = Rz(yaw) Ry(pitch) Rx(roll), shape (..., 3, 3)."""
    cr, sr = np.cos(q[..., 3]), np.sin(q[..., 3])
    cp, sp = np.cos(q[..., 4]), np.sin(q[..., 4])
    cy, sy = np.cos(q[..., 5]), np.sin(q[..., 5])
    return np.stack([
        np.stack([cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr], axis=-1),
        np.stack([sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr], axis=-1),
        np.stack([-sp, cp * sr, cp * cr], axis=-1),
    ], axis=-2)


def _omega(q, qd):
    """omega = roll_d Rz Ry x + pitch_d Rz y + yaw_d z (base frame)."""
    cp, sp = np.cos(q[..., 4]), np.sin(q[..., 4])
    cy, sy = np.cos(q[..., 5]), np.sin(q[..., 5])
    rd, pd, yd = qd[..., 3], qd[..., 4], qd[..., 5]
    return np.stack([rd * cy * cp - pd * sy, rd * sy * cp + pd * cy, -rd * sp + yd], axis=-1)


def _platform_points(m, q):
    """Origin p, rotation R and the platform joints P_i (..., 6, 3) in the base frame."""
    p = m["home"] + q[..., :3]
    R = _rotation(q)
    P = p[..., None, :] + np.einsum("...ij,kj->...ki", R, m["p"])
    return p, R, P


def leg_lengths(m, q) -> np.ndarray:
    """L_i = |P_i - B_i| for poses q (..., 6) -> (..., 6)."""
    m = _machine(m)
    q = np.asarray(q)
    d = _platform_points(m, q)[2] - m["B"]
    return np.sqrt(_dot(d, d))


def leg_rates(m, q, qd) -> np.ndarray:
    """dL_i/dt = u_i . dP_i/dt."""
    m = _machine(m)
    q, qd = np.asarray(q), np.asarray(qd)
    _, R, P = _platform_points(m, q)
    w = _omega(q, qd)
    dP = qd[..., None, :3] + _cross(w[..., None, :], np.einsum("...ij,kj->...ki", R, m["p"]))
    d = P - m["B"]
    return _dot(d, dP) / np.sqrt(_dot(d, d))


def _rigid_energy(body, g, p, R, w, dp):
    """T and V of a rigid body on the platform (com and inertia in the platform frame)."""
    rc = np.einsum("...ij,j->...i", R, body["com"])
    v = dp + _cross(w, rc)
    wb = np.einsum("...ji,...j->...i", R, w)  # R^T omega
    T = 0.5 * body["mass"] * _dot(v, v) + 0.5 * _dot(wb, np.einsum("ij,...j->...i", body["inertia"], wb))
    V = body["mass"] * g * (p[..., 2] + rc[..., 2])
    return T, V


def _axisymmetric(body, w, u):
    wu = _dot(w, u)
    return 0.5 * (body["inertia_across"] * (_dot(w, w) - wu * wu) + body["inertia_along"] * wu * wu)


def energy(m, q, qd):
    """Kinetic and potential energy (T, V) of the hexapod, closed form (formulation (b))."""
    m = _machine(m)
    q, qd = np.asarray(q), np.asarray(qd)
    g = m["g"]
    p, R, P = _platform_points(m, q)
    w = _omega(q, qd)
    dp = qd[..., :3]
    T, V = _rigid_energy(m["platform"], g, p, R, w, dp)
    if m["payload"]["mass"] > 0.0:
        Tp, Vp = _rigid_energy(m["payload"], g, p, R, w, dp)
        T, V = T + Tp, V + Vp
    # legs: (..., 6, 3)
    rp = np.einsum("...ij,kj->...ki", R, m["p"])
    dP = dp[..., None, :] + _cross(w[..., None, :], rp)
    d = P - m["B"]
    L = np.sqrt(_dot(d, d))
    u = d / L[..., None]
    dL = _dot(u, dP)
    du = (dP - dL[..., None] * u) / L[..., None]
    a1 = m["a1"]
    a1u = _cross(a1, u)
    theta1_d = _dot(a1u, du) / _dot(a1u, a1u)
    w_leg = _cross(u, du) + (_dot(a1, u) * theta1_d)[..., None] * u
    cyl, rod = m["cylinder"], m["rod"]
    v_cyl = cyl["com_distance"] * du
    v_rod = dP - rod["com_distance"] * du
    T_legs = (0.5 * cyl["mass"] * _dot(v_cyl, v_cyl) + _axisymmetric(cyl, w_leg, u)
              + 0.5 * rod["mass"] * _dot(v_rod, v_rod) + _axisymmetric(rod, w_leg, u))
    z_cyl = m["B"][:, 2] + cyl["com_distance"] * u[..., 2]
    z_rod = P[..., 2] - rod["com_distance"] * u[..., 2]
    V_legs = g * (cyl["mass"] * z_cyl + rod["mass"] * z_rod)
    return T + T_legs.sum(axis=-1), V + V_legs.sum(axis=-1)


# ---------------------------------------------------------------------------
# (b) Lagrange by energy
# ---------------------------------------------------------------------------

def energy_rate(m, q, qd, qdd) -> np.ndarray:
    """d(T + V)/dt along the motion, by a complex step."""
    m = _machine(m)
    q, qd, qdd = (np.asarray(a, dtype=float) for a in (q, qd, qdd))
    T, V = energy(m, q + 1j * _H * qd, qd + 1j * _H * qdd)
    return (T + V).imag / _H


def generalised_forces(m, q, qd, qdd) -> np.ndarray:
    """Q = d/dt dT/dqd - dT/dq + dV/dq for q, qd, qdd of shape (N, 6) -> (N, 6)."""
    m = _machine(m)
    q, qd, qdd = _batch(*(np.asarray(a, dtype=float) for a in (q, qd, qdd)))
    E6 = np.eye(6)
    # d/dt dT/dqd_j: T quadratic in qd, so dT/dqd_j = (T(qd + e_j) - T(qd - e_j)) / 2
    # exactly; its time derivative is that difference of directional derivatives.
    qs = (q + 1j * _H * qd)[:, None, :]
    d_plus = energy(m, qs, (qd[:, None, :] + E6) + 1j * _H * qdd[:, None, :])[0].imag / _H
    d_minus = energy(m, qs, (qd[:, None, :] - E6) + 1j * _H * qdd[:, None, :])[0].imag / _H
    ddt_p = 0.5 * (d_plus - d_minus)
    T_q, V_q = energy(m, q[:, None, :] + 1j * _H * E6, qd[:, None, :] + 0j)
    return ddt_p - T_q.imag / _H + V_q.imag / _H


def length_jacobian(m, q) -> np.ndarray:
    """J_L = dL/dq (N, 6 legs, 6 coordinates), by complex steps."""
    m = _machine(m)
    (q,) = _batch(np.asarray(q, dtype=float))
    L = leg_lengths(m, q[:, None, :] + 1j * _H * np.eye(6))  # (N, coord, leg)
    return np.swapaxes(L.imag / _H, -1, -2)


def forces_lagrange(m, q, qd, qdd) -> np.ndarray:
    """Actuator forces (N, 6) from Q = J_L^T f (formulation (b))."""
    Q = generalised_forces(m, q, qd, qdd)
    J = length_jacobian(m, q)
    return np.linalg.solve(np.swapaxes(J, -1, -2), Q[..., None])[..., 0]


# ---------------------------------------------------------------------------
# (a) Pinocchio: tree + loop closures
# ---------------------------------------------------------------------------

def _leg_frame(a1) -> np.ndarray:
    """C = [e1 e2 e3]: e1 = a1, e3 = z (x if a1 is vertical) made perpendicular to a1."""
    ref = np.array([0.0, 0.0, 1.0]) if abs(a1[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    e3 = ref - (ref @ a1) * a1
    e3 /= np.linalg.norm(e3)
    return np.column_stack([a1, np.cross(e3, a1), e3])


def _axisymmetric_inertia(body, com_z) -> pin.Inertia:
    I = np.diag([body["inertia_across"], body["inertia_across"], body["inertia_along"]])
    return pin.Inertia(body["mass"], np.array([0.0, 0.0, com_z]), I)


class PinocchioHexapod:
    """The hexapod as a pinocchio tree (free-flying platform, three joints per leg)."""

    def __init__(self, m):
        m = _machine(m)
        self.m = m
        model = pin.Model()
        model.gravity = pin.Motion(np.array([0.0, 0.0, -m["g"]]), np.zeros(3))
        self.j_platform = model.addJoint(0, pin.JointModelFreeFlyer(), pin.SE3.Identity(), "platform")
        pl = m["platform"]
        model.appendBodyToJoint(self.j_platform, pin.Inertia(pl["mass"], pl["com"], pl["inertia"]),
                                pin.SE3.Identity())
        if m["payload"]["mass"] > 0.0:
            py = m["payload"]
            model.appendBodyToJoint(self.j_platform, pin.Inertia(py["mass"], py["com"], py["inertia"]),
                                    pin.SE3.Identity())
        self.C, self.j_legs, self.f_P, self.f_tip = [], [], [], []
        for i in range(6):
            C = _leg_frame(m["a1"][i])
            j1 = model.addJoint(0, pin.JointModelRX(), pin.SE3(C, m["B"][i]), f"leg{i + 1}_u1")
            j2 = model.addJoint(j1, pin.JointModelRY(), pin.SE3.Identity(), f"leg{i + 1}_u2")
            model.appendBodyToJoint(j2, _axisymmetric_inertia(m["cylinder"], m["cylinder"]["com_distance"]),
                                    pin.SE3.Identity())
            j3 = model.addJoint(j2, pin.JointModelPZ(), pin.SE3.Identity(), f"leg{i + 1}_rod")
            model.appendBodyToJoint(j3, _axisymmetric_inertia(m["rod"], -m["rod"]["com_distance"]),
                                    pin.SE3.Identity())
            self.f_tip.append(model.addFrame(pin.Frame(f"tip{i + 1}", j3, pin.SE3.Identity(),
                                                       pin.FrameType.OP_FRAME)))
            self.f_P.append(model.addFrame(pin.Frame(f"P{i + 1}", self.j_platform,
                                                     pin.SE3(np.eye(3), m["p"][i]),
                                                     pin.FrameType.OP_FRAME)))
            self.C.append(C)
            self.j_legs.append((j1, j2, j3))
        self.model, self.data = model, model.createData()
        self.iv_platform = model.joints[self.j_platform].idx_v
        self.iv_legs = [[model.joints[j].idx_v for j in js] for js in self.j_legs]
        self.iq_legs = [[model.joints[j].idx_q for j in js] for js in self.j_legs]

    def configuration(self, q):
        """Tree configuration for the pose q: free-flyer (p, R) and the legs' closed-form joints."""
        m = self.m
        R = pin.rpy.rpyToMatrix(q[3], q[4], q[5])
        p = m["home"] + q[:3]
        x = pin.neutral(self.model)
        iq = self.model.joints[self.j_platform].idx_q
        x[iq:iq + 7] = pin.SE3ToXYZQUAT(pin.SE3(R, p))
        for i in range(6):
            d = p + R @ m["p"][i] - m["B"][i]
            L = np.linalg.norm(d)
            ul = self.C[i].T @ (d / L)
            x[self.iq_legs[i]] = (np.arctan2(-ul[1], ul[2]), np.arcsin(ul[0]), L)
        return x, R

    def motion(self, q, qd, qdd):
        """Tree configuration, velocity, acceleration and W (nv x 6) for one sample."""
        model, data = self.model, self.data
        x, R = self.configuration(q)
        rpy, rpyd, rpydd = q[3:], qd[3:], qdd[3:]
        Jr = pin.rpy.computeRpyJacobian(rpy, pin.LOCAL)
        dJr = pin.rpy.computeRpyJacobianTimeDerivative(rpy, rpyd, pin.LOCAL)
        w_b = Jr @ rpyd
        v_b = R.T @ qd[:3]
        nu = np.concatenate([v_b, w_b])
        dnu = np.concatenate([R.T @ qdd[:3] - np.cross(w_b, v_b), Jr @ rpydd + dJr @ rpyd])
        ivp = self.iv_platform
        # velocities: closure J_tip qd_leg = J_P nu
        pin.computeJointJacobians(model, data, x)
        pin.updateFramePlacements(model, data)
        W = np.zeros((model.nv, 6))
        W[ivp:ivp + 6] = np.eye(6)
        J_tips = []
        for i in range(6):
            J_tip = pin.getFrameJacobian(model, data, self.f_tip[i], pin.LOCAL_WORLD_ALIGNED)[:3, self.iv_legs[i]]
            J_P = pin.getFrameJacobian(model, data, self.f_P[i], pin.LOCAL_WORLD_ALIGNED)[:3, ivp:ivp + 6]
            W[self.iv_legs[i]] = np.linalg.solve(J_tip, J_P)
            J_tips.append(J_tip)
        v = W @ nu
        # accelerations: closure J_tip qdd_leg + g_tip = a_P (classical accelerations)
        a = np.zeros(model.nv)
        a[ivp:ivp + 6] = dnu
        pin.forwardKinematics(model, data, x, v, a)
        pin.updateFramePlacements(model, data)
        for i in range(6):
            a_P = pin.getFrameClassicalAcceleration(model, data, self.f_P[i], pin.LOCAL_WORLD_ALIGNED).linear
            g_tip = pin.getFrameClassicalAcceleration(model, data, self.f_tip[i], pin.LOCAL_WORLD_ALIGNED).linear
            a[self.iv_legs[i]] = np.linalg.solve(J_tips[i], a_P - g_tip)
        return x, v, a, W

    def forces(self, q, qd, qdd) -> np.ndarray:
        """f = J^-T W^T rnea(q, v, a) for one sample."""
        x, v, a, W = self.motion(q, qd, qdd)
        tau = pin.rnea(self.model, self.data, x, v, a)
        J = W[[iv[2] for iv in self.iv_legs]]  # dL/dt = J nu
        return np.linalg.solve(J.T, W.T @ tau)

    def energy(self, q, qd):
        """(T, V) of the tree at the closed configuration, pinocchio's."""
        x, v, _, _ = self.motion(q, qd, np.zeros(6))
        T = pin.computeKineticEnergy(self.model, self.data, x, v)
        V = pin.computePotentialEnergy(self.model, self.data, x)
        return T, V


def forces_pinocchio(m, q, qd, qdd) -> np.ndarray:
    """Actuator forces (N, 6) by formulation (a)."""
    hexapod = m if isinstance(m, PinocchioHexapod) else PinocchioHexapod(m)
    q, qd, qdd = _batch(*(np.asarray(a, dtype=float) for a in (q, qd, qdd)))
    return np.array([hexapod.forces(*s) for s in zip(q, qd, qdd)])


def energy_pinocchio(m, q, qd):
    """(T, V) arrays of the pinocchio tree for poses/rates (N, 6)."""
    hexapod = m if isinstance(m, PinocchioHexapod) else PinocchioHexapod(m)
    q, qd = _batch(np.asarray(q, dtype=float), np.asarray(qd, dtype=float))
    return np.array([hexapod.energy(*s) for s in zip(q, qd)]).T


# ---------------------------------------------------------------------------
# Tsai's motions
# ---------------------------------------------------------------------------

TSAI_OMEGA = 3.0


def tsai_motion(k: int, t):
    """(q, qd, qdd) of Tsai's motion k (stewart.md): 1 surge = sway = heave = 0.2 sin wt,
    2 yaw = pi/6 sin wt, 3 surge = 0.2 sin wt, 4 at rest at home; w = 3 rad/s."""
    t = np.asarray(t, dtype=float)
    w = TSAI_OMEGA
    s, c = np.sin(w * t), np.cos(w * t)
    q, qd, qdd = (np.zeros((t.size, 6)) for _ in range(3))
    cols, amp = {1: ([0, 1, 2], 0.2), 2: ([5], np.pi / 6), 3: ([0], 0.2), 4: ([], 0.0)}[k]
    for j in cols:
        q[:, j], qd[:, j], qdd[:, j] = amp * s, amp * w * c, -amp * w * w * s
    return q, qd, qdd


if __name__ == "__main__":
    np.set_printoptions(precision=6, suppress=True, linewidth=120)
    dm = default_machine()
    z = np.zeros((1, 6))
    print("home leg lengths", repr(leg_lengths(machine_from_dict(dm), np.zeros(6))))
    print("static (a)", forces_pinocchio(dm, z, z, z)[0])
    print("static (b)", forces_lagrange(dm, z, z, z)[0])
    pm = with_payload(dm, 80.0, (0.0, 0.0, 0.5))
    print("payload (a)", forces_pinocchio(pm, z, z, z)[0])
    print("payload (b)", forces_lagrange(pm, z, z, z)[0])
    ts = machine_from_dict(tsai_2000())
    t = np.linspace(0.0, 2 * np.pi / TSAI_OMEGA, 121)
    for k in (1, 2, 3, 4):
        f = forces_pinocchio(ts, *tsai_motion(k, t))
        print(f"Tsai motion {k}: peak |f_i| (N)", np.abs(f).max(axis=0))
