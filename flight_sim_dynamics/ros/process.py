"""Start and stop the node (or, with ``module=SIM_MODULE``, the twin) as a
separate process, as a user starts it: for the demo, the benchmarks and the
node tests. No rclpy here.

In the executables, Ctrl-C and SIGTERM only *request* a stop
(:func:`stop_on_signals`), which their spin loop sees between callbacks:
rclpy's own handlers raise KeyboardInterrupt inside whatever callback runs,
or shut the context down under a publish. So they call ``rclpy.init`` with
``SignalHandlerOptions.NO`` and shut down themselves once the executor stopped.
"""
from __future__ import annotations

import atexit
import os
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import IO, Any, Sequence

NODE_MODULE = 'flight_sim_dynamics.ros.node'
#: The twin node's executable (``platform_sim``): ``start_node(..., module=SIM_MODULE)``.
SIM_MODULE = 'flight_sim_dynamics.ros.sim_node'
#: The directory holding the imported flight_sim_dynamics (a source tree or
#: site-packages): the child imports this very package, not another install.
PACKAGE_PARENT = str(Path(__file__).resolve().parents[2])


def node_env(env: dict[str, str] | None = None) -> dict[str, str]:
    """The environment of a node process: ``env`` (default: this process's),
    with this package importable first and unbuffered output (its log is
    complete when it is read).
    """
    out = dict(os.environ if env is None else env)
    out['PYTHONPATH'] = os.pathsep.join(filter(None, [PACKAGE_PARENT, out.get('PYTHONPATH')]))
    out['PYTHONUNBUFFERED'] = '1'
    out.setdefault('RCUTILS_LOGGING_BUFFERED_STREAM', '0')
    return out


def node_command(params_file: Path | str | None = None, ros_args: Sequence[str] = (), *,
                 executor: str | None = None, launcher: Sequence[str] | None = None,
                 module: str = NODE_MODULE) -> list[str]:
    """``python -m flight_sim_dynamics.ros.node [--executor E] --ros-args
    [--params-file FILE] ROS_ARGS`` (``module``: another executable, e.g.
    :data:`SIM_MODULE`); ``launcher`` replaces the first part (for example a
    profiling wrapper that runs the node's ``main``).
    """
    cmd = list(launcher) if launcher is not None else [sys.executable, '-m', module]
    if executor:
        cmd += ['--executor', executor]
    cmd.append('--ros-args')
    if params_file is not None:
        cmd += ['--params-file', str(params_file)]
    return cmd + list(ros_args)


def start_node(params_file: Path | str | None, ros_args: Sequence[str] = (),
               log: Path | str | IO[str] | None = None, *, executor: str | None = None,
               launcher: Sequence[str] | None = None, env: dict[str, str] | None = None,
               cwd: Path | str | None = None, module: str = NODE_MODULE) -> subprocess.Popen:
    """Start the node (see :func:`node_command`) in its own session, so that a
    Ctrl-C meant for the caller does not reach it too; its standard output and
    error go to ``log`` (a path, written anew, or an open file; None: discarded).
    Stop it with :func:`stop_node`.
    """
    cmd = node_command(params_file, ros_args, executor=executor, launcher=launcher,
                       module=module)
    kwargs = dict(stderr=subprocess.STDOUT, env=node_env(env), cwd=cwd, start_new_session=True)
    if isinstance(log, (str, Path)):
        with open(log, 'w') as out:          # the child keeps its own copy of the descriptor
            return subprocess.Popen(cmd, stdout=out, **kwargs)
    return subprocess.Popen(cmd, stdout=subprocess.DEVNULL if log is None else log, **kwargs)


def stop_node(proc: subprocess.Popen, timeout: float = 5.0) -> int | None:
    """SIGINT (as Ctrl-C: the node shuts down cleanly), then SIGKILL if it has
    not exited after ``timeout`` s; returns its exit status.
    """
    if proc.poll() is None:
        proc.send_signal(signal.SIGINT)
        try:
            proc.wait(timeout)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait(5)
    return proc.returncode


#: The signals that request a stop of an executable.
STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM)
#: Seconds after a first stop signal during which more are the same request:
#: Ctrl-C under ``ros2 launch`` reaches each process twice (the terminal
#: signals the whole process group, and launch forwards SIGINT to its children).
REPEAT_WINDOW = 2.0
_stop: list[float] = []


def _on_stop_signal(signum: int, frame: Any) -> None:
    now = time.monotonic()
    if not _stop:
        _stop.append(now)
        return
    if now - _stop[0] < REPEAT_WINDOW:
        return
    # a later signal: the stop hangs; end the process by the signal itself, as
    # without a handler (no KeyboardInterrupt raised inside a callback)
    signal.signal(signum, signal.SIG_DFL)
    os.kill(os.getpid(), signum)


def _ignore_stop_signals() -> None:
    for signum in STOP_SIGNALS:
        signal.signal(signum, signal.SIG_IGN)


def stop_on_signals() -> None:
    """Make SIGINT and SIGTERM set :func:`stop_requested`; repeats within
    :data:`REPEAT_WINDOW` s are the same request, a later one ends the process
    at once (by that signal). Main thread only, as Python's signal handlers.

    Once the interpreter exits they are ignored: its finalisation puts a
    Python handler back to the default action, so the repeat of a Ctrl-C
    that arrived then killed a process that had stopped cleanly (exit -2
    instead of 0 under ``ros2 launch``).
    """
    _stop.clear()
    for signum in STOP_SIGNALS:
        signal.signal(signum, _on_stop_signal)
    atexit.unregister(_ignore_stop_signals)
    atexit.register(_ignore_stop_signals)


def stop_requested() -> bool:
    """Whether SIGINT or SIGTERM arrived since :func:`stop_on_signals`."""
    return bool(_stop)
