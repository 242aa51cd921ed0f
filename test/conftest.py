"""Shared pytest configuration: test tiers, ROS 2 isolation, Hypothesis profiles."""
from __future__ import annotations

import contextlib
import fcntl
import multiprocessing.process
import os
import random
import shutil
import subprocess
import tempfile
from pathlib import Path
from typing import Callable, Iterator

import pytest


# ---------------------------------------------------------------------------
# Parallel runs (pytest-xdist, scripts/run_tests.sh: -n 3): each worker gets its
# own ROS domain, the run's (ROS_DOMAIN_ID, else one drawn from the run's id)
# plus the worker's number, set here before anything initialises rclpy, so the
# nodes and clients of two workers never see each other. The worker's child
# processes (the node, the twin) inherit it.
# ---------------------------------------------------------------------------
def _worker_domain(worker: str, run_domain: str, run_id: str) -> int:
    """The ROS domain of xdist worker ``worker`` ('gw0', 'gw1', ...): 1..101."""
    base = int(run_domain) if run_domain else int(run_id or '0', 16) % 100 + 1
    return (base - 1 + int(worker.removeprefix('gw'))) % 101 + 1


if os.environ.get('PYTEST_XDIST_WORKER'):
    os.environ['ROS_DOMAIN_ID'] = str(_worker_domain(
        os.environ['PYTEST_XDIST_WORKER'], os.environ.get('ROS_DOMAIN_ID', ''),
        os.environ.get('PYTEST_XDIST_TESTRUNUID', '')))


# ---------------------------------------------------------------------------
# Tiers (markers registered in setup.cfg, --strict-markers):
#   ros   the test starts a process (the node, the command line, a tool) or
#         uses DDS (an rclpy context);
#   slow  long property sweeps and long simulations;
#   unit  the rest: `bash scripts/run_tests.sh -m "not ros and not slow"`.
# A test that starts a Python or shell process (subprocess, or a multiprocessing
# Process: a fork), or initialises rclpy, without the ros mark fails (the unit
# tier must stay in-process and fast). Other programs started by libraries
# (e.g. matplotlib's fc-list) are not checked.
# ---------------------------------------------------------------------------
_running: list[pytest.Item] = []


def _unmarked() -> pytest.Item | None:
    """The test being run, if it has no ros mark."""
    if _running and _running[-1].get_closest_marker('ros') is None:
        return _running[-1]
    return None


def _runs_python_or_a_shell(args, executable) -> bool:
    """The command runs Python (the interpreter or a console script) or a shell."""
    if executable is None:
        argv = (os.fsdecode(args).split() if isinstance(args, (str, bytes, os.PathLike))
                else list(args))
        executable = argv[0] if argv else ''
    program = os.fsdecode(executable)
    name = os.path.basename(program)
    if name.startswith('python') or name in ('bash', 'sh'):
        return True
    try:
        with open(shutil.which(program), 'rb') as f:
            first_line = f.readline(200)
    except (OSError, TypeError):        # not found (which: None) or unreadable
        return False
    return first_line.startswith(b'#!') and b'python' in first_line


_popen_init = subprocess.Popen.__init__


def _checked_popen_init(self, args, *rest, **kwargs):
    item = _unmarked()
    if item is not None and _runs_python_or_a_shell(args, kwargs.get('executable')):
        pytest.fail(f'{item.nodeid} starts a process ({args!r}) but has no '
                    '@pytest.mark.ros: mark it (or its module: pytestmark = pytest.mark.ros)',
                    pytrace=False)
    _popen_init(self, args, *rest, **kwargs)


_process_start = multiprocessing.process.BaseProcess.start


def _checked_process_start(self):
    item = _unmarked()
    if item is not None:
        pytest.fail(f'{item.nodeid} starts a process ({self!r}) but has no '
                    '@pytest.mark.ros: mark it (or its module: pytestmark = pytest.mark.ros)',
                    pytrace=False)
    _process_start(self)


try:
    from rclpy.context import Context as _RclpyContext
except ImportError:                       # rclpy missing: nothing to check
    _RclpyContext = None
else:
    _context_init = _RclpyContext.init

    def _checked_context_init(self, *args, **kwargs):
        item = _unmarked()
        if item is not None:
            pytest.fail(f'{item.nodeid} initialises rclpy (DDS) but has no @pytest.mark.ros: '
                        'mark it (or its module: pytestmark = pytest.mark.ros)', pytrace=False)
        return _context_init(self, *args, **kwargs)


def pytest_configure(config: pytest.Config) -> None:
    subprocess.Popen.__init__ = _checked_popen_init
    multiprocessing.process.BaseProcess.start = _checked_process_start
    if _RclpyContext is not None:
        _RclpyContext.init = _checked_context_init


def pytest_unconfigure(config: pytest.Config) -> None:
    subprocess.Popen.__init__ = _popen_init
    multiprocessing.process.BaseProcess.start = _process_start
    if _RclpyContext is not None:
        _RclpyContext.init = _context_init


# ---------------------------------------------------------------------------
# Scheduling across the workers, by lock files of the run (pytest-xdist's run
# id), each taken for a test's set-up, call and teardown:
#   real_time   a test judged on how closely a process follows real time (a
#               twin's tracking) runs alone: it waits for the tests running,
#               and no test starts until it ends. Beside two other workers on
#               2 cores the hexapod twin got 443 of its 750 ticks out and fell
#               more than 0.3 s behind its commands.
#   slow + ros  the slow tier's node tests run one at a time: each runs nodes
#               in real time at about a core (dynamics node, twin and client:
#               50 + 37 + 19 %); two at once (a 1 kHz stream beside the
#               node-driven twin) held the twin's commands back 0.3 s. The
#               unit tests beside them take a core at most.
# (pytest-xdist's --dist loadgroup could schedule the second, but 3.8 cannot
# rename pytest 9's node ids: its groups are silently ignored.)
# ---------------------------------------------------------------------------
_RUN = os.environ.get('PYTEST_XDIST_TESTRUNUID', str(os.getpid()))
_LOCKS = {name: Path(tempfile.gettempdir()) / f'fsd_tests_{_RUN}_{name}.lock'
          for name in ('turnstile', 'alone', 'slow_ros')}


@contextlib.contextmanager
def _locked(name: str, mode: int) -> Iterator[None]:
    with open(_LOCKS[name], 'a') as lock:
        fcntl.flock(lock, mode)                 # released when the file closes
        yield


@contextlib.contextmanager
def _scheduled(item: pytest.Item) -> Iterator[None]:
    """Every test holds 'alone' shared, a real_time test exclusive; the
    turnstile (held by a real_time test while it waits and runs) keeps new
    tests from starting meanwhile, so it is not starved."""
    with contextlib.ExitStack() as held:
        if item.get_closest_marker('real_time') is not None:
            held.enter_context(_locked('turnstile', fcntl.LOCK_EX))
            held.enter_context(_locked('alone', fcntl.LOCK_EX))
        else:
            with _locked('turnstile', fcntl.LOCK_EX):
                held.enter_context(_locked('alone', fcntl.LOCK_SH))
        if item.get_closest_marker('slow') and item.get_closest_marker('ros'):
            held.enter_context(_locked('slow_ros', fcntl.LOCK_EX))
        yield


@pytest.hookimpl(wrapper=True)
def pytest_runtest_protocol(item: pytest.Item, nextitem: pytest.Item | None):
    _running.append(item)          # its fixtures' set-up and teardown included
    try:
        with _scheduled(item):
            return (yield)
    finally:
        _running.pop()


# ---------------------------------------------------------------------------
# ROS 2 isolation (node tests): every test run gets its own ROS domain and
# discovery limited to this machine, unless the caller already chose them
# (scripts/run_tests.sh does). Child processes (the node) inherit them.
# ---------------------------------------------------------------------------
@pytest.fixture(scope='session', autouse=True)
def ros_isolation() -> None:
    if not os.environ.get('ROS_DOMAIN_ID'):
        os.environ['ROS_DOMAIN_ID'] = str(random.randint(1, 100))
    os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')
    yield


# ---------------------------------------------------------------------------
# Hypothesis profiles (property-based tests: test_workspace_properties.py,
# test_hard_cases.py, test_csv_garbage.py and any test without its own
# max_examples):
#
#   ci    (default) 100 examples per property test. The workspace tests draw
#         a batch of 24..32 samples per example, so each of them checks about
#         2,500 (pose, rate, acceleration) cases per run, and the three
#         files below together run in ~10 s on a 2-core machine.
#   long  20x as many examples (2000 per test, ~50,000 cases per workspace
#         property; ~1.5 min for the three files): a soak run before a release,
#         or after touching the solver, e.g.
#             FSD_HYPOTHESIS_PROFILE=long PYTHONPATH=. python -m pytest -q \
#                 test/machines/staicu/test_workspace_properties.py \
#                 test/machines/staicu/test_hard_cases.py \
#                 test/cli/test_csv_garbage.py
#
# Select one with the environment variable FSD_HYPOTHESIS_PROFILE (ci or
# long; any other name is an error). Both have no deadline: a solve near a
# singularity or a forward-kinematics iteration may legitimately take longer
# than Hypothesis' default 200 ms on a loaded CI machine. Tests that set their
# own max_examples keep it; the hard-cases tests scale theirs from the profile
# (hypothesis.settings.default.max_examples), so `long` makes them 20x longer.
# ---------------------------------------------------------------------------
from hypothesis import settings as _hypothesis_settings  # noqa: E402

HYPOTHESIS_PROFILES = {'ci': 100, 'long': 2000}
for _name, _examples in HYPOTHESIS_PROFILES.items():
    _hypothesis_settings.register_profile(_name, max_examples=_examples, deadline=None,
                                          print_blob=True)
_profile = os.environ.get('FSD_HYPOTHESIS_PROFILE', 'ci')
if _profile not in HYPOTHESIS_PROFILES:
    raise ValueError(f'FSD_HYPOTHESIS_PROFILE={_profile!r}: expected one of '
                     f'{", ".join(HYPOTHESIS_PROFILES)}')
_hypothesis_settings.load_profile(_profile)


@pytest.fixture(params=[pytest.param(0.25, id='quick'),
                        pytest.param(0.75, id='deep', marks=pytest.mark.slow)])
def sweep(request) -> Callable[[int], int]:
    """A long property sweep in two parts: ``sweep(n)`` examples are a quarter
    of ``n`` in the unit or ros tier (``[quick]``) and the other three quarters
    in the slow tier (``[deep]``), so the full run draws all ``n``. Use:
    ``@settings(max_examples=sweep(400)) @given(...) def check(...)``, then
    ``check()``, inside the test; or ``for i in range(sweep(10))`` for a test
    that repeats a random stop or start (seeded by the count, so the two parts
    draw different moments)."""
    return lambda examples: max(1, round(examples * request.param))


# ---------------------------------------------------------------------------
# Solver implementation under test: the compiled kernel (default, when built;
# scripts/run_tests.sh builds it and sets FSD_REQUIRE_KERNEL=1 so that a
# failed build fails the run) or, with FSD_KERNEL=0, the Python reference code
# for the whole suite:  FSD_KERNEL=0 PYTHONPATH=. python -m pytest -q test
# test/machines/staicu/test_kernel.py checks the two against each other in every run.
# ---------------------------------------------------------------------------
# (read by flight_sim_dynamics.kernel itself, so the node and command-line
# processes the tests start follow the same choice)
