#!/usr/bin/env python3
"""The node's own Python cost per setpoint, by input (docs/node.md, "What a
cycle costs"): the subscription callbacks of a real ``DynamicsNode`` called
directly with serialized samples, without DDS delivering them, so the figure
is what the node's Python does per setpoint (read, check, synchronise,
estimate, solve, fill and publish both outputs, bookkeeping) and nothing of
the executor's taking and dispatching.

    python scripts/bench_callbacks.py [--setpoints 5000] [--repeat 4]

Prints, per repeat, microseconds per setpoint for the three topics (pose +
twist + accel callbacks) and for one ``platform_setpoint`` JointTrajectory,
and the reading + checking of the JointTrajectory alone. The publishers have
no subscriber (the middleware drops the samples). Uses its own
ROS_DOMAIN_ID unless one is set.
"""
from __future__ import annotations

import argparse
import os
import random
import struct
import sys
import time
from pathlib import Path
from typing import Sequence

ROOT = Path(__file__).resolve().parent.parent
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))


def main(argv: Sequence[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    p.add_argument('--setpoints', type=int, default=5000)
    p.add_argument('--repeat', type=int, default=4)
    args = p.parse_args(argv)
    os.environ.setdefault('ROS_DOMAIN_ID', str(random.randint(101, 200)))
    os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')

    import rclpy
    from geometry_msgs.msg import AccelStamped, PoseStamped, TwistStamped
    from rclpy.serialization import serialize_message
    from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

    from flight_sim_dynamics.ros.dynamics_node import DynamicsNode
    from flight_sim_dynamics.ros.inputs import (PLATFORM_DOF_NAMES, platform_setpoints,
                                                rpy_to_quaternion)
    from flight_sim_dynamics.ros.wire import read_joint_trajectory

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
    node = DynamicsNode()
    n, k = args.setpoints, 0
    print(f'# {n} setpoints per figure; us per setpoint')
    for _ in range(args.repeat):
        three = [tuple(stamped(t, k + i) for t in templates[:3]) for i in range(n)]
        one = [stamped(templates[3], k + n + i) for i in range(n)]
        k += 2 * n
        t0 = time.perf_counter()
        for p_, t_, a_ in three:
            node._on_pose(p_)
            node._on_twist(t_)
            node._on_accel(a_)
        t1 = time.perf_counter()
        for m in one:
            node._on_platform_setpoint(m)
        t2 = time.perf_counter()
        for m in one:
            platform_setpoints(read_joint_trajectory(m), 100.0, 100.0)
        t3 = time.perf_counter()
        print(f'three topics {1e6 * (t1 - t0) / n:.1f}, platform_setpoint '
              f'{1e6 * (t2 - t1) / n:.1f}, of which reading + checking the '
              f'JointTrajectory {1e6 * (t3 - t2) / n:.1f}', flush=True)
    answered = node._stats.answered
    rejected = {r: c for r, c in node._stats.rejected.items() if c}
    node.destroy_node()
    rclpy.try_shutdown()
    if answered != 2 * n * args.repeat or rejected:
        print(f'ERROR answered {answered} of {2 * n * args.repeat}, rejected {rejected}')
        return 1
    return 0


if __name__ == '__main__':
    sys.exit(main())
