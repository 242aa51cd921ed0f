"""The node (or the twin: ``module=SIM_MODULE``; the motion-cueing node:
``module=CUEING_MODULE``) as a separate process, and the
executables' stop signals. No rclpy here: Ctrl-C and SIGTERM only request a
stop (:func:`stop_on_signals`), seen between callbacks, since rclpy's own
handlers raise inside a callback or shut the context down under a publish.
"""
from __future__ import annotations

import atexit
import contextlib
import os
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import IO, Any, Iterator, Sequence

NODE_MODULE = 'flight_sim_dynamics.ros.node'
SIM_MODULE = 'flight_sim_dynamics.ros.sim_node'
CUEING_MODULE = 'flight_sim_dynamics.ros.motion_cueing'
# the child imports this very package, not another install
PACKAGE_PARENT = str(Path(__file__).resolve().parents[2])
# -P (Python >= 3.11): ``python -m`` puts no working directory first on sys.path, so
# a child started in a source checkout (the repository root) imports the package
# found through PYTHONPATH (node_env: PACKAGE_PARENT), not the un-built source tree
SAFE_PATH = ('-P',) if sys.version_info >= (3, 11) else ()


def python_module(module: str) -> list[str]:
    """The command line running ``module`` with this interpreter: ``python -P -m
    MODULE`` (with :func:`node_env`'s environment, it imports this package,
    whatever the child's working directory holds).
    """
    return [sys.executable, *SAFE_PATH, '-m', module]


def node_env(env: dict[str, str] | None = None) -> dict[str, str]:
    """``env`` (default: ours) with this package first and unbuffered output."""
    out = dict(os.environ if env is None else env)
    out['PYTHONPATH'] = os.pathsep.join(filter(None, [PACKAGE_PARENT, out.get('PYTHONPATH')]))
    out['PYTHONUNBUFFERED'] = '1'
    out.setdefault('RCUTILS_LOGGING_BUFFERED_STREAM', '0')
    return out


def node_command(params_file: Path | str | None = None, ros_args: Sequence[str] = (), *,
                 executor: str | None = None, launcher: Sequence[str] | None = None,
                 module: str = NODE_MODULE) -> list[str]:
    """``python -P -m MODULE [--executor E] --ros-args [--params-file F] ROS_ARGS``
    (:func:`python_module`); ``launcher`` replaces ``python -P -m MODULE`` (e.g. a
    profiling wrapper).
    """
    cmd = list(launcher) if launcher is not None else python_module(module)
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
    """In its own session (the caller's Ctrl-C is not its own); output to ``log``
    (a path, an open file, or None: discarded).
    """
    cmd = node_command(params_file, ros_args, executor=executor, launcher=launcher,
                       module=module)
    kwargs = dict(stderr=subprocess.STDOUT, env=node_env(env), cwd=cwd, start_new_session=True)
    if isinstance(log, (str, Path)):
        with open(log, 'w') as out:          # the child keeps its own copy of the descriptor
            return subprocess.Popen(cmd, stdout=out, **kwargs)
    return subprocess.Popen(cmd, stdout=subprocess.DEVNULL if log is None else log, **kwargs)


def stop_node(proc: subprocess.Popen, timeout: float = 5.0) -> int | None:
    """SIGINT, then SIGKILL after ``timeout`` s; the exit status."""
    if proc.poll() is None:
        proc.send_signal(signal.SIGINT)
        try:
            proc.wait(timeout)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait(5)
    return proc.returncode


STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM)
# s during which more signals are the same request: under ros2 launch a Ctrl-C
# arrives twice (the terminal's and launch's)
REPEAT_WINDOW = 2.0
_stop: list[float] = []


def _on_stop_signal(signum: int, frame: Any) -> None:
    now = time.monotonic()
    if not _stop:
        _stop.append(now)
        return
    if now - _stop[0] < REPEAT_WINDOW:
        return
    # a later signal: the stop hangs; end by the signal itself
    signal.signal(signum, signal.SIG_DFL)
    os.kill(os.getpid(), signum)


def _ignore_stop_signals() -> None:
    for signum in STOP_SIGNALS:
        signal.signal(signum, signal.SIG_IGN)


def stop_on_signals() -> None:
    """SIGINT and SIGTERM set :func:`stop_requested`; a repeat after
    :data:`REPEAT_WINDOW` ends the process. Ignored at interpreter exit, whose
    finalisation would restore the default action for a late repeat.
    """
    _stop.clear()
    for signum in STOP_SIGNALS:
        signal.signal(signum, _on_stop_signal)
    atexit.unregister(_ignore_stop_signals)
    atexit.register(_ignore_stop_signals)


def stop_requested() -> bool:
    return bool(_stop)


_spins: list[Any] = []          # futures whose completion ends a spin (see end_spins)


@contextlib.contextmanager
def ending_spin(future: Any) -> Iterator[None]:
    """While in this block, ``future`` (an rclpy Future a spin waits for) is
    completed by :func:`end_spins`.
    """
    _spins.append(future)
    try:
        yield
    finally:
        if future in _spins:
            _spins.remove(future)


def end_spins() -> None:
    """From a callback that saw the stop request: the spins waiting for the
    futures of :func:`ending_spin` return after this callback. rclpy's
    EventsExecutor returns from a timed spin only once its queue is empty,
    which a backlog arriving faster than it is taken never is. Not called
    from the signal handler, which may interrupt the future's own lock.
    Pinned: docs/design/rclpy.md R8.
    """
    while _spins:
        future = _spins.pop()
        if not future.done():
            future.set_result(True)
