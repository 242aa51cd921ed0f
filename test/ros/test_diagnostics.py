"""Unit tests of the limits, /diagnostics and log helpers
(flight_sim_dynamics.ros.diagnostics)."""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

import flight_sim_dynamics as fsd
from flight_sim_dynamics.core.machine import LimitUsage
from flight_sim_dynamics.ros.diagnostics import CycleStats, LogThrottle, limit_report
from flight_sim_dynamics.ros.messages import ERROR, NON_FINITE, OK, WARN
from flight_sim_dynamics.machines import FLIGHT_SIMULATOR


# ----------------------------------------------------------------------------
# Limits, diagnostics bookkeeping
# ----------------------------------------------------------------------------
def test_limits():
    """A limit used beyond 1: ERROR, from warn_fraction on: WARN, each by its name."""
    names = ('stroke A', 'speed A', 'force A', 'stroke B', 'speed B', 'force B')
    ok = limit_report(LimitUsage(names, np.array([0.0, 0.1, 0.3, 0.2, 0.1, 0.3])), 0.9)
    assert ok.level == OK and not ok.exceeded and not ok.near
    near = limit_report(LimitUsage(names, np.array([0.9, 0.1, 0.3, 0.2, 0.95, 1.0])), 0.9)
    assert near.level == WARN and set(near.near) == {'stroke A', 'speed B', 'force B'}
    over = limit_report(LimitUsage(names, np.array([0.0, 0.0, 0.3, 0.95, 0.0, 1.01])), 0.9)
    assert over.level == ERROR and over.exceeded == ('force B',) and over.near == ('stroke B',)


def test_limit_usages_of_the_3dof_machine():
    """A leg's stroke usage is its distance from mid-stroke over half the
    stroke, speed and force their magnitudes over the maxima."""
    model = fsd.load_model()
    lim = model.limits
    sol = SimpleNamespace(stroke=np.array([lim.stroke_max, lim.stroke_min, 0.5 * (
                              lim.stroke_min + lim.stroke_max)]),
                          rate=np.array([0.0, -0.95 * lim.max_speed, 0.0]),
                          force=np.array([0.0, 0.0, -1.01 * lim.max_force]))
    usage = FLIGHT_SIMULATOR.limit_usage(model, sol)
    report = limit_report(usage, 0.9)
    assert report.exceeded == ('force C',)
    assert set(report.near) == {'stroke A', 'stroke B', 'speed B'}
    np.testing.assert_allclose(usage.usage, [1.0, 0.0, 0.0, 1.0, 0.95, 0.0, 0.0, 0.0, 1.01])


def test_cycle_stats_report():
    stats = CycleStats()
    level, message, values = stats.report(0.0)
    assert level == OK and message == 'waiting for setpoints'
    stats.solved(0.001, 12.0, 3.5)
    stats.reject(NON_FINITE, 'nan')
    level, message, values = stats.report(1.0, exact_cond=10.25)
    d = dict(values)
    assert d['cond(Q) last'] == '10.25' and d['kinematic condition last'] == '12'
    assert d['Jacobian condition max this period'] == '3.5'
    assert level == ERROR and 'non_finite' in message
    assert d['rejected non_finite'] == '1' and d['setpoints answered'] == '1'
    assert float(d['solve time mean (us)']) == pytest.approx(1000.0)
    assert float(d['solve time median (us)']) == pytest.approx(1000.0)
    level, _, values = stats.report(2.0)                       # next period: clean
    assert level == OK and dict(values)['rejected total'] == '1'


def test_cycle_stats_solve_time_figures():
    """Mean, median, p99 and max of one period's solve times; one preemption
    (a 5 ms solve among 2 us ones) moves the mean, not the median."""
    stats = CycleStats()
    times = [2e-6] * 99 + [5e-3]
    for t in times:
        stats.solved(t, 1.0, 1.0)
    d = dict(stats.report(1.0)[2])
    assert float(d['solve time median (us)']) == pytest.approx(2.0)
    assert float(d['solve time mean (us)']) == pytest.approx(1e6 * sum(times) / 100, rel=1e-3)
    assert float(d['solve time p99 (us)']) == pytest.approx(2.0)
    assert float(d['solve time max (us)']) == pytest.approx(5000.0)
    for t in (1e-6, 3e-6, 2e-6, 10e-6):       # even count: mean of the middle two
        stats.solved(t, 1.0, 1.0)
    d = dict(stats.report(2.0)[2])
    assert float(d['solve time median (us)']) == pytest.approx(2.5)
    d = dict(stats.report(3.0)[2])            # no solve this period
    assert d['solve time median (us)'] == 'no samples'


def test_log_throttle():
    throttle = LogThrottle(1.0)
    assert throttle('a', 0.0) == 0
    assert throttle('a', 0.5) is None and throttle('a', 0.6) is None
    assert throttle('b', 0.6) == 0
    assert throttle('a', 1.1) == 2
