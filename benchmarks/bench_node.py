#!/usr/bin/env python3
"""Measure the node, and a bare rclpy echo, under a setpoint stream (docs/node.md,
"Executor"; docs/performance.md).

Three roles, each its own process:

* the **target**: the node (``python -m flight_sim_dynamics.ros.node --executor E``
  with the packaged parameters) or the bare echo (``python -m benchmarks.bench_node
  echo``: PoseStamped in, JointState out, nothing else);
* the **driver** (``python -m benchmarks.bench_node drive ...``): publishes pose +
  twist + accel with one stamp per sample (``--input trajectory``: one
  ``trajectory_msgs/JointTrajectory`` per sample on ``platform_setpoint``
  instead) at a fixed rate (the paper's general
  motion then the motion-cueing sequence, looped; reliable QoS, KEEP_LAST depth
  = the node's ``qos.depth``), receives ``actuator_states`` and records, per
  sample, the time just before its pose was published and the time its
  JointState arrived (both CLOCK_MONOTONIC, which all processes of the machine
  share), plus every ``/diagnostics`` message. It publishes messages
  serialized once before the stream (per sample only the stamp is put in) and
  takes ``actuator_states`` serialized (only the stamp is read), so that its
  own Python message conversions (tens of microseconds per message, on the
  measured path of both targets, and for the node twice more: its twist and
  accel go out after the pose) stay out of the latency; ``--python-messages``
  restores message objects;
* the caller (:func:`benchmarks.node_stream.run_stream`, no rclpy): starts both, samples the
  target's resident memory and CPU time (per thread) from /proc, stops everything.

``python -m benchmarks.bench_node profiled-node OUT [node arguments]`` runs the node
with cProfile enabled from SIGUSR1 on (:func:`run_stream` sends it when the
measured stream starts) and writes the stats to OUT when it exits.

The default command prints the executor table of docs/node.md:

    python -m benchmarks.bench_node [--rates 200 500] [--seconds 3] [--executors events single]
                                 [--echo] [--inputs topics trajectory] [--repeat 1]
                                 [--python-messages] [--domain-id 87]

"driver publishing" is the time the driver takes to publish one sample (three
messages with the topics, one with the trajectory); "after publishing" is the
latency counted from the end of that instead of its start. Every row also
gives the hypervisor's steal over the stream (``steal %``, from
/proc/stat): on a virtual machine a stolen core stalls every process on it,
which no executor or node code can avoid.

``python -m benchmarks.performance`` uses :func:`benchmarks.node_stream.run_stream`
for its node, echo and soak sections. Run from the repository root.
"""

from __future__ import annotations

import argparse
import cProfile
import math
import os
import signal
import sys
from typing import Sequence

import numpy as np

from flight_sim_dynamics.ros import node

from .node_driver import drive_main, echo_main
from .node_stream import SETPOINT_INPUTS, load_average, ros_env, run_stream


# ----------------------------------------------------------------------------
# The executor table (docs/node.md)
# ----------------------------------------------------------------------------
def _p99(values: np.ndarray) -> float:
    values = values[np.isfinite(values)]
    return float(np.percentile(values, 99)) if values.size else math.nan


def table_main(argv: Sequence[str]) -> int:
    parser = argparse.ArgumentParser(prog='python -m benchmarks.bench_node',
                                     description=__doc__.split('\n\n')[0])
    parser.add_argument('--rates', type=float, nargs='+', default=[200.0, 500.0])
    parser.add_argument('--seconds', type=float, default=3.0)
    parser.add_argument('--executors', nargs='+', default=['events', 'single'])
    parser.add_argument('--echo', action='store_true',
                        help='also measure the bare rclpy echo with each executor')
    parser.add_argument('--inputs', nargs='+', choices=SETPOINT_INPUTS, default=['topics'],
                        help='how the driver sends setpoints to the node (topics: pose + '
                             'twist + accel; trajectory: one JointTrajectory on '
                             'platform_setpoint); each is measured (default: topics)')
    parser.add_argument('--repeat', type=int, default=1,
                        help='run every stream this many times (echo and node alternate)')
    parser.add_argument('--python-messages', action='store_true',
                        help='the driver publishes and receives Python message objects '
                             '(default: serialized messages, see the module docstring)')
    parser.add_argument('--domain-id', type=int, default=None,
                        help='ROS_DOMAIN_ID of every process (default: $ROS_DOMAIN_ID or '
                             'random 1..100)')
    args = parser.parse_args(argv)
    env = ros_env(args.domain_id)
    print(f'# {os.cpu_count()} CPUs, load average {load_average()[0]:.2f} at start, '
          f'ROS_DOMAIN_ID={env["ROS_DOMAIN_ID"]}, driver '
          f'{"message objects" if args.python_messages else "serialized"}')
    print('| target | executor | rate Hz | answered / sent | lost | latency median ms '
          '| p90 ms | p99 ms | max ms | driver publishing p99 ms | p99 after publishing ms '
          '| target CPU per setpoint ms (Python thread) | load avg | steal % |')
    print('|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|')
    targets = ([('echo', 'topics')] if args.echo else []) + [('node', i) for i in args.inputs]
    for executor in args.executors:
        for rate in args.rates:
            for _ in range(args.repeat):
                for kind, setpoint_input in targets:
                    r = run_stream(kind, rate, args.seconds, env=env, executor=executor,
                                   python_messages=args.python_messages,
                                   setpoint_input=setpoint_input)
                    main_ms = 1e3 * r.main_thread_cpu_s / max(r.answered, 1)
                    name = kind if kind == 'echo' else f'node ({setpoint_input})'
                    print(f'| {name} | {executor} | {rate:g} | {r.answered} / {r.sent} '
                          f'| {r.lost} | {r.median:.2f} | {r.pct(90):.2f} | {r.p99:.2f} '
                          f'| {r.max:.1f} | {_p99(r.publish_ms):.2f} '
                          f'| {_p99(r.after_publish_ms):.2f} '
                          f'| {r.cpu_ms_per_setpoint:.3f} ({main_ms:.3f}) '
                          f'| {r.load[0]:.2f} | {r.steal_pct:.1f} |', flush=True)
    print(f'# load average {load_average()[0]:.2f} at end')
    return 0


def profiled_node_main(argv: Sequence[str]) -> int:
    """``profiled-node OUT [node arguments]``: the node with cProfile enabled from
    SIGUSR1 on (sent when the measured stream starts, so start-up, imports and
    discovery stay out), stats written to OUT when it exits.
    """
    out, rest = argv[0], list(argv[1:])
    prof = cProfile.Profile()
    signal.signal(signal.SIGUSR1, lambda *_: prof.enable())
    try:
        return node.main(rest)
    finally:
        prof.disable()
        prof.dump_stats(out)


def main(argv: Sequence[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    if argv and argv[0] == 'profiled-node':
        return profiled_node_main(argv[1:])
    if argv and argv[0] == 'drive':
        return drive_main(argv[1:])
    if argv and argv[0] == 'echo':
        return echo_main(argv[1:])
    return table_main(argv)


if __name__ == '__main__':
    sys.exit(main())
