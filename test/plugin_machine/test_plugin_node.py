"""The dynamics node serves the plugin machine of test/plugin_machine (its
folder on the node process's PYTHONPATH, its parameter file given): a setpoint
in, ``actuator_states`` out with the plugin's leg names and fsd.solve's numbers."""
from __future__ import annotations

import itertools
import os

import numpy as np
import pytest
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

import flight_sim_dynamics as fsd
from node_harness import Client, NodeProcess, stamp_ns
from plugin_site import DIST, PARAMS

pytestmark = pytest.mark.ros


def test_the_node_answers_a_setpoint_of_the_plugin_machine(monkeypatch, model):
    monkeypatch.setenv('PYTHONPATH', os.pathsep.join(filter(None, [
        str(DIST), os.environ.get('PYTHONPATH')])))
    node = NodeProcess(params_file=PARAMS)
    client = None
    try:
        client = Client('plugin_client')
        client.wait_for_node(node)
        probes = itertools.count(10 ** 18, 5_000_000)
        client.round_trip(lambda: next(probes))
        stamp = next(probes) + 10 ** 9      # a new stream
        q, qd, qdd = [0.1, -0.05], [0.2, 0.1], [0.5, -0.3]
        msg = JointTrajectory(joint_names=['pitch', 'roll'])
        msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(stamp, 10 ** 9)
        msg.points = [JointTrajectoryPoint(positions=[q[1], q[0]], velocities=[qd[1], qd[0]],
                                           accelerations=[qdd[1], qdd[0]])]
        client.platform_pub.publish(msg)

        def answer():
            return next((m for _, m in reversed(client.actuator) if stamp_ns(m) == stamp), None)
        assert client.spin_until(lambda: answer() is not None, 10.0), client.explain()
        out = answer()
        sol = fsd.solve(model, q, qd, qdd)
        assert list(out.name) == list(fsd.machine_of(model).legs) == ['leg_1', 'leg_2']
        np.testing.assert_allclose(out.position, sol.length, atol=1e-12)
        np.testing.assert_allclose(out.velocity, sol.rate, rtol=1e-9, atol=1e-12)
        np.testing.assert_allclose(out.effort, sol.force, rtol=1e-9, atol=1e-8)
    finally:
        if client is not None:
            client.close()
        node.stop()
