"""The estimator of the rates and accelerations a planner does not send:
backward differences, their order of convergence, given values, gaps, roll
unwrapping."""
from __future__ import annotations

import math

import numpy as np
import pytest

from flight_sim_dynamics.core.estimator import (DerivativeEstimator, backward_derivative,
                                                estimate_rows, wrap_angle)
from flight_sim_dynamics.machines import FLIGHT_SIMULATOR, STEWART
from flight_sim_dynamics.machines.staicu.motions import motion

#: the angles of the 3-DOF machine's pose (surge, heave, roll): its roll
ROLL = FLIGHT_SIMULATOR.angles


def test_backward_derivatives_exact_on_polynomials():
    t = [0.0, 0.1, 0.25]                                       # unequal steps
    lin = [(2 * x, 0.0, 0.0) for x in t]
    quad = [(x * x, 0.0, 0.0) for x in t]
    assert backward_derivative(t, lin, 1)[0] == pytest.approx(2.0)
    assert backward_derivative(t, quad, 2)[0] == pytest.approx(0.5)    # BDF2 exact on x^2
    assert backward_derivative(t[:1], quad, 2) == (0.0, 0.0, 0.0)


@pytest.mark.parametrize('method, order', [('backward', 1), ('backward2', 2)])
def test_estimator_convergence_order(method, order):
    """Error of the estimated acceleration of the paper's general motion:
    first / second order in the step."""
    errors = []
    for rate in (100.0, 200.0, 400.0):
        t = np.arange(0.0, 3.0, 1.0 / rate)
        q, qd, qdd = motion('general', t)
        est = DerivativeEstimator(method, angles=ROLL)
        worst = 0.0
        for k in range(len(t)):
            qd_e, qdd_e = est.update(t[k], tuple(q[k]), None, None)
            if k >= 4:
                worst = max(worst, np.abs(np.array(qdd_e) - qdd[k]).max())
        errors.append(worst)
    ratios = [errors[i] / errors[i + 1] for i in range(2)]
    assert all(r > 2 ** order * 0.8 for r in ratios), (errors, ratios)


def test_estimator_uses_given_values_and_resets():
    est = DerivativeEstimator('backward2', max_gap=0.5, angles=ROLL)
    assert est.update(0.0, (0.0, 0.0, 0.0), None, None) == ((0.0,) * 3, (0.0,) * 3)
    est.reset()
    est.update(0.0, (0.0, 0.0, 0.0), (1.0, 2.0, 3.0), None)
    qd, qdd = est.update(0.01, (0.01, 0.0, 0.0), (1.0, 2.0, 3.0), (4.0, 5.0, 6.0))
    assert qd == (1.0, 2.0, 3.0) and qdd == (4.0, 5.0, 6.0)
    qd, qdd = est.update(0.02, (0.02, 0.0, 0.0), (1.0, 2.0, 3.0), None)
    assert qd == (1.0, 2.0, 3.0) and qdd[0] == pytest.approx(0.0, abs=1e-9)
    qd, qdd = est.update(5.0, (0.5, 0.0, 0.0), None, None)    # gap: restart from rest
    assert qd == (0.0,) * 3 and qdd == (0.0,) * 3


def test_estimator_unwraps_roll():
    est = DerivativeEstimator('backward', angles=ROLL)
    est.update(0.0, (0.0, 0.0, math.pi - 0.01), None, None)
    qd, _ = est.update(0.01, (0.0, 0.0, -math.pi + 0.01), None, None)
    assert qd[2] == pytest.approx(2.0)


def test_the_angles_are_the_machines_coordinates_in_rad():
    """What the callers pass (Machine.angles); the estimator has no default."""
    assert ROLL == (2,) and STEWART.angles == (3, 4, 5)
    with pytest.raises(TypeError):
        DerivativeEstimator('backward')
    with pytest.raises(TypeError, match='angles'):
        estimate_rows(np.zeros(2), np.zeros((2, 3)))


def test_estimator_of_six_coordinates_unwraps_the_angles_it_is_told():
    """A hexapod's pose: six numbers, roll, pitch and yaw unwrapped, not heave."""
    est = DerivativeEstimator('backward2', angles=(3, 4, 5))
    near_pi = (0.0, 0.0, math.pi - 0.01, math.pi - 0.01, 0.0, math.pi - 0.01)
    across = (0.01, 0.0, -math.pi + 0.01, -math.pi + 0.01, 0.0, -math.pi + 0.01)
    assert est.update(0.0, near_pi, None, None) == ((0.0,) * 6, (0.0,) * 6)
    qd, qdd = est.update(0.01, across, None, None)
    assert len(qd) == len(qdd) == 6
    assert qd[0] == pytest.approx(1.0) and qd[3] == pytest.approx(2.0)
    assert qd[5] == pytest.approx(2.0) and qd[4] == 0.0
    assert qd[2] == pytest.approx((-2.0 * math.pi + 0.02) / 0.01)   # heave is not an angle
    t = [0.0, 0.1, 0.25]
    quad = [(x * x,) * 6 for x in t]
    assert backward_derivative(t, quad, 2) == pytest.approx((0.5,) * 6)


def test_every_angle_of_a_six_coordinate_pose_is_unwrapped():
    """The hexapod's roll, pitch and yaw (coordinates 3-5) cross +-pi smoothly."""
    t = np.arange(8) * 0.01
    yaw = math.pi - 0.5 + 0.2 * t / 0.01             # 0.2 rad per sample, through pi
    q = np.zeros((8, 6))
    q[:, 5] = np.vectorize(wrap_angle)(yaw)
    q[:, 0] = 0.1 * t
    rates, accs = estimate_rows(t, q, angles=(3, 4, 5))
    np.testing.assert_allclose(rates[1:, 5], 20.0, rtol=1e-9)
    np.testing.assert_allclose(rates[1:, 0], 0.1, rtol=1e-9)
    np.testing.assert_allclose(accs[3:], 0.0, atol=1e-6)
