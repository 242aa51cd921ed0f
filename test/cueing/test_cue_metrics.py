"""The cue metrics (flight_sim_dynamics/cueing/metrics.py) on hand-computed
cases: the felt specific force and angular velocity of simple platform motions,
RMSE, correlation, delay and false cues of made-up signals, the actuators' use
against the solver's own batch."""
from __future__ import annotations

import math

import numpy as np
import pytest

import flight_sim_dynamics as fsd
from flight_sim_dynamics.cueing.metrics import (FORCE_THRESHOLDS, actuator_use, compare,
                                                cue_metrics, delay, felt)
from flight_sim_dynamics.config.cueing import G, defaults
from flight_sim_dynamics.cueing.planner import run

HEAD = (0.0, 0.0, 0.8)


def pose(**values):
    """One sample (1, 6) of q, qd, qdd: keys like roll=..., roll_rate=..., roll_acc=..."""
    out = np.zeros((3, 1, 6))
    names = ('surge', 'sway', 'heave', 'roll', 'pitch', 'yaw')
    for key, value in values.items():
        name, _, kind = key.partition('_')
        out[{'': 0, 'rate': 1, 'acc': 2}[kind], 0, names.index(name)] = value
    return out


@pytest.mark.parametrize('motion, f_expected, w_expected', [
    ({}, (0.0, 0.0, G), (0.0, 0.0, 0.0)),
    ({'surge_acc': 1.5, 'heave_acc': -2.0}, (1.5, 0.0, G - 2.0), (0.0, 0.0, 0.0)),
    ({'roll': 0.2}, (0.0, G * math.sin(0.2), G * math.cos(0.2)), (0.0, 0.0, 0.0)),
    ({'pitch': 0.1}, (-G * math.sin(0.1), 0.0, G * math.cos(0.1)), (0.0, 0.0, 0.0)),
    ({'roll_rate': 0.5}, (0.0, 0.0, G - 0.25 * 0.8), (0.5, 0.0, 0.0)),      # centripetal
    ({'roll_acc': 2.0}, (0.0, -2.0 * 0.8, G), (0.0, 0.0, 0.0)),             # tangential
    # yawing while rolled: the head circles the yaw axis (radius 0.8 sin 0.3, centripetal
    # 0.4² of it towards the axis, +y), all seen in the rolled platform's axes
    ({'roll': 0.3, 'yaw_rate': 0.4},
     (0.0, math.cos(0.3) * 0.16 * 0.8 * math.sin(0.3) + math.sin(0.3) * G,
      -math.sin(0.3) * 0.16 * 0.8 * math.sin(0.3) + math.cos(0.3) * G),
     (0.0, 0.4 * math.sin(0.3), 0.4 * math.cos(0.3))),
])
def test_felt_specific_force_and_angular_velocity_of_simple_motions(motion, f_expected,
                                                                    w_expected):
    q, qd, qdd = pose(**motion)
    f, w = felt(q, qd, qdd, HEAD)
    np.testing.assert_allclose(f[0], f_expected, atol=1e-12)
    np.testing.assert_allclose(w[0], w_expected, atol=1e-12)


def test_a_perfect_cue_has_no_error_full_correlation_and_no_delay():
    t = np.arange(4000) / 1000.0
    v = np.column_stack([np.sin(t), np.cos(2 * t), G + 0.3 * np.sin(3 * t)])
    c = compare(v, v, v[0], v[0], FORCE_THRESHOLDS, 1e-3)
    assert np.all(c.rmse == 0) and np.allclose(c.correlation, 1.0)
    assert np.all(c.delay == 0) and np.all(c.false_cues == 0)


def test_the_delay_is_the_lag_of_the_cross_correlation_peak():
    rng = np.random.default_rng(0)
    x = np.convolve(rng.normal(size=6000), np.ones(50) / 50, mode='same')
    lag = 120
    late = np.concatenate([np.zeros(lag), x[:-lag]])
    assert delay(late, x, 1e-3) == pytest.approx(0.120)
    assert delay(x, late, 1e-3) == pytest.approx(-0.120)


def test_rmse_and_correlation_of_a_scaled_offset_cue():
    t = np.arange(1000) / 100.0
    v = np.column_stack([np.sin(t)] * 3)
    c = compare(0.5 * v + 0.1, v, np.zeros(3), np.zeros(3), FORCE_THRESHOLDS, 0.01)
    expected = np.sqrt(np.mean((-0.5 * v[:, 0] + 0.1) ** 2))
    np.testing.assert_allclose(c.rmse, expected)
    np.testing.assert_allclose(c.correlation, 1.0)


def test_false_cues_are_opposite_signs_beyond_the_thresholds():
    vehicle = np.tile([0.1, 0.1, 0.1], (4, 1))
    felt_ = np.array([[-0.2, -0.2, -0.2],     # apart 0.3: beyond 0.17 (x, y) and 0.28 (z)
                      [-0.1, -0.1, -0.1],     # apart 0.2: beyond 0.17 only
                      [0.5, 0.5, 0.5],        # same sign: never
                      [-0.05, -0.05, -0.05]])  # apart 0.15: below every threshold
    c = compare(felt_, vehicle, np.zeros(3), np.zeros(3), FORCE_THRESHOLDS, 1e-3)
    assert c.false_cues.tolist() == [2, 2, 1]
    np.testing.assert_allclose(c.false_fraction, [0.5, 0.5, 0.25])


@pytest.mark.parametrize('path', [None, 'config/stewart_6dof.yaml'])
def test_actuator_use_is_the_solvers_batch_summed_up_in_any_chunks(path):
    model = fsd.load_model(path)
    dof = len(fsd.machine_of(model).coordinates)
    t = np.linspace(0, 2, 301)[:, None]
    q = 0.05 * np.sin(2 * t + np.arange(dof)) * np.ones((1, dof))
    qd = 0.1 * np.cos(2 * t + np.arange(dof)) * np.ones((1, dof))
    qdd = -0.2 * np.sin(2 * t + np.arange(dof)) * np.ones((1, dof))
    sol = fsd.solve_batch(model, q, qd, qdd)
    use, _ = actuator_use(model, q, qd, qdd, chunk=7)
    whole, _ = actuator_use(model, q, qd, qdd)
    np.testing.assert_allclose(use.peak_force, np.abs(sol.force).max(axis=0))
    np.testing.assert_allclose(use.rms_force, np.sqrt((sol.force ** 2).mean(axis=0)))
    np.testing.assert_allclose(use.peak_speed, np.abs(sol.rate).max(axis=0))
    np.testing.assert_allclose(use.peak_power, np.abs(sol.power).max(axis=0))
    np.testing.assert_allclose(use.stroke_max, sol.stroke.max(axis=0))
    limits = fsd.machine_of(model).actuator_limits(model)
    np.testing.assert_allclose(use.stroke_used, (sol.stroke.max(axis=0) - sol.stroke.min(axis=0))
                               / (limits.stroke_max - limits.stroke_min))
    assert sum(use.statuses.values()) == len(t)
    for field in ('peak_force', 'rms_force', 'peak_speed', 'peak_power', 'stroke_used'):
        np.testing.assert_allclose(getattr(use, field), getattr(whole, field))


def test_the_pure_washout_gives_nothing_up_and_the_three_dof_machine_reports_its_channels():
    model = fsd.load_model()
    params = defaults().replace(limiter='none', translation_gain=(0.1, 0.1, 0.1))
    t = np.arange(3000) / 1000.0
    f = np.tile([0.0, 0.0, G], (len(t), 1))
    f[t > 0.5, 1] = 0.5
    result = run(model, params, t, f, np.zeros((len(t), 3)))
    m = cue_metrics(model, result, params)
    assert m.given_up_max == 0 and not m.limits and np.all(m.given_up_rmse == 0)
    assert m.dropped == ('sway', 'pitch', 'yaw') and m.samples == len(t)
    assert m.legs.statuses == {'ok': len(t)}


def test_at_home_the_three_dof_machine_feels_the_rest_its_own_pitch_there_is_neutral():
    model = fsd.load_model()
    params = defaults().replace(limiter='none')
    t = np.arange(200) / 1000.0
    rest = np.tile([0.0, 0.0, G], (len(t), 1))
    m = cue_metrics(model, run(model, params, t, rest, np.zeros((len(t), 3))), params)
    np.testing.assert_allclose(m.felt_f, rest, atol=1e-9)
    assert np.all(m.force.rmse < 1e-9)
