"""Demo planner: streams pose, twist and accel setpoints of a machine's
built-in motions (:attr:`Machine.planner_motions`, each machine's own), stamped
``start + k / rate`` on the node's clock. The pose carries the machine's coordinates as their
components (:class:`.messages.PoseMap`); twist and accel the rates, and the angular
velocity and acceleration in the base frame of the Euler-angle rates (S2), (S3).

    flight-sim-dynamics demo-planner --example general --rate 200 --loop
    flight-sim-dynamics demo-planner --example cueing --no-accel
    flight-sim-dynamics demo-planner --params config/<name>.yaml --example all
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

from ..config.machine_files import example_params_file, load_model_noting
from ..core.machine import Machine
from ..core.motion import PlannerSequence
from ..machines import MACHINES
from ..machines.api import machine_of
from .dynamics_node import default_qos
from .node import own_options, running, spin_until
from .process import stop_requested
from .messages import pose_map, rpy_to_quaternion


class SetpointPublisher:
    """The dynamics node's setpoint topics of one machine, published by
    ``node``: :meth:`send` fills and publishes one stamped pose, twist and
    acceleration of the machine's coordinates (docs/node.md); ``create``
    makes the publishers (default: ``node.create_publisher``).
    """

    def __init__(self, node: Node, machine: Machine, frame_id: str, qos: Any, *,
                 twist: bool = True, accel: bool = True, create: Any = None) -> None:
        create = node.create_publisher if create is None else create
        self.poses = pose_map(machine)
        self.send_twist, self.send_accel = twist, accel
        self.pose_pub = create(PoseStamped, 'pose_setpoint', qos)
        self.twist_pub = create(TwistStamped, 'twist_setpoint', qos)
        self.accel_pub = create(AccelStamped, 'accel_setpoint', qos)
        self._pose, self._twist, self._accel = PoseStamped(), TwistStamped(), AccelStamped()
        self.frame_id = frame_id

    @property
    def publishers(self) -> tuple[Any, Any, Any]:
        return self.pose_pub, self.twist_pub, self.accel_pub

    @property
    def frame_id(self) -> str:
        return self._pose.header.frame_id

    @frame_id.setter
    def frame_id(self, value: str) -> None:
        for msg in (self._pose, self._twist, self._accel):
            msg.header.frame_id = value

    def subscribers_ready(self) -> bool:
        return (self.pose_pub.get_subscription_count() > 0
                and (not self.send_twist or self.twist_pub.get_subscription_count() > 0)
                and (not self.send_accel or self.accel_pub.get_subscription_count() > 0))

    def send(self, stamp_ns: int, q: Any, qd: Any, qdd: Any) -> None:
        """One setpoint of the machine's coordinates ``q`` and their rates and
        accelerations, stamped ``stamp_ns``: the angular parts in the base
        frame (S2), (S3).
        """
        stamp = Time(nanoseconds=stamp_ns).to_msg()
        poses = self.poses
        x, y, z, *rpy = poses.message(q)
        msg = self._pose
        msg.header.stamp = stamp
        p, o = msg.pose.position, msg.pose.orientation
        p.x, p.y, p.z = x, y, z
        o.x, o.y, o.z, o.w = rpy_to_quaternion(*rpy)
        self.pose_pub.publish(msg)
        if self.send_twist:
            tw = self._twist
            tw.header.stamp = stamp
            v, w = tw.twist.linear, tw.twist.angular
            v.x, v.y, v.z, w.x, w.y, w.z = poses.twist(q, qd)
            self.twist_pub.publish(tw)
        if self.send_accel:
            ac = self._accel
            ac.header.stamp = stamp
            a, e = ac.accel.linear, ac.accel.angular
            a.x, a.y, a.z, e.x, e.y, e.z = poses.accel(q, qd, qdd)
            self.accel_pub.publish(ac)


class PlannerNode(Node):
    """Publishes a PlannerSequence of ``machine``'s motions at ``rate`` from
    :meth:`start` on; ``on_sample(stamp_ns, label)`` after each sample;
    ``done`` once sent.
    """

    def __init__(self, sequence: PlannerSequence, rate: float, *, machine: Machine = MACHINES[0],
                 twist: bool = True, accel: bool = True, frame_id: str = 'simulator_base',
                 node_name: str = 'demo_planner', on_sample: Any = None,
                 **kwargs: Any) -> None:
        super().__init__(node_name, **kwargs)
        self.sequence = sequence
        self.rate = float(rate)
        self.on_sample = on_sample
        self.setpoints = SetpointPublisher(self, machine, frame_id, default_qos(100),
                                           twist=twist, accel=accel)
        self.pose_pub, self.twist_pub, self.accel_pub = (
            self.setpoints.pose_pub, self.setpoints.twist_pub, self.setpoints.accel_pub)
        self.sent = 0
        self.done = False
        self._k = 0
        self._t0_ns: int | None = None
        self._wall0 = 0.0
        self._timer = None

    def subscribers_ready(self) -> bool:
        return self.setpoints.subscribers_ready()

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
        self._send(stamp_ns, q, [0.0] * len(q), [0.0] * len(q))

    def _send(self, stamp_ns: int, q: Any, qd: Any, qdd: Any) -> None:
        self.setpoints.send(stamp_ns, q, qd, qdd)

def _planner_motions() -> str:
    """Each machine's planner motions and their durations, for the help."""
    return '; '.join(f"{m.title}: " + ', '.join(f'{name} ({m.motions[name].duration:g} s)'
                                              for name in m.planner_motions)
                     for m in MACHINES)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog='flight-sim-dynamics demo-planner',
        description="Publish pose/twist/accel_setpoint of a machine's built-in planner "
                    f'motions ({_planner_motions()}). ROS arguments go after --ros-args.')
    parser.add_argument('--params', '--params-file', type=str, default=None, metavar='FILE',
                        help="parameter file naming the machine (the node's, e.g. "
                             f'{example_params_file()}; default: the {MACHINES[0].title})')
    parser.add_argument('--example', default=None, metavar='NAME',
                        help="motion to play, one of the machine's planner motions; all = "
                             'each in turn (default: '
                             + ', '.join(f'{m.planner_example} ({m.title})' for m in MACHINES)
                             + ')')
    parser.add_argument('--rate', type=float, default=100.0, metavar='HZ',
                        help='setpoint rate (default: 100 Hz)')
    parser.add_argument('--loop', action='store_true',
                        help='repeat forever (a motion that ends away from neutral is washed back '
                             'to it)')
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
    try:
        # only the file's machine: what its scene leaves out is the node's note
        machine = MACHINES[0] if args.params is None else \
            machine_of(load_model_noting(args.params)[0])
    except (OSError, ValueError) as exc:
        build_parser().error(f'--params: {exc}')
    example = args.example or machine.planner_example
    if example not in (*machine.planner_motions, 'all'):
        build_parser().error(f'--example: {example!r} is not a motion of the {machine.title}; '
                             f"choose one of {', '.join((*machine.planner_motions, 'all'))}")
    from rclpy.experimental import EventsExecutor
    with running('demo_planner', argv) as nodes:
        sequence = PlannerSequence(machine.motions, list(machine.planner_motions)
                                   if example == 'all' else [example], loop=args.loop)
        node = PlannerNode(sequence, args.rate, machine=machine, twist=not args.no_twist,
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
