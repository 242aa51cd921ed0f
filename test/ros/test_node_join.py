"""A node started next to a running 500 Hz planner starts quietly (issue 15 #7).

Its three subscriptions match the planner's publishers at different moments,
so the first stamps it sees lack the messages published before their topic
matched: in 4 of 10 starts this logged a burst of ``more than 64 incomplete
stamps pending``, late twists and absurd estimated accelerations. Now such
partial setpoints are ``joining`` (quiet). Each stream here is started first
(the demo planner, a plain rclpy publisher process), then the node, STARTS
times in a row (one in the ros tier, the others in the slow one): no ERROR
and no WARN line in its output over its first second, and the setpoints are
answered.
"""
from __future__ import annotations

import time

import pytest

from node_harness import PARAMS_FILE, Client, NodeProcess, PlannerProcess, stamp_ns

pytestmark = pytest.mark.ros

STARTS = 4             # per stream, over both tiers (the sweep fixture)
RATE = 500


@pytest.fixture(scope='module')
def client():
    c = Client()
    yield c
    c.close()


@pytest.mark.parametrize('stream', [[], ['--no-twist', '--no-accel']],
                         ids=['pose+twist+accel', 'pose only'])
def test_a_node_joining_a_running_stream_is_quiet(client, stream, sweep):
    planner = PlannerProcess('--rate', str(RATE), '--loop', '--wait', '0', *stream)
    try:
        assert planner.wait_output('publishing'), planner.output()[-3000:]
        for i in range(sweep(STARTS)):
            # A twist or accel the loaded host delays (a lost sample holds its
            # reliable stream until repaired) is `late` by design once its pose
            # waited sync.wait or was pushed out by sync.max_pending newer stamps
            # (seen in CI: 340 ms past 50 ms; 262 ms past 64 stamps = 128 ms), and so
            # is a twist+accel whose pose the host delays as long (seen: 470 ms past
            # 0.5 s, "no pose with the same stamp"), which is not what this test is
            # about: 2 s, 2 s of stamps
            node = NodeProcess('-p', 'sync.wait:=2.0', '-p', f'sync.max_pending:={2 * RATE}',
                               params_file=PARAMS_FILE)
            try:
                client.watch = node
                assert node.wait_output('active: answering setpoints'), node.output()[-3000:]
                ready_ns = time.time_ns()

                def answers() -> int:
                    return sum(stamp_ns(m) > ready_ns for _, m in client.actuator[-2 * RATE:])
                # its first second of answers (one per setpoint), or the deadline
                assert client.spin_until(lambda: answers() >= RATE, 20.0), \
                    f'start {i}: {answers()} setpoints answered\n{node.output()[-3000:]}'
            finally:
                node.stop()
            out = node.output()
            noisy = [line for line in out.splitlines()
                     if line.startswith(('[ERROR]', '[WARN]', '[FATAL]'))]
            assert not noisy, f'start {i}:\n' + '\n'.join(noisy[:20])
    finally:
        planner.stop()
