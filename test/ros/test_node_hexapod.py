"""The dynamics node on the 6-DOF hexapod (``--params-file
config/stewart_6dof.yaml``), over DDS as a user runs it: a streamed motion
with roll, pitch and yaw all moving, its twist's and acceleration's angular
part the platform's angular velocity and acceleration in the base frame,
answered with fsd.solve's numbers for the Euler-angle rates; the
platform_setpoint in any joint order; bad setpoints get a status and the next
valid one is answered; its parameters (descriptors, a live model change, a
refused one, the machine refused); docs/node.md's hexapod one-liners; lifecycle
transitions; a 3-DOF node and a hexapod side by side in two namespaces.
"""
from __future__ import annotations

import dataclasses
import itertools
import math
import time

import numpy as np
import pytest
import yaml
from builtin_interfaces.msg import Time
from lifecycle_msgs.msg import Transition
from geometry_msgs.msg import AccelStamped, PoseStamped, TwistStamped
from rcl_interfaces.srv import DescribeParameters
from rclpy.qos import QoSProfile, ReliabilityPolicy
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

import flight_sim_dynamics as fsd
from flight_sim_dynamics.machines import STEWART
from flight_sim_dynamics.machines.stewart.kinematics import (euler_rate_matrix,
                                                             euler_rate_matrix_derivative)
from flight_sim_dynamics.ros.messages import rpy_to_quaternion
from node_harness import ROOT, Client, NodeProcess, stamp_ns
from test_node_lifecycle import LifecycleClient
from test_node_readme_poke import ONE_LINER, poking_section, fill, message_type

pytestmark = pytest.mark.ros

HEXAPOD_FILE = ROOT / 'config' / 'stewart_6dof.yaml'
# a motion of every coordinate: q = A sin(w t + phase)
AMPLITUDE = np.array([0.05, 0.04, 0.03, 0.08, 0.06, 0.1])
PHASE = np.array([0.0, 0.7, 1.4, 2.1, 2.8, 3.5])
OMEGA = 2.0


def motion(t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    angle = OMEGA * t + PHASE
    return (AMPLITUDE * np.sin(angle), OMEGA * AMPLITUDE * np.cos(angle),
            -OMEGA ** 2 * AMPLITUDE * np.sin(angle))


def twist_of(q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(v, omega), (a, eps) in the base frame of the Euler-angle motion, by the
    solver's own E and dE/dt ((S2), (S3))."""
    E = euler_rate_matrix(q[None])[0]
    Ed = euler_rate_matrix_derivative(q[None], qd[None])[0]
    omega = E @ qd[3:]
    eps = E @ qdd[3:] + Ed @ qd[3:]
    return np.concatenate([qd[:3], omega]), np.concatenate([qdd[:3], eps])


def publish(client: Client, stamp: int, q, twist=None, accel=None,
            quaternion=None) -> None:
    """One setpoint: twist and acceleration (six numbers) if given, then the
    pose (q's surge, sway, heave; its roll, pitch, yaw as a quaternion unless
    given), which completes it (the streams are then expected, whatever came
    before: a pose-only stream earlier found them silent)."""
    msg_stamp = rclpy_time(stamp)
    for values, kind, pub, field in ((twist, TwistStamped, client.twist_pub, 'twist'),
                                     (accel, AccelStamped, client.accel_pub, 'accel')):
        if values is None:
            continue
        msg = kind()
        msg.header.stamp = msg_stamp
        body = getattr(msg, field)
        body.linear.x, body.linear.y, body.linear.z = (float(v) for v in values[:3])
        body.angular.x, body.angular.y, body.angular.z = (float(v) for v in values[3:])
        pub.publish(msg)
    pose = PoseStamped()
    pose.header.stamp = msg_stamp
    p = pose.pose.position
    p.x, p.y, p.z = (float(v) for v in q[:3])
    o = pose.pose.orientation
    o.x, o.y, o.z, o.w = quaternion if quaternion is not None else rpy_to_quaternion(*q[3:])
    client.pose_pub.publish(pose)


def rclpy_time(stamp: int) -> Time:
    return Time(sec=stamp // 1_000_000_000, nanosec=stamp % 1_000_000_000)


#: The stamps of the module's setpoints: increasing over its tests (one node),
#: in the past (input.max_future), after the discovery probes.
_STAMPS = itertools.count(15 * 10 ** 17, 10_000_000)


def stamps(n: int) -> list[int]:
    """``n`` stamps 10 ms apart, more than estimator.max_gap after the last ones
    (a new stream: the estimator restarts)."""
    for _ in range(100):
        next(_STAMPS)
    return [next(_STAMPS) for _ in range(n)]


def answer(client: Client, stamp: int, timeout: float = 10.0):
    """The actuator_states and joint_states stamped ``stamp`` (None: not answered)."""
    def found():
        a = next((m for _, m in reversed(client.actuator) if stamp_ns(m) == stamp), None)
        j = next((m for m in reversed(client.joints) if stamp_ns(m) == stamp), None)
        return (a, j) if a is not None and j is not None else None
    client.spin_until(lambda: found() is not None, timeout)
    return found()


def assert_solved(msgs, sol) -> None:
    actuator, joints = msgs
    assert list(actuator.name) == list(STEWART.legs)
    assert list(joints.name) == list(STEWART.joints)
    np.testing.assert_allclose(actuator.position, sol.length, rtol=0, atol=1e-12)
    np.testing.assert_allclose(actuator.velocity, sol.rate, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(actuator.effort, sol.force, rtol=1e-9, atol=1e-8)
    np.testing.assert_allclose(joints.position, sol.joints.ravel(), rtol=0, atol=1e-12)
    np.testing.assert_allclose(joints.velocity, sol.joint_rates.ravel(), rtol=1e-9,
                               atol=1e-12)


@pytest.fixture(scope='module')
def hexapod():
    proc = NodeProcess('-p', 'diagnostics.period:=0.25',
                       '-p', 'sync.wait:=0.5', params_file=HEXAPOD_FILE)
    yield proc
    proc.stop()


@pytest.fixture(scope='module')
def client(hexapod):
    c = Client('hexapod_client')
    try:
        c.wait_for_node(hexapod)
        probes = itertools.count(10 ** 18, 5_000_000)
        c.round_trip(lambda: next(probes))
        yield c
    finally:
        c.close()


@pytest.fixture(scope='module')
def model():
    return fsd.load_model(HEXAPOD_FILE)


def test_a_streamed_motion_is_answered_with_the_solvers_numbers(client, model):
    """Roll, pitch and yaw all moving: the node's answers are fsd.solve's at
    the Euler-angle rates and accelerations of the twist's angular velocity and
    the acceleration's angular acceleration."""
    expected = {}
    for k, stamp in enumerate(stamps(60)):
        q, qd, qdd = motion(0.01 * k)
        twist, accel = twist_of(q, qd, qdd)
        assert np.all(np.abs(qd[3:]) > 1e-3)        # every angle moving
        publish(client, stamp, q, twist, accel)
        expected[stamp] = fsd.solve(model, q, qd, qdd)
        if k % 10 == 9:
            client.spin_until(lambda: False, 0.02)
    for stamp, sol in expected.items():
        msgs = answer(client, stamp)
        assert msgs is not None, f'{stamp} not answered' + client.explain()
        assert_solved(msgs, sol)
    values = client.wait_diagnostics(lambda v: int(v['setpoints answered']) >= 60)
    assert 'ignored sway' not in values and 'kinematic condition last' not in values
    assert float(values['Jacobian condition last']) > 1.0


def test_pose_only_stream_is_estimated_and_answered(client, model):
    sent = stamps(20)
    for k, stamp in enumerate(sent):
        publish(client, stamp, motion(0.01 * k)[0])
    last = answer(client, sent[-1])
    assert last is not None, client.explain()
    q, qd, _ = motion(0.19)
    # BDF2 of a 2 rad/s sine at 100 Hz: rates within a few per mille of the truth
    np.testing.assert_allclose(last[0].velocity, fsd.solve(model, q, qd, qd * 0).rate,
                               atol=2e-3)


def test_platform_setpoint_in_any_joint_order(client, model):
    names = ['yaw', 'heave', 'roll', 'surge', 'pitch', 'sway']
    order = [STEWART.coordinates.index(n) for n in names]
    q, qd, qdd = motion(0.3)
    msg = JointTrajectory(joint_names=names)
    stamp, later = stamps(2)
    msg.header.stamp = rclpy_time(stamp)
    msg.points = [JointTrajectoryPoint(positions=[float(q[i]) for i in order],
                                       velocities=[float(qd[i]) for i in order],
                                       accelerations=[float(qdd[i]) for i in order])]
    client.platform_pub.publish(msg)
    msgs = answer(client, stamp)
    assert msgs is not None, client.explain()
    assert_solved(msgs, fsd.solve(model, q, qd, qdd))
    # the 3-DOF machine's names are refused whole
    bad = JointTrajectory(joint_names=['surge', 'heave', 'roll'])
    bad.header.stamp = rclpy_time(later)
    bad.points = [JointTrajectoryPoint(positions=[0.0, 0.0, 0.0])]
    client.platform_pub.publish(bad)
    client.wait_diagnostics(lambda v: int(v['rejected bad_setpoint']) >= 1)


@pytest.mark.parametrize('bad, reason', [
    ({'quaternion': (0.0, 0.0, math.nan, 1.0)}, 'non_finite'),          # a NaN yaw
    ({'quaternion': (0.0, 0.0, 0.0, 0.0)}, 'bad_quaternion'),
    ({'q': (0.0, 0.0, 0.8, 0.0, 0.0, 0.0)}, 'limit exceeded'),          # past the strokes
])
def test_a_bad_setpoint_gets_a_status_and_the_next_is_answered(client, model, bad, reason):
    key = reason if ' ' in reason else f'rejected {reason}'
    before = client.wait_diagnostics(lambda v: key in v)
    stamp, after = stamps(2)
    zero = np.zeros(6)
    publish(client, stamp, np.array(bad.get('q', zero)), zero, zero,
            quaternion=bad.get('quaternion'))
    values = client.wait_diagnostics(lambda v: int(v[key]) > int(before[key]))
    assert int(values['level']) == 2, values            # ERROR
    if reason == 'limit exceeded':      # published anyway, the solver's numbers
        q = np.array(bad['q'])
        msgs = answer(client, stamp)
        assert msgs is not None and fsd.solve(model, q, zero, zero).status.value == 'limit'
        assert_solved(msgs, fsd.solve(model, q, zero, zero))
    q, qd, qdd = motion(0.5)
    twist, accel = twist_of(q, qd, qdd)
    publish(client, after, q, twist, accel)
    msgs = answer(client, after)
    assert msgs is not None, client.explain()
    assert_solved(msgs, fsd.solve(model, q, qd, qdd))


def test_parameters_are_the_hexapods(client, model):
    response = client.call('describe', DescribeParameters.Request(
        names=['machine', 'limits.length_min', 'geometry.base_joints', 'input.max_future']))
    machine, length_min, joints, max_future = response.descriptors
    assert machine.read_only and 'machine' in machine.description
    assert not length_min.read_only and length_min.floating_point_range[0].from_value == 0.0
    assert '[m]' in length_min.description
    assert joints.additional_constraints == '18 numbers'
    assert max_future.floating_point_range[0].to_value == 86400.0
    assert client.get_params(['machine', 'limits.length_max']) == ['stewart_6dof', 1.55]


def test_the_machine_is_not_a_live_parameter(client):
    for atomic in (False, True):
        [result] = client.set_params({'machine': 'flight_simulator_3dof'}, atomic=atomic)
        assert not result.successful and 'read-only' in result.reason
        assert 'another node' in result.reason
    assert client.get_params(['machine']) == ['stewart_6dof']


def test_a_model_parameter_changes_live_and_a_bad_one_is_refused(client, model, tmp_path):
    [refused] = client.set_params({'limits.length_max': 0.5})
    assert not refused.successful and 'length_max' in refused.reason
    [accepted] = client.set_params({'bodies.platform.mass': 200.0})
    assert accepted.successful, accepted.reason
    path = tmp_path / 'heavy.yaml'
    path.write_text(yaml.safe_dump({'flight_sim_dynamics': {'ros__parameters': {
        'machine': 'stewart_6dof', 'bodies': {'platform': {'mass': 200.0}}}}}))
    heavy = fsd.load_model(path)
    q, qd, qdd = motion(0.7)
    twist, accel = twist_of(q, qd, qdd)
    [stamp] = stamps(1)
    publish(client, stamp, q, twist, accel)
    msgs = answer(client, stamp)
    assert msgs is not None, client.explain()
    assert_solved(msgs, fsd.solve(heavy, q, qd, qdd))
    assert not np.allclose(msgs[0].effort, fsd.solve(model, q, qd, qdd).force)
    [back] = client.set_params({'bodies.platform.mass': float(model.platform.mass)})
    assert back.successful
    # the scene switches the hexapod's effects as the 3-DOF machine's
    [scene] = client.set_params({'scene': 'quasi_static'})
    assert scene.successful, scene.reason
    [stamp] = stamps(1)
    publish(client, stamp, q, twist, accel)
    msgs = answer(client, stamp)
    assert msgs is not None, client.explain()
    quasi = fsd.load_model(HEXAPOD_FILE, scene='quasi_static')
    assert_solved(msgs, fsd.solve(quasi, q, qd, qdd))
    [unknown] = client.set_params({'scene': 'no_such_scene'})
    assert not unknown.successful
    assert client.set_params({'scene': 'full'})[0].successful


def test_the_readme_one_liners_for_the_hexapod_are_answered(client):
    text = poking_section().split('On a hexapod', 1)[1]
    commands = ONE_LINER.findall(text)
    assert [topic for topic, _, _ in commands] == ['/pose_setpoint', '/platform_setpoint']
    qos = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE)
    for topic, type_name, body in commands:
        kind = message_type(type_name)
        msg = kind()
        now = time.time_ns()
        fill(msg, yaml.safe_load(body), now)
        pub = client.node.create_publisher(kind, 'pose_setpoint' if 'pose' in topic
                                           else 'platform_setpoint', qos)
        assert client.spin_until(lambda: pub.get_subscription_count() > 0, 10.0)
        before = len(client.actuator)
        pub.publish(msg)
        assert client.spin_until(lambda: len(client.actuator) > before, 10.0), \
            f'{topic}: not answered' + client.explain()
        assert stamp_ns(client.actuator[-1][1]) == now
        assert len(client.actuator[-1][1].effort) == 6
        client.node.destroy_publisher(pub)


def test_diagnostics_name_the_scene(client):
    values = client.wait_diagnostics(lambda v: 'scene' in v)
    assert values['scene'] == 'full'


# -- nodes of their own: a namespace needs a section that reaches it ----------------
def namespaced_file(tmp_path) -> str:
    """The packaged hexapod for a node in any namespace (a section named
    ``flight_sim_dynamics`` reaches only the root namespace's node)."""
    path = tmp_path / 'hexapod.yaml'
    path.write_text(yaml.safe_dump({'/**': {'ros__parameters': {'machine': 'stewart_6dof'}}}))
    return str(path)


def test_lifecycle_transitions_on_the_hexapod(tmp_path, model):
    proc = NodeProcess('-p', 'autostart:=false', '-p', 'diagnostics.period:=0.2',
                       '-r', '__ns:=/lc6', params_file=namespaced_file(tmp_path))
    client = LifecycleClient('/lc6')
    client.watch = proc
    q, qd, qdd = motion(0.2)
    twist, accel = twist_of(q, qd, qdd)
    expected = fsd.solve(model, q, qd, qdd)

    def answered() -> bool:
        stamp = time.time_ns()
        publish(client, stamp, q, twist, accel)
        msgs = answer(client, stamp, 3.0)
        if msgs is not None:
            assert_solved(msgs, expected)
        return msgs is not None
    try:
        assert client.spin_until(lambda: client.srv['get_state'].service_is_ready(), 20.0)
        assert client.state() == 'unconfigured'
        assert client.change(Transition.TRANSITION_CONFIGURE)
        assert client.state() == 'inactive'
        client.wait_matched()
        assert not answered()
        assert client.wait_diagnostics(lambda v: int(v['rejected inactive']) >= 1)
        assert client.change(Transition.TRANSITION_ACTIVATE)
        assert answered()
        assert client.change(Transition.TRANSITION_DEACTIVATE)
        assert not answered()
        assert client.change(Transition.TRANSITION_CLEANUP)
        assert client.state() == 'unconfigured'
        # configured again, the same machine: answered again
        assert client.change(Transition.TRANSITION_CONFIGURE)
        assert client.change(Transition.TRANSITION_ACTIVATE)
        client.wait_matched()
        assert answered()
        assert client.get_params(['machine']) == ['stewart_6dof']
        client.watch = None
        assert client.change(Transition.TRANSITION_ACTIVE_SHUTDOWN)
        proc.proc.wait(10.0)
        assert proc.proc.returncode == 0, proc.output()[-3000:]
    finally:
        client.close()
        proc.stop()
    assert 'Traceback' not in proc.output()


def test_two_machines_side_by_side_in_two_namespaces(model):
    """A 3-DOF node in /three and a hexapod in /six, the latter on the packaged
    file itself (its `/**/flight_sim_dynamics` reaches a node in any namespace):
    each answers its own setpoints with its own legs and numbers; neither takes
    a machine change."""
    three = NodeProcess('-r', '__ns:=/three', '-p', 'sync.wait:=0.5')
    six = NodeProcess('-r', '__ns:=/six', '-p', 'sync.wait:=0.5', params_file=HEXAPOD_FILE)
    clients = {'/three': Client('three_client', '/three'), '/six': Client('six_client', '/six')}
    try:
        for (ns, c), proc in zip(clients.items(), (three, six)):
            c.wait_for_node(proc)
            probes = itertools.count(10 ** 18, 5_000_000)
            c.round_trip(lambda: next(probes))
        assert clients['/six'].get_params(['machine']) == ['stewart_6dof']
        # the 3-DOF machine: surge, heave, roll of the same kind of messages
        flight = fsd.load_model()
        q3, qd3, qdd3 = (0.02, 0.05, 0.1), (0.1, 0.0, 0.2), (0.0, 0.5, 0.0)
        stamp = 16 * 10 ** 17
        clients['/three'].send(stamp, q3, qd3, qdd3)
        q, qd, qdd = motion(0.4)
        twist, accel = twist_of(q, qd, qdd)
        publish(clients['/six'], stamp, q, twist, accel)
        msgs = answer(clients['/six'], stamp)
        assert msgs is not None, clients['/six'].explain()
        assert_solved(msgs, fsd.solve(model, q, qd, qdd))
        msgs3 = answer(clients['/three'], stamp)
        assert msgs3 is not None, clients['/three'].explain()
        assert list(msgs3[0].name) == ['leg_a', 'leg_b', 'leg_c']
        np.testing.assert_allclose(msgs3[0].effort, fsd.solve(flight, q3, qd3, qdd3).force,
                                   rtol=1e-12)
        # each answered its own only
        assert all(len(m.name) == 3 for _, m in clients['/three'].actuator)
        assert all(len(m.name) == 6 for _, m in clients['/six'].actuator)
        for c, other in ((clients['/three'], 'stewart_6dof'),
                         (clients['/six'], 'flight_simulator_3dof')):
            [result] = c.set_params({'machine': other})
            assert not result.successful and 'read-only' in result.reason
    finally:
        for c in clients.values():
            c.close()
        three.stop()
        six.stop()


def test_a_bad_start_up_value_of_the_hexapod_ends_the_start():
    """Checked by the hexapod's own declarations and builder, as the 3-DOF
    machine's: one error line, exit status 2."""
    for args in (('-p', 'limits.length_min:=-1.0'), ('-p', 'limits.length_max:=0.5')):
        proc = NodeProcess(*args, params_file=HEXAPOD_FILE)
        try:
            assert proc.proc.wait(30.0) == 2, proc.output()[-2000:]
            out = proc.output()
            assert 'error: invalid parameters' in out and 'limits.length_' in out, out[-2000:]
        finally:
            proc.stop()


def test_a_section_that_does_not_reach_the_node_is_refused(tmp_path):
    """A file of one's own with a bare `flight_sim_dynamics:` section naming the
    hexapod, in a namespace: ROS gives the node none of its parameters; the node
    refuses to start (exit 2) rather than run the 3-DOF machine."""
    path = tmp_path / 'bare.yaml'
    path.write_text(yaml.safe_dump({'flight_sim_dynamics': {
        'ros__parameters': {'machine': 'stewart_6dof'}}}))
    proc = NodeProcess('-r', '__ns:=/elsewhere', params_file=str(path))
    try:
        assert proc.proc.wait(30.0) == 2
        assert 'error:' in proc.output() and 'machine' in proc.output()
    finally:
        proc.stop()


def test_a_payload_the_scene_leaves_out_is_logged(tmp_path):
    """``payload: {mass: 80}`` with the scene ``full``: the node says it simulates
    no payload (a log line naming the parameter); with ``scene: payload``, or
    the packaged files' own values, it says nothing."""
    lines = []
    for scene in ('full', 'payload'):
        path = tmp_path / f'{scene}.yaml'
        path.write_text(yaml.safe_dump({'flight_sim_dynamics': {'ros__parameters': {
            'machine': 'stewart_6dof', 'scene': scene, 'payload': {'mass': 80.0}}}}))
        proc = NodeProcess(params_file=path)
        try:
            assert proc.wait_output('active: answering setpoints'), proc.output()[-2000:]
            lines.append([line for line in proc.output().splitlines()
                          if 'payload.mass' in line and 'WARN' in line])
        finally:
            proc.stop()
    proc = NodeProcess(params_file=ROOT / 'config' / 'flight_sim_dynamics.yaml')
    try:      # the packaged 3-DOF file gives its 140 kg payload: no news with scene full
        assert proc.wait_output('active: answering setpoints'), proc.output()[-2000:]
        lines.append([line for line in proc.output().splitlines() if 'not simulated' in line])
    finally:
        proc.stop()
    assert len(lines[0]) == 1 and "'full'" in lines[0][0], lines
    assert lines[1] == [] and lines[2] == [], lines


def test_a_hexapod_beyond_its_u_joint_limit_reports_an_exceeded_limit(tmp_path, model):
    """``limits.u_joint_max_angle: 0.30`` rad, below the U-joints' angle at home
    (about 0.5 rad): a setpoint at home has the status limit; the node
    publishes fsd.solve's numbers, and /diagnostics is ERROR and counts it a
    limit exceeded, as the status promises."""
    path = tmp_path / 'u_joint.yaml'
    path.write_text(yaml.safe_dump({'/**': {'ros__parameters': {
        'machine': 'stewart_6dof', 'limits': {'u_joint_max_angle': 0.30}}}}))
    limited = dataclasses.replace(model, limits=dataclasses.replace(model.limits,
                                                                    u_joint_max_angle=0.30))
    zero = np.zeros(6)
    assert fsd.solve(limited, zero, zero, zero).status.value == 'limit'
    proc = NodeProcess('-r', '__ns:=/u_joint', '-p', 'diagnostics.period:=0.25',
                       '-p', 'sync.wait:=0.5', params_file=path)
    client = Client('u_joint_client', '/u_joint')
    try:
        client.wait_for_node(proc)
        probes = itertools.count(10 ** 18, 5_000_000)
        client.round_trip(lambda: next(probes))
        [stamp] = stamps(1)
        publish(client, stamp, zero, zero, zero)
        msgs = answer(client, stamp)
        assert msgs is not None, client.explain()
        assert_solved(msgs, fsd.solve(limited, zero, zero, zero))
        values = client.wait_diagnostics(
            lambda v: int(v['limit exceeded']) >= 1 and int(v['level']) == 2)   # ERROR
        assert int(values['setpoints answered']) >= 1
    finally:
        client.close()
        proc.stop()
    assert 'Traceback' not in proc.output()
