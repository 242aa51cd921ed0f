"""The executable of the ROS 2 node (``dynamics_node``): runs a
:class:`~.dynamics_node.DynamicsNode` until Ctrl-C / SIGTERM.

    dynamics_node --ros-args --params-file config/flight_sim_dynamics.yaml
    python -m flight_sim_dynamics.ros.node        # packaged defaults
    flight-sim-dynamics node --ros-args -r __ns:=/sim

Invalid parameters (a value of the schema, or a ``qos_overrides.*``) make
it exit with status 2 and say why.
"""
from __future__ import annotations

import argparse
import sys
from typing import Any, Sequence

import rclpy
import rclpy.task
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.experimental import EventsExecutor

from ..config import parameters as prm
from .dynamics_node import DynamicsNode

EXECUTORS = ('events', 'single')
DEFAULT_EXECUTOR = 'events'


def make_executor(name: str, context: Any = None) -> Any:
    """``events``: rclpy.experimental.EventsExecutor; ``single``:
    SingleThreadedExecutor.
    """
    if name == 'events':
        return EventsExecutor(context=context)
    return SingleThreadedExecutor(context=context)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog='dynamics_node',
        description='ROS 2 node of flight_sim_dynamics: subscribes pose_setpoint, '
                    'twist_setpoint, accel_setpoint (one setpoint: the three with one stamp) '
                    'and platform_setpoint (trajectory_msgs/JointTrajectory over surge, '
                    'heave, roll: one setpoint per point); publishes actuator_states, '
                    'joint_states and /diagnostics. ROS arguments go after --ros-args, e.g. '
                    '--ros-args --params-file config/flight_sim_dynamics.yaml '
                    '-r __ns:=/sim -p limits.max_force:=500.0',
        epilog='See docs/node.md for topics, parameters and QoS.')
    parser.add_argument('--executor', choices=EXECUTORS, default=DEFAULT_EXECUTOR,
                        help=f'rclpy executor (default: {DEFAULT_EXECUTOR})')
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run the node until Ctrl-C / SIGTERM. ``argv``: arguments after the
    program name (None: sys.argv[1:]), ROS arguments after ``--ros-args``.
    """
    argv = list(sys.argv[1:] if argv is None else argv)
    own = rclpy.utilities.remove_ros_args(['dynamics_node', *argv])[1:]
    args = build_parser().parse_args(own)
    rclpy.init(args=['dynamics_node', *argv])
    node = None
    executor = None
    try:
        try:
            node = DynamicsNode()
        except prm.ParameterError as exc:
            rclpy.logging.get_logger(prm.NODE_NAME).fatal(f'invalid parameters: {exc}')
            return 2
        executor = make_executor(args.executor)
        executor.add_node(node)
        spin(executor)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown()
    return 0


def spin(executor: Any, context: Any = None) -> None:
    """Spin until the context shuts down (Ctrl-C, SIGTERM).

    Always with a timeout: rclpy 7.1.6's EventsExecutor busy-loops at 100 % CPU
    in ``spin()`` (and hangs in ``spin_until_future_complete`` without a
    timeout), and does not return on SIGINT; with a timeout it idles and the
    shutdown is noticed within ``timeout_sec``.
    """
    never = rclpy.task.Future()
    while rclpy.ok(context=context):
        executor.spin_until_future_complete(never, timeout_sec=0.5)


if __name__ == '__main__':
    sys.exit(main())
