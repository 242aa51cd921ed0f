"""The machine's motion as the setpoint messages carry it
(:class:`flight_sim_dynamics.ros.messages.PoseMap`, the twin's and the
planner's side): position surge, sway, heave; ZYX roll, pitch, yaw; twist and
acceleration angular as base-frame vectors (S2)/(S3); read back by the node's
side of the same map to the numbers given.
"""
from __future__ import annotations

import numpy as np
import pytest

from flight_sim_dynamics.machines import MACHINES
from flight_sim_dynamics.ros.messages import pose_map

THREE, SIX = MACHINES
RNG = np.random.default_rng(5)


def test_the_3dof_machine_fills_x_z_and_roll():
    poses = pose_map(THREE)
    assert poses.message((0.1, 0.2, 0.3)) == (0.1, 0.0, 0.2, 0.3, 0.0, 0.0)
    assert poses.twist((0.1, 0.2, 0.3), (1.0, 2.0, 3.0)) == (1.0, 0.0, 2.0, 3.0, 0.0, 0.0)
    assert poses.accel((0.1, 0.2, 0.3), (1.0, 2.0, 3.0), (4.0, 5.0, 6.0)) == \
        (4.0, 0.0, 5.0, 6.0, 0.0, 0.0)
    assert poses.coordinates((0.1, 9.0, 0.2, 0.3, 9.0, 9.0)) == (0.1, 0.2, 0.3)


@pytest.mark.parametrize('machine', MACHINES, ids=lambda m: m.name)
def test_messages_read_back_to_the_machines_numbers(machine):
    poses = pose_map(machine)
    for _ in range(20):
        q, qd, qdd = (RNG.uniform(-0.5, 0.5, machine.dof) for _ in range(3))
        pose = poses.message(q)
        np.testing.assert_allclose(poses.coordinates(pose), q, atol=0)
        rates = poses.rates(q, poses.twist(q, qd))
        np.testing.assert_allclose(rates, qd, atol=1e-14)
        np.testing.assert_allclose(poses.accelerations(q, qd, poses.accel(q, qd, qdd)), qdd,
                                   atol=1e-13)
    assert poses.message([0.0] * machine.dof) == (0.0,) * 6
