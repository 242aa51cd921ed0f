"""The stamp policy and "a rejected message leaves no trace" (issue 12 #2,
#3, #5, #6, #8), with the node as a separate process over DDS.

* A stamp more than ``input.max_future`` ahead of the node's clock is
  ``future_stamp``: not answered, and the setpoints after it are.
* A rewound planner clock is a restart: after three setpoints in a row far
  behind, the node answers again (counted, logged).
* A rejected message (an accel stamped far ahead without its pose, an
  unreachable pose in a pose-only stream) does not degrade what follows.
* A ``platform_setpoint`` of more than ``input.max_points`` points is refused
  whole.
* With ``use_sim_time`` and no /clock, diagnostics keep coming and pose-only
  setpoints are answered.
* A second node of the same name exits 2; the first carries on.
"""
from __future__ import annotations

import time

import numpy as np
import pytest

import flight_sim_dynamics as fsd
from flight_sim_dynamics.machines.staicu.trajectories import paper_example
from node_harness import PARAMS_FILE, Client, NodeProcess, all_finite, stamp_ns

pytestmark = pytest.mark.ros

STEP = 5_000_000                       # 5 ms between stamps
Q, QD, QDD = (v[0] for v in paper_example('general', np.array([1.0])))


def now_ns() -> int:
    return time.time_ns()


def counter(values: dict, key: str) -> int:
    return int(values[key])


def answered_stream(client: Client, model, stamps, *, order: str = 'pta') -> list:
    """Send the paper's general motion at ``stamps`` (rates and accelerations
    as ``order`` says); return the answers received for them."""
    t = 1.0 + np.arange(len(stamps)) * STEP * 1e-9
    q, qd, qdd = paper_example('general', t)
    first = len(client.actuator)
    for k, stamp in enumerate(stamps):
        client.send(int(stamp), q[k], qd[k] if 't' in order else None,
                    qdd[k] if 'a' in order else None, order=order)
    want = set(int(s) for s in stamps)
    client.spin_until(lambda: want <= {stamp_ns(m) for _, m in client.actuator[first:]}, 5.0)
    return [m for _, m in client.actuator[first:]]


@pytest.fixture(scope='module')
def unchecked():
    """A second node, without the clock check (``input.max_future`` 0, as
    with sim time before its first /clock), in namespace /unchecked."""
    proc = NodeProcess('-p', 'diagnostics.period:=0.25', '-p', 'sync.wait:=0.5',
                       '-p', 'input.max_future:=0.0', '-r', '__ns:=/unchecked',
                       params_file=PARAMS_FILE)
    c = Client('stamps_unchecked_client', namespace='/unchecked')
    try:
        c.wait_for_node(proc)
        yield proc, c
    finally:
        c.close()
        proc.stop()


def test_a_future_stamp_is_rejected_and_leaves_no_trace(client, model):
    base = now_ns() - 60_000_000_000
    before = client.wait_diagnostics(lambda v: 'rejected future_stamp' in v, 3.0)
    got = answered_stream(client, model, [base])
    assert [stamp_ns(m) for m in got] == [base]
    n = len(client.actuator)
    future = now_ns() + 3600 * 1_000_000_000
    client.send(future, Q, QD, QDD, order='pta')
    client.send_platform(future, [(Q, QD, QDD)])
    got = answered_stream(client, model, [base + STEP, base + 2 * STEP])
    assert [stamp_ns(m) for m in got] == [base + STEP, base + 2 * STEP]
    assert all(stamp_ns(m) != future for _, m in client.actuator[n:])
    after = client.wait_diagnostics(
        lambda v: counter(v, 'rejected future_stamp') >= counter(before, 'rejected future_stamp')
        + 4, 3.0)
    assert counter(after, 'rejected future_stamp') - counter(before, 'rejected future_stamp') == 4
    for key in ('rejected stamp_backwards', 'rejected late', 'rejected no_pose'):
        assert counter(after, key) == counter(before, key), key
    assert 'ahead of the node' in after['stamp check']


def test_a_rewound_planner_clock_is_a_restart(client, model, node):
    base = now_ns() - 30_000_000_000
    assert [stamp_ns(m) for m in answered_stream(client, model, [base])] == [base]
    before = client.wait_diagnostics(lambda v: 'planner restarts' in v, 3.0)
    rewound = base - 20_000_000_000           # 20 s back: more than input.restart_jump
    stamps = [rewound + k * STEP for k in range(10)]
    got = answered_stream(client, model, stamps)
    # the first two are taken for stray old messages; from the third on: a restart
    assert [stamp_ns(m) for m in got] == stamps[2:]
    for m in got:
        assert all_finite(m)
    after = client.wait_diagnostics(
        lambda v: counter(v, 'planner restarts') > counter(before, 'planner restarts'), 3.0)
    assert counter(after, 'planner restarts') == counter(before, 'planner restarts') + 1
    assert (counter(after, 'rejected stamp_backwards')
            - counter(before, 'rejected stamp_backwards')) == 2
    assert client.spin_until(lambda: 'planner restart:' in node.output(), 3.0)


def test_one_stray_old_setpoint_is_not_a_restart(client, model):
    base = now_ns() - 10_000_000_000
    assert [stamp_ns(m) for m in answered_stream(client, model, [base])] == [base]
    before = client.wait_diagnostics(lambda v: 'planner restarts' in v, 3.0)
    client.send(base - 5_000_000_000, Q, QD, QDD, order='pta')      # one stray, far back
    got = answered_stream(client, model, [base + STEP, base + 2 * STEP])
    assert [stamp_ns(m) for m in got] == [base + STEP, base + 2 * STEP]
    after = client.wait_diagnostics(
        lambda v: counter(v, 'setpoints answered') >= counter(before, 'setpoints answered') + 2,
        3.0)
    assert counter(after, 'planner restarts') == counter(before, 'planner restarts')


def test_a_planner_restarted_on_the_other_input_is_a_restart(client, model, node):
    """100 ``platform_setpoint`` points at wall-clock stamps, then a restarted
    planner on pose/twist/accel stamped from 1 s after the epoch, at 100 Hz
    for 3 s: answered from the restart on (once the platform input has been
    silent for ``input.restart_jump`` = 1 s), to the last; one restart counted."""
    rate = 100.0
    wall = now_ns() - 5_000_000_000
    platform = [wall + k * 10_000_000 for k in range(100)]
    first = len(client.actuator)
    for k in range(0, 100, 10):
        client.send_platform(platform[k], [(Q, QD, QDD)] * 10,
                             offsets_ns=[j * 10_000_000 for j in range(10)])
    assert client.spin_until(lambda: set(platform) <= {
        stamp_ns(m) for _, m in client.actuator[first:]}, 10.0), client.explain()
    before = client.wait_diagnostics(lambda v: 'planner restarts' in v, 3.0)
    restarted = [1_000_000_000 + k * 10_000_000 for k in range(300)]
    first, start = len(client.actuator), time.monotonic()
    for k, stamp in enumerate(restarted):
        client.spin_until(lambda: time.monotonic() - start >= k / rate, 1.0)   # paced
        client.send(stamp, Q, QD, QDD)
    assert client.spin_until(lambda: any(stamp_ns(m) == restarted[-1]
                                         for _, m in client.actuator[first:]), 10.0), \
        client.explain()
    got = [stamp_ns(m) for _, m in client.actuator[first:]]
    assert got == restarted[-len(got):]
    after = client.wait_diagnostics(
        lambda v: counter(v, 'setpoints answered') >= counter(before, 'setpoints answered')
        + len(got), 3.0)
    assert counter(after, 'planner restarts') == counter(before, 'planner restarts') + 1


def test_a_far_future_accel_without_pose_leaves_no_trace(unchecked, model):
    """Issue 12 #3: an AccelStamped stamped 2038 is rejected (no_pose) and the
    three-topic setpoints after it are answered with their own accelerations
    (nothing estimated, nothing late)."""
    _, client = unchecked
    base = now_ns() - 50_000_000_000
    answered_stream(client, model, [base])
    before = client.wait_diagnostics(lambda v: 'estimated accel' in v, 3.0)
    client.send(2_147_000_000 * 1_000_000_000, Q, None, QDD, order='a')
    stamps = [base + (k + 1) * STEP for k in range(50)]
    got = answered_stream(client, model, stamps, order='pta')
    assert [stamp_ns(m) for m in got] == stamps
    t = 1.0 + np.arange(len(stamps)) * STEP * 1e-9
    q, qd, qdd = paper_example('general', t)
    expected = fsd.solve_batch(model, q, qd, qdd).force
    np.testing.assert_allclose([list(m.effort) for m in got], expected, rtol=0, atol=1e-9)
    after = client.wait_diagnostics(lambda v: counter(v, 'rejected no_pose')
                                    > counter(before, 'rejected no_pose'), 3.0)
    assert counter(after, 'estimated accel') == counter(before, 'estimated accel')
    assert counter(after, 'rejected late') == counter(before, 'rejected late')


def test_a_far_future_pose_is_answered_then_a_restart_recovers(unchecked, model):
    """Without the clock check (sim time before /clock), a valid pose stamped
    2038 is answered; the planner's next setpoints are then far behind it: a
    restart, after which all are answered."""
    _, client = unchecked
    far = 2_147_000_000 * 1_000_000_000
    assert [stamp_ns(m) for m in answered_stream(client, model, [far])] == [far]
    base = now_ns() - 40_000_000_000
    stamps = [base + k * STEP for k in range(20)]
    got = answered_stream(client, model, stamps)
    assert [stamp_ns(m) for m in got] == stamps[2:]


def test_a_rejected_pose_leaves_no_trace_in_the_estimates(unchecked, model):
    """Issue 12 #3: in a pose-only stream, an unreachable pose is rejected and
    the setpoints after it are answered, estimated from the valid ones."""
    _, client = unchecked
    base = now_ns() - 20_000_000_000
    t = np.arange(40) * STEP * 1e-9
    q = np.column_stack([0.05 * np.sin(2 * t), 0.02 * np.sin(3 * t), 0.1 * np.sin(t)])
    before = client.wait_diagnostics(lambda v: 'rejected unreachable' in v, 3.0)
    first = len(client.actuator)
    bad = {10, 20, 30}
    for k in range(len(t)):
        pose = (5.0, 0.0, 0.0) if k in bad else q[k]
        client.send(base + k * STEP, pose, order='p')
    kept = [k for k in range(len(t)) if k not in bad and k != 1]     # 1: warming up
    want = {base + k * STEP for k in kept}
    assert client.spin_until(
        lambda: want <= {stamp_ns(m) for _, m in client.actuator[first:]}, 5.0)
    # each bad pose is rejected once (an absurd estimate, or unreachable), and
    # only they are: the estimates after them do not see them
    def rejected(v: dict) -> int:
        return counter(v, 'rejected absurd_acceleration') + counter(v, 'rejected unreachable')
    # (every other setpoint was answered above, so none of them can add to it)
    after = client.wait_diagnostics(lambda v: rejected(v) >= rejected(before) + 3, 3.0)
    assert rejected(after) - rejected(before) == 3


@pytest.mark.parametrize('points', [1001, 10_000])
def test_a_platform_setpoint_over_max_points_is_refused_whole(client, model, points):
    base = now_ns() - 5_000_000_000 + points
    before = client.wait_diagnostics(lambda v: 'rejected bad_setpoint' in v, 3.0)
    n = len(client.actuator)
    client.send_platform(base, [(Q, QD, QDD)] * points, offsets_ns=[k * 1000 for k in
                                                                   range(points)])
    got = answered_stream(client, model, [base + points * 1000 + STEP])
    assert [stamp_ns(m) for m in got] == [base + points * 1000 + STEP]
    assert len(client.actuator) - n == 1
    after = client.wait_diagnostics(lambda v: counter(v, 'rejected bad_setpoint')
                                    > counter(before, 'rejected bad_setpoint'), 3.0)
    assert counter(after, 'rejected bad_setpoint') == counter(before, 'rejected bad_setpoint') + 1
    assert 'input.max_points' in after['last rejection']


def test_sim_time_without_clock_keeps_diagnostics_and_pose_only_answers(model):
    proc = NodeProcess('-p', 'diagnostics.period:=0.25', '-p', 'use_sim_time:=true',
                       '-r', '__ns:=/simtime', params_file=PARAMS_FILE)
    client = Client('stamps_simtime_client', namespace='/simtime')
    try:
        client.wait_for_node(proc)
        count = len(client.diagnostics)
        assert client.spin_until(lambda: len(client.diagnostics) >= count + 3, 5.0)
        values = client.wait_diagnostics(lambda v: 'stamp check' in v, 3.0)
        assert 'first /clock' in values['stamp check']
        base = now_ns()
        first = len(client.actuator)
        for k in range(5):
            client.send(base + k * STEP, (0.0, 0.0, 0.0), order='p')
        # pose only: released once the (steady-clock) wait for twist/accel expires
        assert client.spin_until(lambda: len(client.actuator) >= first + 4, 5.0)
    finally:
        client.close()
        assert proc.stop() == 0


def test_a_second_node_of_the_same_name_runs_as_ros2_allows(client, node, model):
    """ROS 2 names are not unique: a second node of the same name starts, runs
    and stops cleanly; the first one keeps answering."""
    second = NodeProcess(params_file=PARAMS_FILE)
    try:
        # up before it is stopped (a Ctrl-C while it still starts ends it by the
        # signal: seen on a loaded host, where its start takes seconds)
        assert second.wait_output('active: answering setpoints', 60.0), second.output()[-2000:]
        assert not client.spin_until(lambda: not second.alive(), 3.0), second.output()[-2000:]
        base = now_ns() - 1_000_000_000
        stamps = [stamp_ns(m) for m in answered_stream(client, model, [base])]
        assert base in stamps
    finally:
        assert second.stop() == 0
    assert node.alive()
    assert 'Traceback' not in second.output()
