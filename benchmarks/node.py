"""The node's round trip under a setpoint stream (pose + twist + accel at
--rate, the machine's ``cueing`` motion, each timed until its
``actuator_states``; the driver subscribes to ``markers`` as a viewer does): the
node with its markers at the file's rate, the node without markers
(``output.markers_rate:=0``) and a same-traffic rclpy echo (the node's three
subscriptions and two JointStates, no solve), in rotating order;
the ratios to the echo and of markers on to off; then what one markers array
costs the node's thread and the renderer process.

    python -m benchmarks.node [--params FILE] [--rate 1000] [--seconds 5] [--repeats 3] [--quick]
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
MOTION = 'cueing'
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


def echo_main(legs: int, joints: int) -> int:
    """The reference: the node's subscriptions and outputs, no solve."""
    import rclpy
    from geometry_msgs.msg import AccelStamped, PoseStamped, TwistStamped
    from rclpy.experimental import EventsExecutor
    from sensor_msgs.msg import JointState

    rclpy.init()
    node = rclpy.create_node('bench_echo')
    n_legs, n_joints = legs, joints
    legs = JointState(name=[f'leg_{i}' for i in range(n_legs)])
    joints = JointState(name=[f'j{i}' for i in range(n_joints)])
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
                legs.position = legs.velocity = legs.effort = [0.1] * n_legs  # as the node:
                joints.position = joints.velocity = [0.1] * n_joints         # 3 and 2 arrays
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


def setpoint_messages(machine: Any, q: Any, qd: Any, qdd: Any) -> tuple[Any, Any, Any]:
    """Pose, twist and acceleration of one sample by the machine's coordinate
    names (absent ones 0; the Euler-angle rates sent as the angular parts).
    """
    from geometry_msgs.msg import AccelStamped, PoseStamped, TwistStamped

    def named(values: Any) -> dict[str, float]:
        return dict(zip(machine.coordinates, (float(v) for v in values)))
    p, v, a = named(q), named(qd), named(qdd)
    pose, twist, accel = PoseStamped(), TwistStamped(), AccelStamped()
    pose.pose.position.x, pose.pose.position.y, pose.pose.position.z = (
        p.get(k, 0.0) for k in ('surge', 'sway', 'heave'))
    r, pi, y = (p.get(k, 0.0) / 2 for k in ('roll', 'pitch', 'yaw'))   # ZYX quaternion
    o = pose.pose.orientation
    o.w = math.cos(r) * math.cos(pi) * math.cos(y) + math.sin(r) * math.sin(pi) * math.sin(y)
    o.x = math.sin(r) * math.cos(pi) * math.cos(y) - math.cos(r) * math.sin(pi) * math.sin(y)
    o.y = math.cos(r) * math.sin(pi) * math.cos(y) + math.sin(r) * math.cos(pi) * math.sin(y)
    o.z = math.cos(r) * math.cos(pi) * math.sin(y) - math.sin(r) * math.sin(pi) * math.cos(y)
    for msg, d in ((twist.twist, v), (accel.accel, a)):
        msg.linear.x, msg.linear.y, msg.linear.z = (d.get(k, 0.0) for k in ('surge', 'sway',
                                                                             'heave'))
        msg.angular.x, msg.angular.y, msg.angular.z = (d.get(k, 0.0) for k in ('roll', 'pitch',
                                                                              'yaw'))
    return pose, twist, accel


def drive_main(params: str, rate: float, seconds: float) -> int:
    """Stream, then print one JSON line: sent, and the latency (ms) of each answer."""
    import rclpy
    from geometry_msgs.msg import AccelStamped, PoseStamped, TwistStamped
    from rclpy.experimental import EventsExecutor
    from rclpy.serialization import serialize_message
    from sensor_msgs.msg import JointState
    from visualization_msgs.msg import MarkerArray

    import flight_sim_dynamics as fsd

    rclpy.init()
    node = rclpy.create_node('bench_driver')
    pubs = [node.create_publisher(k, t, qos())
            for k, t in zip((PoseStamped, TwistStamped, AccelStamped), TOPICS)]
    # the machine's cueing motion, each message serialized once; per sample
    # only the stamp (bytes 4-11 of a stamped message) is written
    machine = fsd.machine_of(fsd.load_model(params))
    _, *motion = machine.motions[MOTION].sampled(rate)
    samples = [[serialize_message(m) for m in setpoint_messages(machine, *sample)]
               for sample in zip(*motion)]
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
    # a viewer of the markers, as RViz is (the node draws them only for a subscriber)
    node.create_subscription(MarkerArray, 'markers', lambda data: None, 10, raw=True)
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


def stream(target: str, params: Path, rate: float, seconds: float, env: dict[str, str],
           log_dir: Path) -> dict[str, float]:
    """One stream against ``target`` (a key of :data:`TARGETS`): answered,
    lost, median, p99 and max latency (ms).
    """
    import flight_sim_dynamics as fsd
    from flight_sim_dynamics.ros.process import start_node, stop_node

    log = log_dir / f'{target}_{rate:g}.log'
    if target == ECHO:
        machine = fsd.machine_of(fsd.load_model(params))
        proc = subprocess.Popen([sys.executable, '-m', 'benchmarks.node', 'echo',
                                 str(len(machine.legs)), str(len(machine.joints))], cwd=ROOT,
                                env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                                start_new_session=True)
    else:
        proc = start_node(params, TARGETS[target], log=log, env=env, cwd=ROOT)
    try:
        driver = subprocess.run([sys.executable, '-m', 'benchmarks.node', 'drive', str(params),
                                 f'{rate:g}', f'{seconds:g}'], cwd=ROOT, env=env,
                                capture_output=True, text=True, timeout=seconds + 120)
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


def marker_costs(params: Path, n: int) -> list[list[str]]:
    """Per markers array, µs (median, p99) on the node's thread (the snapshot,
    the renderer's request, the raw publish) and in the renderer (building and
    serializing the array), over ``n`` solutions of the cueing motion.
    """
    import rclpy
    from rclpy.context import Context
    from visualization_msgs.msg import MarkerArray

    import flight_sim_dynamics as fsd
    from flight_sim_dynamics.ros.marker_publisher import render, request
    from flight_sim_dynamics.ros.markers import snapshot

    model = fsd.load_model(params)
    machine = fsd.machine_of(model)
    _, q, qd, qdd = machine.motions[MOTION].sampled(n / machine.motions[MOTION].duration)
    sols = [machine.solve(model, *sample) for sample in zip(q[:n], qd[:n], qdd[:n])]
    _, builder = render(request(model, 'simulator_base', (0, 0), None), None)
    context = Context()
    rclpy.init(context=context)
    node = rclpy.create_node('bench_markers', context=context)
    pub = node.create_publisher(MarkerArray, 'bench_markers', 10)
    node_side, renderer = [], []
    try:
        for k, sol in enumerate(sols):
            t0 = time.perf_counter()
            message = request(None, 'simulator_base', (k, 0), snapshot(machine, model, sol))
            t1 = time.perf_counter()
            reply, builder = render(message, builder)
            t2 = time.perf_counter()
            pub.publish(reply[1:])
            t3 = time.perf_counter()
            node_side.append(1e6 * (t1 - t0 + t3 - t2))
            renderer.append(1e6 * (t2 - t1))
    finally:
        node.destroy_node()
        rclpy.try_shutdown(context=context)

    def cells(values: list[float]) -> list[str]:
        values = sorted(values)
        return [f'{values[len(values) // 2]:.1f}', f'{values[int(0.99 * len(values))]:.1f}']
    return [["node's thread (snapshot, request, raw publish)", *cells(node_side)],
            ['renderer process (build, serialize)', *cells(renderer)]]


ECHO = 'echo'
#: the streams' targets: the node's ROS arguments, or the echo
TARGETS = {'node, markers on': (), 'node, markers off': ('-p', 'output.markers_rate:=0.0'),
           ECHO: None}


def main(argv: Sequence[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    if argv[:1] == ['echo']:                  # the processes this one starts
        return echo_main(int(argv[1]), int(argv[2]))
    if argv[:1] == ['drive']:
        return drive_main(argv[1], float(argv[2]), float(argv[3]))
    p = argparse.ArgumentParser(prog='python -m benchmarks.node',
                                description=__doc__.split('\n\n')[0])
    p.add_argument('--params', type=Path, default=PARAMS_FILE,
                   help="the node's parameter file (the machine; default: %(default)s)")
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
    params = args.params.resolve()
    names = list(TARGETS)
    runs: dict[str, list[dict[str, float]]] = {name: [] for name in names}
    with tempfile.TemporaryDirectory(prefix='fsd_bench_') as tmp:
        for r in range(repeats):
            for target in names[r % len(names):] + names[:r % len(names)]:
                runs[target].append(stream(target, params, args.rate, seconds, env, Path(tmp)))
    print(header(f'{params.name}, {args.rate:g} Hz, {repeats} x {seconds:g} s per target, '
                 f'ROS_DOMAIN_ID {env["ROS_DOMAIN_ID"]}; latency ms, median of the streams'))
    rows, figures = [], {}
    for target, results in runs.items():
        m = figures[target] = {k: statistics.median(r[k] for r in results) for k in results[0]}
        rows.append([target, f'{m["median"]:.3f}', f'{m["p99"]:.3f}', f'{m["max"]:.1f}',
                     f'{sum(r["lost"] for r in results):g} / '
                     f'{sum(r["answered"] + r["lost"] for r in results):g}'])
    print(table(['target', 'median ms', 'p99 ms', 'max ms', 'lost / sent'], rows))
    echo = figures[ECHO]
    print(table(['ratio to the echo', 'median', 'p99'],
                [[target, f'{m["median"] / echo["median"]:.2f}x', f'{m["p99"] / echo["p99"]:.2f}x']
                 for target, m in figures.items() if target != ECHO]))
    on, off = figures['node, markers on'], figures['node, markers off']
    print(table(['the markers\' cost', 'median', 'p99'],
                [['node, markers on / markers off', f'{on["median"] / off["median"]:.2f}x',
                  f'{on["p99"] / off["p99"]:.2f}x']]))
    print(table(['markers, per array', 'median µs', 'p99 µs'],
                marker_costs(params, 100 if args.quick else 1000)))
    return 0


if __name__ == '__main__':
    raise SystemExit(main())
