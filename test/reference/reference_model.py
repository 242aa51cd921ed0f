"""Independent reference model of the 3-DOF parallel flight simulator.

This module is a *second* implementation of the mechanism of Staicu,
Ocnarescu and Ungureanu (2013), written from the plain-vector description in
``docs/design/mechanism.md`` and the body-frame conventions of the header
of ``config/flight_sim_dynamics.yaml`` only.  It shares no code, no
intermediate quantities and no method with the production solver in
``flight_sim_dynamics/`` (which follows the paper's recursive matrix method:
joint-variable connectivity matrix Q, recursive Newton-Euler wrenches along
the open chains).  Nothing here imports ``flight_sim_dynamics``.

How it works
------------
1. *Truncated Taylor jets* (forward-mode automatic differentiation in time).
   A :class:`Jet` holds the normalised Taylor coefficients
   ``c_k = x^(k)(t) / k!`` of a quantity, k = 0..K, over arbitrary numpy
   array shapes.  +, -, *, /, sqrt, sin, cos and tensor contractions are
   implemented with the exact Taylor recurrences, so derivatives come out
   exact to round-off (no finite differences anywhere).
2. The pose jet (q, qd, qdd) is pushed through the *position* geometry
   only (points G, A3, D2, E2, B4, C4, rod axis l, platform axes l, n, t, leg
   axes, U-joint axes).  The parasitic pitch is obtained in closed form from
   the crank-D loop ``|G - (h - d1) l - D1| = l5`` (root near zero) and E2
   from the crank-E circle / rod line intersection (root between A3 and G).
3. Every body gets the frame of the YAML header (origin point + rotation
   matrix R whose columns are the body x, y, z axes in the fixed frame);
   its centre of mass is ``origin + R com`` and its world inertia
   ``R I R^T``, with the *general* com / inertia values of the parameter
   file (no slender-rod formulas).  Velocities and accelerations are the
   time derivatives of these jets, the angular velocity is
   ``vee(Rdot R^T)`` and the angular acceleration its time derivative.
4. Energy ``E = sum 1/2 m v.v + 1/2 w.(R I R^T) w + m g y_com`` is itself
   evaluated on jets, so its exact time derivative ``dE/dt`` along
   (q, qd, qdd) comes out of the same arithmetic (this includes the time
   variation of ``R I R^T``; no rigid-body identity is assumed).
5. Actuator forces by the principle of virtual power: the generalised force
   ``tau_j = sum_bodies m (a - g).dv/dqd_j + (I eps + w x I w).dw/dqd_j``,
   the partial velocities coming from first-order jets with qd = unit
   vector j (the three directions run as one batch); ``J = dL/dq`` from
   the same jets; ``f = solve(J^T, tau)``.
   Power ``P_i = f_i dL_i/dt``.  Static forces: the same with qd = qdd = 0.

Axes are the paper's: x0 forward, y0 up, z0 lateral right, gravity -y0.
Pose q = (surge, heave, roll) relative to the central configuration.

Public API
----------
``load_reference_params(path=None)``   -> parameter dict (reads the YAML with
                                          PyYAML; accepts the ROS file layout)
``params_from_dict(d)``                -> normalise a (possibly modified) dict
``reference_solve(params, q, qd, qdd)`` -> dict of numpy arrays (vectorised:
                                          q, qd, qdd of shape (3,) or (N, 3))
``reference_static_forces(params, q)`` -> forces at rest (qd = qdd = 0)
``reference_energy(params, q, qd)``    -> total mechanical energy
``reference_points(params, q)``        -> positions of the named points
``reference_kinematics(params, q, qd, qdd)`` -> positions, velocities,
                                          accelerations of points and bodies
``reachable(params, q)``               -> bool array: loops close, E2 between
                                          A3 and G, legs non-degenerate
``paper_trajectory(name, t)``          -> eq. 6 of the paper (q, qd, qdd)

Test helpers (not part of the model): ``sinusoid_trajectory``,
``sinusoid_terms_strategy`` (hypothesis), ``random_sinusoid_terms``,
``random_mass_properties``, ``random_geometry``, ``params_to_ros_dict``,
``copy_params`` and ``call_batch`` (loops any single-pose ``solve`` callable
over arrays; used to drive the production solver, never by the reference).

Note on legs B and C: their frame (x = leg axis d, z = e2 = unit(z0 x d)) is
body-fixed, so omega = vee(Rdot R^T) = rate1 z0 + rate2 e2 (the U-joint), which
is *not* perpendicular to d: omega.d = rate1 (z0.d).  An inertia about the
leg's own axis (zero in the default slender-rod data) therefore does enter.
"""

import copy
import math
from pathlib import Path

import numpy as np
import yaml

DEFAULT_PARAMS_PATH = Path(__file__).resolve().parents[2] / "config" / "flight_sim_dynamics.yaml"

BODY_NAMES = (
    "cylinder_a", "piston_a", "rod", "platform",
    "cylinder_b", "piston_b", "cylinder_c", "piston_c",
    "crank_d", "crank_e",
)
GEOMETRY_KEYS = (
    "d1", "d2", "d3", "d4", "d5", "l1", "l2", "l3", "l4", "l5", "l6",
    "b", "h", "h_G", "s_A", "s_B", "s_C",
)
LEGS = ("A", "B", "C")


# --------------------------------------------------------------------------
# Truncated Taylor jets
# --------------------------------------------------------------------------
class Jet:
    """Truncated Taylor series in time, with array-valued coefficients.

    ``c`` has shape ``(K + 1,) + shape``; ``c[k] = x^(k) / k!``.  Arithmetic
    broadcasts over ``shape`` like numpy.  Plain numbers / arrays act as
    constants.
    """

    __slots__ = ("c",)
    __array_priority__ = 1000  # make ndarray (op) Jet defer to Jet

    def __init__(self, c):
        self.c = np.asarray(c, dtype=float)

    # -- construction / access ---------------------------------------------
    @staticmethod
    def from_derivatives(derivs):
        """Build from [x, x', x'', ...] (arrays of a common shape)."""
        derivs = [np.asarray(d, dtype=float) for d in derivs]
        return Jet(np.stack([d / math.factorial(k) for k, d in enumerate(derivs)]))

    @staticmethod
    def constant(value, order):
        value = np.asarray(value, dtype=float)
        c = np.zeros((order + 1,) + value.shape)
        c[0] = value
        return Jet(c)

    @property
    def order(self):
        return self.c.shape[0] - 1

    @property
    def shape(self):
        return self.c.shape[1:]

    def d(self, n=0):
        """n-th time derivative (value for n = 0)."""
        return self.c[n] * math.factorial(n)

    @property
    def value(self):
        return self.c[0]

    def deriv(self):
        """Time derivative, as a jet of one order less."""
        k = np.arange(1, self.order + 1, dtype=float).reshape((-1,) + (1,) * len(self.shape))
        return Jet(self.c[1:] * k)

    def truncate(self, order):
        return Jet(self.c[: order + 1])

    def __getitem__(self, idx):
        if not isinstance(idx, tuple):
            idx = (idx,)
        return Jet(self.c[(slice(None),) + idx])

    def col(self):
        """Append a trailing axis of length 1 (scalar -> broadcast over a vector)."""
        return Jet(self.c[..., None])

    def sum(self, axis):
        if axis >= 0:
            axis += 1
        return Jet(self.c.sum(axis=axis))

    # -- helpers --------------------------------------------------------------
    @staticmethod
    def _pair(a, b):
        if not isinstance(a, Jet):
            a = Jet.constant(a, b.order)
        if not isinstance(b, Jet):
            b = Jet.constant(b, a.order)
        k = min(a.order, b.order)
        return a.truncate(k), b.truncate(k)

    @staticmethod
    def _bcast(c, shape):
        return np.broadcast_to(c, (c.shape[0],) + shape)

    # -- arithmetic -----------------------------------------------------------
    def __add__(self, other):
        if not isinstance(other, Jet):  # constant: shifts the value only
            shape = np.broadcast_shapes(self.shape, np.shape(other))
            c = np.array(np.broadcast_to(self.c, (self.c.shape[0],) + shape))
            c[0] += other
            return Jet(c)
        a, b = Jet._pair(self, other)
        return Jet(a.c + b.c)

    __radd__ = __add__

    def __neg__(self):
        return Jet(-self.c)

    def __sub__(self, other):
        return self + (-other)

    def __rsub__(self, other):
        return (-self) + other

    def __mul__(self, other):
        if not isinstance(other, Jet):
            return Jet(self.c * np.asarray(other, dtype=float))
        a, b = (self, other) if self.c.shape[0] == other.c.shape[0] else Jet._pair(self, other)
        K = a.order
        out = np.empty((K + 1,) + np.broadcast_shapes(a.shape, b.shape))
        for k in range(K + 1):
            acc = a.c[0] * b.c[k]
            for j in range(1, k + 1):
                acc = acc + a.c[j] * b.c[k - j]
            out[k] = acc
        return Jet(out)

    __rmul__ = __mul__

    def __truediv__(self, other):
        if not isinstance(other, Jet):
            return Jet(self.c / np.asarray(other, dtype=float))
        a, b = Jet._pair(self, other)
        K = a.order
        shape = np.broadcast_shapes(a.shape, b.shape)
        q = []
        for k in range(K + 1):
            acc = a.c[k] - sum(b.c[j] * q[k - j] for j in range(1, k + 1))
            q.append(np.broadcast_to(acc / b.c[0], shape))
        return Jet(np.stack(q))

    def __rtruediv__(self, other):
        return Jet.constant(np.asarray(other, dtype=float), self.order) / self

    def sqrt(self):
        s = [np.sqrt(self.c[0])]
        for k in range(1, self.order + 1):
            acc = self.c[k] - sum(s[j] * s[k - j] for j in range(1, k))
            s.append(acc / (2.0 * s[0]))
        return Jet(np.stack(s))

    def sincos(self):
        u = self.c
        s = [np.sin(u[0])]
        c = [np.cos(u[0])]
        for k in range(1, self.order + 1):
            s.append(sum(j * u[j] * c[k - j] for j in range(1, k + 1)) / k)
            c.append(-sum(j * u[j] * s[k - j] for j in range(1, k + 1)) / k)
        return Jet(np.stack(s)), Jet(np.stack(c))

    @staticmethod
    def einsum(spec, a, b):
        """Cauchy product with an einsum contraction of the coefficients.

        ``spec`` is an einsum spec over the *tail* shapes, e.g. '...ik,...jk->...ij'.
        """
        if not isinstance(b, Jet):  # constant right factor (body com / inertia)
            return Jet(np.stack([np.einsum(spec, ak, np.asarray(b, dtype=float)) for ak in a.c]))
        a, b = Jet._pair(a, b)
        K = a.order
        out = [sum(np.einsum(spec, a.c[j], b.c[k - j]) for j in range(k + 1)) for k in range(K + 1)]
        return Jet(np.stack(out))

    @staticmethod
    def stack(jets, axis=-1):
        order = min(j.order for j in jets)
        shape = np.broadcast_shapes(*[j.shape for j in jets])
        cs = [Jet._bcast(j.c[: order + 1], shape) for j in jets]
        if axis < 0:
            axis = len(shape) + 1 + axis
        return Jet(np.stack(cs, axis=axis + 1))


def dot(a, b):
    return (a * b).sum(-1)


def cross(a, b):
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    return Jet.stack([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0])


def norm(a):
    return dot(a, a).sqrt()


def unit(a):
    return a / norm(a).col()


def const_vec(v, like):
    """Constant 3-vector broadcast to the batch shape of the jet ``like``."""
    v = np.broadcast_to(np.asarray(v, dtype=float), like.shape[:-1] + (3,))
    return Jet.constant(v, like.order)


# --------------------------------------------------------------------------
# Parameters
# --------------------------------------------------------------------------
def params_from_dict(d):
    """Normalise a parameter dict.

    Accepts the full ROS layout ``{flight_sim_dynamics: {ros__parameters:
    {...}}}`` (or the packaged files' ``/**/flight_sim_dynamics``), the inner
    ``ros__parameters`` dict, or an already normalised dict.  Returns ``{'gravity': float, 'geometry': {key: float},
    'bodies': {name: {'mass': float, 'com': (3,), 'inertia': (3, 3)}}}``.
    """
    for section in ("flight_sim_dynamics", "/**/flight_sim_dynamics"):
        if section in d:
            d = d[section]
    if "ros__parameters" in d:
        d = d["ros__parameters"]
    geometry = {k: float(d["geometry"][k]) for k in GEOMETRY_KEYS}
    bodies = {}
    for name in BODY_NAMES:
        b = d["bodies"][name]
        inertia = np.asarray(b["inertia"], dtype=float).reshape(3, 3)
        bodies[name] = {
            "mass": float(b["mass"]),
            "com": np.asarray(b["com"], dtype=float).reshape(3),
            "inertia": inertia,
        }
    return {"gravity": float(d["gravity"]), "geometry": geometry, "bodies": bodies}


def load_reference_params(path=None):
    """Read the ROS 2 parameter YAML with PyYAML (default: the repo's config)."""
    path = DEFAULT_PARAMS_PATH if path is None else Path(path)
    with open(path, "r", encoding="utf-8") as fh:
        # (libyaml's safe loader where PyYAML has it: the same document, 20x faster)
        return params_from_dict(yaml.load(fh, Loader=getattr(yaml, "CSafeLoader", yaml.SafeLoader)))


def params_to_ros_dict(params):
    """Inverse of :func:`params_from_dict` (for writing modified YAML files)."""
    p = params_from_dict(params)
    return {
        "flight_sim_dynamics": {
            "ros__parameters": {
                "gravity": p["gravity"],
                "geometry": dict(p["geometry"]),
                "bodies": {
                    n: {
                        "mass": b["mass"],
                        "com": [float(x) for x in b["com"]],
                        "inertia": [float(x) for x in b["inertia"].reshape(9)],
                    }
                    for n, b in p["bodies"].items()
                },
            }
        }
    }


def copy_params(params):
    return copy.deepcopy(params_from_dict(params))


# --------------------------------------------------------------------------
# Geometry on jets
# --------------------------------------------------------------------------
def _pose_jet(q, qd=None, qdd=None, order=2):
    q = np.asarray(q, dtype=float)
    derivs = [q]
    if order >= 1:
        derivs.append(np.zeros_like(q) if qd is None else np.broadcast_to(np.asarray(qd, float), q.shape))
    if order >= 2:
        derivs.append(np.zeros_like(q) if qdd is None else np.broadcast_to(np.asarray(qdd, float), q.shape))
    return Jet.from_derivatives(derivs)


def _frame(x, z):
    """Rotation matrix with columns x, y = z cross x, z (jets of shape (..., 3))."""
    y = cross(z, x)
    return Jet.stack([x, y, z], axis=-1)  # R[..., i, j] = column j, component i


def _geometry(params, qj):
    """Positions (jets) of all points and frames of all bodies for a pose jet.

    ``qj`` is a Jet of shape (..., 3).  Returns a dict with point jets,
    'beta' (value array), loop-closure discriminants and the body list
    [(name, origin jet, R jet)].
    """
    g = params["geometry"]
    d1, d2, d3, d4, d5 = g["d1"], g["d2"], g["d3"], g["d4"], g["d5"]
    h, b, h_G, l5, l6 = g["h"], g["b"], g["h_G"], g["l5"], g["l6"]
    surge, heave, roll = qj[..., 0], qj[..., 1], qj[..., 2]
    zero = surge * 0.0
    xF = d2 + d3 + d4

    G = Jet.stack([surge + xF, heave + h_G, zero])
    A1 = const_vec([0.0, 0.0, 0.0], G)
    E1 = const_vec([d2, 0.0, 0.0], G)
    D1 = const_vec([d2 + d3, 0.0, 0.0], G)
    F = np.array([xF, 0.0, 0.0])
    B1 = const_vec(F + [0.0, 0.0, d5], G)
    C1 = const_vec(F - [0.0, 0.0, d5], G)
    z0 = const_vec([0.0, 0.0, 1.0], G)

    # Rod axis l from the crank-D loop: with P = G - D1, r = h - d1,
    # |P - r l| = l5  <=>  P.l = k = (|P|^2 + r^2 - l5^2) / (2 r).
    # In the plane: l = (k P - sqrt(|P|^2 - k^2) Pperp) / |P|^2, Pperp = P
    # turned +90 deg about z0; the minus sign is the root near beta = 0.
    r = h - d1
    Px, Py = G[..., 0] - (d2 + d3), G[..., 1]
    P2 = Px * Px + Py * Py
    k = (P2 + (r * r - l5 * l5)) / (2.0 * r)
    disc_d = P2 - k * k
    root = disc_d.sqrt()
    lx = (k * Px + root * Py) / P2
    ly = (k * Py - root * Px) / P2
    l = Jet.stack([lx, ly, zero])
    beta = np.arctan2(ly.value, lx.value)

    A3 = G - l * h
    D2 = G - l * r

    # Platform axes.
    sr, cr = roll.sincos()
    lxt0 = Jet.stack([ly, -lx, zero])  # l x (0, 0, 1)
    t = z0 * cr.col() + lxt0 * sr.col()
    n = cross(t, l)
    B4 = G + t * (0.5 * b)
    C4 = G - t * (0.5 * b)

    # E2 = G + s l on the circle |E2 - E1| = l6:
    # s^2 + 2 s (W.l) + |W|^2 - l6^2 = 0 with W = G - E1; the '+' root is the
    # one between A3 (s = -h) and G (s = 0).
    W = G - E1
    Wl = dot(W, l)
    disc_e = Wl * Wl - dot(W, W) + l6 * l6
    s = -Wl + disc_e.sqrt()
    E2 = G + l * s.col()

    # Legs.
    vA, vB, vC = A3 - A1, B4 - B1, C4 - C1
    LA, LB, LC = norm(vA), norm(vB), norm(vC)
    dA, dB, dC = vA / LA.col(), vB / LB.col(), vC / LC.col()
    e2B = unit(cross(z0, dB))
    e2C = unit(cross(z0, dC))
    uD = (D2 - D1) / l5
    uE = (E2 - E1) / l6

    bodies = [
        ("cylinder_a", A1, _frame(dA, z0)),
        ("piston_a", A3, _frame(dA, z0)),
        ("rod", A3, _frame(l, z0)),
        ("platform", A3, Jet.stack([l, n, t], axis=-1)),
        ("cylinder_b", B1, _frame(dB, e2B)),
        ("piston_b", B4, _frame(dB, e2B)),
        ("cylinder_c", C1, _frame(dC, e2C)),
        ("piston_c", C4, _frame(dC, e2C)),
        ("crank_d", D1, _frame(uD, z0)),
        ("crank_e", E1, _frame(uE, z0)),
    ]
    return {
        "points": {
            "A1": A1, "B1": B1, "C1": C1, "D1": D1, "E1": E1,
            "G": G, "A3": A3, "B4": B4, "C4": C4, "D2": D2, "E2": E2,
        },
        "axes": {"l": l, "t": t, "n": n, "dA": dA, "dB": dB, "dC": dC},
        "lengths": Jet.stack([LA, LB, LC]),
        "beta": beta,
        "s_E2": s.value,
        "disc_d": disc_d.value,
        "disc_e": disc_e.value,
        "bodies": bodies,
    }


def _vee(Wm):
    return Jet.stack([Wm[..., 2, 1], Wm[..., 0, 2], Wm[..., 1, 0]])


def _body_motion(params, geo):
    """CoM jets, angular-velocity jets and world inertia for every body.

    Returns a list of (name, mass, com jet (order K), omega jet (order K-1),
    world inertia jet (order K-1)).
    """
    out = []
    for name, origin, R in geo["bodies"]:
        bp = params["bodies"][name]
        com = origin + Jet.einsum("...ij,j->...i", R, bp["com"])
        Rd = R.deriv()
        R1 = R.truncate(Rd.order)
        omega = _vee(Jet.einsum("...ik,...jk->...ij", Rd, R1))
        Iw = Jet.einsum("...ik,...jk->...ij", Jet.einsum("...ij,jk->...ik", R1, bp["inertia"]), R1)
        out.append((name, bp["mass"], com, omega, Iw))
    return out


def _gvec(params):
    return np.array([0.0, -params["gravity"], 0.0])


def _energy_jet(params, motion):
    g = params["gravity"]
    E = None
    for _, m, com, omega, Iw in motion:
        v = com.deriv()
        T = 0.5 * m * dot(v, v) + 0.5 * dot(omega, Jet.einsum("...ij,...j->...i", Iw, omega))
        V = (m * g) * com.truncate(v.order)[..., 1]
        E = T + V if E is None else E + T + V
    return E


# --------------------------------------------------------------------------
# Public functions
# --------------------------------------------------------------------------
def _as_params(params):
    if params is None:
        return load_reference_params()
    if "bodies" in params and isinstance(params["bodies"].get("rod", {}).get("inertia"), np.ndarray):
        return params
    return params_from_dict(params)


def reference_points(params, q):
    """Positions of the named points (values, shape (..., 3)) plus beta."""
    params = _as_params(params)
    geo = _geometry(params, _pose_jet(q, order=0))
    out = {k: v.value for k, v in geo["points"].items()}
    out.update({k: v.value for k, v in geo["axes"].items()})
    out["beta"] = geo["beta"]
    out["length"] = geo["lengths"].value
    return out


def reachable(params, q, margin=1e-9):
    """True where the pose is assembled on the intended branch.

    Both crank loops close (positive discriminants), E2 lies strictly between
    A3 and G, and no leg has zero length.
    """
    params = _as_params(params)
    geo = _geometry(params, _pose_jet(q, order=0))
    h = params["geometry"]["h"]
    with np.errstate(invalid="ignore"):
        ok = (geo["disc_d"] > margin) & (geo["disc_e"] > margin)
        ok &= (geo["s_E2"] < 0.0) & (geo["s_E2"] > -h)
        ok &= np.all(geo["lengths"].value > margin, axis=-1)
        ok &= np.all(np.isfinite(geo["lengths"].value), axis=-1)
    return ok


def reference_kinematics(params, q, qd, qdd):
    """Positions, velocities, accelerations of points; CoM and angular motion of bodies."""
    params = _as_params(params)
    geo = _geometry(params, _pose_jet(q, qd, qdd, order=2))
    pts = {k: (v.d(0), v.d(1), v.d(2)) for k, v in geo["points"].items()}
    bodies = {}
    frames = {name: R for name, _, R in geo["bodies"]}
    for name, m, com, omega, Iw in _body_motion(params, geo):
        bodies[name] = {
            "R": frames[name].d(0), "com": com.d(0), "v": com.d(1), "a": com.d(2),
            "omega": omega.d(0), "eps": omega.d(1), "inertia_world": Iw.d(0),
        }
    L = geo["lengths"]
    return {"points": pts, "bodies": bodies, "length": L.d(0), "rate": L.d(1),
            "acceleration": L.d(2), "beta": geo["beta"]}


def reference_energy(params, q, qd):
    """Total mechanical energy (kinetic + gravitational, zero at y0 = 0), J."""
    params = _as_params(params)
    geo = _geometry(params, _pose_jet(q, qd, None, order=1))
    return _energy_jet(params, _body_motion(params, geo)).value


def reference_solve(params, q, qd, qdd):
    """Inverse dynamics of the mechanism at (q, qd, qdd).

    ``q, qd, qdd``: (surge m, heave m, roll rad) and derivatives, shape (3,)
    or (N, 3).  Returns a dict of numpy arrays (leading batch shape kept):

    length, stroke, rate, acceleration, force, power: (..., 3) for legs A, B, C
    (force > 0 pushes the leg ends apart; power = force * rate);
    jacobian: (..., 3, 3) dL/dq;  tau: (..., 3) generalised force;
    beta: parasitic pitch, rad;  energy, dE_dt: total mechanical energy and
    its exact time derivative;  kinetic, potential.
    """
    params = _as_params(params)
    q = np.asarray(q, dtype=float)
    qd = np.broadcast_to(np.asarray(qd, dtype=float), q.shape)
    qdd = np.broadcast_to(np.asarray(qdd, dtype=float), q.shape)
    gv = _gvec(params)

    # Full second-order pass along the actual motion.
    geo = _geometry(params, _pose_jet(q, qd, qdd, order=2))
    motion = _body_motion(params, geo)
    E = _energy_jet(params, motion)
    L = geo["lengths"]

    # Per-body "required" force and moment (inertial minus gravity), world frame.
    need = []
    for _, m, com, omega, Iw in motion:
        w, eps, I0 = omega.d(0), omega.d(1), Iw.d(0)
        Iw_w = np.einsum("...ij,...j->...i", I0, w)
        force = m * (com.d(2) - gv)
        moment = np.einsum("...ij,...j->...i", I0, eps) + np.cross(w, Iw_w)
        need.append((force, moment))

    # Partial velocities: first-order jets with qd = unit vectors, all three
    # directions at once along a new leading axis j (jet shape (3, ..., 3)).
    qj = np.broadcast_to(q, (3,) + q.shape)
    ej = np.broadcast_to(np.eye(3).reshape((3,) + (1,) * (q.ndim - 1) + (3,)), qj.shape)
    geo_j = _geometry(params, _pose_jet(qj, ej, None, order=1))
    Jac = np.moveaxis(geo_j["lengths"].d(1), 0, -1)  # [..., leg, j]
    tau_j = 0.0
    for (force, moment), (_, _, com, omega, _) in zip(need, _body_motion(params, geo_j)):
        tau_j = tau_j + np.sum(force * com.d(1), axis=-1) + np.sum(moment * omega.d(0), axis=-1)
    tau = np.moveaxis(np.asarray(tau_j), 0, -1)

    f = np.linalg.solve(np.swapaxes(Jac, -1, -2), tau[..., None])[..., 0]
    g = params["geometry"]
    L0 = np.array([g["s_A"] + g["l2"], g["s_B"] + g["l4"], g["s_C"] + g["l4"]])
    kin = sum(0.5 * m * np.sum(c.d(1) ** 2, axis=-1)
              + 0.5 * np.einsum("...i,...ij,...j->...", o.d(0), I.d(0), o.d(0))
              for _, m, c, o, I in motion)
    return {
        "length": L.d(0),
        "stroke": L.d(0) - L0,
        "rate": L.d(1),
        "acceleration": L.d(2),
        "force": f,
        "power": f * L.d(1),
        "jacobian": Jac,
        "tau": tau,
        "beta": geo["beta"],
        "energy": E.d(0),
        "dE_dt": E.d(1),
        "kinetic": kin,
        "potential": E.d(0) - kin,
    }


def reference_static_forces(params, q):
    """Actuator forces holding the mechanism at rest at pose q."""
    q = np.asarray(q, dtype=float)
    z = np.zeros_like(q)
    return reference_solve(params, q, z, z)["force"]


# --------------------------------------------------------------------------
# Trajectories
# --------------------------------------------------------------------------
PAPER_EXAMPLES = {
    "vertical": (0.0, 0.1, 0.0),
    "rectilinear": (0.05, 0.1, 0.0),
    "general": (0.05, 0.1, math.pi / 12.0),
}


def paper_trajectory(name, t):
    """Eq. 6 of the paper: q = q* (1 - cos(pi t / 3)); returns (q, qd, qdd), each (N, 3)."""
    amp = np.asarray(PAPER_EXAMPLES[name], dtype=float)
    t = np.asarray(t, dtype=float)[:, None]
    w = math.pi / 3.0
    return amp * (1.0 - np.cos(w * t)), amp * w * np.sin(w * t), amp * w * w * np.cos(w * t)


def sinusoid_trajectory(terms, t):
    """q_j(t) = sum over terms[j] of a sin(w t + p); terms[j] = [(a, w, p), ...]."""
    t = np.asarray(t, dtype=float)
    q = np.zeros((t.size, 3))
    qd = np.zeros_like(q)
    qdd = np.zeros_like(q)
    for j, tj in enumerate(terms):
        for a, w, p in tj:
            ph = w * t + p
            q[:, j] += a * np.sin(ph)
            qd[:, j] += a * w * np.cos(ph)
            qdd[:, j] -= a * w * w * np.sin(ph)
    return q, qd, qdd


def sinusoid_terms_strategy(bounds=(0.1, 0.1, 0.3), max_terms=3, w_range=(0.3, 4.0)):
    """Hypothesis strategy for :func:`sinusoid_trajectory` terms.

    Each coordinate j gets 1..max_terms sinusoids whose amplitudes sum to at
    most ``bounds[j]`` (so |q_j| <= bounds[j] for all t).
    """
    from hypothesis import strategies as st

    def coord(bound):
        term = st.tuples(
            st.floats(-1.0, 1.0),
            st.floats(*w_range),
            st.floats(0.0, 2.0 * math.pi),
        )
        return st.lists(term, min_size=1, max_size=max_terms).map(
            lambda ts: [(a * bound / len(ts), w, p) for a, w, p in ts])

    return st.tuples(*[coord(b) for b in bounds]).map(list)


def random_sinusoid_terms(rng, bounds=(0.1, 0.1, 0.3), max_terms=3, w_range=(0.3, 4.0)):
    """Same family as :func:`sinusoid_terms_strategy`, drawn from a numpy Generator."""
    terms = []
    for bound in bounds:
        n = int(rng.integers(1, max_terms + 1))
        terms.append([(float(rng.uniform(-1, 1)) * bound / n, float(rng.uniform(*w_range)),
                       float(rng.uniform(0, 2 * math.pi))) for _ in range(n)])
    return terms


def random_mass_properties(params, rng):
    """Copy of ``params`` with random masses, CoM offsets and full (physical) inertia tensors."""
    p = copy_params(params)
    for b in p["bodies"].values():
        b["mass"] = float(rng.uniform(0.3, 6.0))
        b["com"] = b["com"] + rng.uniform(-0.2, 0.2, 3)
        x = rng.uniform(0.0, 0.5, 3)  # second moments along the principal axes
        principal = np.array([x[1] + x[2], x[0] + x[2], x[0] + x[1]])
        Qm, _ = np.linalg.qr(rng.normal(size=(3, 3)))
        b["inertia"] = Qm @ np.diag(principal) @ Qm.T
        b["inertia"] = 0.5 * (b["inertia"] + b["inertia"].T)
    p["gravity"] = float(rng.uniform(5.0, 12.0))
    return p


def random_geometry(params, rng, rel=0.05):
    """Copy of ``params`` with every geometric length scaled by a random factor in [1-rel, 1+rel]."""
    p = copy_params(params)
    for k in p["geometry"]:
        p["geometry"][k] *= float(rng.uniform(1.0 - rel, 1.0 + rel))
    return p


def call_batch(solve, model, q, qd, qdd, fields=("length", "stroke", "rate", "acceleration",
                                                 "force", "power", "beta")):
    """Call a single-pose ``solve(model, q, qd, qdd)`` over (N, 3) arrays.

    Returns {field: np.ndarray of shape (N, ...)}.  Used to drive the
    production solver; nothing of it is used by the reference itself.
    """
    rows = [solve(model, list(map(float, a)), list(map(float, b)), list(map(float, c)))
            for a, b, c in zip(np.atleast_2d(q), np.atleast_2d(qd), np.atleast_2d(qdd))]
    return {f: np.array([np.asarray(getattr(r, f), dtype=float) for r in rows]) for f in fields}
