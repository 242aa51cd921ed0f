"""Demo planner: streams pose, twist and accel setpoints of the paper's motions
(and a motion-cueing sequence), stamped ``start + k / rate`` on the node's clock.

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
from rclpy.time import Time

from ..machines.staicu.motions import PLANNER_MOTIONS as MOTIONS
from ..machines.staicu.motions import PlannerSequence
from .dynamics_node import default_qos
from .node import own_options, running, spin_until
from .process import stop_requested
from .setpoints import rpy_to_quaternion


class PlannerNode(Node):
    """Publishes a PlannerSequence at ``rate`` from :meth:`start` on;
    ``on_sample(stamp_ns, label)`` after each sample; ``done`` once sent.
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
        qos = default_qos(100)
        self.pose_pub = self.create_publisher(PoseStamped, 'pose_setpoint', qos)
        self.twist_pub = self.create_publisher(TwistStamped, 'twist_setpoint', qos)
        self.accel_pub = self.create_publisher(AccelStamped, 'accel_setpoint', qos)
        self._pose, self._twist, self._accel = PoseStamped(), TwistStamped(), AccelStamped()
        for msg in (self._pose, self._twist, self._accel):
            msg.header.frame_id = frame_id
        self.sent = 0
        self.done = False
        self._k = 0
        self._t0_ns: int | None = None
        self._wall0 = 0.0
        self._timer = None

    def subscribers_ready(self) -> bool:
        return (self.pose_pub.get_subscription_count() > 0
                and (not self.send_twist or self.twist_pub.get_subscription_count() > 0)
                and (not self.send_accel or self.accel_pub.get_subscription_count() > 0))

    def start(self) -> None:
        self._t0_ns = self.get_clock().now().nanoseconds
        self._wall0 = time.monotonic()
        # a fast timer catching up by index: the count follows wall time
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
            # the context was shut down under this callback: stop quietly
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
        """One setpoint at rest, not counted: answered, it proves the chain matched
        both ways (matching seen from one side does not).
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


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog='flight-sim-dynamics demo-planner',
        description="Publish pose/twist/accel_setpoint of the paper's motions (eq. 6, "
                    '3 s each) or a motion-cueing sequence (6.5 s). ROS arguments go after '
                    '--ros-args.')
    parser.add_argument('--example', choices=(*MOTIONS, 'all'), default='general',
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
    argv = list(sys.argv[1:] if argv is None else argv)
    args = own_options('demo_planner', build_parser(), argv)
    if not (args.rate > 0 and args.rate <= 10000):
        build_parser().error('--rate must be in (0, 10000] Hz')
    if args.no_twist and not args.no_accel:
        build_parser().error('--no-twist needs --no-accel (accelerations without rates '
                             'are not a stream the node expects)')
    from rclpy.experimental import EventsExecutor
    with running('demo_planner', argv) as nodes:
        sequence = PlannerSequence(list(MOTIONS) if args.example == 'all' else [args.example],
                                   loop=args.loop)
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
                node.pose_pub.wait_for_all_acked(rclpy.duration.Duration(seconds=2.0))
        log.info(f'sent {node.sent} setpoints')
    return 0

if __name__ == '__main__':
    sys.exit(main())
