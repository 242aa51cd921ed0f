#!/usr/bin/env python3
"""The node's own Python cost per setpoint, by input, and the A/B of its wire
path (docs/node.md, "What a cycle costs"): the subscription callbacks of two
real ``DynamicsNode`` objects in this one process, called directly with the
same serialized samples, without DDS delivering them, so the figure is what
the node's Python does per setpoint (read, check, synchronise, estimate,
solve, fill and publish both outputs, bookkeeping) and nothing of the
executor's taking and dispatching.

* ``cdr``: the node as it runs (``fast_wire=True``): setpoints read by the
  hand-written CDR readers, outputs written into serialized templates
  (flight_sim_dynamics.ros.wire);
* ``rclpy``: the same node with ``fast_wire=False``: every setpoint through
  rclpy's ``deserialize_message`` and every output published as a message
  object (rclpy converts and serializes it).

    python -m benchmarks.bench_callbacks [--setpoints 5000] [--repeat 4]

Prints, per repeat and path (the two alternate, in turn first; the rclpy
path's lines start with ``rclpy (de)serialisation:``), microseconds
per setpoint of wall time (the node's share of the latency: the callbacks run
back to back, nothing waits) and of CPU time (process_time), for the three
topics (pose + twist + accel callbacks) and for one ``platform_setpoint``
JointTrajectory, and the reading + checking of the JointTrajectory alone.
The publishers have no subscriber (the middleware drops the samples). Uses
its own ROS_DOMAIN_ID unless one is set.
"""
from __future__ import annotations

import argparse
import os
import random
import struct
import sys
import time
from typing import Any, Callable, Sequence

import rclpy
from geometry_msgs.msg import AccelStamped, PoseStamped, TwistStamped
from rclpy.serialization import serialize_message
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

from flight_sim_dynamics.ros import wire
from flight_sim_dynamics.ros.dynamics_node import DynamicsNode
from flight_sim_dynamics.ros.inputs import PLATFORM_DOF_NAMES, platform_setpoints, rpy_to_quaternion


def timed(run: Callable[[], Any], n: int) -> tuple[float, float]:
    """(wall, CPU) microseconds per item of ``run()`` over ``n`` items."""
    w0, c0 = time.perf_counter(), time.process_time()
    run()
    return 1e6 * (time.perf_counter() - w0) / n, 1e6 * (time.process_time() - c0) / n


def main(argv: Sequence[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    p.add_argument('--setpoints', type=int, default=5000)
    p.add_argument('--repeat', type=int, default=4)
    args = p.parse_args(argv)
    os.environ.setdefault('ROS_DOMAIN_ID', str(random.randint(101, 200)))
    os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')

    q, qd, qdd = (0.01, 0.02, 0.02), (0.1, 0.05, 0.02), (0.2, 0.1, 0.05)
    pose, twist, accel = PoseStamped(), TwistStamped(), AccelStamped()
    pose.pose.position.x, pose.pose.position.z = q[0], q[1]
    o = pose.pose.orientation
    o.x, o.y, o.z, o.w = rpy_to_quaternion(q[2])
    twist.twist.linear.x, twist.twist.linear.z, twist.twist.angular.x = qd
    accel.accel.linear.x, accel.accel.linear.z, accel.accel.angular.x = qdd
    traj = JointTrajectory()
    traj.joint_names = list(PLATFORM_DOF_NAMES)
    order = [('surge', 'heave', 'roll').index(n) for n in PLATFORM_DOF_NAMES]
    traj.points = [JointTrajectoryPoint(positions=[q[i] for i in order],
                                        velocities=[qd[i] for i in order],
                                        accelerations=[qdd[i] for i in order])]
    templates = [serialize_message(m) for m in (pose, twist, accel, traj)]
    stamp = struct.Struct('<iI' if templates[0][1] == 1 else '>iI')

    def stamped(data: bytes, k: int) -> bytes:
        """``data`` with header stamp 1000 s + k ms (bytes 4-11 of a stamped message)."""
        return data[:4] + stamp.pack(1000 + k // 1000, (k % 1000) * 1_000_000) + data[12:]

    rclpy.init()
    nodes = {'cdr': DynamicsNode(fast_wire=True), 'rclpy': DynamicsNode(fast_wire=False)}
    for node in nodes.values():
        assert node.start(), node.failure       # configure + activate, as autostart does
    n, k = args.setpoints, 0
    print(f'# {n} setpoints per figure; us per setpoint, wall / CPU')
    totals: dict[str, list[float]] = {path: [0.0, 0.0] for path in nodes}
    for r in range(args.repeat):
        three = [tuple(stamped(t, k + i) for t in templates[:3]) for i in range(n)]
        one = [stamped(templates[3], k + n + i) for i in range(n)]
        k += 2 * n
        paths = list(nodes) if r % 2 == 0 else list(reversed(nodes))
        for path in paths:
            node, fast = nodes[path], path == 'cdr'

            def topics(node: Any = node) -> None:
                for p_, t_, a_ in three:
                    node._on_pose(p_)
                    node._on_twist(t_)
                    node._on_accel(a_)

            def platform(node: Any = node) -> None:
                for m in one:
                    node._on_platform_setpoint(m)

            def reading(fast: bool = fast) -> None:
                for m in one:
                    platform_setpoints(wire.read_trajectory(m, fast)[0], 100.0, 100.0)

            t_wall, t_cpu = timed(topics, n)
            p_wall, p_cpu = timed(platform, n)
            r_wall, r_cpu = timed(reading, n)
            totals[path][0] += t_cpu
            totals[path][1] += p_cpu
            # the CDR path's lines keep their historical form ('three topics ...')
            label = '' if path == 'cdr' else 'rclpy (de)serialisation: '
            print(f'{label}three topics {t_wall:.1f} / {t_cpu:.1f}, platform_setpoint '
                  f'{p_wall:.1f} / {p_cpu:.1f}, of which reading + checking the '
                  f'JointTrajectory {r_wall:.1f} / {r_cpu:.1f}', flush=True)
    for what, i in (('three topics', 0), ('platform_setpoint', 1)):
        cdr, slow = totals['cdr'][i] / args.repeat, totals['rclpy'][i] / args.repeat
        print(f'mean CPU per setpoint, {what}: cdr {cdr:.1f} us, rclpy {slow:.1f} us, '
              f'difference {slow - cdr:.1f} us ({100 * (slow - cdr) / slow:.0f} %)')
    status = 0
    for path, node in nodes.items():
        answered = node._stats.answered
        rejected = {r: c for r, c in node._stats.rejected.items() if c}
        fallbacks = node._stats.wire_fallbacks
        if answered != 2 * n * args.repeat or rejected:
            print(f'ERROR {path}: answered {answered} of {2 * n * args.repeat}, '
                  f'rejected {rejected}')
            status = 1
        if (fallbacks == 0) != (path == 'cdr'):
            print(f'ERROR {path}: {fallbacks} wire fallbacks')
            status = 1
        node.destroy_node()
    rclpy.try_shutdown()
    return status


if __name__ == '__main__':
    sys.exit(main())
