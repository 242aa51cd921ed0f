"""Harness of the twin tests (test/ros/test_platform_sim*.py): the twin node
``platform_sim`` started as a process (:func:`start_sim`, :func:`own_twin`),
subscriptions to its outputs on a harness :class:`~node_harness.Client`
(:class:`SimClient`), and commands (:func:`command`).
"""
from __future__ import annotations

import contextlib
import itertools
import math
import tempfile
import time
from pathlib import Path
from typing import Callable, Iterator, Sequence

import numpy as np
import rclpy
from geometry_msgs.msg import PoseStamped, TwistStamped
from sensor_msgs.msg import JointState

from flight_sim_dynamics.machines.staicu.model import LEG_NAMES
from flight_sim_dynamics.ros.platform_sim import SIM_TASK
from flight_sim_dynamics.ros.process import SIM_MODULE, start_node, stop_node
from node_harness import PARAMS_FILE, QOS, ROOT, Client, NodeProcess, diagnostic_values


def start_sim(*ros_args: str, namespace: str = '', params_file: Path | str | None = None):
    """The twin as a process (``--params-file params_file`` when given) and its log."""
    log = tempfile.NamedTemporaryFile('w+', prefix='fsd_sim_', suffix='.log', delete=False)
    args = ['-p', 'diagnostics.period:=0.25', *ros_args]
    if namespace:
        args += ['-r', f'__ns:={namespace}']
    return start_node(params_file, args, log, cwd=ROOT, module=SIM_MODULE), log


def sim_output(log) -> str:
    log.flush()
    return Path(log.name).read_text(errors='replace')


@contextlib.contextmanager
def node_and_twin(client_name: str, params_file: Path = PARAMS_FILE
                  ) -> Iterator[tuple[Client, 'SimClient', object, object]]:
    """The node and the twin on ``params_file``, one remap apart (the twin takes
    the node's ``actuator_states`` as its commands), matched both ways before
    anything is streamed: (client, twin, twin process, twin log).
    """
    node = NodeProcess('-p', 'diagnostics.period:=0.25', '-p', 'sync.wait:=0.5',
                       params_file=params_file)
    client = Client(client_name)
    sim = log = None
    try:
        client.wait_for_node(node)
        # what is published before matching is lost (seen in CI: 1 node answer and
        # 13 twin commands): a probe round trip through the node, then through node
        # and twin (probes at home, stamped long ago; the twin then holds them)
        probes = itertools.count(time.time_ns() - 60 * 10**9, 5 * 10**6)
        client.round_trip(lambda: next(probes))
        sim, log = start_sim('-r', 'actuator_commands:=actuator_states',
                             params_file=params_file)
        twin = SimClient(client)
        ok = client.spin_until(lambda: twin.ready() or sim.poll() is not None, 20.0)
        assert ok and sim.poll() is None, 'twin not up:\n' + sim_output(log)[-3000:]
        zero = (0.0, 0.0, 0.0)
        deadline = time.monotonic() + 20.0
        while not twin.has(lambda v: int(v['commands accepted']) > 0):
            assert time.monotonic() < deadline, 'no probe reached the twin\n' + sim_output(log)
            client.send(next(probes), zero, zero, zero)
            client.spin_until(lambda: False, 0.3)
        yield client, twin, sim, log
    finally:
        client.close()
        node.stop()
        if sim is not None:
            stop_node(sim)
            print(sim_output(log)[-2000:])
            log.close()
            Path(log.name).unlink(missing_ok=True)


class SimClient:
    """Subscriptions to the twin's outputs on a harness Client's node."""

    def __init__(self, client: Client, namespace: str = '') -> None:
        prefix = namespace.rstrip('/') + '/' if namespace else ''
        n = client.node
        self.client = client
        self.poses: list[PoseStamped] = []
        self.twists: list[TwistStamped] = []
        self.measured: list[JointState] = []
        self.pose_sub = n.create_subscription(PoseStamped, prefix + 'platform_pose',
                                              self.poses.append, QOS)
        self.twist_sub = n.create_subscription(TwistStamped, prefix + 'platform_twist',
                                               self.twists.append, QOS)
        self.measured_sub = n.create_subscription(JointState, prefix + 'measured_actuator_states',
                                                  self.measured.append, QOS)
        self.status_name = f'{namespace.rstrip("/")}/platform_sim: {SIM_TASK}'

    def ready(self) -> bool:
        return (self.pose_sub.get_publisher_count() > 0
                and self.twist_sub.get_publisher_count() > 0
                and self.measured_sub.get_publisher_count() > 0)

    def diagnostics(self, predicate, timeout: float = 10.0) -> dict[str, str]:
        client = self.client
        start = len(client.diagnostics)
        found: list[dict[str, str]] = []

        def check() -> bool:
            for msg in client.diagnostics[start + len(found):]:
                found.append(diagnostic_values(msg, self.status_name))
            return any(v and predicate(v) for v in found)
        client.spin_until(check, timeout)
        matching = [v for v in found if v and predicate(v)]
        seen = [v for v in found if v]
        assert matching, f'no matching twin diagnostics; last: {seen[-1] if seen else None}'
        return matching[-1]

    def has(self, predicate) -> bool:
        """Whether a twin diagnostics message received so far satisfies ``predicate``."""
        values = (diagnostic_values(m, self.status_name) for m in self.client.diagnostics)
        return any(v and predicate(v) for v in values)

    def all_finite(self) -> bool:
        poses = all(math.isfinite(v) for m in self.poses for v in (
            m.pose.position.x, m.pose.position.y, m.pose.position.z, m.pose.orientation.x,
            m.pose.orientation.y, m.pose.orientation.z, m.pose.orientation.w))
        twists = all(math.isfinite(v) for m in self.twists for v in (
            m.twist.linear.x, m.twist.linear.y, m.twist.linear.z, m.twist.angular.x,
            m.twist.angular.y, m.twist.angular.z))
        measured = all(math.isfinite(v) for m in self.measured
                       for arr in (m.position, m.velocity, m.effort) for v in arr)
        return poses and twists and measured


def stamp(msg) -> int:
    return msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec


def command(stamp_ns: int, names: Sequence[str] = LEG_NAMES, position=(1.0, 1.0, 1.0),
            velocity=None, effort=None) -> JointState:
    """A command; ``velocity``, ``effort`` default to zeros of ``position``'s size."""
    msg = JointState()
    msg.header.stamp = rclpy.time.Time(nanoseconds=stamp_ns).to_msg()
    msg.name = list(names)
    zeros = [0.0] * len(position)
    msg.position = list(position)
    msg.velocity = zeros if velocity is None else list(velocity)
    msg.effort = zeros if effort is None else list(effort)
    return msg


@contextlib.contextmanager
def own_twin(namespace: str, *ros_args: str, params_file: Path | str | None = None):
    """A twin of its own in ``namespace``, matched with a client's publisher
    of its commands: (client, twin, publisher, process)."""
    sim, log = start_sim(*ros_args, namespace=namespace, params_file=params_file)
    client = Client(f'twin{namespace.replace("/", "_")}_client')
    try:
        twin = SimClient(client, namespace)
        pub = client.node.create_publisher(JointState, f'{namespace}/actuator_commands', QOS)
        ok = client.spin_until(lambda: twin.ready() and pub.get_subscription_count() > 0
                               or sim.poll() is not None, 20.0)
        assert ok and sim.poll() is None, sim_output(log)[-3000:]
        yield client, twin, pub, sim
    finally:
        client.close()
        stop_node(sim)
        print(sim_output(log)[-2000:])
        log.close()
        Path(log.name).unlink(missing_ok=True)


#: the delays (s) the twin's poses are compared at: a command reaches the twin
#: late when the host is busy (0.1-0.2 s at load average 4-5 on 2 cores), which
#: the twin cannot know; following the motion is what is checked
DELAYS = np.arange(0.0, 0.305, 0.005)

#: a busy host holds the test back (no command sent for a while) or the twin
#: (no tick: its poses' stamps jump): the twin ran its plant on a stale command
#: or froze it (steps dropped, counted in /diagnostics) and then steps to the
#: newest one. A hold-up of up to HOLD_UP (s) lags the motion by less than the
#: fitted delays span (0.1 s at the fastest sequence's 0.375 m/s: 0.04 m at
#: most) and is judged (under six busy loops on 2 cores the hexapod twin's worst RMS ratio
#: went from 0.035 to 0.030 and its peak error from 0.005 to 0.008, against
#: bounds of 0.5 and 0.1, with 221 of 748 poses judged, then all of them)
HOLD_UP = 0.1

#: the poses this long after a longer hold-up are not judged (the default 5 Hz
#: servo settles to 0.1 % of a step in 0.3 s)
SETTLE = 0.3


def stream(client: Client, n: int, rate: float, publish: Callable[[int, int], None]
           ) -> tuple[int, np.ndarray]:
    """Sample ``k`` of ``n`` published at ``k / rate`` s of wall time, spinning
    in between: ``publish(k, stamp)`` with ``stamp = t0 + k / rate`` (ROS ns).
    Returns t0 and the ROS times (ns) the samples were actually sent at (a busy
    host holds the test process back, and the commands with it)."""
    clock = client.node.get_clock()
    t0 = clock.now().nanoseconds
    wall0 = time.monotonic()
    sent = np.empty(n, dtype=np.int64)
    for k in range(n):
        while (wait := wall0 + k / rate - time.monotonic()) > 0:
            client.executor.spin_once(timeout_sec=wait)
        sent[k] = clock.now().nanoseconds
        publish(k, t0 + round(k * 1e9 / rate))
    return t0, sent


def _after_gaps(t: np.ndarray, times: np.ndarray) -> np.ndarray:
    """Which of ``t`` fall within :data:`SETTLE` after a gap in ``times`` of over
    :data:`HOLD_UP`."""
    resumed = times[1:][np.diff(times) > HOLD_UP]
    after = np.zeros(len(t), dtype=bool)
    for t_r in resumed:
        after |= (t >= t_r) & (t < t_r + SETTLE)
    return after


def tracking_errors(poses, sequence, t0: int, sent: np.ndarray, rate: float,
                    coordinates: Callable[[object], list]) -> tuple[np.ndarray, np.ndarray, int]:
    """Per coordinate: max |simulated - commanded| and RMS error / RMS motion of
    the poses stamped from t0 to the last sample (``coordinates(msg)``: a
    platform_pose's, in the sequence's order), against the samples of the
    sequence (``k / rate``) as they were sent (``sent``: their ROS times, see
    :func:`stream`; between two sends the motion runs on for at most one
    sample) and then delayed by the one of :data:`DELAYS` that fits best
    (printed), but for the poses :data:`SETTLE` after the test or the twin
    was held back; the count of the poses judged."""
    step = 1.0 / rate
    scheduled = np.arange(len(sent)) * step
    end = t0 + round(scheduled[-1] * 1e9)
    chosen = [m for m in poses if t0 <= stamp(m) <= end]
    q_sim = np.array([coordinates(m) for m in chosen])
    t = np.array([(stamp(m) - t0) * 1e-9 for m in chosen])
    twin_held = _after_gaps(t, t)
    # the commanded motion on a 1 ms grid, read at the sequence time in force
    grid = np.arange(0.0, t.max() + 1e-3, 1e-3)
    q_grid = np.array([sequence.sample(s)[0] for s in grid])
    sent_s = (sent - t0) * 1e-9
    best = None
    for delay in DELAYS:
        when = t - delay
        judged = ~(twin_held | _after_gaps(when, sent_s))
        last = np.clip(np.searchsorted(sent_s, when, side='right') - 1, 0, len(sent) - 1)
        held = np.minimum(np.interp(when, sent_s, scheduled), scheduled[last] + step)
        q_ref = np.column_stack([np.interp(held[judged], grid, q_grid[:, i])
                                 for i in range(q_grid.shape[1])])
        error = q_sim[judged] - q_ref
        ratio = np.sqrt((error ** 2).mean(axis=0) / (q_ref ** 2).mean(axis=0))
        if best is None or ratio.max() < best[1].max():
            best = (np.abs(error).max(axis=0), ratio, delay, judged)
    judged = best[3]
    late = np.diff(sent_s - scheduled).max()
    print(f'best fit at a delay of {best[2] * 1e3:.0f} ms; the longest hold-up of the '
          f'commands sent: {late * 1e3:.0f} ms; {(~judged).sum()} of {len(t)} poses not '
          f'judged (after a hold-up of the test or the twin)')
    return best[0], best[1], int(judged.sum())
