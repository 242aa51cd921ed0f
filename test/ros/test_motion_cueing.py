"""The motion-cueing node as a user runs it: ``motion_cueing`` and
``dynamics_node`` as processes on the same parameter file (the hexapod), a
vehicle's motion replayed as ``sensor_msgs/Imu`` on ``vehicle_imu`` at an
irregular rate, the setpoints answered by the dynamics node; bad messages,
the input stopping, parameter sets and requests that must not take it down.
"""
from __future__ import annotations

import math
import time

import numpy as np
import pytest
import rclpy
from lifecycle_msgs.msg import Transition
from lifecycle_msgs.srv import ChangeState, GetState
from rcl_interfaces.msg import Parameter as RclParameter
from rcl_interfaces.srv import GetParameters, SetParameters, SetParametersAtomically

from cueing_harness import G, dynamics_counts, start_chain, vehicle
from node_harness import ROOT, stamp_ns

pytestmark = pytest.mark.ros

PARAMS_FILE = ROOT / 'config' / 'stewart_6dof.yaml'
RATE = 200.0            # Hz, the cueing node's output in these tests (a light load)
#: a washout that is back at neutral about three seconds after the vehicle stops (the
#: tests wait for it; omega_b = 0: no slow return term)
CUEING_ARGS = ('-p', f'cueing.rate:={RATE}', '-p', 'diagnostics.period:=0.25',
               '-p', 'input.timeout:=0.1',
               '-p', 'cueing.translation.omega:=[3.0, 3.0, 3.0]',
               '-p', 'cueing.translation.omega_b:=[0.0, 0.0, 0.0]',
               '-p', 'cueing.rotation.omega:=[3.0, 3.0, 3.0]',
               '-p', 'cueing.tilt.omega:=[4.0, 4.0]',
               '-p', 'cueing.tilt.rate_limit:=0.2')


@pytest.fixture(scope='module')
def chain():
    """dynamics_node and motion_cueing on the hexapod's file, and a client that
    has seen the cueing node's setpoints answered and its first Imu accepted.
    """
    node, cue, client = start_chain(PARAMS_FILE, CUEING_ARGS)
    try:
        yield client, node, cue
    finally:
        client.close()
        cue.stop()
        node.stop()
        print(cue.output()[-3000:])


def test_a_vehicle_log_through_both_nodes_is_answered_ok(chain):
    client, node, cue = chain
    client.settle()
    before = dynamics_counts(client)
    first, _ = client.replay(3.0)
    client.settle()             # the whole cue, back to neutral (a loaded host lags)
    last = client.poses[-1][0]
    stamps = [s for s, _ in client.poses if first <= s <= last]
    assert client.spin_until(lambda: {stamp_ns(m) for _, m in client.actuator}.issuperset(
        stamps), 5.0), 'setpoints not answered'
    after = dynamics_counts(client)
    assert after['setpoints answered'] - before['setpoints answered'] >= len(stamps)
    for key in ('rejected total', 'limit exceeded', 'near singular'):
        assert after[key] == before[key], (key, before, after)
    # it moved: a cue on every axis the vehicle moved
    motion = np.array([p for s, p in client.poses if first <= s <= last])
    assert np.all(np.abs(motion).max(axis=0) > 1e-3), np.abs(motion).max(axis=0)
    # at the output rate, stamped in order
    gaps = np.diff(stamps) * 1e-9
    assert np.all(gaps > 0) and np.median(gaps) == pytest.approx(1.0 / RATE, rel=1e-3)
    values = client.cue_diagnostics(lambda v: v.get('input') == 'stale', 5.0)
    assert values['rejected total'] == '0'
    assert cue.alive() and node.alive()


def test_the_platform_washes_back_to_neutral_when_the_input_stops(chain):
    client, _, cue = chain
    client.settle()
    # stopped while accelerating and turning (yaw rate 0.3 rad/s): displaced and tilted
    start, start_accel = len(client.poses), len(client.accels)
    client.replay(1.2)
    client.settle()
    after = np.array([p for _, p in client.poses[start:]])
    assert np.abs(after).max() > 0.01, np.abs(after).max(axis=0)
    # smoothly: no step between two samples larger than 2 m/s or 1 rad/s allow
    steps = np.abs(np.diff(after, axis=0)).max(axis=0)
    assert np.all(steps[:3] < 2.0 / RATE) and np.all(steps[3:] < 1.0 / RATE), steps
    # nor an acceleration spike: the rates joined to the rest over input.timeout, not
    # at once (k_r 0.6 x 0.3 rad/s in one 5 ms sample: 36 rad/s^2 of yaw)
    accels = np.abs([a for _, a in client.accels[start_accel:]]).max(axis=0)
    assert np.all(accels[3:] < 5.0) and np.all(accels[:3] < 5.0), accels
    # a period without problems says the input's state (one with samples late on a
    # busy host says that instead)
    values = client.cue_diagnostics(lambda v: v['status'] == 'OK', 15.0)
    assert values['input'] == 'stale' and values['message'].startswith('input stale')


def test_bad_messages_are_rejected_counted_and_the_node_carries_on(chain):
    client, _, cue = chain
    before = client.caught_up()
    stamp = client.next_stamp()
    client.imu(stamp, (0.0, 0.0, G), (0.0, 0.0, 0.0))
    client.imu(stamp, (0.0, 0.0, G), (0.0, 0.0, 0.0))                       # repeated
    client.imu(stamp - 5_000_000, (0.0, 0.0, G), (0.0, 0.0, 0.0))           # backwards
    client.imu(client.next_stamp(), (math.nan, 0.0, G), (0.0, 0.0, 0.0))    # NaN
    client.imu(client.next_stamp(), (0.0, 0.0, G), (0.0, math.inf, 0.0))    # infinite
    client.imu(client.next_stamp(), (1e300, 0.0, G), (0.0, 0.0, 0.0))       # no vehicle's
    client.imu(client.next_stamp(), (0.0, 0.0, G), (0.0, 0.0, -1e3))
    count = len(client.poses)

    def counted(v: dict[str, str]) -> bool:
        return all(int(v[f'rejected {reason}']) - int(before[f'rejected {reason}']) == n
                   for reason, n in (('non_finite', 2), ('stamp_backwards', 1),
                                     ('stamp_repeated', 1), ('out_of_range', 2)))
    values = client.cue_diagnostics(counted, 5.0)
    assert int(values['imu accepted']) - int(before['imu accepted']) == 1
    assert client.spin_until(lambda: len(client.poses) > count + 20, 5.0), 'output stopped'
    assert all(math.isfinite(v) for _, p in client.poses for v in p)
    assert cue.alive()
    assert 'vehicle_imu rejected' in cue.output()


def test_parameters_are_validated_and_a_good_set_applies(chain):
    client, _, cue = chain
    client.settle()
    rejections = int(client.cue_diagnostics(lambda v: True)['parameter rejections'])
    old = client.call('cue_get', GetParameters.Request(names=['cueing.rate']))
    assert old.values[0].double_value == RATE
    for name, value in (('cueing.rate', -1.0), ('cueing.limiter', 'bogus'),
                        ('cueing.tilt.gain', [0.1, 0.2, 0.3]), ('input.timeout', 0.0)):
        params = [rclpy.parameter.Parameter(name, value=value).to_parameter_msg()]
        result = client.call('cue_set', SetParameters.Request(parameters=params)).results[0]
        assert not result.successful and name in result.reason, (name, result.reason)
    read_only = rclpy.parameter.Parameter('params_file', value='/tmp/x.yaml').to_parameter_msg()
    result = client.call('cue_set', SetParameters.Request(parameters=[read_only])).results[0]
    assert not result.successful and 'read-only' in result.reason
    unknown_type = RclParameter(name='cueing.rate')
    unknown_type.value.type = 99                      # rclpy 7.1.6 dies on it unguarded
    result = client.call('cue_atomic', SetParametersAtomically.Request(
        parameters=[unknown_type])).result
    assert not result.successful
    values = client.cue_diagnostics(
        lambda v: int(v['parameter rejections']) >= rejections + 4, 5.0)
    assert values['rate (Hz)'] == f'{RATE:g}'
    # a good set: the planner rebuilt at the new rate (at neutral: at once)
    try:
        good = rclpy.parameter.Parameter('cueing.rate', value=100.0).to_parameter_msg()
        assert client.call('cue_set', SetParameters.Request(parameters=[good])).results[0] \
            .successful
        client.cue_diagnostics(lambda v: v['rate (Hz)'] == '100', 5.0)
        # (samples of the old rate may still be on their way: the last 30 count)
        count = len(client.poses)
        assert client.spin_until(lambda: len(client.poses) > count + 60, 5.0)
        gaps = np.diff([s for s, _ in client.poses[-31:]]) * 1e-9
        assert np.median(gaps) == pytest.approx(0.01, rel=1e-3)
        assert np.all(gaps > 0)
    finally:
        back = rclpy.parameter.Parameter('cueing.rate', value=RATE).to_parameter_msg()
        client.call('cue_set', SetParameters.Request(parameters=[back]))
    client.cue_diagnostics(lambda v: v['rate (Hz)'] == f'{RATE:g}', 5.0)
    assert cue.alive()


def test_requests_a_lifecycle_client_can_send_leave_it_running(chain):
    client, _, cue = chain
    for transition in (Transition(id=200), Transition(id=Transition.TRANSITION_CONFIGURE),
                       Transition(label='no_such_transition')):
        response = client.call('cue_change', ChangeState.Request(transition=transition))
        assert not response.success
    assert client.call('cue_state', GetState.Request()).current_state.label == 'active'
    count = len(client.poses)
    assert client.spin_until(lambda: len(client.poses) > count + 10, 5.0)
    assert cue.alive()


def test_a_planner_change_mid_run_waits_for_neutral_without_a_jump(chain):
    client, _, cue = chain
    client.settle()
    gain = rclpy.parameter.Parameter('cueing.translation.gain', value=[0.3, 0.3, 0.25])
    rng = np.random.default_rng(2)
    start = time.monotonic()
    first = len(client.poses)
    t, changed_at = 0.0, None
    # the vehicle accelerating and turning, held from 1.2 s on (the platform stays
    # tilted); the change once the platform is seen away from neutral, then one
    # more second of the vehicle (a loaded host delays what the node sends)
    while changed_at is None or t < changed_at + 1.0:
        assert t < 20.0, 'the platform never left neutral'
        client.imu(client.next_stamp(), *vehicle(min(t, 1.2)))
        if changed_at is None and max(abs(v) for v in client.poses[-1][1]) > 0.01:
            result = client.call('cue_set', SetParameters.Request(
                parameters=[gain.to_parameter_msg()])).results[0]
            assert result.successful, result.reason
            changed_at = t
        t += rng.uniform(0.005, 0.015)
        client.spin_until(lambda: time.monotonic() - start >= t, 1.0)
    pending = client.cue_diagnostics(lambda v: True)
    assert pending['parameter change pending'].startswith('yes'), pending
    assert client.call('cue_get', GetParameters.Request(
        names=['cueing.translation.gain'])).values[0].double_array_value.tolist() == \
        [0.3, 0.3, 0.25]
    client.settle()
    client.cue_diagnostics(lambda v: v['parameter change pending'] == 'no', 5.0)
    assert 'the new planner took over' in cue.output()
    motion = np.array([p for _, p in client.poses[first:]])
    steps = np.abs(np.diff(motion, axis=0)).max(axis=0)
    assert np.all(steps[:3] < 2.0 / RATE) and np.all(steps[3:] < 1.0 / RATE), steps


def test_deactivate_stops_the_setpoints_and_activate_starts_at_neutral(chain):
    client, _, cue = chain
    client.settle()
    deactivate = ChangeState.Request(transition=Transition(
        id=Transition.TRANSITION_DEACTIVATE))
    activate = ChangeState.Request(transition=Transition(id=Transition.TRANSITION_ACTIVATE))
    try:
        assert client.call('cue_change', deactivate, timeout=10.0).success
        assert client.call('cue_state', GetState.Request()).current_state.label == 'inactive'
        count = len(client.poses)
        client.imu(client.next_stamp(), (1.0, 0.0, G), (0.0, 0.0, 0.0))
        values = client.cue_diagnostics(lambda v: v['rejected inactive'] != '0'
                                        and v['lifecycle state'] == 'inactive', 5.0)
        assert values['input'] == 'inactive'
        # what was queued before the deactivation may still arrive; nothing after
        client.spin_until(lambda: False, 0.3)
        count = len(client.poses)
        client.spin_until(lambda: False, 0.5)
        assert len(client.poses) == count
    finally:
        assert client.call('cue_change', activate, timeout=10.0).success
    assert client.spin_until(lambda: len(client.poses) > count + 20, 5.0)
    assert all(max(map(abs, p)) == 0.0 for _, p in client.poses[count:count + 20])
    client.cue_diagnostics(lambda v: v['input'] == 'waiting for vehicle_imu', 5.0)
    assert cue.alive()


def test_a_change_set_back_before_neutral_is_void(chain):
    """A change waiting for neutral, then the running planner's values set again:
    nothing waits any more (the waiting planner is not installed later)."""
    client, _, cue = chain
    client.settle()
    running = client.call('cue_get', GetParameters.Request(
        names=['cueing.rotation.gain'])).values[0].double_array_value.tolist()
    start, t, rng = time.monotonic(), 0.0, np.random.default_rng(4)
    while max(abs(v) for v in client.poses[-1][1]) <= 0.01:
        assert t < 20.0, 'the platform never left neutral'
        client.imu(client.next_stamp(), *vehicle(min(t, 1.2)))
        t += rng.uniform(0.005, 0.015)
        client.spin_until(lambda: time.monotonic() - start >= t, 1.0)
    for value in ([0.1, 0.1, 0.1], running):
        param = rclpy.parameter.Parameter('cueing.rotation.gain', value=value)
        assert client.call('cue_set', SetParameters.Request(
            parameters=[param.to_parameter_msg()])).results[0].successful
    client.settle()
    values = client.cue_diagnostics(lambda v: True)
    assert values['parameter change pending'] == 'no'
    assert cue.output().count('the new planner took over') == \
        cue.output().count('the new planner takes over once') - 1
