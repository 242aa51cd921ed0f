"""Ctrl-C at any moment (issue 15 #3): the demo planner streaming at 1 kHz, and
the node answering a 1 kHz stream, stop silently with exit status 0.

rclpy's own signal handlers raised KeyboardInterrupt inside whatever callback
was running (``[FATAL] Exception in 'subscriptions' callback`` and a
traceback) and shut the context down under a publishing callback ("publisher's
context is invalid", exit 2 through the CLI): seen in 7 of 10 planner stops
at 5 kHz and 1 of 8 node stops under 1 kHz before the fix. Each stop here
comes at a random moment (seeded) after the process is streaming.
"""
from __future__ import annotations

import random
import time

import pytest

from node_harness import PARAMS_FILE, Client, NodeProcess, PlannerProcess, stamp_ns

STOPS = 10
SEED = 15


def assert_silent_stop(proc: NodeProcess, what: str) -> None:
    rc = proc.stop(timeout=10.0)
    out = proc.output()
    assert rc == 0, f'{what}: exit status {rc}\n{out[-3000:]}'
    for word in ('FATAL', 'Traceback'):
        assert word not in out, f'{what}: {word} in the output\n{out[-3000:]}'


@pytest.fixture(scope='module')
def client():
    c = Client()
    yield c
    c.close()


def answering(client: Client, node: NodeProcess, timeout: float = 20.0) -> bool:
    """Wait until ``node`` (started after the earlier ones stopped) answers:
    an actuator_states stamped after it was ready."""
    client.watch = node
    assert node.wait_output('ready:'), node.output()[-3000:]
    ready_ns = time.time_ns()
    return client.spin_until(
        lambda: bool(client.actuator) and stamp_ns(client.actuator[-1][1]) > ready_ns, timeout)


def test_node_stops_silently_under_a_1khz_stream(client):
    rng = random.Random(SEED)
    planner = PlannerProcess('--rate', '1000', '--loop', '--wait', '0')
    try:
        for i in range(STOPS):
            node = NodeProcess(params_file=PARAMS_FILE)
            try:
                assert answering(client, node), f'stop {i}: not answering\n' \
                                                f'{node.output()[-3000:]}'
                time.sleep(rng.uniform(0.0, 0.2))     # the random moment of the Ctrl-C
            finally:
                assert_silent_stop(node, f'node, stop {i}')
    finally:
        assert_silent_stop(planner, 'the streaming planner')


def test_planner_stops_silently_while_streaming():
    """At 5 kHz its timer callback runs nearly all the time (the race of the
    issue's 1 in 15 at 100 Hz, made likely: 7 of 10 stops before the fix)."""
    rng = random.Random(SEED + 1)
    for i in range(STOPS):
        planner = PlannerProcess('--rate', '5000', '--loop', '--wait', '0')
        try:
            assert planner.wait_output('publishing'), planner.output()[-3000:]
            time.sleep(rng.uniform(0.05, 0.3))
        finally:
            assert_silent_stop(planner, f'planner, stop {i}')
