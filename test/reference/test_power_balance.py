"""Power balance of the production solver against the reference energy.

With friction neglected, the actuators' total power equals the rate of
change of the mechanism's mechanical energy at every instant:

    sol.power[A] + sol.power[B] + sol.power[C] = dE/dt

The left side comes from the production solver (``flight_sim_dynamics``);
dE/dt comes from the independent reference (test/reference/reference_model.py), which
differentiates E(q, qd) = sum 1/2 m v.v + 1/2 w.I w + m g y_com exactly with
Taylor jets.  Tolerance: 1e-9 relative, per sample, to the scale
max(|dE/dt|, |P_A| + |P_B| + |P_C|, 1 W) (the 1 W floor covers the instants
where the machine is at rest and both sides vanish).  Measured at the time
of writing: <= ~1e-15.
"""

import tempfile
from pathlib import Path

import numpy as np
import pytest
import yaml
from hypothesis import assume, given, settings
from hypothesis import strategies as st

import flight_sim_dynamics as fsd
import reference_model as rm

RTOL = 1e-9
PARAMS = rm.load_reference_params()
MODEL = fsd.load_model()
T = np.linspace(0.0, 3.0, 301)
T_RANDOM = np.linspace(0.0, 3.0, 31)


def balance_error(sol_power, ref):
    """Max over samples of |sum P - dE/dt| / max(|dE/dt|, sum |P|, 1 W)."""
    sol_power = np.atleast_2d(sol_power)
    P = sol_power.sum(axis=-1)
    scale = np.maximum(np.maximum(np.abs(ref["dE_dt"]), np.abs(sol_power).sum(axis=-1)), 1.0)
    return float(np.max(np.abs(P - ref["dE_dt"]) / scale))


def model_for(params):
    """Production model loaded from a YAML file holding ``params``."""
    with tempfile.TemporaryDirectory() as d:
        path = Path(d) / "params.yaml"
        path.write_text(yaml.safe_dump(rm.params_to_ros_dict(params)))
        return fsd.load_model(path)


@pytest.mark.parametrize("name", sorted(rm.PAPER_EXAMPLES))
def test_power_balance_paper_examples(name):
    q, qd, qdd = rm.paper_trajectory(name, T)
    ref = rm.reference_solve(PARAMS, q, qd, qdd)
    sol = fsd.solve_batch(MODEL, q, qd, qdd)
    assert balance_error(sol.power, ref) < RTOL
    # the per-cycle entry point too (every 10th sample)
    single = rm.call_batch(fsd.solve, MODEL, q[::10], qd[::10], qdd[::10], fields=("power",))
    sub = {"dE_dt": ref["dE_dt"][::10]}
    assert balance_error(single["power"], sub) < RTOL
    # not vacuous: the machine does work
    assert np.max(np.abs(ref["dE_dt"])) > 1.0


@settings(max_examples=25, deadline=None)
@given(terms=rm.sinusoid_terms_strategy())
def test_power_balance_random_smooth_trajectories(terms):
    q, qd, qdd = rm.sinusoid_trajectory(terms, T_RANDOM)
    assume(np.all(rm.reachable(PARAMS, q)))
    ref = rm.reference_solve(PARAMS, q, qd, qdd)
    sol = fsd.solve_batch(MODEL, q, qd, qdd)
    assert balance_error(sol.power, ref) < RTOL
    single = rm.call_batch(fsd.solve, MODEL, q[::15], qd[::15], qdd[::15], fields=("power",))
    assert balance_error(single["power"], {"dE_dt": ref["dE_dt"][::15]}) < RTOL


@pytest.mark.parametrize("seed", range(4))
def test_power_balance_modified_mass_properties(seed):
    """Random masses, CoM offsets, full inertia tensors and gravity, via a YAML file."""
    rng = np.random.default_rng(1000 + seed)
    params = rm.random_mass_properties(PARAMS, rng)
    model = model_for(params)
    q, qd, qdd = rm.sinusoid_trajectory(rm.random_sinusoid_terms(rng), T_RANDOM)
    ref = rm.reference_solve(params, q, qd, qdd)
    assert balance_error(fsd.solve_batch(model, q, qd, qdd).power, ref) < RTOL


@settings(max_examples=8, deadline=None)
@given(terms=rm.sinusoid_terms_strategy(), seed=st.integers(0, 2**32 - 1))
def test_power_balance_random_mass_properties_hypothesis(terms, seed):
    params = rm.random_mass_properties(PARAMS, np.random.default_rng(seed))
    model = model_for(params)
    q, qd, qdd = rm.sinusoid_trajectory(terms, T_RANDOM)
    ref = rm.reference_solve(params, q, qd, qdd)
    assert balance_error(fsd.solve_batch(model, q, qd, qdd).power, ref) < RTOL


def test_power_balance_detects_a_wrong_energy():
    """The check has teeth: a 1 % error in one body's mass breaks the balance."""
    q, qd, qdd = rm.paper_trajectory("general", T)
    wrong = rm.copy_params(PARAMS)
    wrong["bodies"]["piston_b"]["mass"] *= 1.01
    ref = rm.reference_solve(wrong, q, qd, qdd)
    assert balance_error(fsd.solve_batch(MODEL, q, qd, qdd).power, ref) > 1e3 * RTOL
