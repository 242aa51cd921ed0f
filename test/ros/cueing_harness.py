"""What the motion-cueing tests share: a vehicle's motion (:func:`vehicle`),
its log as the demo and ``cue`` read it (:func:`write_vehicle_log`), the
harness client with the cueing node's input, output and services
(:class:`CueingClient`), and both nodes started and matched (:func:`start_chain`).
"""
from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np
import rclpy
from geometry_msgs.msg import AccelStamped, PoseStamped
from lifecycle_msgs.srv import ChangeState, GetState
from rcl_interfaces.srv import GetParameters, SetParameters, SetParametersAtomically
from sensor_msgs.msg import Imu

from flight_sim_dynamics.config.schema import CUEING_NODE_NAME, CUEING_TASK
from flight_sim_dynamics.ros.process import CUEING_MODULE
from flight_sim_dynamics.ros.diagnostics import diagnostic_name
from flight_sim_dynamics.ros.messages import quaternion_to_rpy
from node_harness import QOS, Client, NodeProcess, stamp_ns

G = 9.80665     # m/s^2, the specific force of a vehicle at rest and level
#: the cueing node's status in /diagnostics
STATUS = diagnostic_name('/' + CUEING_NODE_NAME, CUEING_TASK)


def vehicle(t: float) -> tuple[tuple[float, float, float], tuple[float, float, float]]:
    """A vehicle's specific force and angular velocity at ``t`` s: at rest, then
    accelerating (surge) and climbing (heave), then a turn (sway and yaw) with
    a roll rate, smooth (raised-cosine) edges; at rest again after 2.5 s.
    """
    def pulse(start: float, end: float, edge: float = 0.2) -> float:
        if t <= start or t >= end:
            return 0.0
        rise = min(1.0, (t - start) / edge, (end - t) / edge)
        return 0.5 - 0.5 * math.cos(math.pi * rise)
    accelerate, turn = pulse(0.2, 1.4), pulse(1.0, 2.5)
    f = (2.0 * accelerate, 1.5 * turn, G + 1.0 * pulse(0.3, 0.9))
    omega = (0.15 * pulse(1.0, 1.6), 0.05 * accelerate, 0.3 * turn)
    return f, omega


def write_vehicle_log(path: Path, duration: float = 2.0, rate: float = 100.0) -> None:
    """:func:`vehicle` from 0 to ``duration`` s at ``rate``, as a CSV log
    (``t, f_x, f_y, f_z, omega_x, omega_y, omega_z``).
    """
    rows = ['t,f_x,f_y,f_z,omega_x,omega_y,omega_z']
    for k in range(int(round(duration * rate)) + 1):
        f, omega = vehicle(k / rate)
        rows.append(','.join(repr(v) for v in (k / rate, *f, *omega)))
    path.write_text('\n'.join(rows) + '\n')


class CueingClient(Client):
    """The harness client plus the cueing node's input, output and services."""

    def __init__(self) -> None:
        super().__init__('cueing_test_client')
        n = self.node
        self.imu_pub = n.create_publisher(Imu, 'vehicle_imu', QOS)
        self.poses: list[tuple[int, tuple[float, ...]]] = []
        self.pose_sub = n.create_subscription(PoseStamped, 'pose_setpoint', self._on_pose, QOS)
        #: (stamp, linear and angular acceleration) of accel_setpoint
        self.accels: list[tuple[int, tuple[float, ...]]] = []
        self.accel_sub = n.create_subscription(AccelStamped, 'accel_setpoint', lambda m: (
            self.accels.append((stamp_ns(m), (m.accel.linear.x, m.accel.linear.y,
                                              m.accel.linear.z, m.accel.angular.x,
                                              m.accel.angular.y, m.accel.angular.z)))), QOS)
        target = '/' + CUEING_NODE_NAME
        for name, srv, path in (('cue_get', GetParameters, 'get_parameters'),
                                ('cue_set', SetParameters, 'set_parameters'),
                                ('cue_atomic', SetParametersAtomically,
                                 'set_parameters_atomically'),
                                ('cue_state', GetState, 'get_state'),
                                ('cue_change', ChangeState, 'change_state')):
            self.srv[name] = n.create_client(srv, f'{target}/{path}')
        self._vehicle_ns = time.time_ns()       # the vehicle's clock: its stamps
        self.sent = 0                           # Imu messages published

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
        self.sent += 1

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

    def caught_up(self, timeout: float = 15.0) -> dict[str, str]:
        """The cueing node's diagnostics once it has taken every Imu sent (a
        loaded host can hold them back for seconds)."""
        return self.cue_diagnostics(lambda v: int(v.get('imu received', -1)) >= self.sent,
                                    timeout)

    def settle(self, timeout: float = 15.0) -> None:
        """Wait until the node has taken every Imu sent, the input is stale and
        the platform at neutral."""
        self.caught_up(timeout)
        assert self.cue_diagnostics(lambda v: v.get('input') in ('stale',
                                                                  'waiting for vehicle_imu'),
                                    timeout), 'input never stale'
        assert self.spin_until(lambda: self.poses and max(map(abs, self.poses[-1][1])) < 1e-4,
                               timeout), f'not at neutral: {self.poses[-1:]}'


def start_chain(params_file: Path, cueing_args: tuple[str, ...] = ()
                ) -> tuple[NodeProcess, NodeProcess, CueingClient]:
    """dynamics_node and motion_cueing on ``params_file`` (the cueing node with
    ``cueing_args`` too), and a client that has seen the cueing node's setpoints
    answered and its first Imu (the vehicle at rest) accepted; the caller stops
    all three (on failure here: stopped).
    """
    node = NodeProcess('-p', 'diagnostics.period:=0.25', '-p', 'sync.wait:=0.5',
                       params_file=params_file)
    cue = NodeProcess(*cueing_args, params_file=params_file, module=CUEING_MODULE)
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
    except BaseException:
        client.close()
        cue.stop()
        node.stop()
        raise
    return node, cue, client


def dynamics_counts(client: Client) -> dict[str, int]:
    """The dynamics node's counters that say whether its answers were ok."""
    values = client.wait_diagnostics(lambda v: True, 3.0)
    return {k: int(values[k]) for k in ('setpoints answered', 'rejected total', 'limit exceeded',
                                        'near singular')}
