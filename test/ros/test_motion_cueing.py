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
from geometry_msgs.msg import PoseStamped
from lifecycle_msgs.msg import Transition
from lifecycle_msgs.srv import ChangeState, GetState
from rcl_interfaces.msg import Parameter as RclParameter
from rcl_interfaces.srv import GetParameters, SetParameters, SetParametersAtomically
from sensor_msgs.msg import Imu

from flight_sim_dynamics.config.schema import CUEING_NODE_NAME
from flight_sim_dynamics.ros.motion_cueing import CUEING_TASK
from flight_sim_dynamics.ros.process import CUEING_MODULE
from flight_sim_dynamics.ros.setpoints import diagnostic_name, quaternion_to_rpy
from cueing_harness import G, vehicle
from node_harness import QOS, ROOT, Client, NodeProcess, stamp_ns

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
STATUS = diagnostic_name('/' + CUEING_NODE_NAME, CUEING_TASK)


class CueingClient(Client):
    """The harness client plus the cueing node's input, output and services."""

    IDEMPOTENT = Client.IDEMPOTENT | {'cue_get', 'cue_set', 'cue_atomic', 'cue_state'}
    PROBES = {**Client.PROBES,
              'cue_change': lambda: ChangeState.Request(transition=Transition(id=255))}

    def __init__(self) -> None:
        super().__init__('cueing_test_client')
        n = self.node
        self.imu_pub = n.create_publisher(Imu, 'vehicle_imu', QOS)
        self.poses: list[tuple[int, tuple[float, ...]]] = []
        self.pose_sub = n.create_subscription(PoseStamped, 'pose_setpoint', self._on_pose, QOS)
        target = '/' + CUEING_NODE_NAME
        for name, srv, path in (('cue_get', GetParameters, 'get_parameters'),
                                ('cue_set', SetParameters, 'set_parameters'),
                                ('cue_atomic', SetParametersAtomically,
                                 'set_parameters_atomically'),
                                ('cue_state', GetState, 'get_state'),
                                ('cue_change', ChangeState, 'change_state')):
            self.srv[name] = n.create_client(srv, f'{target}/{path}')
        self._vehicle_ns = time.time_ns()       # the vehicle's clock: its stamps

    def _on_pose(self, msg: PoseStamped) -> None:
        p, o = msg.pose.position, msg.pose.orientation
        self.poses.append((stamp_ns(msg), (p.x, p.y, p.z, *quaternion_to_rpy(o.x, o.y, o.z,
                                                                             o.w))))

    def next_stamp(self) -> int:
        self._vehicle_ns += 10_000_000
        return self._vehicle_ns

    def imu(self, stamp: int, f, omega) -> None:
        msg = Imu()
        msg.header.stamp = rclpy.time.Time(nanoseconds=stamp).to_msg()
        msg.header.frame_id = 'vehicle'
        a, w = msg.linear_acceleration, msg.angular_velocity
        a.x, a.y, a.z = (float(v) for v in f)
        w.x, w.y, w.z = (float(v) for v in omega)
        self.imu_pub.publish(msg)

    def cue_diagnostics(self, predicate, timeout: float = 5.0) -> dict[str, str]:
        return self.wait_diagnostics(predicate, timeout, name=STATUS)

    def replay(self, duration: float, seed: int = 1) -> tuple[int, int]:
        """The vehicle's motion from its start for ``duration`` s in real time, one
        Imu every 5 to 15 ms (irregular); (first, last) stamp of the cueing node's
        setpoints meanwhile (the node's own stamps).
        """
        rng = np.random.default_rng(seed)
        first = len(self.poses)
        start = time.monotonic()
        t = 0.0
        while t < duration:
            self.imu(self.next_stamp(), *vehicle(t))
            t += rng.uniform(0.005, 0.015)
            self.spin_until(lambda: time.monotonic() - start >= t, 1.0)
        assert len(self.poses) > first, 'no setpoint from the cueing node during the replay'
        return self.poses[first][0], self.poses[-1][0]

    def settle(self, timeout: float = 15.0) -> None:
        """Wait until the input is stale and the platform at neutral."""
        assert self.cue_diagnostics(lambda v: v.get('input') in ('stale',
                                                                  'waiting for vehicle_imu'),
                                    timeout), 'input never stale'
        assert self.spin_until(lambda: self.poses and max(map(abs, self.poses[-1][1])) < 1e-4,
                               timeout), f'not at neutral: {self.poses[-1:]}'


@pytest.fixture(scope='module')
def chain():
    """dynamics_node and motion_cueing on the hexapod's file, and a client that
    has seen the cueing node's setpoints answered and its first Imu accepted.
    """
    node = NodeProcess('-p', 'diagnostics.period:=0.25', '-p', 'sync.wait:=0.5',
                       params_file=PARAMS_FILE)
    cue = NodeProcess(*CUEING_ARGS, params_file=PARAMS_FILE, module=CUEING_MODULE)
    client = CueingClient()
    try:
        client.wait_for_node(node)
        ok = client.spin_until(lambda: client.imu_pub.get_subscription_count() > 0
                               and client.pose_sub.get_publisher_count() > 0
                               and bool(client.poses) and bool(client.actuator)
                               or not cue.alive(), 20.0)
        assert ok and cue.alive(), 'cueing node not up:\n' + cue.output()[-3000:]
        # the cueing node publishes from its activation on (neutral): answered
        # setpoints show both nodes matched; then one Imu at rest accepted
        deadline = time.monotonic() + 10.0
        while client.cue_diagnostics(lambda v: True, 2.0).get('imu accepted', '0') == '0':
            assert time.monotonic() < deadline, 'no Imu accepted:\n' + cue.output()[-3000:]
            client.imu(client.next_stamp(), (0.0, 0.0, G), (0.0, 0.0, 0.0))
        yield client, node, cue
    finally:
        client.close()
        cue.stop()
        node.stop()
        print(cue.output()[-3000:])


def dynamics_counts(client: Client) -> dict[str, int]:
    values = client.wait_diagnostics(lambda v: True, 3.0)
    return {k: int(values[k]) for k in ('setpoints answered', 'rejected total', 'limit exceeded',
                                        'near singular')}


def test_a_vehicle_log_through_both_nodes_is_answered_ok(chain):
    client, node, cue = chain
    client.settle()
    before = dynamics_counts(client)
    first, last = client.replay(3.0)
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
    client.replay(1.2)          # stopped while accelerating: displaced and tilted
    stop = len(client.poses)
    assert max(abs(v) for v in client.poses[stop - 1][1]) > 0.01, client.poses[stop - 1]
    client.settle()
    after = np.array([p for _, p in client.poses[stop - 1:]])
    # smoothly: no step between two samples larger than 2 m/s or 1 rad/s allow
    steps = np.abs(np.diff(after, axis=0)).max(axis=0)
    assert np.all(steps[:3] < 2.0 / RATE) and np.all(steps[3:] < 1.0 / RATE), steps
    values = client.cue_diagnostics(lambda v: True)
    assert values['input'] == 'stale' and values['message'].startswith('input stale')


def test_bad_messages_are_rejected_counted_and_the_node_carries_on(chain):
    client, _, cue = chain
    before = client.cue_diagnostics(lambda v: True)
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
        count = len(client.poses)
        assert client.spin_until(lambda: len(client.poses) > count + 30, 5.0)
        gaps = np.diff([s for s, _ in client.poses[count + 1:]]) * 1e-9
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
    t, changed = 0.0, False
    while t < 2.0:                       # the vehicle keeps moving after the change
        client.imu(client.next_stamp(), *vehicle(t))
        if not changed and t > 1.0:      # accelerating: the platform away from neutral
            assert max(abs(v) for v in client.poses[-1][1]) > 0.01, client.poses[-1]
            result = client.call('cue_set', SetParameters.Request(
                parameters=[gain.to_parameter_msg()])).results[0]
            assert result.successful, result.reason
            changed = True
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
