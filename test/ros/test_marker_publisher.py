"""The markers off the node's thread (ros/marker_publisher.py): the renderer's
answers (unit), and a MarkerPublisher on a plain rclpy node (ros): the latest
offered solution published at the rate, stamped like it; model, frame and rate
changes; errors logged, never raised, and the next solution drawn."""
from __future__ import annotations

import pickle
import time
from dataclasses import replace
from types import SimpleNamespace

import numpy as np
import pytest
import rclpy
from rclpy.context import Context
from rclpy.experimental import EventsExecutor
from rclpy.serialization import deserialize_message
from visualization_msgs.msg import Marker, MarkerArray

import flight_sim_dynamics as fsd
from flight_sim_dynamics.ros import marker_publisher
from flight_sim_dynamics.ros.marker_publisher import MarkerPublisher, render
from flight_sim_dynamics.ros.markers import snapshot
from node_harness import QOS, stamp_ns

MODEL = fsd.load_model()
HEXAPOD = fsd.load_model('config/stewart_6dof.yaml')


def solution(model, q0: float = 0.05):
    dof = fsd.machine_of(model).dof
    zero = [0.0] * dof
    return fsd.solve(model, [q0] + zero[1:], zero, zero)


@pytest.mark.parametrize('model', [MODEL, HEXAPOD], ids=['3dof', 'hexapod'])
def test_the_renderer_answers_the_serialized_array(model):
    sol = solution(model)
    snap = snapshot(fsd.machine_of(model), model, sol)
    reply, builder = render(pickle.dumps((model, 'frame_a', (4, 5), snap)), None)
    assert reply[:1] == b'M'
    array = deserialize_message(reply[1:], MarkerArray)
    assert [m.ns for m in array.markers] == list(builder.namespaces)
    assert all(m.header.frame_id == 'frame_a' and stamp_ns(m) == 4 * 10**9 + 5
               for m in array.markers)
    # no model: the builder kept; no snapshot: home
    reply, same = render(pickle.dumps((None, 'frame_b', (6, 0), None)), builder)
    assert same is builder and reply[:1] == b'M'
    array = deserialize_message(reply[1:], MarkerArray)
    assert array.markers[0].header.frame_id == 'frame_b'
    zero = [0.0] * fsd.machine_of(model).dof
    # in the setpoints' frame: origin at the platform's home position
    home = {k: tuple(np.subtract(v, builder.drawing.origin))
            for k, v in builder.drawing.points(zero).items()}
    first, second = builder.drawing.segments[array.markers[0].ns]
    got = array.markers[0].points
    assert (got[0].x, got[0].y, got[0].z) == pytest.approx(home[first])
    assert (got[1].x, got[1].y, got[1].z) == pytest.approx(home[second])


def test_the_renderer_tells_errors_and_keeps_its_builder():
    _, builder = render(pickle.dumps((MODEL, 'f', (0, 0), None)), None)
    # no forces: cannot colour
    bad = snapshot(fsd.machine_of(MODEL), MODEL, solution(MODEL))._replace(force=())
    reply, kept = render(pickle.dumps((None, 'f', (1, 0), bad)), builder)
    assert reply[:1] == b'E' and b'IndexError' in reply and kept is builder
    reply, _ = render(b'not a pickle', builder)
    assert reply[:1] == b'E'
    reply, none = render(pickle.dumps((None, 'f', (1, 0), None)), None)
    assert reply[:1] == b'E' and none is None


class Recorder:
    """A logger keeping what is logged."""

    def __init__(self) -> None:
        self.lines: list[tuple[str, str]] = []

    def error(self, text: str, **kwargs) -> None:
        self.lines.append(('error', text))

    def warn(self, text: str, **kwargs) -> None:
        self.lines.append(('warn', text))

    info = warn


@pytest.fixture
def ros():
    context = Context()
    rclpy.init(context=context)
    node = rclpy.create_node('marker_publisher_test', context=context)
    listener = rclpy.create_node('marker_listener', context=context)
    executor = EventsExecutor(context=context)
    executor.add_node(listener)
    arrays: list[MarkerArray] = []
    listener.create_subscription(MarkerArray, 'markers', arrays.append, QOS)
    log = Recorder()
    node.get_logger = lambda: log

    def spin_until(predicate, timeout: float) -> bool:
        deadline = time.monotonic() + timeout
        while not predicate() and time.monotonic() < deadline:
            executor.spin_once(timeout_sec=0.05)
        return predicate()
    try:
        yield SimpleNamespace(node=node, arrays=arrays, log=log, spin_until=spin_until)
    finally:
        executor.shutdown()
        listener.destroy_node()
        node.destroy_node()
        rclpy.try_shutdown(context=context)


@pytest.mark.ros
def test_latest_offer_at_the_rate_then_model_frame_rate_changes(ros):
    markers = MarkerPublisher(ros.node, fsd.machine_of(MODEL), MODEL, 'base_a', 20.0)
    try:
        assert ros.spin_until(lambda: bool(ros.arrays), 15.0), ros.log.lines
        assert ros.arrays[0].markers[-1].text == 'ok'          # home, before any offer
        for k in range(5):                                     # only the latest is drawn
            markers.offer((100, k), solution(MODEL, 0.01 * k))
        assert ros.spin_until(lambda: stamp_ns(ros.arrays[-1].markers[0]) == 100 * 10**9 + 4,
                              5.0)
        assert {stamp_ns(a.markers[0]) for a in ros.arrays
                if a.markers[0].header.stamp.sec == 100} == {100 * 10**9 + 4}
        # another model: forces at rest of about 38 N over a 30 N limit, the legs red
        low = replace(MODEL, limits=replace(MODEL.limits, max_force=30.0))
        markers.set_model(low)
        markers.offer((101, 0), fsd.solve(low, [0.0] * 3, [0.0] * 3, [0.0] * 3))
        markers.set_frame('base_b')

        def red() -> bool:
            m = ros.arrays[-1].markers
            return m[0].header.frame_id == 'base_b' and stamp_ns(m[0]) == 101 * 10**9 and \
                (m[0].color.r, m[0].color.g) == (1.0, 0.0)
        assert ros.spin_until(red, 5.0)
        markers.set_rate(0.0)
        assert ros.spin_until(lambda: ros.arrays[-1].markers[0].action == Marker.DELETEALL, 5.0)
        count = len(ros.arrays)
        assert not ros.spin_until(lambda: len(ros.arrays) > count, 0.5)
        markers.set_rate(50.0)
        assert ros.spin_until(lambda: len(ros.arrays) > count + 2, 5.0)
        markers.clear()                 # forgets the offers: home next
        assert ros.spin_until(lambda: any(a.markers[0].action == Marker.DELETEALL
                                          for a in ros.arrays[count:]), 5.0)
        assert ros.spin_until(lambda: stamp_ns(ros.arrays[-1].markers[0]) != 101 * 10**9
                              and ros.arrays[-1].markers[0].action == Marker.ADD, 5.0)
    finally:
        markers.close()
    assert markers._child.poll() is not None
    assert not ros.log.lines


@pytest.mark.ros
def test_errors_are_logged_never_raised_and_the_next_offer_is_drawn(ros, monkeypatch):
    markers = MarkerPublisher(ros.node, fsd.machine_of(HEXAPOD), HEXAPOD, 'base', 50.0)
    try:
        assert ros.spin_until(lambda: bool(ros.arrays), 15.0), ros.log.lines
        batch = fsd.solve_batch(HEXAPOD, np.zeros((2, 6)), np.zeros((2, 6)), np.zeros((2, 6)))
        markers.offer((7, 0), batch)                             # fails in the node's process
        assert ros.spin_until(lambda: any('batch' in t for _, t in ros.log.lines), 5.0)
        # a snapshot the renderer cannot colour (no forces): fails in the renderer
        whole = marker_publisher.snapshot
        monkeypatch.setattr(marker_publisher, 'snapshot',
                            lambda *args: whole(*args)._replace(force=()))
        markers.offer((8, 0), solution(HEXAPOD))
        assert ros.spin_until(lambda: any('not drawn' in t for _, t in ros.log.lines), 5.0)
        monkeypatch.setattr(marker_publisher, 'snapshot', whole)
        markers.offer((9, 0), solution(HEXAPOD))
        assert ros.spin_until(lambda: stamp_ns(ros.arrays[-1].markers[0]) == 9 * 10**9, 5.0)
        assert all(level == 'error' for level, _ in ros.log.lines)
    finally:
        markers.close()
