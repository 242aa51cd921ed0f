"""The twin node's real-time figures: CPU, overruns, real-time factor.

``platform_sim`` runs as a separate process, driven for ``--seconds``
(default 60) by actuator commands at ``--command-rate`` (the inverse dynamics
of the demo planner's looping paper motions, computed here). Measured:

* the CPU time of the twin's process over the run (user + system, from
  /proc/<pid>/stat), as a percentage of one core;
* its overruns (ticks whose work outlasted the tick period, or that had to
  drop steps) and dropped steps, from its /diagnostics;
* its real-time factor: simulated time over wall time, from its steps.

    python -m benchmarks.twin_node [--seconds 60] [--rate 1000] [--tick-rate 100]

The issue's target: at most 20 % of one core and no overrun at 1 kHz. Use
an unused ROS_DOMAIN_ID (the figures include whatever else talks there).
"""
from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path
from typing import Sequence

import rclpy
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PoseStamped
from rclpy.context import Context
from rclpy.experimental import EventsExecutor
from sensor_msgs.msg import JointState

import flight_sim_dynamics as fsd
from flight_sim_dynamics.cli.bench_report import machine_header
from flight_sim_dynamics.config.schema import SIM_PARAMETERS
from flight_sim_dynamics.core.model import LEG_NAMES
from flight_sim_dynamics.core.motions import PAPER_EXAMPLES, PlannerSequence
from flight_sim_dynamics.ros.process import SIM_MODULE, start_node, stop_node
from flight_sim_dynamics.ros.qos import default_qos
from flight_sim_dynamics.ros.twin_intake import SIM_TASK


def cpu_seconds(pid: int) -> float:
    """User + system CPU time of process ``pid`` so far (s)."""
    fields = Path(f'/proc/{pid}/stat').read_text().rsplit(')', 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf('SC_CLK_TCK')


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog='python -m benchmarks.twin_node', description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument('--seconds', type=float, default=60.0, help='length of the run (default 60)')
    p.add_argument('--rate', type=float, default=1000.0, help="the twin's rate (default 1000 Hz)")
    tick_rate = next(s.default for s in SIM_PARAMETERS if s.name == 'tick_rate')
    p.add_argument('--tick-rate', type=float, default=tick_rate,
                   help=f"the twin's tick rate (default: the node's, {tick_rate:g} Hz)")
    p.add_argument('--command-rate', type=float, default=100.0,
                   help='commands per second (default 100)')
    return p


def main(argv: Sequence[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    args = build_parser().parse_args(argv)
    print('\n'.join(line for line in machine_header(argv) if not line.startswith('- command')))
    print(f"- command: `{' '.join(['python -m benchmarks.twin_node', *argv])}`", flush=True)
    model = fsd.load_model()
    sequence = PlannerSequence(list(PAPER_EXAMPLES), loop=True)
    log = tempfile.NamedTemporaryFile('w+', prefix='twin_node_', suffix='.log', delete=False)
    proc = start_node(None, ['-p', f'rate:={args.rate}', '-p', f'tick_rate:={args.tick_rate}',
                             '-p', 'diagnostics.period:=1.0'], log, module=SIM_MODULE)
    context = Context()
    rclpy.init(context=context)
    node = rclpy.create_node('twin_node_bench', context=context)
    executor = EventsExecutor(context=context)
    executor.add_node(node)
    pub = node.create_publisher(JointState, 'actuator_commands', default_qos())
    poses: list[int] = []
    diagnostics: list[dict[str, str]] = []

    def on_diagnostics(msg: DiagnosticArray) -> None:
        for status in msg.status:
            if status.name.endswith(': ' + SIM_TASK):
                diagnostics.append({kv.key: kv.value for kv in status.values})

    node.create_subscription(PoseStamped, 'platform_pose', lambda m: poses.append(1),
                             default_qos())
    node.create_subscription(DiagnosticArray, '/diagnostics', on_diagnostics, 10)

    def spin_until(predicate, timeout: float) -> bool:
        deadline = time.monotonic() + timeout
        while not predicate() and time.monotonic() < deadline:
            executor.spin_once(timeout_sec=0.01)
        return predicate()

    try:
        if not spin_until(lambda: pub.get_subscription_count() > 0 or proc.poll() is not None,
                          30.0) or proc.poll() is not None:
            print('the twin did not come up:\n' + Path(log.name).read_text()[-2000:])
            return 1
        msg = JointState()
        msg.name = list(LEG_NAMES)
        start = time.monotonic()
        cpu0 = cpu_seconds(proc.pid)
        k = 0
        while True:
            now = time.monotonic()
            if now - start >= args.seconds:
                break
            while k <= (now - start) * args.command_rate:
                q, qd, qdd, _ = sequence.sample(k / args.command_rate)
                sol = fsd.solve(model, q, qd, qdd)
                msg.header.stamp = node.get_clock().now().to_msg()
                msg.position, msg.velocity, msg.effort = (sol.length.tolist(),
                                                          sol.rate.tolist(), sol.force.tolist())
                pub.publish(msg)
                k += 1
            executor.spin_once(timeout_sec=0.5 / args.command_rate)
        wall = time.monotonic() - start
        cpu = cpu_seconds(proc.pid) - cpu0
        count = len(diagnostics)
        spin_until(lambda: len(diagnostics) > count, 3.0)
        last = diagnostics[-1] if diagnostics else {}
        first = next((d for d in diagnostics if int(d.get('commands accepted', '0')) > 0), {})
        print(f'platform_sim: RK4 at {args.rate:g} Hz, ticks at {args.tick_rate:g} Hz, '
              f'{k} commands at {args.command_rate:g} Hz over {wall:.1f} s')
        print(f'  CPU of the twin process: {cpu:.2f} s in {wall:.1f} s = '
              f'{100 * cpu / wall:.1f} % of one core (target <= 20 %)')
        steps = int(last.get('steps', '0')) - int(first.get('steps', '0'))
        span = float(last.get('simulated time (s)', 'nan')) - float(
            first.get('simulated time (s)', 'nan'))
        print(f'  steps: {last.get("steps")} in all; real-time factor (last period) '
              f'{last.get("real-time factor")}; {steps} steps = {span:.2f} s simulated '
              f'between the first and last diagnostics of the run')
        print(f'  overruns: {last.get("overruns")} (target 0), steps dropped '
              f'{last.get("steps dropped")}; tick work mean {last.get("tick work mean (us)")} '
              f'us, max {last.get("tick work max (us)")} us (last period); '
              f'{len(poses)} poses received')
        print(f'  commands accepted {last.get("commands accepted")}, rejected '
              f'{last.get("rejected total")}; outcome {last.get("outcome")}')
        return 0
    finally:
        stop_node(proc)
        node.destroy_node()
        rclpy.try_shutdown(context=context)
        log.close()
        Path(log.name).unlink(missing_ok=True)


if __name__ == '__main__':
    sys.exit(main())
