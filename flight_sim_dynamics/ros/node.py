"""The ``dynamics_node`` executable: runs a :class:`~.dynamics_node.DynamicsNode`
until Ctrl-C / SIGTERM or the ``shutdown`` transition (exit 0). A start-up it
cannot make ends it with one ``error:`` line and exit status 2;
``autostart:=false`` waits for a lifecycle manager. As everywhere in ROS 2,
node names are not unique: give each instance its own namespace.
"""
from __future__ import annotations

import argparse
import contextlib
import faulthandler
import sys
import time
from typing import Any, Callable, Iterator, NoReturn, Sequence, TypeVar

import rclpy
import rclpy.task
from rclpy.node import Node
from rclpy.exceptions import ParameterException
from rclpy.executors import Executor, ExternalShutdownException, SingleThreadedExecutor
from rclpy.experimental import EventsExecutor
from rclpy.signals import SignalHandlerOptions

from ..config import parameters as prm
from ..config.files import params_files_in, read_params_sections
from ..config.machine_files import load_layers
from ..config.node_schema import check_node_params_files
from .dynamics_node import DynamicsNode
from .process import ending_spin, stop_on_signals, stop_requested

SPIN_STEP = 0.1                  # s between two looks at a requested stop
N = TypeVar('N', bound=Node)
# s for the teardown; then faulthandler (a C thread, runs while rclpy holds the GIL) exits 1
TEARDOWN_TIMEOUT = 10.0


def make_executor(name: str, context: Any = None) -> Any:
    # the experimental EventsExecutor and its quirks: docs/design/rclpy.md R6-R9
    return (EventsExecutor if name == 'events' else SingleThreadedExecutor)(context=context)


def executable_parser(prog: str, description: str, epilog: str) -> argparse.ArgumentParser:
    """A node executable's own options (before ``--ros-args``)."""
    parser = argparse.ArgumentParser(prog=prog, description=description, epilog=epilog)
    parser.add_argument('--executor', choices=('events', 'single'), default='events',
                        help='rclpy executor (default: %(default)s)')
    return parser


def build_parser() -> argparse.ArgumentParser:
    return executable_parser(
        'dynamics_node',
        'ROS 2 node of flight_sim_dynamics: pose/twist/accel_setpoint and '
        'platform_setpoint in; actuator_states, joint_states and /diagnostics out. '
        'ROS arguments go after --ros-args, e.g. --ros-args -p limits.max_force:=500.0',
        'See docs/node.md for topics, parameters and QoS.')


def refuse(message: str) -> NoReturn:
    """One ``error:`` line on stderr, exit status 2 (as argparse's usage errors)."""
    print('error: ' + ' '.join(str(message).split()), file=sys.stderr)
    raise SystemExit(2)


def own_options(program: str, parser: argparse.ArgumentParser,
                argv: Sequence[str]) -> argparse.Namespace:
    """The options before ``--ros-args``; ROS arguments rcl refuses: :func:`refuse`."""
    try:
        own = rclpy.utilities.remove_ros_args([program, *argv])[1:]
    except Exception as exc:  # noqa: BLE001 - rcl's refusals are private pybind11 types
        refuse(_params_file_problem(argv) or f'invalid ROS arguments: {exc}')
    return parser.parse_args(own)


def create(node_class: Callable[[], N]) -> N:
    try:
        return node_class()
    except (prm.ParameterError, ParameterException) as exc:
        refuse(f'invalid parameters: {exc}')


def _params_file_problem(argv: Sequence[str]) -> str | None:
    """The package loader's message on the params files (names file and key)."""
    for path in params_files_in(argv):
        try:
            load_layers([(path, read_params_sections(path))])
        except prm.ParameterError as exc:
            return f'invalid parameters: {exc}'
    return None


@contextlib.contextmanager
def running(program: str, argv: Sequence[str]) -> Iterator[list[Any]]:
    """Every executable's frame: stop signals seen between callbacks; the nodes
    appended to the yielded list are destroyed and rclpy shut down on the way out.
    """
    stop_on_signals()       # neither executor replaces them: docs/design/rclpy.md R11
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


def run_managed(program: str, parser: argparse.ArgumentParser, argv: Sequence[str],
                make: Callable[[], Any], check: Callable[[Any], None] | None = None) -> int:
    """Run the managed node ``make()`` as the executable ``program`` (module
    docstring): ``check(node)`` (e.g. its ``--params-file`` names) may end the
    start as a refused value does; 0 at the end.
    """
    args = own_options(program, parser, argv)
    with running(program, argv) as nodes:
        node = create(make)
        nodes.append(node)
        if check is not None:
            create(lambda: check(node))
        if not node.get_parameter('autostart').value:
            node.get_logger().info('autostart is false: unconfigured, waiting for a lifecycle '
                                   'manager (configure, then activate)')
        elif not node.start():
            refuse(node.failure)
        executor = make_executor(args.executor)
        node.serve_parameters_apart(executor)
        executor.add_node(node)
        spin(executor, until=[node.finalized])
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    # an unknown name or bad value in a --params-file ends the start
    return run_managed('dynamics_node', build_parser(), argv, DynamicsNode,
                       lambda node: check_node_params_files(
                           argv, node.get_fully_qualified_name(), node.machine_name))

def spin_until(executor: Any, predicate: Callable[[], bool], timeout: float | None = None,
               step: float = 0.05) -> bool:
    """Spin until ``predicate()``, the timeout, shutdown or a requested stop;
    always with a timeout: rclpy 7.1.6's EventsExecutor busy-loops in ``spin()``
    (docs/design/rclpy.md R7, R8, R10).
    """
    deadline = None if timeout is None else time.monotonic() + timeout
    never = rclpy.task.Future()      # done only by a stop request (end_spins)
    with ending_spin(never):
        while rclpy.ok(context=executor.context) and not predicate() and not stop_requested():
            if deadline is not None and time.monotonic() >= deadline:
                break
            if isinstance(executor, Executor):
                # rclpy's Python executors add a done callback to the future at every
                # spin_until_future_complete and keep it: one callback at a time instead
                executor.spin_once(timeout_sec=step)
            else:
                executor.spin_until_future_complete(never, timeout_sec=step)
    return bool(predicate())


def spin(executor: Any, until: Sequence[rclpy.task.Future] = ()) -> None:
    """Spin until shutdown, a requested stop or any of ``until`` is done."""
    spin_until(executor, lambda: any(f.done() for f in until), step=SPIN_STEP)


if __name__ == '__main__':
    sys.exit(main())
