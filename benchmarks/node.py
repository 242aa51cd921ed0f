"""The node's round trip under a setpoint stream (pose + twist + accel at
--rate, each timed until its ``actuator_states``), next to a same-traffic rclpy
echo (the node's three subscriptions and two JointStates, no solve), alternating.

    python -m benchmarks.node [--rate 1000] [--seconds 5] [--repeats 3] [--quick]
"""
from __future__ import annotations

import argparse
import json
import math
import os
import random
import statistics
import struct
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any, Sequence

from ._common import ROOT, header, table

PARAMS_FILE = ROOT / 'config' / 'flight_sim_dynamics.yaml'
TOPICS = ('pose_setpoint', 'twist_setpoint', 'accel_setpoint')
LEGS = ('leg_a', 'leg_b', 'leg_c')
JOINTS = 12
BASE_NS = 1_700_000_000 * 10**9
WARM = 200


def qos() -> Any:
    """The node's default QoS of setpoints and outputs: reliable, volatile, keep last 1000."""
    from rclpy.qos import QoSProfile
    return QoSProfile(depth=1000)


def spin_for(executor: Any, seconds: float, until: Any = lambda: False) -> bool:
    end = time.monotonic() + seconds
    while not until() and time.monotonic() < end:
        executor.spin_once(timeout_sec=min(0.05, max(end - time.monotonic(), 0.0)))
    return bool(until())


def echo_main() -> int:
    """The reference: the node's subscriptions and outputs, no solve."""
    import rclpy
    from geometry_msgs.msg import AccelStamped, PoseStamped, TwistStamped
    from rclpy.experimental import EventsExecutor
    from sensor_msgs.msg import JointState

    rclpy.init()
    node = rclpy.create_node('bench_echo')
    legs, joints = JointState(name=list(LEGS)), JointState(name=[f'j{i}' for i in range(JOINTS)])
    pubs = [node.create_publisher(JointState, t, qos()) for t in ('actuator_states',
                                                                    'joint_states')]
    got: dict[tuple[int, int], list] = {}

    def on(i: int) -> Any:
        def callback(msg: Any) -> None:
            key = (msg.header.stamp.sec, msg.header.stamp.nanosec)
            seen = got.setdefault(key, [None] * 3)
            seen[i] = msg
            if all(seen):
                del got[key]
                legs.header.stamp = joints.header.stamp = msg.header.stamp
                legs.position = legs.velocity = legs.effort = [0.1] * 3   # as the node:
                joints.position = joints.velocity = [0.1] * JOINTS       # 3 and 2 arrays
                pubs[0].publish(legs)
                pubs[1].publish(joints)
        return callback

    for i, (t, kind) in enumerate(zip(TOPICS, (PoseStamped, TwistStamped, AccelStamped))):
        node.create_subscription(kind, t, on(i), qos())
    executor = EventsExecutor()
    executor.add_node(node)
    try:
        while rclpy.ok():
            executor.spin_once(timeout_sec=0.1)
    except KeyboardInterrupt:
        pass
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
    return 0


def drive_main(rate: float, seconds: float) -> int:
    """Stream, then print one JSON line: sent, and the latency (ms) of each answer."""
    import numpy as np
    import rclpy
    from geometry_msgs.msg import AccelStamped, PoseStamped, TwistStamped
    from rclpy.experimental import EventsExecutor
    from rclpy.serialization import serialize_message
    from sensor_msgs.msg import JointState

    import flight_sim_dynamics as fsd

    rclpy.init()
    node = rclpy.create_node('bench_driver')
    pubs = [node.create_publisher(k, t, qos())
            for k, t in zip((PoseStamped, TwistStamped, AccelStamped), TOPICS)]
    # one period of the paper's general motion, each message serialized once;
    # per sample only the stamp (bytes 4-11 of a stamped message) is written
    t = np.arange(0.0, 3.0, 1.0 / rate)
    samples = []
    for q, qd, qdd in zip(*fsd.trajectories.paper_example('general', t)):
        pose, twist, accel = PoseStamped(), TwistStamped(), AccelStamped()
        pose.pose.position.x, pose.pose.position.z = q[0], q[1]
        pose.pose.orientation.x, pose.pose.orientation.w = math.sin(q[2] / 2), math.cos(q[2] / 2)
        twist.twist.linear.x, twist.twist.linear.z, twist.twist.angular.x = qd
        accel.accel.linear.x, accel.accel.linear.z, accel.accel.angular.x = qdd
        samples.append([serialize_message(m) for m in (pose, twist, accel)])
    stamp = struct.Struct('<iI' if samples[0][0][1] == 1 else '>iI')
    period_ns = int(round(1e9 / rate))
    n = int(round(seconds * rate))
    sent, got, late = [math.nan] * n, [math.nan] * n, {'n': 0}

    def on_answer(data: bytes) -> None:
        now = time.monotonic()
        sec, nsec = stamp.unpack_from(data, 4)
        k = (sec * 10**9 + nsec - BASE_NS) // period_ns - WARM
        if 0 <= k < n and got[k] != got[k]:
            got[k] = now
        elif k < 0:
            late['n'] += 1

    node.create_subscription(JointState, 'actuator_states', on_answer, qos(), raw=True)
    executor = EventsExecutor()
    executor.add_node(node)

    def publish(j: int) -> None:
        head = stamp.pack(*divmod(BASE_NS + j * period_ns, 10**9))
        for pub, data in zip(pubs, samples[j % len(samples)]):
            pub.publish(data[:4] + head + data[12:])

    if not spin_for(executor, 60.0, lambda: all(p.get_subscription_count() for p in pubs)
                    and node.count_publishers('actuator_states') > 0):
        print(json.dumps({'error': 'discovery timed out'}), flush=True)
        return 1
    for j in range(WARM):                              # until answers flow
        publish(j)
        if spin_for(executor, 0.01, lambda: late['n'] >= 20):
            break
    spin_for(executor, 0.3)
    start = time.monotonic() + 0.01
    for k in range(n):
        target = start + k / rate
        while (now := time.monotonic()) < target:
            executor.spin_once(timeout_sec=target - now)
        sent[k] = time.monotonic()
        publish(WARM + k)
    spin_for(executor, 3.0, lambda: all(g == g for g in got))
    print(json.dumps({'sent': n, 'latency_ms': [1e3 * (g - s) for s, g in zip(sent, got)
                                                if g == g]}), flush=True)
    node.destroy_node()
    rclpy.try_shutdown()
    return 0


def stream(target: str, rate: float, seconds: float, env: dict[str, str],
           log_dir: Path) -> dict[str, float]:
    """One stream against ``target`` ('node' or 'echo'): answered, lost,
    median, p99 and max latency (ms).
    """
    from flight_sim_dynamics.ros.process import start_node, stop_node

    log = log_dir / f'{target}_{rate:g}.log'
    proc = (start_node(PARAMS_FILE, log=log, env=env, cwd=ROOT) if target == 'node' else
            subprocess.Popen([sys.executable, '-m', 'benchmarks.node', 'echo'], cwd=ROOT,
                             env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                             start_new_session=True))
    try:
        driver = subprocess.run([sys.executable, '-m', 'benchmarks.node', 'drive', f'{rate:g}',
                                 f'{seconds:g}'], cwd=ROOT, env=env, capture_output=True,
                                text=True, timeout=seconds + 120)
    finally:
        stop_node(proc)
    lines = [line for line in driver.stdout.splitlines() if line.startswith('{')]
    result = json.loads(lines[-1]) if lines else {'error': driver.stderr[-2000:]}
    if 'error' in result:
        raise RuntimeError(f'{target} at {rate:g} Hz: {result["error"]}\n'
                           + (log.read_text()[-2000:] if log.exists() else ''))
    lat = sorted(result['latency_ms'])
    pct = (lambda q: lat[min(len(lat) - 1, int(q * len(lat)))]) if lat else lambda q: math.nan
    return dict(answered=len(lat), lost=result['sent'] - len(lat), median=pct(0.5),
                p99=pct(0.99), max=lat[-1] if lat else math.nan)


def main(argv: Sequence[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    if argv[:1] == ['echo']:                  # the processes this one starts
        return echo_main()
    if argv[:1] == ['drive']:
        return drive_main(float(argv[1]), float(argv[2]))
    p = argparse.ArgumentParser(prog='python -m benchmarks.node',
                                description=__doc__.split('\n\n')[0])
    p.add_argument('--rate', type=float, default=1000.0, help='setpoints per second')
    p.add_argument('--seconds', type=float, default=5.0, help='per stream')
    p.add_argument('--repeats', type=int, default=3, help='streams per target (median of)')
    p.add_argument('--quick', action='store_true', help='1 stream of 1 s per target')
    args = p.parse_args(argv)
    if args.rate <= 0 or args.seconds <= 0 or args.repeats < 1:
        p.error('--rate and --seconds must be > 0, --repeats >= 1')
    seconds, repeats = (1.0, 1) if args.quick else (args.seconds, args.repeats)
    env = dict(os.environ, ROS_AUTOMATIC_DISCOVERY_RANGE='LOCALHOST', PYTHONUNBUFFERED='1')
    env.setdefault('ROS_DOMAIN_ID', str(random.randint(1, 100)))
    runs: dict[str, list[dict[str, float]]] = {'echo': [], 'node': []}
    with tempfile.TemporaryDirectory(prefix='fsd_bench_') as tmp:
        for r in range(repeats):
            for target in ('echo', 'node') if r % 2 == 0 else ('node', 'echo'):
                runs[target].append(stream(target, args.rate, seconds, env, Path(tmp)))
    print(header(f'{args.rate:g} Hz, {repeats} x {seconds:g} s per target, ROS_DOMAIN_ID '
                 f'{env["ROS_DOMAIN_ID"]}; latency ms, median of the streams'))
    rows = []
    for target, results in runs.items():
        m = {k: statistics.median(r[k] for r in results) for k in results[0]}
        rows.append([target, f'{m["median"]:.3f}', f'{m["p99"]:.3f}', f'{m["max"]:.1f}',
                     f'{sum(r["lost"] for r in results):g} / '
                     f'{sum(r["answered"] + r["lost"] for r in results):g}'])
    print(table(['target', 'median ms', 'p99 ms', 'max ms', 'lost / sent'], rows))
    return 0


if __name__ == '__main__':
    raise SystemExit(main())
