"""Launch-free harness of the node tests (test/test_node_*.py).

* :class:`NodeProcess` starts ``python -m flight_sim_dynamics.ros.node`` (or
  another ``module``: the motion-cueing node's) as a separate process, as a
  user starts it (``ros.process.start_node``), and always stops it.
* :class:`Client` is the test's own ROS 2 participant (its own rclpy
  context): setpoint publishers and output subscriptions (QoS :data:`QOS`
  unless told otherwise), parameter-service
  clients, and waits with deadlines (never blind sleeps).
"""
from __future__ import annotations

import math
import os
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any, Callable, Iterable, Sequence

import rclpy
import rclpy.task
from diagnostic_msgs.msg import DiagnosticArray
from lifecycle_msgs.msg import Transition
from lifecycle_msgs.srv import ChangeState, GetAvailableTransitions, GetState
from geometry_msgs.msg import AccelStamped, PoseStamped, TwistStamped
from rcl_interfaces.msg import Parameter as ParameterMsg
from rcl_interfaces.srv import (DescribeParameters, GetParameters, GetParameterTypes,
                                ListParameters, SetParameters, SetParametersAtomically)
from rclpy.context import Context
from rclpy.parameter import Parameter
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import JointState
from std_srvs.srv import Trigger
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

from flight_sim_dynamics.ros.diagnostics import diagnostic_name
from flight_sim_dynamics.machines import FLIGHT_SIMULATOR
from flight_sim_dynamics.ros.messages import rpy_to_quaternion
from flight_sim_dynamics.ros.process import (NODE_MODULE, node_command, node_env, start_node,
                                              stop_node)

ROOT = Path(__file__).resolve().parents[2]
PARAMS_FILE = ROOT / 'config' / 'flight_sim_dynamics.yaml'
NODE_NAME = 'flight_sim_dynamics'
#: The 3-DOF machine's platform_setpoint joint names, in the order of its q.
PLATFORM_DOF_NAMES = FLIGHT_SIMULATOR.coordinates

# The test side: reliable, deep enough for every message of a test run.
QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=2000,
                 reliability=ReliabilityPolicy.RELIABLE,
                 durability=DurabilityPolicy.VOLATILE)


class NodeProcess:
    """The node under test, started like a user starts it."""

    def __init__(self, *ros_args: str, params_file: Path | None = PARAMS_FILE,
                 executor: str | None = None, module: str = NODE_MODULE) -> None:
        self.cmd = node_command(params_file, ros_args, executor=executor, module=module)
        self.log = tempfile.NamedTemporaryFile('w+', prefix='fsd_node_', suffix='.log',
                                               delete=False)
        self._final_output: str | None = None
        self.proc = start_node(params_file, ros_args, self.log, executor=executor, cwd=ROOT,
                               module=module)

    def alive(self) -> bool:
        return self.proc.poll() is None

    def output(self) -> str:
        if self._final_output is not None:
            return self._final_output
        self.log.flush()
        return Path(self.log.name).read_text(errors='replace')

    def cpu_seconds(self) -> float:
        """User + system CPU time of the node process so far."""
        fields = Path(f'/proc/{self.proc.pid}/stat').read_text().rsplit(')', 1)[1].split()
        return (int(fields[11]) + int(fields[12])) / os.sysconf('SC_CLK_TCK')

    def wait_output(self, text: str, timeout: float = 20.0) -> bool:
        """Wait until ``text`` is in the output (or the process ended, or the deadline)."""
        deadline = time.monotonic() + timeout
        while text not in self.output():
            if not self.alive() or time.monotonic() > deadline:
                return text in self.output()
            time.sleep(0.02)
        return True

    def stop(self, timeout: float = 5.0, repeat_after: float | None = None) -> int:
        """SIGINT (as Ctrl-C), then SIGKILL if it does not exit in ``timeout`` s.
        ``repeat_after``: a second SIGINT that many seconds after the first, as
        a Ctrl-C under ``ros2 launch`` arrives (the terminal's, then launch's)."""
        if repeat_after is not None and self.alive():
            self.proc.send_signal(signal.SIGINT)
            time.sleep(repeat_after)
        stop_node(self.proc, timeout)
        if self._final_output is None:
            self._final_output = self.output()
            self.log.close()
            Path(self.log.name).unlink(missing_ok=True)
        return self.proc.returncode


class PlannerProcess(NodeProcess):
    """The demo planner (``python -m flight_sim_dynamics.ros.planner ARGS``) as
    a separate process, e.g. a stream the node under test joins mid-way."""

    def __init__(self, *args: str) -> None:      # noqa: D107 - NodeProcess's, another command
        self.cmd = [sys.executable, '-m', 'flight_sim_dynamics.ros.planner', *args]
        self.log = tempfile.NamedTemporaryFile('w+', prefix='fsd_planner_', suffix='.log',
                                               delete=False)
        self._final_output = None
        self.proc = subprocess.Popen(self.cmd, stdout=self.log, stderr=subprocess.STDOUT,
                                     env=node_env(), cwd=ROOT, start_new_session=True)


class Client:
    """The test's own ROS 2 participant."""

    def __init__(self, name: str = 'node_test_client', namespace: str = '',
                 qos: QoSProfile = QOS) -> None:
        self.context = Context()
        rclpy.init(context=self.context)
        self.node = rclpy.create_node(name, namespace=namespace, context=self.context)
        # The EventsExecutor costs a third of the SingleThreadedExecutor's CPU per
        # message (docs/node.md); the test side runs at 200 Hz too. Always spun
        # with a timeout (rclpy 7.1.6's EventsExecutor hangs without one).
        from rclpy.experimental import EventsExecutor
        self.executor = EventsExecutor(context=self.context)
        self.executor.add_node(self.node)
        n = self.node
        self.pose_pub = n.create_publisher(PoseStamped, 'pose_setpoint', qos)
        self.twist_pub = n.create_publisher(TwistStamped, 'twist_setpoint', qos)
        self.accel_pub = n.create_publisher(AccelStamped, 'accel_setpoint', qos)
        self.platform_pub = n.create_publisher(JointTrajectory, 'platform_setpoint', qos)
        self.actuator: list[tuple[float, JointState]] = []
        self.joints: list[JointState] = []
        self.diagnostics: list[DiagnosticArray] = []
        self.actuator_sub = n.create_subscription(
            JointState, 'actuator_states', lambda m: self.actuator.append((time.monotonic(), m)),
            qos)
        self.joint_sub = n.create_subscription(JointState, 'joint_states', self.joints.append, qos)
        self.diag_sub = n.create_subscription(DiagnosticArray, '/diagnostics',
                                              self.diagnostics.append, 10)
        target = f'{namespace.rstrip("/")}/{NODE_NAME}' if namespace else NODE_NAME
        #: the status of the node this client talks to in /diagnostics
        self.status_name = diagnostic_name(f'{namespace.rstrip("/")}/{NODE_NAME}')
        self.srv = {
            'get': n.create_client(GetParameters, f'{target}/get_parameters'),
            'set': n.create_client(SetParameters, f'{target}/set_parameters'),
            'atomic': n.create_client(SetParametersAtomically,
                                      f'{target}/set_parameters_atomically'),
            'list': n.create_client(ListParameters, f'{target}/list_parameters'),
            'describe': n.create_client(DescribeParameters, f'{target}/describe_parameters'),
            'types': n.create_client(GetParameterTypes, f'{target}/get_parameter_types'),
        }
        self.watch: NodeProcess | None = None
        self._answered: set[Any] = set()     # service clients answered once

    # -- waiting ---------------------------------------------------------------
    def spin_until(self, predicate: Callable[[], bool], timeout: float) -> bool:
        """Spin until ``predicate()`` or the deadline; fails fast if the
        watched node process died."""
        deadline = time.monotonic() + timeout
        while True:
            if predicate():
                return True
            if self.watch is not None and not self.watch.alive():
                raise AssertionError('node process died:\n' + self.watch.output()[-3000:])
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                return predicate()
            self.executor.spin_once(timeout_sec=min(0.05, remaining))

    def wait_for_node(self, node: NodeProcess, timeout: float = 20.0) -> None:
        """Discovery: the node's subscriptions see our publishers and we see its
        output publishers and parameter services."""
        self.watch = node
        ok = self.spin_until(lambda: (
            self.pose_pub.get_subscription_count() > 0
            and self.twist_pub.get_subscription_count() > 0
            and self.accel_pub.get_subscription_count() > 0
            and self.platform_pub.get_subscription_count() > 0
            and self.actuator_sub.get_publisher_count() > 0
            and self.joint_sub.get_publisher_count() > 0
            and all(c.service_is_ready() for c in self.srv.values())), timeout)
        assert ok, 'node not discovered in time:\n' + node.output()[-3000:]

    def round_trip(self, next_stamp: Callable[[], int], timeout: float = 20.0) -> None:
        """Discovery, both ways: matching seen from this side (wait_for_node)
        does not mean the node's readers and writers have matched too, and
        what is published before they have is lost (seen under load: the
        first 0.7 s of a 200 Hz stream). Sends setpoints at rest (stamps
        from ``next_stamp``) until one is answered on actuator_states and
        joint_states and the node's diagnostics have counted a twist and an
        acceleration."""
        zero = (0.0, 0.0, 0.0)
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            stamp = next_stamp()
            self.send(stamp, zero, zero, zero)
            answered = self.spin_until(lambda: any(
                stamp_ns(m) == stamp for m in [a for _, a in self.actuator[-3:]]) and any(
                stamp_ns(m) == stamp for m in self.joints[-3:]), 0.25)
            if answered:
                self.wait_diagnostics(lambda v: int(v.get('received twist', 0)) > 0
                                      and int(v.get('received accel', 0)) > 0,
                                      max(0.5, deadline - time.monotonic()))
                return
        raise AssertionError('no setpoint answered in time (discovery)\n' + self.explain())

    def explain(self) -> str:
        """For a failure message: the node's last /diagnostics values and the
        end of its log (why setpoints were not answered)."""
        self.spin_until(lambda: False, 1.5)      # one more diagnostics period
        values = [diagnostic_values(m, self.status_name) for m in self.diagnostics]
        last = next((v for v in reversed(values) if v), {})
        log = self.watch.output()[-3000:] if self.watch is not None else ''
        return f'\nlast diagnostics: {last}\nnode log:\n{log}'

    def wait_actuator(self, count: int, timeout: float = 5.0) -> bool:
        return self.spin_until(lambda: len(self.actuator) >= count, timeout)

    def wait_diagnostics(self, predicate: Callable[[dict[str, str]], bool],
                         timeout: float = 5.0, name: str | None = None) -> dict[str, str]:
        """The values of the first /diagnostics message (received from now on)
        that satisfies ``predicate``; ``name``: the status (default: the node's)."""
        seen = [len(self.diagnostics)]
        found: list[dict[str, str]] = []

        def check() -> bool:
            while len(self.diagnostics) > seen[0]:
                values = diagnostic_values(self.diagnostics[seen[0]], name or self.status_name)
                seen[0] += 1
                if values:                  # (other nodes' statuses are skipped)
                    found.append(values)
                    if predicate(values):
                        return True
            return False
        self.spin_until(check, timeout)
        matching = [v for v in found if predicate(v)]
        assert matching, f'no matching /diagnostics in {timeout} s; last: ' \
                         f'{found[-1] if found else None}'
        return matching[0]

    #: services whose repeated request leaves the node as one does (sent again,
    #: see :meth:`call`), whatever name a test gives their client
    IDEMPOTENT = (GetParameters, SetParameters, SetParametersAtomically, ListParameters,
                  DescribeParameters, GetParameterTypes, GetState, GetAvailableTransitions,
                  Trigger)
    #: before a new client's first request of a service that must not be sent twice,
    #: one that changes nothing (a transition no state has: refused), sent until answered
    PROBES = {ChangeState: lambda: ChangeState.Request(transition=Transition(id=255))}

    def call(self, name: str, request: Any, timeout: float = 15.0) -> Any:
        """``request`` to the service ``name``, its response (``timeout`` s each way:
        a CI host at load 2.8 on 2 cores once answered a planner's set later than 5 s).

        A service drops its response to a client whose response reader it has
        not matched yet (rmw_fastrtps waits only its writer's max_blocking_time
        for that match, which discovery on a loaded host can exceed), so until
        a client's first answer an idempotent request is sent again every
        second, and a request that is not idempotent waits for a probe's answer."""
        client = self.srv[name]
        assert self.spin_until(client.service_is_ready, timeout), f'{name} service not ready'
        deadline = time.monotonic() + timeout
        if client not in self._answered and client.srv_type in self.PROBES:
            self._send(name, client, self.PROBES[client.srv_type](), deadline, resend=True)
        return self._send(name, client, request, deadline,
                          resend=client.srv_type in self.IDEMPOTENT
                          and client not in self._answered)

    def _send(self, name: str, client: Any, request: Any, deadline: float, resend: bool) -> Any:
        future = client.call_async(request)
        while True:
            remaining = max(0.0, deadline - time.monotonic())
            if self.spin_until(future.done, min(1.0, remaining) if resend else remaining):
                break
            if not resend or time.monotonic() >= deadline:
                raise AssertionError(f'{name} call timed out')
            client.remove_pending_request(future)
            future = client.call_async(request)
        self._answered.add(client)
        return future.result()

    # -- parameters --------------------------------------------------------------
    def get_params(self, names: Sequence[str]) -> list[Any]:
        response = self.call('get', GetParameters.Request(names=list(names)))
        return [Parameter.from_parameter_msg(ParameterMsg(name=n, value=v)).value
                for n, v in zip(names, response.values)]

    def set_params(self, values: dict[str, Any], atomic: bool = False) -> list[Any]:
        params = [Parameter(name, value=value).to_parameter_msg()
                  for name, value in values.items()]
        if atomic:
            return [self.call('atomic', SetParametersAtomically.Request(parameters=params)).result]
        return list(self.call('set', SetParameters.Request(parameters=params)).results)

    # -- setpoints -----------------------------------------------------------------
    def send(self, stamp_ns: int, q: Iterable[float], qd: Iterable[float] | None = None,
             qdd: Iterable[float] | None = None, *, order: str = 'pta',
             pitch: float = 0.0, yaw: float = 0.0, sway: float = 0.0,
             quaternion: tuple[float, float, float, float] | None = None,
             raw: dict[str, Any] | None = None) -> None:
        """Publish one setpoint: pose always (unless 'p' is not in ``order``),
        twist if ``qd`` is given, accel if ``qdd`` is given, in ``order``
        (p = pose, t = twist, a = accel). ``raw`` overrides message fields
        (e.g. {'pose.position.x': nan})."""
        surge, heave, roll = (float(v) for v in q)
        stamp = rclpy.time.Time(nanoseconds=stamp_ns).to_msg()
        msgs = {}
        if 'p' in order:
            pose = PoseStamped()
            pose.header.stamp = stamp
            pose.header.frame_id = 'simulator_base'
            pose.pose.position.x, pose.pose.position.y, pose.pose.position.z = surge, sway, heave
            x, y, z, w = (quaternion if quaternion is not None
                          else rpy_to_quaternion(roll, pitch, yaw))
            o = pose.pose.orientation
            o.x, o.y, o.z, o.w = x, y, z, w
            msgs['p'] = (self.pose_pub, pose)
        if qd is not None and 't' in order:
            twist = TwistStamped()
            twist.header.stamp = stamp
            twist.twist.linear.x, twist.twist.linear.z, twist.twist.angular.x = (
                float(v) for v in qd)
            msgs['t'] = (self.twist_pub, twist)
        if qdd is not None and 'a' in order:
            accel = AccelStamped()
            accel.header.stamp = stamp
            accel.accel.linear.x, accel.accel.linear.z, accel.accel.angular.x = (
                float(v) for v in qdd)
            msgs['a'] = (self.accel_pub, accel)
        for path, value in (raw or {}).items():
            kind, *fields = path.split('.')
            target = msgs[{'pose': 'p', 'twist': 't', 'accel': 'a'}[kind]][1]
            target = getattr(target, kind)
            for f in fields[:-1]:
                target = getattr(target, f)
            setattr(target, fields[-1], value)
        for key in order:
            if key in msgs:
                publisher, msg = msgs[key]
                publisher.publish(msg)

    def send_platform(self, stamp_ns: int, points: Sequence[Sequence[Any]], *,
                      names: Sequence[str] = PLATFORM_DOF_NAMES,
                      offsets_ns: Sequence[int] | None = None,
                      effort: Sequence[Sequence[float]] | None = None) -> None:
        """Publish one ``platform_setpoint`` (JointTrajectory) with header stamp
        ``stamp_ns``: one point per item of ``points``, each ``(q, qd, qdd)``
        (surge, heave, roll order; ``qd``/``qdd`` None or empty: not sent),
        reordered to ``names``; ``offsets_ns``: the points' time_from_start
        (default 0, 1, 2 ... times 5 ms; negative allowed, for the tests);
        ``effort``: per point (default empty)."""
        self.platform_pub.publish(self.platform_message(stamp_ns, points, names=names,
                                                        offsets_ns=offsets_ns, effort=effort))

    @staticmethod
    def platform_message(stamp_ns: int, points: Sequence[Sequence[Any]], *,
                         names: Sequence[str] = PLATFORM_DOF_NAMES,
                         offsets_ns: Sequence[int] | None = None,
                         effort: Sequence[Sequence[float]] | None = None) -> JointTrajectory:
        """The message :meth:`send_platform` publishes."""
        msg = JointTrajectory()
        msg.header.stamp = rclpy.time.Time(nanoseconds=stamp_ns).to_msg()
        msg.header.frame_id = 'simulator_base'
        msg.joint_names = list(names)
        index = {name: i for i, name in enumerate(PLATFORM_DOF_NAMES)}

        def arranged(values: Any) -> list[float]:
            if values is None or len(values) == 0:
                return []
            values = [float(v) for v in values]
            # values given in surge, heave, roll order; extra/missing names: as given
            return ([values[index[name]] for name in names]
                    if len(values) == 3 and sorted(names) == sorted(PLATFORM_DOF_NAMES)
                    else values)
        for k, (q, qd, qdd) in enumerate(points):
            point = JointTrajectoryPoint()
            point.positions = arranged(q)
            point.velocities = arranged(qd)
            point.accelerations = arranged(qdd)
            if effort is not None:
                point.effort = [float(v) for v in effort[k]]
            offset = offsets_ns[k] if offsets_ns is not None else k * 5_000_000
            point.time_from_start.sec, point.time_from_start.nanosec = divmod(
                int(offset), 1_000_000_000)
            msg.points.append(point)
        return msg

    def close(self) -> None:
        # the executor first: while it holds the node, the context keeps its DDS
        # participant, and 32 participants on the host hide newcomers from each
        # other (rmw_fastrtps' localhost discovery probes participant ids 0-31)
        self.executor.shutdown(timeout_sec=5.0)
        self.node.destroy_node()
        rclpy.try_shutdown(context=self.context)


def diagnostic_values(msg: DiagnosticArray, name: str = diagnostic_name('/' + NODE_NAME)
                      ) -> dict[str, str]:
    """Key/values of the status ``name`` in a DiagnosticArray, plus 'level'
    and 'message'."""
    for status in msg.status:
        if status.name == name:
            values = {kv.key: kv.value for kv in status.values}
            level = status.level
            values['level'] = str(level[0] if isinstance(level, (bytes, bytearray)) else level)
            values['message'] = status.message
            return values
    return {}


def stamp_ns(msg: Any) -> int:
    return msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec


def all_finite(msg: JointState) -> bool:
    return all(math.isfinite(v) for arr in (msg.position, msg.velocity, msg.effort) for v in arr)
