"""The hexapod's built-in motions (machines/stewart/motions.py, the machine's
``motions``): exact derivatives, reachable on the default machine, Tsai's four
motions giving the forces stewart.md documents on Tsai's machine."""
from __future__ import annotations

import numpy as np
import pytest
from stewart_cases import doc_tsai_peaks, model_of

import flight_sim_dynamics as fsd
from flight_sim_dynamics.core.motion import Motion
from flight_sim_dynamics.machines.stewart import motions

HEXAPOD = fsd.load_model('config/stewart_6dof.yaml')
MACHINE = fsd.machine_of(HEXAPOD)
#: The motions built for the default machine: within its limits throughout.
OWN = ('gentle', 'cueing', 'violent')
TSAI = ('tsai_1', 'tsai_2', 'tsai_3', 'tsai_4')


def test_the_machine_offers_the_registry():
    assert MACHINE.motions is motions.MOTIONS
    assert set(MACHINE.motions) == set(OWN + TSAI)
    assert set(MACHINE.examples) <= set(MACHINE.motions)
    for name, m in MACHINE.motions.items():
        assert isinstance(m, Motion) and m.name == name and m.duration > 0 and m.description
        t, q, qd, qdd = m.sampled(100.0)
        assert t[0] == 0.0 and t[-1] <= m.duration
        assert q.shape == qd.shape == qdd.shape == (t.size, MACHINE.dof)


@pytest.mark.parametrize('name', OWN + TSAI)
def test_rates_and_accelerations_are_the_derivatives_of_the_poses(name):
    m = motions.MOTIONS[name]
    h = 1e-4
    t = np.linspace(0.0, m.duration, 397)
    q, qd, qdd = m.trajectory(t)
    q_plus, qd_plus, _ = m.trajectory(t + h)
    q_minus, qd_minus, _ = m.trajectory(t - h)
    scale = 1.0 + np.abs(qdd).max()
    # central differences, O(h^2): a quintic step's jerk is at most 60 change / duration^3
    np.testing.assert_allclose((q_plus - q_minus) / (2 * h), qd, rtol=0, atol=1e-5 * scale)
    np.testing.assert_allclose((qd_plus - qd_minus) / (2 * h), qdd, rtol=0,
                               atol=2e-3 * scale)


@pytest.mark.parametrize('name', OWN)
def test_own_motions_start_and_end_at_rest_at_home_within_the_limits(name):
    t, q, qd, qdd = motions.MOTIONS[name].sampled(1000.0)
    for k in (0, -1):
        assert np.abs(np.stack([q[k], qd[k], qdd[k]])).max() < 1e-12
    sol = fsd.solve_batch(HEXAPOD, q, qd, qdd)
    assert set(map(str, sol.status)) == {'ok'}, sol.detail[np.argmax(sol.status != 'ok')]


def test_violent_is_near_the_speed_limit_and_gentle_is_not():
    limit = HEXAPOD.limits.max_speed
    speed = {name: np.abs(fsd.solve_batch(HEXAPOD, *motions.MOTIONS[name].sampled(1000.0)[1:])
                          .rate).max() for name in OWN}
    assert 0.8 * limit < speed['violent'] <= limit
    assert speed['gentle'] < 0.1 * limit < speed['cueing'] < speed['violent']
    _, _, _, qdd = motions.MOTIONS['violent'].sampled(1000.0)
    assert np.abs(qdd[:, :3]).max() > 9.0 and np.abs(qdd[:, 3:]).max() > 10.0


@pytest.mark.parametrize('name', TSAI)
def test_tsai_motions_are_reachable_on_the_default_machine(name):
    """Tsai's motions are plain hexapod motions: on the default machine they
    are reachable, (1) past a leg's longest length (status limit, documented)."""
    sol = fsd.solve_batch(HEXAPOD, *motions.MOTIONS[name].sampled(1000.0)[1:])
    statuses = set(map(str, sol.status))
    assert statuses <= ({'ok', 'limit'} if name == 'tsai_1' else {'ok'}), statuses
    assert np.isfinite(sol.force).all()


@pytest.mark.parametrize('k, peaks', sorted(doc_tsai_peaks().items()))
def test_tsai_motions_give_the_documented_forces_on_tsais_machine(k, peaks):
    """stewart.md's peaks |f_i| over one period (121 samples), status ok throughout."""
    model = model_of('stewart_tsai2000')
    m = motions.MOTIONS[f'tsai_{k}']
    sol = fsd.solve_batch(model, *m.trajectory(np.linspace(0.0, m.duration, 121)))
    np.testing.assert_allclose(np.abs(sol.force).max(axis=0), peaks, rtol=0, atol=1e-6)
    assert set(map(str, sol.status)) == {'ok'}


def test_tsai_at_rest_gives_the_static_forces():
    model = fsd.load_model('config/stewart_tsai2000.yaml')
    t, q, qd, qdd = motions.MOTIONS['tsai_4'].sampled(50.0)
    assert not np.any(q) and not np.any(qd) and not np.any(qdd)
    static = fsd.solve(model, np.zeros(6), np.zeros(6), np.zeros(6)).force
    np.testing.assert_array_equal(fsd.solve_batch(model, q, qd, qdd).force,
                                  np.broadcast_to(static, (t.size, 6)))
    np.testing.assert_allclose(static, doc_tsai_peaks()[4], rtol=0, atol=1e-6)
