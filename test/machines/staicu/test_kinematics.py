"""Kinematics against geometry and finite differences (eq. 5-17)."""
import math

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

import flight_sim_dynamics as fsd
from flight_sim_dynamics.core.vectors import backend
from flight_sim_dynamics.machines.staicu import kinematics
from flight_sim_dynamics.machines.staicu.trajectories import paper_example

MODEL = fsd.load_model()


def _geometric(q):
    """Inverse geometry of a batch with every vector as an (N, 3) array."""
    g = kinematics.inverse_geometry(MODEL, tuple(np.asarray(q, float).T), backend(True))
    return g, lambda v: np.stack(np.broadcast_arrays(*v), axis=-1)


def test_central_configuration_matches_mechanism_md():
    c = MODEL.central
    assert c.beta0 == pytest.approx(0.037670, abs=5e-7)
    assert c.s == pytest.approx(0.611555, abs=5e-7)
    np.testing.assert_allclose(c.length, [1.140254, 1.331353, 1.331353], atol=5e-7)
    sol = fsd.solve(MODEL, [0, 0, 0], [0, 0, 0], [0, 0, 0])
    np.testing.assert_allclose(sol.stroke, [0.000254, 0.001353, 0.001353], atol=5e-7)
    np.testing.assert_allclose(sol.joints[[0, 2, 3, 4, 6, 7, 9, 10, 11]], 0.0, atol=1e-15)


def test_points_close_every_loop():
    """The positions returned by the inverse geometry satisfy eq. (7)."""
    q = np.array([[0.03, -0.05, 0.2], [-0.04, 0.08, -0.25]])
    g, arr = _geometric(q)
    geom = MODEL.geometry
    G, A3, D2, E2, B4, C4 = (arr(v) for v in (g.G, g.A3, g.D2, g.E2, g.B4, g.C4))
    l, t, n = arr(g.l), arr(g.t), arr(g.n)
    np.testing.assert_allclose(np.linalg.norm(D2 - geom.D1, axis=1), geom.l5, rtol=1e-14)
    np.testing.assert_allclose(np.linalg.norm(E2 - geom.E1, axis=1), geom.l6, rtol=1e-14)
    np.testing.assert_allclose(np.linalg.norm(G - A3, axis=1), geom.h, rtol=1e-14)
    np.testing.assert_allclose(A3 + geom.h * l, G, atol=1e-15)
    np.testing.assert_allclose(np.linalg.norm(B4 - C4, axis=1), geom.b, rtol=1e-14)
    np.testing.assert_allclose(np.linalg.norm(B4 - geom.B1, axis=1), arr(g.length)[:, 1])
    # E2 on the rod line, between A3 and G
    np.testing.assert_allclose(np.cross(E2 - A3, l)[:, 2], 0.0, atol=1e-15)
    assert np.all((g.u > 0) & (g.u < geom.h))
    # platform axes orthonormal and l stays in the median plane
    for a, b in ((l, t), (t, n), (n, l)):
        np.testing.assert_allclose(np.einsum('ni,ni->n', a, b), 0.0, atol=1e-15)
    np.testing.assert_allclose(np.linalg.norm(n, axis=1), 1.0, rtol=1e-15)
    np.testing.assert_allclose(l[:, 2], 0.0)
    # positive roll lowers the right (B) corner
    assert B4[0, 1] < C4[0, 1] and B4[1, 1] > C4[1, 1]


def _smooth_trajectory(coeffs, t):
    """q(t) = sum a_k sin(w_k t + p_k) per coordinate, with exact derivatives."""
    q = np.zeros((t.size, 3))
    qd = np.zeros_like(q)
    qdd = np.zeros_like(q)
    for axis, terms in enumerate(coeffs):
        for a, w, p in terms:
            q[:, axis] += a * np.sin(w * t + p)
            qd[:, axis] += a * w * np.cos(w * t + p)
            qdd[:, axis] -= a * w * w * np.sin(w * t + p)
    return q, qd, qdd


term = st.tuples(st.floats(-0.03, 0.03), st.floats(0.2, 6.0), st.floats(0, 2 * math.pi))
roll_term = st.tuples(st.floats(-0.12, 0.12), st.floats(0.2, 6.0), st.floats(0, 2 * math.pi))
trajectories = st.tuples(st.lists(term, min_size=1, max_size=3),
                         st.lists(term, min_size=1, max_size=3),
                         st.lists(roll_term, min_size=1, max_size=3))


@settings(max_examples=40, deadline=None)
@given(trajectories, st.floats(0.0, 10.0))
def test_rates_and_accelerations_match_finite_differences(coeffs, t0):
    """V = Q^-1 P (eq. 11) and Gamma = Q^-1 S (eq. 16) are the time derivatives
    of the 12 joint variables, and of V: central differences, h = 1e-5 s."""
    h = 1e-5
    t = np.array([t0 - h, t0, t0 + h])
    q, qd, qdd = _smooth_trajectory(coeffs, t)
    sol = fsd.solve_batch(MODEL, q, qd, qdd)
    fd_rate = (sol.joints[2] - sol.joints[0]) / (2 * h)
    fd_acc = (sol.joint_rates[2] - sol.joint_rates[0]) / (2 * h)
    scale_v = 1.0 + np.abs(sol.joint_rates[1]).max()
    scale_a = 1.0 + np.abs(sol.joint_accelerations[1]).max()
    np.testing.assert_allclose(fd_rate, sol.joint_rates[1], atol=1e-7 * scale_v)
    np.testing.assert_allclose(fd_acc, sol.joint_accelerations[1], atol=1e-6 * scale_a)
    fd_len = (sol.length[2] - sol.length[0]) / (2 * h)
    np.testing.assert_allclose(fd_len, sol.rate[1], atol=1e-7 * scale_v)


def test_velocity_satisfies_connectivity_relations():
    q, qd, qdd = paper_example('general', np.linspace(0, 3, 7))
    g, arr = _geometric(q)
    Q, Pq = kinematics.connectivity_matrix(MODEL, g)
    sol = fsd.solve_batch(MODEL, q, qd, qdd)
    residual = np.einsum('nij,nj->ni', Q, sol.joint_rates) - np.einsum('nij,nj->ni', Pq, qd)
    assert np.abs(residual).max() < 1e-14
    S = arr(kinematics.acceleration_column(MODEL, g, list(sol.joint_rates.T), tuple(qd.T),
                                           tuple(qdd.T)))
    residual = np.einsum('nij,nj->ni', Q, sol.joint_accelerations) - S
    assert np.abs(residual).max() < 1e-13


def test_jacobian_maps_pose_rates_to_leg_rates():
    q, qd, qdd = paper_example('general', np.linspace(0.1, 2.9, 5))
    sol = fsd.solve_batch(MODEL, q, qd, qdd)
    np.testing.assert_allclose(np.einsum('nij,nj->ni', sol.jacobian, qd), sol.rate, atol=1e-15)


@pytest.mark.parametrize('q, loop', [
    ([0.0, 2.0, 0.0], 'D'),              # G far above: crank D cannot reach
    ([3.0, 0.0, 0.0], 'D'),
])
def test_unreachable_pose_names_the_loop(q, loop):
    sol = fsd.solve(MODEL, q, [0, 0, 0], [0, 0, 0])
    assert sol.status == fsd.Status.UNREACHABLE and str(sol.status) == 'unreachable'
    assert sol.detail.startswith(f'loop {loop}:')
    with pytest.raises(fsd.UnreachablePoseError) as info:   # the geometry itself raises
        kinematics.inverse_geometry(MODEL, tuple(q), backend(False))
    assert info.value.loop == loop


def test_q_of_single_solve_is_the_dense_matrix():
    sol = fsd.solve(MODEL, [0.01, 0.02, 0.1], [0.1, 0.1, 0.2], [0, 0, 0])
    assert sol.Q.shape == (12, 12)
    assert sol.cond == pytest.approx(np.linalg.cond(sol.Q))
    batch = fsd.solve_batch(MODEL, [[0.01, 0.02, 0.1]], [[0.1, 0.1, 0.2]], [[0, 0, 0]])
    np.testing.assert_allclose(batch.Q[0], sol.Q, rtol=1e-13, atol=1e-15)
    np.testing.assert_allclose(sol.Q @ sol.joint_rates,
                               kinematics.connectivity_matrix(MODEL, sol.geometric)[1][0]
                               @ np.array([0.1, 0.1, 0.2]), atol=1e-15)
    assert np.linalg.matrix_rank(sol.Q) == 12


def test_unreachable_sample_in_batch_is_located():
    q = np.zeros((4, 3))
    q[2, 1] = 2.0
    sol = fsd.solve_batch(MODEL, q, np.zeros((4, 3)), np.zeros((4, 3)))
    assert [str(s) for s in sol.status] == ['ok', 'ok', 'unreachable', 'ok']
    assert sol.detail[2].startswith('loop D') and sol.detail[0] == ''
    assert np.all(sol.force[2] == 0.0) and np.all(sol.force[[0, 1, 3]] > 30.0)


def test_block_solution_of_q_equals_dense_solution():
    """solve_connectivity (block substitution) solves the same system as a dense
    LU of the 12x12 Q of eq. (11)-(12)."""
    q, qd, qdd = paper_example('general', np.linspace(0, 3, 9))
    q = q + np.array([0.02, -0.03, 0.1])
    g, arr = _geometric(q)
    Q, _ = kinematics.connectivity_matrix(MODEL, g)
    rhs = np.random.default_rng(1).normal(size=(len(q), 12))
    X = arr(kinematics.solve_connectivity(g, kinematics.factorize(MODEL, g), list(rhs.T)))
    np.testing.assert_allclose(X, np.linalg.solve(Q, rhs[..., None])[..., 0], rtol=1e-11,
                               atol=1e-12)
    np.testing.assert_allclose(np.einsum('nij,nj->ni', Q, X), rhs, atol=1e-13)
