"""The node's ``markers`` topic over DDS (issue 15, "See the mechanism"):
published at ``output.markers_rate``, stamped like the last answered
setpoint, in ``output.frame_id``, its points the solver's joint positions to
1e-9; the rate can be changed (0: off) at run time."""
from __future__ import annotations

import time

import numpy as np
import pytest
from visualization_msgs.msg import MarkerArray

import flight_sim_dynamics as fsd
from flight_sim_dynamics.machines.staicu.trajectories import paper_example
from flight_sim_dynamics.ros.markers import SEGMENTS
from node_harness import PARAMS_FILE, QOS, Client, NodeProcess, stamp_ns
from test_markers import expected_points, xyz

pytestmark = pytest.mark.ros


def test_markers_show_the_solved_pose(client, model):
    arrays: list[MarkerArray] = []
    client.node.create_subscription(MarkerArray, 'markers', arrays.append, QOS)
    stamp = time.time_ns() - 1_000_000_000
    q, qd, qdd = (v[0] for v in paper_example('general', np.array([1.5])))
    client.send(stamp, q, qd, qdd, order='tap')

    def at_stamp() -> list[MarkerArray]:
        return [a for a in arrays if a.markers and stamp_ns(a.markers[0]) == stamp]
    assert client.spin_until(lambda: bool(at_stamp()), 5.0), 'no markers for the setpoint'
    array = at_stamp()[-1]
    expected = expected_points(fsd.solve(model, q, qd, qdd))
    markers = {m.ns: m for m in array.markers}
    for ns, (start, end) in SEGMENTS.items():
        points = [xyz(p) for p in markers[ns].points]
        np.testing.assert_allclose(points[0], expected[start], rtol=0, atol=1e-9)
        np.testing.assert_allclose(points[1], expected[end], rtol=0, atol=1e-9)
    assert all(m.header.frame_id == 'simulator_base' for m in array.markers)


def test_markers_rate_zero_stops_them(client):
    arrays: list[MarkerArray] = []
    client.node.create_subscription(MarkerArray, 'markers', arrays.append, QOS)
    client.send(time.time_ns() - 500_000_000, (0.0, 0.0, 0.0), (0.0,) * 3, (0.0,) * 3,
                order='tap')
    assert client.spin_until(lambda: len(arrays) >= 2, 5.0)     # 30 Hz by default
    [result] = client.set_params({'output.markers_rate': 0.0})
    assert result.successful, result.reason
    assert client.spin_until(lambda: any(m.action == m.DELETEALL for a in arrays
                                         for m in a.markers), 3.0)
    count = len(arrays)
    assert not client.spin_until(lambda: len(arrays) > count, 0.5)
    [result] = client.set_params({'output.markers_rate': 30.0})
    assert result.successful
    assert client.spin_until(lambda: len(arrays) > count + 1, 3.0)


def test_markers_show_the_machine_at_home_before_any_setpoint(model):
    proc = NodeProcess('-r', '__ns:=/home_markers', params_file=PARAMS_FILE)
    client = Client('home_markers_client', namespace='/home_markers')
    arrays: list[MarkerArray] = []
    client.node.create_subscription(MarkerArray, 'markers', arrays.append, QOS)
    try:
        client.wait_for_node(proc)
        assert client.spin_until(lambda: any(a.markers for a in arrays), 10.0), \
            proc.output()[-2000:]
        expected = expected_points(fsd.solve(model, (0.0,) * 3, (0.0,) * 3, (0.0,) * 3))
        markers = {m.ns: m for m in next(a for a in arrays if a.markers).markers}
        for ns, (start, end) in SEGMENTS.items():
            np.testing.assert_allclose(xyz(markers[ns].points[0]), expected[start], atol=1e-9)
            np.testing.assert_allclose(xyz(markers[ns].points[1]), expected[end], atol=1e-9)
        assert not client.actuator       # nothing was answered: this is the home pose
    finally:
        client.close()
        assert proc.stop() == 0
