"""Demo planner: streams pose, twist and acceleration setpoints of the paper's
motions (and a motion-cueing sequence) to the dynamics node, one header stamp
per sample on its three messages, ``start + k / rate`` in the node clock's
time base.

    flight-sim-dynamics demo-planner --example general --rate 200 --loop
    flight-sim-dynamics demo-planner --example cueing --no-accel
"""
from __future__ import annotations

import argparse
import sys
import time
from typing import Any, Sequence

import rclpy
import rclpy.task
from geometry_msgs.msg import AccelStamped, PoseStamped, TwistStamped
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rclpy.time import Time

from ..core.motions import PLANNER_MOTIONS as MOTIONS
from ..core.motions import PlannerSequence
from .setpoints import rpy_to_quaternion
from .node import own_options, running
from .process import stop_requested

ALL = 'all'
CHOICES = (*MOTIONS, ALL)


def motions_of(example: str) -> list[str]:
    """The motions an ``--example`` value stands for (``all``: every one)."""
    return list(MOTIONS) if example == ALL else [example]


def setpoint_qos(depth: int = 100) -> QoSProfile:
    """The node's default setpoint QoS: reliable, KEEP_LAST, volatile."""
    return QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=depth,
                      reliability=ReliabilityPolicy.RELIABLE,
                      durability=DurabilityPolicy.VOLATILE)


class PlannerNode(Node):
    """Publishes a :class:`~flight_sim_dynamics.core.motions.PlannerSequence` at a fixed rate.

    ``on_sample(stamp_ns, label)`` is called after each published sample;
    ``done`` becomes True when a non-looping sequence has been sent.
    Publishing starts with :meth:`start` (so a caller can wait for discovery).
    """

    def __init__(self, sequence: PlannerSequence, rate: float, *, twist: bool = True,
                 accel: bool = True, frame_id: str = 'simulator_base',
                 node_name: str = 'demo_planner', on_sample: Any = None,
                 **kwargs: Any) -> None:
        super().__init__(node_name, **kwargs)
        self.sequence = sequence
        self.rate = float(rate)
        self.send_twist, self.send_accel = twist, accel
        self.on_sample = on_sample
        qos = setpoint_qos()
        self.pose_pub = self.create_publisher(PoseStamped, 'pose_setpoint', qos)
        self.twist_pub = self.create_publisher(TwistStamped, 'twist_setpoint', qos)
        self.accel_pub = self.create_publisher(AccelStamped, 'accel_setpoint', qos)
        self._pose, self._twist, self._accel = PoseStamped(), TwistStamped(), AccelStamped()
        self._pose.header.frame_id = frame_id
        self._twist.header.frame_id = frame_id
        self._accel.header.frame_id = frame_id
        self.sent = 0
        self.done = False
        self._k = 0
        self._t0_ns: int | None = None
        self._wall0 = 0.0
        self._timer = None

    def subscribers_ready(self) -> bool:
        """The node's setpoint subscriptions are matched."""
        return (self.pose_pub.get_subscription_count() > 0
                and (not self.send_twist or self.twist_pub.get_subscription_count() > 0)
                and (not self.send_accel or self.accel_pub.get_subscription_count() > 0))

    def start(self) -> None:
        self._t0_ns = self.get_clock().now().nanoseconds
        self._wall0 = time.monotonic()
        # A fast timer that catches up by sample index: the sample count follows
        # wall time exactly even when one timer period is late.
        self._timer = self.create_timer(min(0.5 / self.rate, 0.01), self._on_timer)

    def _on_timer(self) -> None:
        due = int((time.monotonic() - self._wall0) * self.rate) + 1
        try:
            while self._k < due and not self.done and not stop_requested():
                self._publish(self._k)
                self._k += 1
        except Exception:
            if self.context.ok():
                raise
            # the context was shut down under this callback (issue 15 #3): a
            # publish after shutdown is not an error; stop quietly
            self.done = True

    def _publish(self, k: int) -> None:
        t = k / self.rate
        if self.sequence.finished(t):
            self.done = True
            if self._timer is not None:
                self._timer.cancel()
            return
        q, qd, qdd, label = self.sequence.sample(t)
        stamp_ns = self._t0_ns + round(k * 1e9 / self.rate)
        self._send(stamp_ns, q, qd, qdd)
        self.sent += 1
        if self.on_sample is not None:
            self.on_sample(stamp_ns, label)

    def probe(self, stamp_ns: int) -> None:
        """One setpoint at rest at the sequence's first pose, stamped
        ``stamp_ns`` (before :meth:`start`; not counted in :attr:`sent`): a
        caller that sees it answered knows the whole chain has matched, both
        ways (matching seen from one side does not say the other side has
        matched, and what is published before is lost).
        """
        q = self.sequence.sample(0.0)[0]
        self._send(stamp_ns, q, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0))

    def _send(self, stamp_ns: int, q: Any, qd: Any, qdd: Any) -> None:
        stamp = Time(nanoseconds=stamp_ns).to_msg()
        pose = self._pose
        pose.header.stamp = stamp
        pose.pose.position.x, pose.pose.position.y, pose.pose.position.z = \
            float(q[0]), 0.0, float(q[1])
        o = pose.pose.orientation
        o.x, o.y, o.z, o.w = rpy_to_quaternion(float(q[2]))
        self.pose_pub.publish(pose)
        if self.send_twist:
            tw = self._twist
            tw.header.stamp = stamp
            tw.twist.linear.x, tw.twist.linear.z, tw.twist.angular.x = \
                float(qd[0]), float(qd[1]), float(qd[2])
            self.twist_pub.publish(tw)
        if self.send_accel:
            ac = self._accel
            ac.header.stamp = stamp
            ac.accel.linear.x, ac.accel.linear.z, ac.accel.angular.x = \
                float(qdd[0]), float(qdd[1]), float(qdd[2])
            self.accel_pub.publish(ac)


def spin_until(executor: Any, predicate: Any, timeout: float | None = None,
               step: float = 0.05) -> bool:
    """Spin (always with a timeout: see node.spin) until ``predicate()``, the
    deadline, shutdown or a requested stop (Ctrl-C, SIGTERM:
    :func:`.process.stop_on_signals`).
    """
    deadline = None if timeout is None else time.monotonic() + timeout
    never = rclpy.task.Future()
    while rclpy.ok(context=executor.context) and not predicate() and not stop_requested():
        if deadline is not None and time.monotonic() >= deadline:
            break
        executor.spin_until_future_complete(never, timeout_sec=step)
    return bool(predicate())


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog='flight-sim-dynamics demo-planner',
        description='Publish pose_setpoint, twist_setpoint and accel_setpoint of the '
                    "paper's motions (vertical, rectilinear, general: eq. 6, 3 s each) or "
                    'a motion-cueing-style sequence (cueing: surge and heave pulses plus '
                    'roll, washed back to neutral, 6.5 s). ROS arguments (remapping, '
                    'namespace) go after --ros-args.')
    parser.add_argument('--example', choices=CHOICES, default='general',
                        help='motion to play; all = the three examples then cueing '
                             '(default: general)')
    parser.add_argument('--rate', type=float, default=100.0, metavar='HZ',
                        help='setpoint rate (default: 100 Hz)')
    parser.add_argument('--loop', action='store_true',
                        help='repeat forever (each paper example is washed back to neutral)')
    parser.add_argument('--no-twist', action='store_true',
                        help='do not publish twist_setpoint (the node estimates rates)')
    parser.add_argument('--no-accel', action='store_true',
                        help='do not publish accel_setpoint (the node estimates accelerations)')
    parser.add_argument('--wait', type=float, default=10.0, metavar='S',
                        help='wait up to S seconds for the node to subscribe before '
                             'starting (0: start at once; default 10)')
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run the demo planner until the sequence is sent (or Ctrl-C with --loop)."""
    argv = list(sys.argv[1:] if argv is None else argv)
    args = own_options('demo_planner', build_parser(), argv)
    if not (args.rate > 0 and args.rate <= 10000):
        build_parser().error('--rate must be in (0, 10000] Hz')
    if args.no_twist and not args.no_accel:
        build_parser().error('--no-twist needs --no-accel (accelerations without rates '
                             'are not a stream the node expects)')
    from rclpy.experimental import EventsExecutor
    with running('demo_planner', argv) as nodes:
        sequence = PlannerSequence(motions_of(args.example), loop=args.loop)
        node = PlannerNode(sequence, args.rate, twist=not args.no_twist,
                           accel=not args.no_accel)
        nodes.append(node)
        executor = EventsExecutor()
        executor.add_node(node)
        log = node.get_logger()
        if args.wait > 0 and not spin_until(executor, node.subscribers_ready, args.wait):
            if stop_requested():
                return 0
            log.warn(f'no subscriber on {node.pose_pub.topic_name} after {args.wait:g} s; '
                     'publishing anyway')
        log.info(f'publishing {", ".join(sequence.names)} at {args.rate:g} Hz '
                 f'({sequence.period:.1f} s{", looping" if args.loop else ""})')
        node.start()
        spin_until(executor, lambda: node.done)
        if node.done and not stop_requested():
            # let the last messages leave (reliable): wait until acknowledged
            node.pose_pub.wait_for_all_acked(rclpy.duration.Duration(seconds=2.0))
        log.info(f'sent {node.sent} setpoints')
    return 0

if __name__ == '__main__':
    sys.exit(main())
