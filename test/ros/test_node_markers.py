"""The node's ``markers`` topic over DDS: published at ``output.markers_rate``
while the node answers a stream, stamped like an answered setpoint, in
``output.frame_id``, its points the solver's joint positions to 1e-9; the rate,
the frame and the model can be changed at run time (rate 0: off); deactivate
clears the view; nothing is drawn before a subscriber comes; a renderer that
dies is logged and the node keeps answering."""
from __future__ import annotations

import itertools
import os
import signal
import time
from pathlib import Path

import numpy as np
import pytest
from lifecycle_msgs.msg import Transition
from visualization_msgs.msg import Marker, MarkerArray

import flight_sim_dynamics as fsd
from flight_sim_dynamics.machines.staicu.trajectories import paper_example
from node_harness import PARAMS_FILE, QOS, Client, NodeProcess, stamp_ns
from test_markers import expected_points, xyz
from test_node_lifecycle import LifecycleClient

pytestmark = pytest.mark.ros
ZERO = (0.0, 0.0, 0.0)


def segments(model) -> dict:
    return fsd.machine_of(model).drawing(model).segments


def listen(client: Client) -> list[tuple[float, MarkerArray]]:
    arrays: list[tuple[float, MarkerArray]] = []
    client.node.create_subscription(MarkerArray, 'markers',
                                    lambda a: arrays.append((time.monotonic(), a)), QOS)
    return arrays


def renderer_pids(pid: int) -> list[int]:
    """The node process's children (its markers' renderer)."""
    out = []
    for task in Path(f'/proc/{pid}/task').iterdir():
        out += [int(c) for c in (task / 'children').read_text().split()]
    return out


def test_markers_show_the_solved_pose(client, model):
    arrays = listen(client)
    stamp = time.time_ns() - 1_000_000_000
    q, qd, qdd = (v[0] for v in paper_example('general', np.array([1.5])))
    client.send(stamp, q, qd, qdd, order='tap')

    def at_stamp() -> list[MarkerArray]:
        return [a for _, a in arrays if a.markers and stamp_ns(a.markers[0]) == stamp]
    assert client.spin_until(lambda: bool(at_stamp()), 5.0), 'no markers for the setpoint'
    array = at_stamp()[-1]
    expected = expected_points(fsd.solve(model, q, qd, qdd))
    markers = {m.ns: m for m in array.markers}
    for ns, (start, end) in segments(model).items():
        points = [xyz(p) for p in markers[ns].points]
        np.testing.assert_allclose(points[0], expected[start], rtol=0, atol=1e-9)
        np.testing.assert_allclose(points[1], expected[end], rtol=0, atol=1e-9)
    assert all(m.header.frame_id == 'simulator_base' for m in array.markers)


def test_markers_follow_a_stream_at_their_rate(client):
    """A 100 Hz stream of 2 s: every setpoint answered, markers at about 30 Hz
    meanwhile, each stamped like an answered setpoint, in stamp order."""
    arrays = listen(client)
    n0 = len(client.actuator)
    t0 = time.time_ns() - 500_000_000
    stamps = [t0 + k * 10_000_000 for k in range(200)]
    q, qd, qdd = paper_example('general', np.arange(200) * 0.01)
    start = time.monotonic()
    for k, stamp in enumerate(stamps):
        client.send(stamp, q[k], qd[k], qdd[k])
        client.spin_until(lambda: False, max(start + (k + 1) * 0.01 - time.monotonic(), 0.0))
    assert client.spin_until(lambda: {stamp_ns(m) for _, m in client.actuator[n0:]}
                             >= set(stamps), 10.0), client.explain()
    seconds = client.actuator[-1][0] - start
    during = [a for t, a in arrays if start <= t <= start + seconds and a.markers]
    # loose bounds: the host is shared; what is checked is "about the rate"
    assert 0.3 * 30 * seconds <= len(during) <= 1.5 * 30 * seconds + 2, (len(during), seconds)
    drawn = [stamp_ns(a.markers[0]) for a in during if stamp_ns(a.markers[0]) >= stamps[0]]
    assert drawn and set(drawn) <= set(stamps) and drawn == sorted(drawn)


def test_frame_rate_and_model_changes_reach_the_markers(client):
    arrays = listen(client)
    try:
        [result] = client.set_params({'output.frame_id': 'moved_base'})
        assert result.successful, result.reason
        assert client.spin_until(lambda: any(
            a.markers and a.markers[0].header.frame_id == 'moved_base' for _, a in arrays), 5.0)
        # a model change: forces at rest of about 38 N over a 30 N limit, the legs red
        [result] = client.set_params({'limits.max_force': 30.0})
        assert result.successful, result.reason
        stamp = time.time_ns() - 500_000_000
        client.send(stamp, ZERO, ZERO, ZERO, order='tap')

        def red_at_stamp() -> bool:
            return any(a.markers and stamp_ns(a.markers[0]) == stamp and any(
                m.ns.startswith('leg_') and (m.color.r, m.color.g) == (1.0, 0.0)
                for m in a.markers) for _, a in arrays)
        assert client.spin_until(red_at_stamp, 5.0)
        # rate 0: cleared, then nothing; back on
        [result] = client.set_params({'output.markers_rate': 0.0})
        assert result.successful
        assert client.spin_until(lambda: any(m.action == Marker.DELETEALL for _, a in arrays
                                             for m in a.markers), 3.0)
        count = len(arrays)
        assert not client.spin_until(lambda: len(arrays) > count, 0.5)
        [result] = client.set_params({'output.markers_rate': 10.0})
        assert result.successful
        assert client.spin_until(lambda: len(arrays) > count + 1, 3.0)
    finally:
        for result in client.set_params({'output.frame_id': 'simulator_base',
                                         'limits.max_force': 2000.0,
                                         'output.markers_rate': 30.0}):
            assert result.successful, result.reason


def test_markers_show_the_machine_at_home_before_any_setpoint(model):
    proc = NodeProcess('-r', '__ns:=/home_markers', params_file=PARAMS_FILE)
    client = Client('home_markers_client', namespace='/home_markers')
    arrays = listen(client)
    try:
        client.wait_for_node(proc)
        assert client.spin_until(lambda: any(a.markers for _, a in arrays), 10.0), \
            proc.output()[-2000:]
        expected = expected_points(fsd.solve(model, ZERO, ZERO, ZERO))
        markers = {m.ns: m for m in next(a for _, a in arrays if a.markers).markers}
        for ns, (start, end) in segments(model).items():
            np.testing.assert_allclose(xyz(markers[ns].points[0]), expected[start], atol=1e-9)
            np.testing.assert_allclose(xyz(markers[ns].points[1]), expected[end], atol=1e-9)
        assert not client.actuator       # nothing was answered: this is the home pose
    finally:
        client.close()
        assert proc.stop() == 0


def test_deactivate_clears_the_view_and_inactive_publishes_none():
    proc = NodeProcess('-r', '__ns:=/lifecycle_markers', params_file=PARAMS_FILE)
    client = LifecycleClient('/lifecycle_markers')
    arrays = listen(client)
    try:
        client.wait_for_node(proc)
        assert client.spin_until(lambda: any(a.markers for _, a in arrays), 10.0)
        assert client.change(Transition.TRANSITION_DEACTIVATE)
        assert client.spin_until(lambda: any(m.action == Marker.DELETEALL for _, a in arrays
                                             for m in a.markers), 3.0)
        count = len(arrays)
        assert not client.spin_until(lambda: len(arrays) > count, 0.5)
        assert client.change(Transition.TRANSITION_ACTIVATE)
        assert client.spin_until(lambda: len(arrays) > count, 5.0)
        assert arrays[-1][1].markers[0].action == Marker.ADD
    finally:
        client.close()
        assert proc.stop() == 0


def test_a_dead_renderer_is_logged_and_the_node_keeps_answering():
    """Also: nothing is drawn, and no renderer started, before anyone
    subscribes to the markers."""
    proc = NodeProcess('-r', '__ns:=/dead_renderer', params_file=PARAMS_FILE)
    client = LifecycleClient('/dead_renderer')
    try:
        client.wait_for_node(proc)
        stamps = itertools.count(time.time_ns() - 900_000_000, 1_000_000)
        client.round_trip(lambda: next(stamps))     # answered: markers would be due
        client.spin_until(lambda: False, 0.2)       # several markers periods
        assert renderer_pids(proc.proc.pid) == []
        arrays = listen(client)
        assert client.spin_until(lambda: any(a.markers for _, a in arrays), 10.0)
        [pid] = renderer_pids(proc.proc.pid)
        os.kill(pid, signal.SIGKILL)
        assert proc.wait_output('markers stopped', 10.0), proc.output()[-2000:]
        stamp = time.time_ns() - 500_000_000
        for k in range(3):
            assert client.answered(stamp + k * 10_000_000, 5.0), client.explain()
        count = len(arrays)
        assert not client.spin_until(lambda: len(arrays) > count, 0.5)
        # a new configuration starts a new renderer
        for transition in (Transition.TRANSITION_DEACTIVATE, Transition.TRANSITION_CLEANUP,
                           Transition.TRANSITION_CONFIGURE, Transition.TRANSITION_ACTIVATE):
            assert client.change(transition)
        assert client.spin_until(lambda: len(arrays) > count + 1, 10.0)
        [pid] = renderer_pids(proc.proc.pid)
    finally:
        client.close()
        assert proc.stop() == 0
    assert not Path(f'/proc/{pid}').exists()      # ended with the node


def test_hexapod_markers_follow_its_solved_pose(tmp_path):
    """The hexapod's node: base, six cylinders and rods, platform, joints and
    status, its joints where the solver puts them for each answered pose."""
    from test_markers import hexapod_points
    from test_node_hexapod import HEXAPOD_FILE, motion, namespaced_file, publish, twist_of

    model = fsd.load_model(HEXAPOD_FILE)
    proc = NodeProcess('-r', '__ns:=/hexapod_markers', params_file=namespaced_file(tmp_path))
    client = Client('hexapod_markers_client', namespace='/hexapod_markers')
    arrays = listen(client)
    try:
        client.wait_for_node(proc)
        t0 = time.time_ns() - 500_000_000
        sent = {}
        for k in range(20):
            q, qd, qdd = motion(0.05 * k)
            twist, accel = twist_of(q, qd, qdd)
            sent[t0 + k * 50_000_000] = q
            publish(client, t0 + k * 50_000_000, q, twist, accel)
            client.spin_until(lambda: False, 0.05)

        def drawn() -> list[MarkerArray]:
            return [a for _, a in arrays if a.markers and stamp_ns(a.markers[0]) in sent]
        assert client.spin_until(lambda: len(drawn()) >= 3, 10.0), proc.output()[-2000:]
        for array in drawn():
            markers = {m.ns: m for m in array.markers}
            assert set(markers) == {f'{part}_{i}' for part in ('cylinder', 'rod')
                                    for i in range(1, 7)} | {'base', 'platform', 'joints',
                                                             'status'}
            zero = np.zeros(6)
            want = hexapod_points(fsd.solve(model, sent[stamp_ns(array.markers[0])], zero, zero))
            for i in range(1, 7):
                np.testing.assert_allclose(xyz(markers[f'rod_{i}'].points[1]), want[f'P{i}'],
                                           atol=1e-9)
                np.testing.assert_allclose(xyz(markers[f'cylinder_{i}'].points[0]),
                                           want[f'B{i}'], atol=1e-9)
            assert all(m.header.frame_id == 'simulator_base' for m in array.markers)
    finally:
        client.close()
        assert proc.stop() == 0
