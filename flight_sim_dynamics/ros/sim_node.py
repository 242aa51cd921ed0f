"""The executable of the twin node (``platform_sim``).

    platform_sim --ros-args -r actuator_commands:=actuator_states
    platform_sim --ros-args --params-file config/<name>.yaml    # a packaged machine's file

A start-up it cannot make ends it with one ``error:`` line and exit status 2.
"""
from __future__ import annotations

import argparse
import sys
from typing import Sequence

from ..config.files import params_files_in
from ..config.machine_files import example_params_file
from ..machines import default_machine
from .node import create, executable_parser, make_executor, own_options, running, spin
from .platform_sim import PlatformSim


def build_parser() -> argparse.ArgumentParser:
    parser = executable_parser(
        'platform_sim',
        'Digital twin of a motion simulator (any machine) as a ROS 2 node: subscribes '
        'actuator_commands (JointState: leg length and rate references, feed-forward '
        'forces, the layout of dynamics_node\'s actuator_states), runs actuator servos and '
        'plant in real time and publishes platform_pose, platform_twist, '
        'measured_actuator_states and /diagnostics. Connect it to dynamics_node with '
        '--ros-args -r actuator_commands:=actuator_states. The plant: plant.params_file, '
        'else the --params-file with a section for the dynamics node (e.g. '
        f'{example_params_file()}), else the packaged {default_machine().title}.',
        'See docs/twin.md for topics and parameters.')
    # The single-threaded executor looks at the tick timer on every wait, whatever
    # the command rate; the events executor serves a burst of commands first.
    parser.set_defaults(executor='single')
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run the twin until Ctrl-C / SIGTERM. ``argv``: arguments after the
    program name (None: sys.argv[1:]), ROS arguments after ``--ros-args``.
    """
    argv = list(sys.argv[1:] if argv is None else argv)
    args = own_options('platform_sim', build_parser(), argv)
    with running('platform_sim', argv) as nodes:
        node = create(lambda: PlatformSim(params_files=params_files_in(argv)))
        nodes.append(node)
        executor = make_executor(args.executor)
        executor.add_node(node)
        spin(executor)
    return 0


if __name__ == '__main__':
    sys.exit(main())
