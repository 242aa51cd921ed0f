#!/usr/bin/env python3
"""Measure the node with each executor (docs/node.md, "Executor").

Starts the node (`python -m flight_sim_dynamics.node --executor E`) with the
packaged parameters, streams the paper's general motion (pose + twist + accel)
at each rate for a few seconds from this process, and reports: setpoints
answered / sent, latency (publish of the pose -> reception of the
actuator_states, both on this machine's monotonic clock), and the node
process's CPU time per setpoint (all its threads: Python and DDS).

    python scripts/bench_node.py [--rates 200 500] [--seconds 3] [--executors events single]
"""
from __future__ import annotations

import argparse
import os
import random
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path[:0] = [str(ROOT), str(ROOT / 'test')]
os.environ.setdefault('ROS_DOMAIN_ID', str(random.randint(1, 100)))
os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')

from flight_sim_dynamics.trajectories import paper_example  # noqa: E402
from node_harness import Client, NodeProcess, stamp_ns  # noqa: E402


def run(executor: str, rate: float, seconds: float) -> dict[str, float]:
    node = NodeProcess(executor=executor)
    client = Client('bench_client')
    try:
        client.wait_for_node(node)
        n = int(seconds * rate)
        t = (np.arange(n) / rate) % 3.0
        q, qd, qdd = paper_example('general', t)
        base = 1_700_000_000 * 1_000_000_000
        sent_at = {}
        cpu0 = node.cpu_seconds()
        start = time.monotonic()
        for k in range(n):
            target = start + k / rate
            client.spin_until(lambda: time.monotonic() >= target,
                              max(0.0, target - time.monotonic()))
            stamp = base + round(k * 1e9 / rate)
            sent_at[stamp] = time.monotonic()
            client.send(stamp, q[k], qd[k], qdd[k])
        client.wait_actuator(n, timeout=10.0)
        cpu = node.cpu_seconds() - cpu0
        lat = np.array([r - sent_at[stamp_ns(m)] for r, m in client.actuator
                        if stamp_ns(m) in sent_at]) * 1e3
        return dict(sent=n, answered=len(client.actuator),
                    median=float(np.median(lat)) if len(lat) else float('nan'),
                    p99=float(np.percentile(lat, 99)) if len(lat) else float('nan'),
                    max=float(lat.max()) if len(lat) else float('nan'),
                    cpu_ms=1e3 * cpu / max(len(client.actuator), 1))
    finally:
        client.close()
        node.stop()


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('--rates', type=float, nargs='+', default=[200.0, 500.0])
    parser.add_argument('--seconds', type=float, default=3.0)
    parser.add_argument('--executors', nargs='+', default=['events', 'single'])
    args = parser.parse_args()
    print(f'# {os.cpu_count()} CPUs, load average {os.getloadavg()[0]:.2f} at start')
    print('| executor | rate Hz | answered / sent | latency median ms | p99 ms | max ms '
          '| node CPU per setpoint ms |')
    print('|---|---:|---:|---:|---:|---:|---:|')
    for executor in args.executors:
        for rate in args.rates:
            r = run(executor, rate, args.seconds)
            print(f"| {executor} | {rate:g} | {r['answered']} / {r['sent']} | {r['median']:.1f} "
                  f"| {r['p99']:.1f} | {r['max']:.1f} | {r['cpu_ms']:.2f} |", flush=True)
    print(f'# load average {os.getloadavg()[0]:.2f} at end')
    return 0


if __name__ == '__main__':
    sys.exit(main())
