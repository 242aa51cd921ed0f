"""The executable of the ROS 2 node (``dynamics_node``): runs a
:class:`~.dynamics_node.DynamicsNode` until Ctrl-C / SIGTERM.

    dynamics_node --ros-args --params-file config/flight_sim_dynamics.yaml
    flight-sim-dynamics node --ros-args -r __ns:=/sim

With ``autostart`` (the default) the node is configured and activated at
once, and a start-up it cannot make (a bad parameter, params file, scene, QoS
override or ROS argument) ends it with one ``error:`` line and exit status 2;
with ``autostart:=false`` it waits unconfigured for a lifecycle manager. The
``shutdown`` transition ends it with exit 0. As everywhere in ROS 2, node
names are not unique: a second node of the same name and namespace answers
every setpoint too (give each its own namespace).
"""
from __future__ import annotations

import argparse
import contextlib
import faulthandler
import sys
from typing import Any, Callable, Iterator, NoReturn, Sequence, TypeVar

import rclpy
import rclpy.task
from rclpy.node import Node
from rclpy.exceptions import ParameterException
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.experimental import EventsExecutor
from rclpy.signals import SignalHandlerOptions

from ..config import parameters as prm
from ..config.files import params_files_in, read_params_file
from .dynamics_node import DynamicsNode
from .process import stop_on_signals, stop_requested

EXECUTORS = ('events', 'single')
DEFAULT_EXECUTOR = 'events'
#: Longest spin between two looks at a requested stop (Ctrl-C, SIGTERM), s.
SPIN_STEP = 0.1
N = TypeVar('N', bound=Node)
#: Seconds the middleware gets to release the nodes and shut down on the way
#: out (it takes milliseconds). Past them the process ends anyway, with the
#: Python stacks of its threads on stderr and exit status 1 (faulthandler's
#: watchdog: a C thread, which runs while rclpy holds the GIL in a destroy).
#: Seen once in CI: a start refused for a bad QoS override printed its
#: ``error:`` line and then hung for 30 s in this teardown.
TEARDOWN_TIMEOUT = 10.0


def make_executor(name: str, context: Any = None) -> Any:
    """``events``: rclpy.experimental.EventsExecutor; ``single``:
    SingleThreadedExecutor.
    """
    if name == 'events':
        return EventsExecutor(context=context)
    return SingleThreadedExecutor(context=context)


def executable_parser(prog: str, description: str, epilog: str) -> argparse.ArgumentParser:
    """The command line of a node executable: its own options before
    ``--ros-args`` (the executor).
    """
    parser = argparse.ArgumentParser(prog=prog, description=description, epilog=epilog)
    parser.add_argument('--executor', choices=EXECUTORS, default=DEFAULT_EXECUTOR,
                        help=f'rclpy executor (default: {DEFAULT_EXECUTOR})')
    return parser


def build_parser() -> argparse.ArgumentParser:
    return executable_parser(
        'dynamics_node',
        'ROS 2 node of flight_sim_dynamics: subscribes pose_setpoint, twist_setpoint, '
        'accel_setpoint (one setpoint: the three with one stamp) and platform_setpoint '
        '(trajectory_msgs/JointTrajectory over surge, heave, roll: one setpoint per '
        'point); publishes actuator_states, joint_states and /diagnostics. ROS arguments '
        'go after --ros-args, e.g. --ros-args --params-file '
        'config/flight_sim_dynamics.yaml -r __ns:=/sim -p limits.max_force:=500.0',
        'See docs/node.md for topics, parameters and QoS.')


def refuse(message: str) -> NoReturn:
    """A start-up the executable cannot make: one ``error:`` line on stderr,
    then exit status 2 (SystemExit, as argparse's usage errors; inside
    :func:`running` the line comes before the teardown).
    """
    print('error: ' + ' '.join(str(message).split()), file=sys.stderr)
    raise SystemExit(2)


def own_options(program: str, parser: argparse.ArgumentParser,
                argv: Sequence[str]) -> argparse.Namespace:
    """The executable's own options (those before ``--ros-args``); a ROS
    argument or params file rcl refuses is refused (:func:`refuse`).
    """
    try:
        own = rclpy.utilities.remove_ros_args([program, *argv])[1:]
    except Exception as exc:  # noqa: BLE001 - rcl's refusal (bad ROS arguments or params
        # file) comes as rclpy's private _rclpy_pybind11 error types
        refuse(_params_file_problem(argv) or f'invalid ROS arguments: {exc}')
    return parser.parse_args(own)


def create(node_class: Callable[[], N]) -> N:
    """The node ``node_class()``; invalid parameters are refused (:func:`refuse`)."""
    try:
        return node_class()
    except (prm.ParameterError, ParameterException) as exc:
        refuse(f'invalid parameters: {exc}')


def _params_file_problem(argv: Sequence[str]) -> str | None:
    """What the package's own reader says of the ``--params-file`` files (a
    clearer message than rcl's, naming the file and the key), or None.
    """
    for path in params_files_in(argv):
        try:
            read_params_file(path)
        except prm.ParameterError as exc:
            return f'invalid parameters: {exc}'
    return None


@contextlib.contextmanager
def running(program: str, argv: Sequence[str]) -> Iterator[list[Any]]:
    """The frame of every executable of the package (node, twin, demo planner):
    Ctrl-C and SIGTERM request a stop, seen between callbacks
    (:func:`.process.stop_on_signals`, issue 15 #3), and rclpy is initialised
    without its own signal handlers. The nodes the block appends to the
    yielded list are destroyed, and rclpy shut down, on the way out, within
    :data:`TEARDOWN_TIMEOUT`; a KeyboardInterrupt or an external shutdown
    ends the block quietly.
    """
    stop_on_signals()
    rclpy.init(args=[program, *argv], signal_handler_options=SignalHandlerOptions.NO)
    nodes: list[Any] = []
    try:
        yield nodes
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        sys.stdout.flush()
        faulthandler.dump_traceback_later(TEARDOWN_TIMEOUT, exit=True)
        try:
            for node in nodes:
                node.destroy_node()
            rclpy.try_shutdown()
        finally:
            faulthandler.cancel_dump_traceback_later()


def main(argv: Sequence[str] | None = None) -> int:
    """Run the node until Ctrl-C / SIGTERM. ``argv``: arguments after the
    program name (None: sys.argv[1:]), ROS arguments after ``--ros-args``.
    """
    argv = list(sys.argv[1:] if argv is None else argv)
    args = own_options('dynamics_node', build_parser(), argv)
    with running('dynamics_node', argv) as nodes:
        node = create(DynamicsNode)
        nodes.append(node)
        # the one rule for parameter files (config.parameters.read_params): an
        # unknown name or bad value in a --params-file ends the start (exit 2)
        create(lambda: prm.check_params_files(argv, node.get_fully_qualified_name()))
        if not node.get_parameter('autostart').value:
            node.get_logger().info('autostart is false: unconfigured, waiting for a lifecycle '
                                   'manager (configure, then activate)')
        elif not node.start():
            refuse(node.failure)
        executor = make_executor(args.executor)
        executor.add_node(node)
        spin(executor, until=node.finalized)
    return 0


def spin(executor: Any, context: Any = None, until: rclpy.task.Future | None = None) -> None:
    """Spin until the context shuts down, a stop is requested (Ctrl-C, SIGTERM:
    :func:`.process.stop_on_signals`) or ``until`` is done.

    Always with a timeout: rclpy 7.1.6's EventsExecutor busy-loops at 100 % CPU
    in ``spin()`` (and hangs in ``spin_until_future_complete`` without a
    timeout), and does not return on SIGINT; with a timeout it idles and the
    stop is noticed within :data:`SPIN_STEP`.
    """
    future = until if until is not None else rclpy.task.Future()
    while rclpy.ok(context=context) and not future.done() and not stop_requested():
        executor.spin_until_future_complete(future, timeout_sec=SPIN_STEP)


if __name__ == '__main__':
    sys.exit(main())
