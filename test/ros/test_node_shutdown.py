"""Ctrl-C at any moment (issue 15 #3): the demo planner streaming at 1 kHz, and
the node answering a 1 kHz stream, stop silently with exit status 0.

rclpy's own signal handlers raised KeyboardInterrupt inside whatever callback
was running (``[FATAL] Exception in 'subscriptions' callback`` and a
traceback) and shut the context down under a publishing callback ("publisher's
context is invalid", exit 2 through the CLI): seen in 7 of 10 planner stops
at 5 kHz and 1 of 8 node stops under 1 kHz before the fix (this test, run
on the code before the fix: both parts failed, twice out of two). Each stop
here comes at a random moment (seeded) once the process streams; the stops
of each test are split between the ros tier (``[quick]``, a quarter) and the
slow tier (``[deep]``, drawn from other seeds), so the whole run makes them all.
"""
from __future__ import annotations

import os
import random
import signal
import subprocess
import sys
import textwrap
import time

import pytest

from geometry_msgs.msg import AccelStamped, PoseStamped, TwistStamped
from rclpy.qos import QoSProfile, ReliabilityPolicy
from rclpy.time import Time
from sensor_msgs.msg import JointState

from node_harness import QOS, Client, NodeProcess, PlannerProcess, stamp_ns

pytestmark = pytest.mark.ros

STOPS = 10            # per test, over both tiers (the sweep fixture)
SEED = 15
# s the node is kept stopped while its backlog is published: well inside its DDS
# participant's lease (rmw_fastrtps: 20 s from its last announcement, sent every
# 3 s). A participant silent for longer is taken for gone, its readers unmatched,
# and what was published for them never delivered: on a loaded 2-core host the
# 60,000 messages took 23 s to publish and the node then received none of them.
MAX_STOPPED = 10.0
# setpoints of the backlog at least left to answer at the stop request: answers
# in flight then (seen: 0-255 under load) are a small part of it (seen: 3,200-8,900
# left at load average 6-16 on 2 cores)
MIN_LEFT = 1000


def assert_silent_stop(proc: NodeProcess, what: str, repeat_after: float | None = None) -> None:
    rc = proc.stop(timeout=10.0, repeat_after=repeat_after)
    out = proc.output()
    assert rc == 0, f'{what}: exit status {rc}\n{out[-3000:]}'
    for word in ('FATAL', 'Traceback'):
        assert word not in out, f'{what}: {word} in the output\n{out[-3000:]}'


@pytest.fixture(scope='module')
def client():
    c = Client()
    yield c
    c.close()


class Answers:
    """The stamps a node publishes on its own ``actuator_states`` topic (each
    node of a pair remaps it), as the client receives them."""

    def __init__(self, client: Client, topic: str) -> None:
        self.latest = 0
        client.node.create_subscription(JointState, topic, self._on, QOS)

    def _on(self, msg: JointState) -> None:
        self.latest = max(self.latest, stamp_ns(msg))


def test_node_stops_silently_under_a_1khz_stream(client, sweep):
    """Two nodes at a time (other names, their own output topics) answer one
    1 kHz stream and are stopped at random moments once they answer it."""
    rounds = sweep(STOPS // 2)
    rng = random.Random(SEED + rounds)
    names = ('fsd_stop_a', 'fsd_stop_b')
    answers = {name: Answers(client, f'{name}/actuator_states') for name in names}
    planner = PlannerProcess('--rate', '1000', '--loop', '--wait', '0')
    try:
        for i in range(rounds):
            nodes = {name: NodeProcess('-r', f'__node:={name}',
                                       '-r', f'actuator_states:={name}/actuator_states',
                                       params_file=None) for name in names}
            try:
                for name, node in nodes.items():
                    client.watch = node
                    assert node.wait_output('active: answering setpoints'), node.output()[-3000:]
                ready_ns = time.time_ns()
                assert client.spin_until(lambda: all(
                    a.latest > ready_ns for a in answers.values()), 20.0), \
                    f'round {i}: not answering\n' + '\n'.join(
                        n.output()[-1500:] for n in nodes.values())
                client.watch = None
                for name, node in nodes.items():
                    time.sleep(rng.uniform(0.0, 0.2))     # the random moment of the Ctrl-C
                    assert_silent_stop(node, f'{name}, round {i}')
            finally:
                for node in nodes.values():
                    node.stop()
    finally:
        assert_silent_stop(planner, 'the streaming planner')


def test_a_stop_ends_a_node_whatever_its_backlog(client):
    """A Ctrl-C reaches a node with a backlog of up to 3 x 20,000 queued messages
    (the node stopped with SIGSTOP while they were sent, at most MAX_STOPPED s):
    the node exits 0 without answering them: of what was left at the stop
    request, it answers at most what it had in hand (half of it here, at least
    MIN_LEFT setpoints left); a node that does not exit within 30 s is killed
    (exit status -9). The time from the stop request to the exit is printed,
    not bounded: the teardown alone (no backlog) takes 0.3 s on a quiet host
    and 0.7-3 s at load average 6-8 on 2 cores."""
    backlog = 20_000
    depth = [f'qos_overrides./{kind}_setpoint.subscription.depth:={backlog}'
             for kind in ('pose', 'twist', 'accel')]
    node = NodeProcess(*(arg for d in depth for arg in ('-p', d)), params_file=None)
    try:
        client.wait_for_node(node)
        client.round_trip(time.time_ns)
        # writers that keep the whole backlog for the stopped reader
        qos = QoSProfile(depth=backlog, reliability=ReliabilityPolicy.RELIABLE)
        pubs = [client.node.create_publisher(t, f'{kind}_setpoint', qos) for t, kind in (
            (PoseStamped, 'pose'), (TwistStamped, 'twist'), (AccelStamped, 'accel'))]
        assert client.spin_until(lambda: all(p.get_subscription_count() for p in pubs), 10.0)
        msgs = [PoseStamped(), TwistStamped(), AccelStamped()]
        msgs[0].pose.orientation.w = 1.0
        base = time.time_ns()
        sent = 0
        os.kill(node.proc.pid, signal.SIGSTOP)
        try:
            stopped = time.monotonic()
            while sent < backlog and time.monotonic() - stopped < MAX_STOPPED:
                sent += 1
                stamp = Time(nanoseconds=base + sent * 1_000).to_msg()
                for pub, msg in zip(pubs, msgs):
                    msg.header.stamp = stamp
                    pub.publish(msg)
        finally:
            os.kill(node.proc.pid, signal.SIGCONT)
        last = base + sent * 1_000
        first = len(client.actuator)

        def latest() -> int:
            return max((stamp_ns(m) for _, m in client.actuator[first:]), default=0)
        # the backlog is being worked through
        assert client.spin_until(lambda: latest() > base, 20.0), \
            f'none of {sent} answered\n' + client.explain()
        left = (last - latest()) // 1_000                  # setpoints yet to answer
        assert left >= MIN_LEFT, f'a backlog of {sent} setpoints, {left} left: too small'
        start = time.monotonic()
        client.watch = None
        rc = node.stop(timeout=30.0)
        took = time.monotonic() - start
        # what it answered before it ended: once no answer has come for 0.5 s
        count, quiet_since = len(client.actuator), time.monotonic()

        def quiet() -> bool:
            nonlocal count, quiet_since
            if len(client.actuator) != count:
                count, quiet_since = len(client.actuator), time.monotonic()
            return time.monotonic() - quiet_since >= 0.5
        client.spin_until(quiet, 10.0)
        unanswered = (last - latest()) // 1_000
        print(f'backlog of {sent} setpoints, {left} left at the stop request, '
              f'{unanswered} never answered; exit {took:.2f} s after the request')
    finally:
        node.stop()
    out = node.output()
    assert rc == 0, out[-3000:]
    assert 'FATAL' not in out and 'Traceback' not in out, out[-3000:]
    assert unanswered >= left // 2, f'{left - unanswered} of {left} answered after the stop'


def test_planner_stops_silently_while_streaming(sweep):
    """At 5 kHz its timer callback runs nearly all the time (the race of the
    issue's 1 in 15 at 100 Hz, made likely: 7 of 10 stops before the fix)."""
    stops = sweep(STOPS)
    rng = random.Random(SEED + 1 + stops)
    for i in range(stops):
        planner = PlannerProcess('--rate', '5000', '--loop', '--wait', '0')
        try:
            assert planner.wait_output('publishing'), planner.output()[-3000:]
            time.sleep(rng.uniform(0.05, 0.3))
        finally:
            assert_silent_stop(planner, f'planner, stop {i}')


@pytest.mark.parametrize('process', ['node', 'planner'])
def test_ctrl_c_under_ros2_launch_stops_silently(process, sweep):
    """Ctrl-C in the terminal of ``ros2 launch`` reaches every process twice
    (the terminal signals the process group, launch forwards SIGINT): found
    by the manual check with the real ``ros2 launch`` (the planner raised
    KeyboardInterrupt in its timer callback, FATAL). Both signals are one
    stop request. The node is stopped while it answers a 1 kHz stream."""
    stops = sweep(STOPS // 2)
    rng = random.Random(SEED + 2 + stops)
    stream = PlannerProcess('--rate', '1000', '--loop', '--wait', '0') \
        if process == 'node' else None
    try:
        for i in range(stops):
            if process == 'planner':
                proc = PlannerProcess('--rate', '5000', '--loop', '--wait', '0')
                ready = 'publishing'
            else:
                proc = NodeProcess('-r', '__node:=fsd_launch_stop', params_file=None)
                ready = 'active: answering setpoints'
            try:
                assert proc.wait_output(ready), proc.output()[-3000:]
                time.sleep(rng.uniform(0.2, 0.5))
            finally:
                assert_silent_stop(proc, f'{process}, stop {i}',
                                   repeat_after=rng.uniform(0.0, 0.05))
    finally:
        if stream is not None:
            assert_silent_stop(stream, 'the streaming planner')


def test_a_teardown_that_hangs_still_ends_the_process():
    """The middleware gets ``TEARDOWN_TIMEOUT`` s to release the nodes on the
    way out (seen once in CI: a refused start hung 30 s after its ``error:``
    line). A destroy that never returns: the process ends anyway, exit 1,
    with the Python stacks that show where it hung."""
    script = textwrap.dedent('''
        import time
        from flight_sim_dynamics.ros import node
        node.TEARDOWN_TIMEOUT = 0.5

        class Stuck:
            def destroy_node(self):
                time.sleep(120)          # a middleware that never lets go

        with node.running('stuck', []) as nodes:
            nodes.append(Stuck())
        print('after the teardown')
    ''')
    proc = subprocess.run([sys.executable, '-c', script], capture_output=True, text=True,
                          timeout=60)
    assert proc.returncode == 1, proc.stderr
    assert 'Timeout' in proc.stderr and 'in destroy_node' in proc.stderr, proc.stderr
    assert 'after the teardown' not in proc.stdout
