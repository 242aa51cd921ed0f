"""The vehicle motions (flight_sim_dynamics/cueing/vehicles.py): from rest, finite,
as their descriptions say."""
from __future__ import annotations

import numpy as np
import pytest

from flight_sim_dynamics.config.cueing import G
from flight_sim_dynamics.cueing.vehicles import VEHICLES, vehicle_log


@pytest.mark.parametrize('name', list(VEHICLES))
def test_every_motion_starts_at_rest_and_is_finite(name):
    log = vehicle_log(name, rate=200.0)
    assert np.allclose(log.f[0], [0.0, 0.0, G]) and np.allclose(log.omega[0], 0.0)
    assert np.all(np.isfinite(log.f)) and np.all(np.isfinite(log.omega))
    assert log.t[-1] == pytest.approx(VEHICLES[name][1])
    assert np.all(np.diff(log.t) > 0)


def test_the_violent_log_has_a_ten_g_crash_and_multi_g_spikes():
    log = vehicle_log('violent')
    assert log.f[:, 0].min() <= -10.0 * G * 0.999
    assert log.f[:, 2].max() - G >= 3.0 * G
    assert np.abs(log.omega).max() >= 3.0


def test_braking_decelerates_then_pulls_away():
    log = vehicle_log('braking')
    assert log.f[:, 0].min() == pytest.approx(-7.0) and log.f[:, 0].max() == pytest.approx(3.0)


def test_a_log_may_be_longer_and_sampled_at_any_rate():
    log = vehicle_log('turbulence', rate=50.0, duration=200.0)
    assert len(log.t) == 10001 and log.t[-1] == pytest.approx(200.0)


def test_an_unknown_motion_is_refused():
    with pytest.raises(ValueError, match='violent'):
        vehicle_log('violet')
