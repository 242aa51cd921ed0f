"""The rclpy side of a measured stream: the driver (publishes setpoints on a
fixed schedule, records when each answer arrives) and the bare echo
(PoseStamped in, JointState out). Started as processes by
:func:`benchmarks.node_stream.run_stream` through ``python -m
benchmarks.bench_node drive|echo``.
"""
from __future__ import annotations

import argparse
import array
import json
import math
import os
import struct
import time
from typing import Any, Callable, Sequence

import numpy as np
import rclpy
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import AccelStamped, PoseStamped, TwistStamped
from rclpy.context import Context
from rclpy.executors import ExternalShutdownException
from rclpy.experimental import EventsExecutor
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rclpy.serialization import deserialize_message, serialize_message
from sensor_msgs.msg import JointState
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

from flight_sim_dynamics.ros.node import make_executor, spin
from flight_sim_dynamics.ros.diagnostics import DIAGNOSTIC_TASK
from flight_sim_dynamics.ros.inputs import PLATFORM_DOF_NAMES, rpy_to_quaternion

from .node_stream import LEG_NAMES, SETPOINT_INPUTS, STAMP_BASE_S, stream_motion


# ----------------------------------------------------------------------------
# The driver process (rclpy)
# ----------------------------------------------------------------------------
def drive_main(argv: Sequence[str]) -> int:
    p = argparse.ArgumentParser(prog='python -m benchmarks.bench_node drive')
    p.add_argument('--expect', choices=('node', 'echo'), default='node')
    p.add_argument('--input', choices=SETPOINT_INPUTS, default='topics',
                   help='how a setpoint is sent (topics: pose + twist + accel; trajectory: '
                        'one JointTrajectory on platform_setpoint)')
    p.add_argument('--rate', type=float, required=True)
    p.add_argument('--seconds', type=float, required=True)
    p.add_argument('--depth', type=int, default=1000)
    p.add_argument('--out', required=True)
    p.add_argument('--progress', type=float, default=0.0,
                   help='print a PROGRESS line every this many seconds (0: never)')
    p.add_argument('--drain', type=float, default=3.0,
                   help='after the last publish, wait until every answer is in or none '
                        'came for this long')
    p.add_argument('--discovery-timeout', type=float, default=60.0)
    p.add_argument('--python-messages', action='store_true',
                   help='publish and receive Python message objects (converted to and from '
                        'C by rclpy in this process) instead of serialized messages')
    args = p.parse_args(argv)


    rate = args.rate
    n = int(round(args.seconds * rate))
    period_ns = int(round(1e9 / rate))
    base_ns = STAMP_BASE_S * 1_000_000_000
    motion_q, motion_qd, motion_qdd = stream_motion(rate)
    quats = [rpy_to_quaternion(q[2]) for q in motion_q]
    m = len(motion_q)

    context = Context()
    rclpy.init(context=context)
    node = rclpy.create_node('bench_driver', context=context)
    qos = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=args.depth,
                     reliability=ReliabilityPolicy.RELIABLE,
                     durability=DurabilityPolicy.VOLATILE)
    pose_pub = node.create_publisher(PoseStamped, 'pose_setpoint', qos)
    twist_pub = node.create_publisher(TwistStamped, 'twist_setpoint', qos)
    accel_pub = node.create_publisher(AccelStamped, 'accel_setpoint', qos)
    trajectory = args.input == 'trajectory'
    traj_pub = node.create_publisher(JointTrajectory, 'platform_setpoint', qos)
    # measured samples are k = 0..n-1; warm-up samples use negative k (earlier stamps)
    warm = 200
    recv = [math.nan] * n
    counts = {'dup': 0, 'warm': 0, 'last': 0.0}
    clock = time.monotonic
    first_ns = base_ns + warm * period_ns       # stamp of sample k = 0

    # The stamp of a serialized (CDR) message: int32 sec, uint32 nanosec right
    # after the 4-byte encapsulation header (byte 1: 1 = little endian).
    stamp_le, stamp_be = struct.Struct('<iI'), struct.Struct('>iI')
    raw = not args.python_messages

    def on_actuator(msg: Any) -> None:
        t = clock()
        if raw:
            sec, nanosec = (stamp_le if msg[1] == 1 else stamp_be).unpack_from(msg, 4)
        else:
            sec, nanosec = msg.header.stamp.sec, msg.header.stamp.nanosec
        k = (sec * 1_000_000_000 + nanosec - first_ns) // period_ns
        if 0 <= k < n:
            if recv[k] != recv[k]:       # nan: first answer
                recv[k] = t
            else:
                counts['dup'] += 1
        else:
            counts['warm'] += 1
        counts['last'] = t

    diagnostics: list = []

    def on_diagnostics(msg: Any) -> None:
        t = clock()
        for status in msg.status:
            if status.name.endswith(': ' + DIAGNOSTIC_TASK):
                diagnostics.append((t, {kv.key: kv.value for kv in status.values}))

    node.create_subscription(JointState, 'actuator_states', on_actuator, qos, raw=raw)
    node.create_subscription(DiagnosticArray, '/diagnostics', on_diagnostics, 10)
    executor = EventsExecutor(context=context)
    executor.add_node(node)

    def spin_until(pred: Callable[[], bool], timeout: float) -> bool:
        end = clock() + timeout
        while not pred():
            left = end - clock()
            if left <= 0:
                return pred()
            executor.spin_once(timeout_sec=min(0.05, left))   # always with a timeout
        return True

    pose, twist, accel = PoseStamped(), TwistStamped(), AccelStamped()
    pose.header.frame_id = 'simulator_base'
    pp, po = pose.pose.position, pose.pose.orientation
    tl, ta = twist.twist.linear, twist.twist.angular
    al, aa = accel.accel.linear, accel.accel.angular
    stamp = pose.header.stamp
    traj = JointTrajectory()
    traj.header.frame_id = 'simulator_base'
    traj.joint_names = list(PLATFORM_DOF_NAMES)
    point = JointTrajectoryPoint()
    traj.points = [point]
    dof = [('surge', 'heave', 'roll').index(name) for name in PLATFORM_DOF_NAMES]

    def fill(i: int) -> None:
        """The messages of motion sample i (stamp aside)."""
        q, qd, qdd = motion_q[i], motion_qd[i], motion_qdd[i]
        pp.x, pp.z = q[0], q[1]
        po.x, po.y, po.z, po.w = quats[i]
        tl.x, tl.z, ta.x = qd
        al.x, al.z, aa.x = qdd
        point.positions = [float(q[j]) for j in dof]
        point.velocities = [float(qd[j]) for j in dof]
        point.accelerations = [float(qdd[j]) for j in dof]
        traj.points = [point]

    def publish_messages(j: int) -> None:
        """Sample j (>= 0: measured k = j - warm) of the whole run."""
        sec, nsec = divmod(base_ns + j * period_ns, 1_000_000_000)
        stamp.sec, stamp.nanosec = sec, nsec
        twist.header.stamp = stamp
        accel.header.stamp = stamp
        traj.header.stamp = stamp
        fill(j % m)
        if trajectory:
            traj_pub.publish(traj)
            return
        pose_pub.publish(pose)
        twist_pub.publish(twist)
        accel_pub.publish(accel)

    # Serialized: each motion sample's three messages are serialized once, before
    # the stream; per sample only the stamp (bytes 4-11 of every *Stamped
    # message) is put in, so the driver's own cost per publish is the
    # middleware's, as for a planner written in C++.
    serialized: list[tuple[bytes, ...]] = []
    head = b''
    if raw:
        for i in range(m):
            fill(i)
            serialized.append(tuple(serialize_message(x)[12:]
                                    for x in (pose, twist, accel, traj)))
        head = serialize_message(pose)[:4]
        stamp_pack = (stamp_le if head[1] == 1 else stamp_be).pack
        # check one sample the slow way
        fill(1 % m)
        stamp.sec, stamp.nanosec = 12345, 678
        back = deserialize_message(head + stamp_pack(12345, 678) + serialized[1 % m][0],
                                   PoseStamped)
        if back != pose:
            print('ERROR serialized pose template does not read back', flush=True)
            return 3
        traj.header.stamp = stamp
        back = deserialize_message(head + stamp_pack(12345, 678) + serialized[1 % m][3],
                                   JointTrajectory)
        if back != traj:
            print('ERROR serialized trajectory template does not read back', flush=True)
            return 3

    def publish_serialized(j: int) -> None:
        """Sample j (>= 0: measured k = j - warm) of the whole run."""
        p_, t_, a_, s_ = serialized[j % m]
        h = head + stamp_pack(*divmod(base_ns + j * period_ns, 1_000_000_000))
        if trajectory:
            traj_pub.publish(h + s_)
            return
        pose_pub.publish(h + p_)
        twist_pub.publish(h + t_)
        accel_pub.publish(h + a_)

    publish = publish_serialized if raw else publish_messages

    subs = ([pose_pub] if args.expect == 'echo' else [traj_pub] if trajectory
            else [pose_pub, twist_pub, accel_pub])
    t0 = clock()
    found = spin_until(lambda: all(pb.get_subscription_count() > 0 for pb in subs)
                       and node.count_publishers('actuator_states') > 0,
                       args.discovery_timeout)
    if not found:
        print('ERROR discovery timed out', flush=True)
        return 3
    discovery_s = clock() - t0
    # warm-up (not measured): until answers flow both ways, at most `warm` samples at 100 Hz
    for j in range(warm):
        publish(j)
        spin_until(lambda: False, 0.01)
        if counts['warm'] >= 20:
            break
    spin_until(lambda: False, 0.3)

    send = [math.nan] * n
    sent = [math.nan] * n           # just after the sample's last message was published
    sched = [math.nan] * n
    period = 1.0 / rate
    start = clock() + 0.01
    print(f'START {start:.6f}', flush=True)
    next_progress = start + args.progress if args.progress > 0 else math.inf
    spin_once = executor.spin_once
    for k in range(n):
        target = start + k * period
        now = clock()
        while now < target:
            spin_once(timeout_sec=target - now)
            now = clock()
        sched[k] = target
        send[k] = clock()
        publish(warm + k)
        sent[k] = clock()
        if now >= next_progress:
            got = sum(1 for r in recv if r == r)
            print(f'PROGRESS t={now - start:.0f}s sent={k + 1} answered={got} '
                  f'load={os.getloadavg()[0]:.2f}', flush=True)
            next_progress += args.progress
    streamed = clock()
    print('STREAMED', flush=True)

    def all_in() -> bool:
        return all(r == r for r in recv)

    while not all_in():
        before = counts['last']
        spin_until(all_in, args.drain)
        if counts['last'] == before:      # nothing new for a whole drain period
            break
    end = clock()
    print('DRAINED', flush=True)
    received = [r for r in recv if r == r]
    meta = dict(start=start, end=end, duplicates=counts['dup'], discovery_s=discovery_s,
                drain_s=(max(received) - streamed) if received else math.nan,
                diagnostics=diagnostics)
    np.savez(args.out, send=np.array(send), sent=np.array(sent), recv=np.array(recv),
             scheduled=np.array(sched), meta=np.array(json.dumps(meta)))
    node.destroy_node()
    rclpy.try_shutdown(context=context)
    return 0


# ----------------------------------------------------------------------------
# The bare echo (rclpy)
# ----------------------------------------------------------------------------
def echo_main(argv: Sequence[str]) -> int:
    """PoseStamped in (``pose_setpoint``), JointState out (``actuator_states``,
    the pose's stamp, 3 names, 3 x 3 values): the middleware's own cost, with
    the node's QoS and executor and nothing else.
    """
    own = rclpy.utilities.remove_ros_args(['bench_echo', *argv])[1:]
    p = argparse.ArgumentParser(prog='python -m benchmarks.bench_node echo')
    p.add_argument('--executor', choices=('events', 'single'), default='events')
    p.add_argument('--depth', type=int, default=100)
    args = p.parse_args(own)
    rclpy.init(args=['bench_echo', *argv])
    node = rclpy.create_node('bench_echo')
    qos = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=args.depth,
                     reliability=ReliabilityPolicy.RELIABLE,
                     durability=DurabilityPolicy.VOLATILE)
    out = JointState()
    out.name = list(LEG_NAMES)
    pub = node.create_publisher(JointState, 'actuator_states', qos)

    def on_pose(msg: Any) -> None:
        out.header.stamp = msg.header.stamp
        p_, o = msg.pose.position, msg.pose.orientation
        values = array.array('d', (p_.x, p_.z, o.x))
        out.position = values
        out.velocity = values
        out.effort = values
        pub.publish(out)

    node.create_subscription(PoseStamped, 'pose_setpoint', on_pose, qos)
    executor = make_executor(args.executor)
    executor.add_node(node)
    try:
        spin(executor)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
    return 0
