"""Production solver against the independent reference model.

The production solver (``flight_sim_dynamics``, the paper's recursive matrix
method) and the reference (test/reference/reference_model.py, Taylor jets through the
plain position geometry + virtual power) share no code.  They must agree on
trajectories the production code has never seen.

Tolerance: RTOL = 1e-9 relative.  For every quantity the error, maximised over
the samples of a trajectory and over the three legs, is compared with
RTOL * scale, where scale is the largest |reference value| of that quantity
over the trajectory, floored at: length and stroke 1 m, rate 1e-3 m/s,
acceleration 1e-3 m/s^2, force 1 N, power 1e-3 W.  The parasitic angle beta
is compared absolutely (scale 1 rad).  Measured at the time of writing:
<= ~1e-14 on all of them.
"""

import numpy as np
import pytest
import yaml
from hypothesis import assume, given, settings
from hypothesis import strategies as st

import flight_sim_dynamics as fsd
import reference_model as rm

RTOL = 1e-9
FLOORS = {"length": 1.0, "stroke": 1.0, "rate": 1e-3, "acceleration": 1e-3,
          "force": 1.0, "power": 1e-3, "beta": 1.0}
PARAMS = rm.load_reference_params()
MODEL = fsd.load_model()
T = np.linspace(0.0, 3.0, 301)
T_RANDOM = np.linspace(0.0, 3.0, 31)
BOX = np.array([0.1, 0.1, 0.3])  # |surge|, |heave| m, |roll| rad


def disagreement(ref, sol):
    """{quantity: max error / scale} (see module docstring)."""
    out = {}
    for key, floor in FLOORS.items():
        r = np.asarray(ref[key], dtype=float)
        s = np.asarray(sol[key], dtype=float)
        assert s.shape == r.shape, key
        scale = max(float(np.max(np.abs(r))), floor) if key != "beta" else 1.0
        out[key] = float(np.max(np.abs(s - r))) / scale
    return out


def production(model, q, qd, qdd):
    sol = fsd.solve_batch(model, q, qd, qdd)
    return {key: getattr(sol, key) for key in FLOORS}


def assert_agree(params, model, q, qd, qdd, single_every=None):
    ref = rm.reference_solve(params, q, qd, qdd)
    bad = {k: v for k, v in disagreement(ref, production(model, q, qd, qdd)).items() if not v < RTOL}
    assert not bad, f"solve_batch disagrees with the reference (error/scale): {bad}"
    if single_every:
        sl = slice(None, None, single_every)
        single = rm.call_batch(fsd.solve, model, q[sl], qd[sl], qdd[sl], fields=tuple(FLOORS))
        sub = {k: np.asarray(v)[sl] for k, v in ref.items() if k in FLOORS}
        bad = {k: v for k, v in disagreement(sub, single).items() if not v < RTOL}
        assert not bad, f"solve disagrees with the reference (error/scale): {bad}"


# ---------------------------------------------------------------------------
# Dynamics along unseen trajectories
# ---------------------------------------------------------------------------
@pytest.mark.parametrize("seed", [11, 23, 37, 41, 59])
def test_agreement_fixed_seed_trajectories(seed):
    q, qd, qdd = rm.sinusoid_trajectory(rm.random_sinusoid_terms(np.random.default_rng(seed)), T)
    assert np.all(rm.reachable(PARAMS, q))
    assert_agree(PARAMS, MODEL, q, qd, qdd, single_every=25)


@settings(max_examples=25, deadline=None)
@given(terms=rm.sinusoid_terms_strategy())
def test_agreement_random_smooth_trajectories(terms):
    q, qd, qdd = rm.sinusoid_trajectory(terms, T_RANDOM)
    assume(np.all(rm.reachable(PARAMS, q)))
    assert_agree(PARAMS, MODEL, q, qd, qdd, single_every=15)


@settings(max_examples=25, deadline=None)
@given(
    q=st.tuples(*[st.floats(-b, b) for b in BOX]),
    qd=st.tuples(*[st.floats(-1.0, 1.0)] * 3),
    qdd=st.tuples(*[st.floats(-3.0, 3.0)] * 3),
)
def test_agreement_random_states(q, qd, qdd):
    """Independent pose, rate and acceleration (not tied to one trajectory)."""
    q, qd, qdd = (np.array([x], dtype=float) for x in (q, qd, qdd))
    assume(np.all(rm.reachable(PARAMS, q)))
    assert_agree(PARAMS, MODEL, q, qd, qdd, single_every=1)


@pytest.mark.parametrize("name", sorted(rm.PAPER_EXAMPLES))
def test_agreement_paper_examples(name):
    assert_agree(PARAMS, MODEL, *rm.paper_trajectory(name, T), single_every=30)


def _write(params, path):
    path.write_text(yaml.safe_dump(rm.params_to_ros_dict(params)))
    return path


@pytest.mark.parametrize("seed,geometry", [(3, False), (4, False), (5, True), (6, True)])
def test_agreement_modified_parameters(seed, geometry, tmp_path):
    """Random masses, CoM offsets, full inertia tensors, gravity (and geometry +-5 %), via YAML."""
    rng = np.random.default_rng(seed)
    params = rm.random_mass_properties(PARAMS, rng)
    if geometry:
        params = rm.random_geometry(params, rng)
    path = _write(params, tmp_path / "params.yaml")
    model = fsd.load_model(path)
    q, qd, qdd = rm.sinusoid_trajectory(rm.random_sinusoid_terms(rng), T_RANDOM)
    assert np.all(rm.reachable(params, q))
    assert_agree(rm.load_reference_params(path), model, q, qd, qdd)
    # and the default-parameter answer is really different (the file was used)
    assert np.max(np.abs(fsd.solve_batch(MODEL, q, qd, qdd).force
                         - fsd.solve_batch(model, q, qd, qdd).force)) > 1e-2


def test_agreement_axial_inertia_of_u_joint_legs(tmp_path):
    """Legs B, C hang from U-joints: omega = rate1 z0 + rate2 e2 has a component along
    the leg (rate1 z0.d), so an inertia about the leg's own axis (zero in the default
    slender-rod data, but allowed by the YAML) must enter the dynamics."""
    params = rm.copy_params(PARAMS)
    for name in ("cylinder_b", "piston_b", "cylinder_c", "piston_c"):
        params["bodies"][name]["inertia"] = params["bodies"][name]["inertia"] + np.diag([0.08, 0.0, 0.0])
    model = fsd.load_model(_write(params, tmp_path / "axial.yaml"))
    q, qd, qdd = rm.sinusoid_trajectory(rm.random_sinusoid_terms(np.random.default_rng(8)), T_RANDOM)
    assert_agree(params, model, q, qd, qdd)
    f_default = rm.reference_solve(PARAMS, q, qd, qdd)["force"]
    assert np.max(np.abs(fsd.solve_batch(model, q, qd, qdd).force - f_default)) > 1e-3


# ---------------------------------------------------------------------------
# Statics
# ---------------------------------------------------------------------------
def test_statics_central_configuration_check_values():
    sol = fsd.solve(MODEL, [0.0, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0])
    assert sol.force == pytest.approx([38.6066, 33.2041, 33.2041], abs=1e-4)
    assert sol.length == pytest.approx([1.140254, 1.331353, 1.331353], abs=1e-6)
    assert sol.beta == pytest.approx(0.037670, abs=1e-6)
    ref = rm.reference_static_forces(PARAMS, np.zeros(3))
    assert np.max(np.abs(sol.force - ref)) < RTOL * np.max(np.abs(ref))
    assert np.all(sol.power == 0.0) and np.all(sol.rate == 0.0)


@settings(max_examples=25, deadline=None)
@given(q=st.tuples(*[st.floats(-b, b) for b in BOX]))
def test_statics_random_rest_poses(q):
    q = np.array(q)
    assume(rm.reachable(PARAMS, q))
    ref = rm.reference_static_forces(PARAMS, q)
    sol = fsd.solve(MODEL, list(q), [0.0, 0.0, 0.0], [0.0, 0.0, 0.0])
    assert np.max(np.abs(sol.force - ref)) < RTOL * max(np.max(np.abs(ref)), 1.0)


# ---------------------------------------------------------------------------
# Symmetry, trajectories, reachability
# ---------------------------------------------------------------------------
def test_vertical_example_forces_and_powers_of_b_and_c_equal():
    q, qd, qdd = rm.paper_trajectory("vertical", T)
    sol = fsd.solve_batch(MODEL, q, qd, qdd)
    f, p = sol.force, sol.power
    assert np.max(np.abs(f[:, 1] - f[:, 2])) < RTOL * max(np.max(np.abs(f[:, 1])), 1.0)
    assert np.max(np.abs(p[:, 1] - p[:, 2])) < RTOL * max(np.max(np.abs(p[:, 1])), 1e-3)
    assert np.max(np.abs(p[:, 1])) > 0.1  # B and C do work (not vacuous)


def test_paper_example_trajectories_are_eq6():
    for name in rm.PAPER_EXAMPLES:
        for got, want in zip(fsd.trajectories.paper_example(name, T), rm.paper_trajectory(name, T)):
            assert np.asarray(got).shape == want.shape
            assert np.allclose(got, want, rtol=1e-13, atol=1e-15)


def test_unreachable_poses_are_refused_exactly_where_the_reference_cannot_assemble():
    rng = np.random.default_rng(2024)
    q = rng.uniform([-0.6, -0.6, -1.5], [0.6, 0.6, 1.5], size=(300, 3))
    with np.errstate(invalid="ignore"):
        ok = rm.reachable(PARAMS, q)
    assert 30 < ok.sum() < 270  # both kinds present
    for qi, oki in zip(q, ok):
        sol = fsd.solve(MODEL, list(qi), [0.0] * 3, [0.0] * 3)
        assert np.all(np.isfinite(sol.force))
        if oki:
            assert sol.status != fsd.Status.UNREACHABLE, sol.detail
        else:
            assert sol.status == fsd.Status.UNREACHABLE and sol.detail.startswith('loop ')
            assert np.all(sol.force == 0.0)
