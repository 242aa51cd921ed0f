"""Self-tests of the independent reference model (test/reference/reference_model.py).

They validate the reference on its own, without the production solver:
check values of mechanism.md, loop closures, jets against central finite
differences of the reference's own positions, the energy balance
sum(P_i) = dE/dt, the virtual-power forces against Lagrange's equations
(finite differences of the reference's own energy), statics against the
gradient of the potential, symmetries, and the handling of parameter dicts.
"""

import math

import numpy as np
import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st

import reference_model as rm

PARAMS = rm.load_reference_params()
ZERO = np.zeros(3)
T = np.linspace(0.0, 3.0, 301)


def _fixed_terms(seed):
    return rm.random_sinusoid_terms(np.random.default_rng(seed))


# ---------------------------------------------------------------------------
# Check values and geometry
# ---------------------------------------------------------------------------
def test_central_configuration_check_values():
    r = rm.reference_solve(PARAMS, ZERO, ZERO, ZERO)
    assert r["length"] == pytest.approx([1.140254, 1.331353, 1.331353], abs=1e-6)
    assert r["stroke"] == pytest.approx([0.000254, 0.001353, 0.001353], abs=1e-6)
    assert r["beta"] == pytest.approx(0.037670, abs=1e-6)
    assert r["force"] == pytest.approx([38.6066, 33.2041, 33.2041], abs=1e-4)
    assert np.all(r["rate"] == 0.0) and np.all(r["power"] == 0.0)
    assert r["dE_dt"] == 0.0 and r["kinetic"] == 0.0
    pts = rm.reference_points(PARAMS, ZERO)
    assert np.linalg.norm(pts["D2"] - pts["E2"]) == pytest.approx(0.611555, abs=1e-6)


@pytest.mark.parametrize("seed", range(5))
def test_loop_closures_and_axes(seed):
    rng = np.random.default_rng(seed)
    q = rng.uniform([-0.1, -0.1, -0.3], [0.1, 0.1, 0.3], size=(50, 3))
    assert np.all(rm.reachable(PARAMS, q))
    g = PARAMS["geometry"]
    p = rm.reference_points(PARAMS, q)
    n = lambda v: np.linalg.norm(v, axis=-1)  # noqa: E731
    assert np.allclose(n(p["D2"] - p["D1"]), g["l5"], atol=1e-12)
    assert np.allclose(n(p["E2"] - p["E1"]), g["l6"], atol=1e-12)
    assert np.allclose(n(p["G"] - p["A3"]), g["h"], atol=1e-12)
    assert np.allclose(n(p["G"] - p["D2"]), g["h"] - g["d1"], atol=1e-12)
    assert np.allclose(n(p["B4"] - p["C4"]), g["b"], atol=1e-12)
    # E2 on the rod line, between A3 and G
    s = np.sum((p["E2"] - p["G"]) * p["l"], axis=-1)
    assert np.allclose(p["G"] + s[:, None] * p["l"], p["E2"], atol=1e-12)
    assert np.all((s < 0) & (s > -g["h"]))
    # G is commanded, the platform axes orthonormal and right-handed
    assert np.allclose(p["G"], [g["d2"] + g["d3"] + g["d4"], g["h_G"], 0.0] + q * [1, 1, 0])
    R = np.stack([p["l"], p["n"], p["t"]], axis=-1)
    assert np.allclose(np.einsum("nki,nkj->nij", R, R), np.eye(3), atol=1e-12)
    assert np.allclose(np.linalg.det(R), 1.0)
    # roll is the angle from t0 = z0 to t about l; positive roll lowers B
    roll = np.arctan2(np.sum(np.cross([0.0, 0.0, 1.0], p["t"]) * p["l"], axis=-1), p["t"][:, 2])
    assert np.allclose(roll, q[:, 2], atol=1e-12)
    assert np.all((p["B4"][:, 1] < p["G"][:, 1]) == (q[:, 2] > 0))
    assert np.allclose(np.arctan2(p["l"][:, 1], p["l"][:, 0]), p["beta"])


# ---------------------------------------------------------------------------
# Jets against finite differences of the reference's own positions
# ---------------------------------------------------------------------------
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_jets_match_central_finite_differences(seed):
    terms = _fixed_terms(seed)
    t = np.linspace(0.0, 3.0, 13)
    hstep = 1e-4
    kin = rm.reference_kinematics(PARAMS, *rm.sinusoid_trajectory(terms, t))
    at = lambda tt: rm.reference_kinematics(PARAMS, *rm.sinusoid_trajectory(terms, tt))  # noqa: E731
    kp, km = at(t + hstep), at(t - hstep)

    def check(x0, xp, xm, v, a, scale):
        fd_v = (xp - xm) / (2 * hstep)
        fd_a = (xp - 2 * x0 + xm) / hstep**2
        assert np.max(np.abs(fd_v - v)) < 1e-6 * scale
        assert np.max(np.abs(fd_a - a)) < 1e-4 * scale  # 2nd difference: round-off ~1e-16/h^2

    for name, (x, v, a) in kin["points"].items():
        check(x, kp["points"][name][0], km["points"][name][0], v, a, 1.0)
    check(kin["length"], kp["length"], km["length"], kin["rate"], kin["acceleration"], 1.0)
    for name, b in kin["bodies"].items():
        check(b["com"], kp["bodies"][name]["com"], km["bodies"][name]["com"], b["v"], b["a"], 1.0)
        # angular velocity from finite differences of the rotation matrix
        Rd = (kp["bodies"][name]["R"] - km["bodies"][name]["R"]) / (2 * hstep)
        W = np.einsum("nik,njk->nij", Rd, b["R"])
        assert np.max(np.abs(W + np.swapaxes(W, 1, 2))) < 1e-6
        w_fd = np.stack([W[:, 2, 1], W[:, 0, 2], W[:, 1, 0]], axis=-1)
        assert np.max(np.abs(w_fd - b["omega"])) < 1e-6
        eps_fd = (kp["bodies"][name]["omega"] - km["bodies"][name]["omega"]) / (2 * hstep)
        assert np.max(np.abs(eps_fd - b["eps"])) < 1e-6


def test_angular_velocities_respect_the_joints():
    q, qd, qdd = rm.sinusoid_trajectory(_fixed_terms(7), np.linspace(0, 3, 31))
    kin = rm.reference_kinematics(PARAMS, q, qd, qdd)
    B = kin["bodies"]
    for name in ("cylinder_a", "piston_a", "rod", "crank_d", "crank_e"):
        assert np.allclose(B[name]["omega"][:, :2], 0.0, atol=1e-14)
    assert np.allclose(B["cylinder_a"]["omega"], B["piston_a"]["omega"], atol=1e-14)
    # platform = rod + roll rate about l
    lax = rm.reference_points(PARAMS, q)["l"]
    assert np.allclose(B["platform"]["omega"] - B["rod"]["omega"], qd[:, 2:3] * lax, atol=1e-13)
    # legs B, C: cylinder and piston turn together; the U-joint (axes z0, then
    # e2 = unit(z0 x d)) only allows omega in span(z0, e2).  Note that this
    # omega is NOT perpendicular to the leg: omega.d = (rate about z0) * (z0.d).
    z0 = np.array([0.0, 0.0, 1.0])
    for leg in ("b", "c"):
        cyl, pis = B["cylinder_" + leg], B["piston_" + leg]
        assert np.allclose(cyl["omega"], pis["omega"], atol=1e-14)
        d, e2 = cyl["R"][:, :, 0], cyl["R"][:, :, 2]
        assert np.allclose(e2, np.cross(z0, d) / np.linalg.norm(np.cross(z0, d), axis=-1)[:, None])
        assert np.allclose(np.sum(cyl["omega"] * np.cross(z0, e2), axis=-1), 0.0, atol=1e-13)
        rate_z0 = cyl["omega"][:, 2] - np.sum(cyl["omega"] * e2, axis=-1) * e2[:, 2]  # e2 is horizontal
        assert np.allclose(e2[:, 2], 0.0, atol=1e-15)
        assert np.allclose(np.sum(cyl["omega"] * d, axis=-1), rate_z0 * d[:, 2], atol=1e-13)


def test_energy_derivative_matches_finite_difference():
    for terms in (_fixed_terms(3), _fixed_terms(4)):
        t = np.linspace(0.0, 3.0, 31)
        hstep = 1e-5
        r = rm.reference_solve(PARAMS, *rm.sinusoid_trajectory(terms, t))
        E = lambda tt: rm.reference_energy(PARAMS, *rm.sinusoid_trajectory(terms, tt)[:2])  # noqa: E731
        fd = (E(t + hstep) - E(t - hstep)) / (2 * hstep)
        assert np.allclose(E(t), r["energy"], rtol=1e-14, atol=1e-12)
        assert np.max(np.abs(fd - r["dE_dt"])) < 1e-7 * max(1.0, np.max(np.abs(r["dE_dt"])))


# ---------------------------------------------------------------------------
# Energy balance of the reference itself
# ---------------------------------------------------------------------------
def _balance_error(params, q, qd, qdd):
    r = rm.reference_solve(params, q, qd, qdd)
    P = r["power"].sum(axis=-1)
    scale = np.maximum(np.maximum(np.abs(r["dE_dt"]), np.abs(r["power"]).sum(axis=-1)), 1.0)
    return np.max(np.abs(P - r["dE_dt"]) / scale)


@pytest.mark.parametrize("name", sorted(rm.PAPER_EXAMPLES))
def test_own_power_balance_paper_examples(name):
    assert _balance_error(PARAMS, *rm.paper_trajectory(name, T)) < 1e-12


@settings(max_examples=20, deadline=None)
@given(terms=rm.sinusoid_terms_strategy())
def test_own_power_balance_random_trajectories(terms):
    q, qd, qdd = rm.sinusoid_trajectory(terms, np.linspace(0.0, 3.0, 31))
    assert np.all(rm.reachable(PARAMS, q))
    assert _balance_error(PARAMS, q, qd, qdd) < 1e-12


@settings(max_examples=10, deadline=None)
@given(terms=rm.sinusoid_terms_strategy(), seed=st.integers(0, 2**32 - 1))
def test_own_power_balance_random_mass_properties(terms, seed):
    params = rm.random_mass_properties(PARAMS, np.random.default_rng(seed))
    q, qd, qdd = rm.sinusoid_trajectory(terms, np.linspace(0.0, 3.0, 21))
    assert _balance_error(params, q, qd, qdd) < 1e-12


# ---------------------------------------------------------------------------
# Forces against Lagrange's equations and the potential (finite differences)
# ---------------------------------------------------------------------------
def _lagrange_tau(params, terms, t, hq=1e-5, ht=1e-4):
    """tau = d/dt dT/dqd - dT/dq + dV/dq, all by finite differences of the energy."""
    def kinetic(q, qd):
        return rm.reference_energy(params, q, qd) - rm.reference_energy(params, q, 0.0 * qd)

    def potential(q):
        return rm.reference_energy(params, q, 0.0 * q)

    def momentum(tt):
        q, qd, _ = rm.sinusoid_trajectory(terms, tt)
        # T is quadratic in qd: the central difference with unit step is exact
        return np.stack([(kinetic(q, qd + e) - kinetic(q, qd - e)) / 2.0 for e in np.eye(3)], axis=-1)

    q, qd, _ = rm.sinusoid_trajectory(terms, t)
    dpdt = (momentum(t + ht) - momentum(t - ht)) / (2 * ht)
    dTdq = np.stack([(kinetic(q + hq * e, qd) - kinetic(q - hq * e, qd)) / (2 * hq) for e in np.eye(3)], -1)
    dVdq = np.stack([(potential(q + hq * e) - potential(q - hq * e)) / (2 * hq) for e in np.eye(3)], -1)
    return dpdt - dTdq + dVdq


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_virtual_power_forces_satisfy_lagrange_equations(seed):
    params = PARAMS if seed < 2 else rm.random_mass_properties(PARAMS, np.random.default_rng(seed))
    terms = _fixed_terms(10 + seed)
    t = np.linspace(0.0, 3.0, 16)
    r = rm.reference_solve(params, *rm.sinusoid_trajectory(terms, t))
    tau_l = _lagrange_tau(params, terms, t)
    assert np.max(np.abs(tau_l - r["tau"])) < 1e-6 * np.max(np.abs(r["tau"]))
    # and the forces map onto tau through the leg Jacobian
    assert np.allclose(np.einsum("nij,ni->nj", r["jacobian"], r["force"]), r["tau"], rtol=1e-12, atol=1e-10)


def test_static_forces_balance_the_potential_gradient():
    rng = np.random.default_rng(42)
    q = rng.uniform([-0.1, -0.1, -0.3], [0.1, 0.1, 0.3], size=(20, 3))
    f = rm.reference_static_forces(PARAMS, q)
    h = 1e-6
    V = lambda qq: rm.reference_energy(PARAMS, qq, 0.0 * qq)  # noqa: E731
    L = lambda qq: rm.reference_points(PARAMS, qq)["length"]  # noqa: E731
    dV = np.stack([(V(q + h * e) - V(q - h * e)) / (2 * h) for e in np.eye(3)], axis=-1)
    J = np.stack([(L(q + h * e) - L(q - h * e)) / (2 * h) for e in np.eye(3)], axis=-1)
    assert np.max(np.abs(np.einsum("nij,ni->nj", J, f) - dV)) < 1e-6 * np.max(np.abs(dV))


# ---------------------------------------------------------------------------
# Symmetry and parameters
# ---------------------------------------------------------------------------
def test_vertical_example_b_equals_c():
    r = rm.reference_solve(PARAMS, *rm.paper_trajectory("vertical", T))
    assert np.max(np.abs(r["force"][:, 1] - r["force"][:, 2])) < 1e-12 * np.max(np.abs(r["force"]))
    assert np.max(np.abs(r["power"][:, 1] - r["power"][:, 2])) < 1e-12 * np.max(np.abs(r["power"]))


def test_mirror_symmetry_swaps_b_and_c():
    q, qd, qdd = rm.sinusoid_trajectory(_fixed_terms(5), np.linspace(0, 3, 31))
    m = np.array([1.0, 1.0, -1.0])
    r1 = rm.reference_solve(PARAMS, q, qd, qdd)
    r2 = rm.reference_solve(PARAMS, q * m, qd * m, qdd * m)
    for key in ("length", "rate", "acceleration", "force", "power"):
        assert np.allclose(r1[key], r2[key][:, [0, 2, 1]], rtol=1e-12, atol=1e-12)
    assert np.allclose(r1["beta"], r2["beta"])


def test_parameter_dicts_are_used_generally(tmp_path):
    # the ROS layout round-trips through YAML
    path = tmp_path / "p.yaml"
    path.write_text(yaml.safe_dump(rm.params_to_ros_dict(PARAMS)))
    again = rm.load_reference_params(path)
    assert again["geometry"] == PARAMS["geometry"]
    for name in rm.BODY_NAMES:
        assert np.array_equal(again["bodies"][name]["inertia"], PARAMS["bodies"][name]["inertia"])
    q = np.array([0.03, -0.02, 0.1])
    f0 = rm.reference_static_forces(PARAMS, q)
    # doubling every mass (and inertia, which does not act at rest) doubles the static forces
    p2 = rm.copy_params(PARAMS)
    for b in p2["bodies"].values():
        b["mass"] *= 2.0
        b["inertia"] = 2.0 * b["inertia"]
    assert np.allclose(rm.reference_static_forces(p2, q), 2.0 * f0, rtol=1e-13)
    # a massless platform changes the forces; moving a CoM changes them too
    p3 = rm.copy_params(PARAMS)
    p3["bodies"]["platform"]["com"] = p3["bodies"]["platform"]["com"] + [0.0, 0.0, 0.1]
    f3 = rm.reference_static_forces(p3, q)
    assert f3[1] - f0[1] > 1e-3 and f0[2] - f3[2] > 1e-3  # load shifted to the B side
    # nested ROS dict accepted as well
    assert np.array_equal(rm.reference_static_forces(rm.params_to_ros_dict(PARAMS), q), f0)


def test_inertia_about_leg_axis():
    """Inertia about a leg's own axis: no effect for leg A (planar), an effect for B/C.

    Leg A turns about z0, perpendicular to its axis.  Legs B and C hang from
    U-joints: omega = rate1 z0 + rate2 e2 has the component rate1 (z0.d) along
    the leg, so an axial moment of inertia (zero in the default slender-rod
    data) does enter the dynamics.
    """
    q, qd, qdd = rm.sinusoid_trajectory(_fixed_terms(6), np.linspace(0, 3, 21))
    f0 = rm.reference_solve(PARAMS, q, qd, qdd)["force"]
    pa = rm.copy_params(PARAMS)
    for name in ("cylinder_a", "piston_a"):
        pa["bodies"][name]["inertia"] = pa["bodies"][name]["inertia"] + np.diag([0.3, 0.0, 0.0])
    assert np.allclose(rm.reference_solve(pa, q, qd, qdd)["force"], f0, rtol=1e-12, atol=1e-12)
    pb = rm.copy_params(PARAMS)
    pb["bodies"]["cylinder_b"]["inertia"] = pb["bodies"]["cylinder_b"]["inertia"] + np.diag([0.3, 0.0, 0.0])
    assert np.max(np.abs(rm.reference_solve(pb, q, qd, qdd)["force"] - f0)) > 1e-3


def test_paper_trajectory_is_eq6():
    q, qd, qdd = rm.paper_trajectory("general", np.array([0.0, 1.5, 3.0]))
    assert np.allclose(q[0], 0.0) and np.allclose(qd[0], 0.0)
    assert np.allclose(q[2], [0.1, 0.2, math.pi / 6])
    assert np.allclose(q[1], [0.05, 0.1, math.pi / 12])
    assert np.allclose(qd[1], np.array([0.05, 0.1, math.pi / 12]) * math.pi / 3)
