"""The rclpy internals the package reaches into, pinned: one test (or more) per
row of docs/design/rclpy.md (R1, R2, ...), each failing with a message that
names its row when an rclpy upgrade takes away what the package relies on.

The unit tests need no DDS; the ``ros`` ones share one rclpy context (no
signal handlers of rclpy's: the package's executables run so) and create their
nodes, services and subscriptions under names of their own.
"""
from __future__ import annotations

import atexit
import functools
import importlib.metadata
import os
import re
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Any, Callable, Iterator

import pytest
import rclpy
import rclpy.serialization
import rclpy.task
import rclpy.utilities
from rcl_interfaces.srv import (DescribeParameters, GetParameters, GetParameterTypes,
                                ListParameters, SetParameters, SetParametersAtomically)
from rclpy.callback_groups import MutuallyExclusiveCallbackGroup
from rclpy.context import Context
from rclpy.executors import Executor, SingleThreadedExecutor
from rclpy.node import Node
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
from rclpy.service import Service
from rclpy.signals import SignalHandlerOptions
from std_msgs.msg import Int32
from std_srvs.srv import Trigger

from flight_sim_dynamics.ros import process
from flight_sim_dynamics.ros.service_thread import _Host

ROOT = Path(__file__).resolve().parents[2]
DOC = ROOT / 'docs' / 'design' / 'rclpy.md'
#: the rclpy release every row of the doc was checked against
VERIFIED_RCLPY = '7.1.6'
EXECUTORS = ('single', 'events')
#: s a request, message or task gets before it counts as not served
SERVED_WITHIN = 5.0
#: s a request the executor must not serve is given nonetheless
NOT_SERVED_FOR = 0.5


def broke(row: str, what: str) -> str:
    """The failure message of a test of ``row`` of docs/design/rclpy.md."""
    return (f'rclpy changed under reach {row} of docs/design/rclpy.md: {what}; the package '
            f'code the row names relies on it (fix it there, then the row and this test)')


def reach(row: str) -> Callable[[Callable[..., Any]], Callable[..., Any]]:
    """The decorated test pins ``row``: whatever breaks in it (an attribute gone,
    a signature changed) fails with a message naming the row.
    """
    def decorate(test: Callable[..., Any]) -> Callable[..., Any]:
        @functools.wraps(test)          # pytest reads the fixtures through __wrapped__
        def run(*args: Any, **kwargs: Any) -> Any:
            try:
                return test(*args, **kwargs)
            except Exception as exc:
                if 'docs/design/rclpy.md' in str(exc):
                    raise
                pytest.fail(broke(row, f'{type(exc).__name__}: {exc}'))
        return run
    return decorate


# ---------------------------------------------------------------------------
# shared set-up of the ros tests
# ---------------------------------------------------------------------------
@pytest.fixture(scope='module')
def context() -> Iterator[Context]:
    ctx = Context()
    rclpy.init(context=ctx, signal_handler_options=SignalHandlerOptions.NO)
    yield ctx
    ctx.try_shutdown()


_names = iter(range(10 ** 6))


def unique(stem: str) -> str:
    """A node, topic or service name no other test of this module uses."""
    return f'rclpy_internals_{stem}_{os.getpid()}_{next(_names)}'


def make_executor(kind: str, context: Context) -> Any:
    from rclpy.experimental import EventsExecutor
    return (EventsExecutor if kind == 'events' else SingleThreadedExecutor)(context=context)


def spin_step(executor: Any, step: float = 0.02) -> None:
    """One timed spin, as ros/node.py's spin_until spins each kind."""
    if isinstance(executor, Executor):
        executor.spin_once(timeout_sec=step)
    else:
        executor.spin_until_future_complete(rclpy.task.Future(), timeout_sec=step)


def spin_until(executors: list[Any], done: Callable[[], bool], timeout: float) -> bool:
    deadline = time.monotonic() + timeout
    while not done() and time.monotonic() < deadline:
        for executor in executors:
            spin_step(executor)
    return done()


class Caller:
    """A client node of its own (spun on its own executor) calling ``name``."""

    def __init__(self, context: Context, srv_type: Any, name: str) -> None:
        self.node = rclpy.create_node(unique('caller'), context=context)
        self.client = self.node.create_client(srv_type, name)
        self.executor = SingleThreadedExecutor(context=context)
        self.executor.add_node(self.node)
        self.srv_type = srv_type
        assert self.client.wait_for_service(timeout_sec=SERVED_WITHIN), f'{name} not discovered'

    def call(self, server: Any, timeout: float) -> Any:
        """The response (None: none within ``timeout`` s, ``server`` spun meanwhile)."""
        future = self.client.call_async(self.srv_type.Request())
        spin_until([server, self.executor], future.done, timeout)
        if not future.done():
            self.client.remove_pending_request(future)
            return None
        return future.result()

    def close(self) -> None:
        self.executor.shutdown()
        self.node.destroy_node()


def answering(message: str) -> Callable[[Any, Any], Any]:
    def answer(request: Any, response: Any) -> Any:
        response.success, response.message = True, message
        return response
    return answer


# ---------------------------------------------------------------------------
# the version the rows were checked against
# ---------------------------------------------------------------------------
def _pinned_rclpy() -> str:
    for name in ('requirements.txt', 'requirements-test.txt'):
        for line in (ROOT / name).read_text().splitlines():
            match = re.match(r'\s*ros-jazzy-rclpy(\[[^]]*\])?\s*==\s*(\S+)', line)
            if match:
                return match.group(2)
    raise AssertionError('no ros-jazzy-rclpy pin in requirements*.txt')


@reach('R0')
def test_rclpy_is_the_release_the_rows_were_checked_against():
    pinned = _pinned_rclpy()
    assert pinned == VERIFIED_RCLPY, broke(
        'R0', f'requirements.txt pins rclpy {pinned}, docs/design/rclpy.md was checked against '
        f'{VERIFIED_RCLPY}: check every row against {pinned}, then move VERIFIED_RCLPY')
    installed = importlib.metadata.version('ros-jazzy-rclpy')
    assert installed == pinned, broke(
        'R0', f'rclpy {installed} is installed, requirements.txt pins {pinned}')


def test_every_row_of_the_doc_has_a_test_and_every_test_a_row():
    rows = set(re.findall(r'^\| (R\d+) \|', DOC.read_text(), flags=re.MULTILINE))
    tested = set(re.findall(r"@reach\('(R\d+)'\)", Path(__file__).read_text()))
    assert rows, f'no rows in {DOC}'
    assert rows == tested, (f'rows without a test: {sorted(rows - tested)}; '
                            f'tests without a row: {sorted(tested - rows)}')
    named = set(re.findall(r'`(test_\w+)', DOC.read_text()))
    defined = {name for name in globals() if name.startswith('test_')}
    assert named <= defined, f'{DOC.name} names tests this file lacks: {sorted(named - defined)}'


# ---------------------------------------------------------------------------
# R1: Service.callback replaced (parameter_guard._guard_services, ServiceThread)
# ---------------------------------------------------------------------------
@reach('R1')
def test_service_callback_group_type_and_name_are_plain_attributes():
    def original(request: Any, response: Any) -> Any:
        return response

    def replacement(request: Any, response: Any) -> Any:
        return response
    group = MutuallyExclusiveCallbackGroup()
    # the constructor only stores its arguments: no rcl service is needed
    service = Service(object(), Trigger, 'name', original, group, QoSProfile(depth=1))
    assert (service.callback, service.srv_type, service.srv_name) == (original, Trigger, 'name'), \
        broke('R1', 'Service no longer keeps callback, srv_type and srv_name as given')
    service.callback = replacement
    other = MutuallyExclusiveCallbackGroup()
    service.callback_group = other
    assert service.callback is replacement and service.callback_group is other, \
        broke('R1', 'Service.callback or Service.callback_group is no longer writable as is')


@pytest.mark.ros
@pytest.mark.parametrize('kind', EXECUTORS)
@reach('R1')
def test_a_service_callback_replaced_after_creation_answers_the_requests(context, kind):
    node = rclpy.create_node(unique('server'), context=context)
    name = unique('trigger')
    service = node.create_service(Trigger, name, answering('original'))
    service.callback = answering('replaced')
    executor = make_executor(kind, context)
    executor.add_node(node)
    caller = Caller(context, Trigger, name)
    try:
        response = caller.call(executor, SERVED_WITHIN)
        assert response is not None, broke('R1', f'{kind} executor: request not answered')
        assert response.message == 'replaced', broke(
            'R1', f'the {kind} executor called the callback given at creation, not '
            'Service.callback as it is at the request')
    finally:
        caller.close()
        executor.shutdown()
        node.destroy_node()


@pytest.mark.ros
@reach('R1')
def test_a_lifecycle_node_lists_its_parameter_and_lifecycle_services(context):
    from lifecycle_msgs.srv import ChangeState, GetState
    from rclpy.lifecycle import LifecycleNode
    node = LifecycleNode(unique('lifecycle'), context=context)
    try:
        types = {s.srv_type for s in node.services}
        wanted = {ChangeState, GetState, DescribeParameters, GetParameters, GetParameterTypes,
                  ListParameters, SetParameters, SetParametersAtomically}
        assert wanted <= types, broke(
            'R1', f'LifecycleNode.services lacks {sorted(t.__name__ for t in wanted - types)}: '
            'the guard no longer wraps every request handler')
        assert all(callable(s.callback) for s in node.services), broke(
            'R1', 'a service of LifecycleNode has no callable Service.callback')
    finally:
        node.destroy_node()


# ---------------------------------------------------------------------------
# R2: Node.services overridden, Node._services read (GuardedParameters)
# ---------------------------------------------------------------------------
class _HidingNode(Node):
    """A node whose ``services`` leaves out ``hidden``, as GuardedParameters does."""

    hidden: frozenset = frozenset()

    @property
    def services(self) -> Iterator[Any]:
        return (s for s in self._services if s not in self.hidden)


@pytest.mark.ros
@pytest.mark.parametrize('kind', EXECUTORS)
@reach('R2')
def test_executors_wait_only_on_what_node_services_yields(context, kind):
    node = _HidingNode(unique('hiding'), context=context)
    shown, hidden = unique('shown'), unique('hidden')
    node.create_service(Trigger, shown, answering('shown'))
    node.hidden = frozenset({node.create_service(Trigger, hidden, answering('hidden'))})
    assert isinstance(node._services, list) and node.hidden <= set(node._services), broke(
        'R2', 'Node no longer keeps its services in the list Node._services')
    assert set(Node.services.fget(node)) == set(node._services), broke(
        'R2', 'Node.services no longer yields the list Node._services')
    executor = make_executor(kind, context)
    executor.add_node(node)
    callers = [Caller(context, Trigger, shown), Caller(context, Trigger, hidden)]
    try:
        assert callers[0].call(executor, SERVED_WITHIN) is not None, broke(
            'R2', f'the {kind} executor does not answer a service node.services yields')
        assert callers[1].call(executor, NOT_SERVED_FOR) is None, broke(
            'R2', f'the {kind} executor answers a service node.services leaves out (it no '
            'longer finds the services through Node.services)')
    finally:
        for caller in callers:
            caller.close()
        executor.shutdown()
        node.destroy_node()


# ---------------------------------------------------------------------------
# R3: a second executor over a duck-typed host (service_thread._Host)
# ---------------------------------------------------------------------------
@pytest.mark.ros
@reach('R3')
def test_a_single_threaded_executor_spins_a_duck_typed_host(context):
    node = rclpy.create_node(unique('owner'), context=context)
    name = unique('apart')
    service = node.create_service(Trigger, name, answering('apart'))
    host = _Host(context, [service])
    executor = SingleThreadedExecutor(context=context)
    try:
        assert executor.add_node(host), broke('R3', 'Executor.add_node refuses the host object')
        assert host.executor is executor, broke(
            'R3', 'Executor.add_node no longer sets the executor attribute of what it adds')
        caller = Caller(context, Trigger, name)
        try:
            response = caller.call(executor, SERVED_WITHIN)
        finally:
            caller.close()
        assert response is not None and response.message == 'apart', broke(
            'R3', 'the executor no longer serves the services of a host object that has '
            'context, services, subscriptions, timers, clients, guards and waitables')
    finally:
        executor.shutdown()
        node.destroy_node()


# ---------------------------------------------------------------------------
# R4: a service's callback group replaced after creation (ServiceThread)
# ---------------------------------------------------------------------------
class _Entity:
    """A stand-in for a timer or subscription of a callback group."""


@pytest.mark.ros
@reach('R4')
def test_the_executor_asks_the_callback_group_the_service_has_at_the_request(context):
    node = rclpy.create_node(unique('grouped'), context=context)
    name = unique('grouped')
    service = node.create_service(Trigger, name, answering('grouped'))
    group = MutuallyExclusiveCallbackGroup()
    service.callback_group = group
    group.add_entity(service)
    busy = _Entity()            # another entity of the group, its callback running
    group.add_entity(busy)
    assert group.beginning_execution(busy)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    caller = Caller(context, Trigger, name)
    try:
        assert caller.call(executor, NOT_SERVED_FOR) is None, broke(
            'R4', 'the executor served a service whose Service.callback_group (set after '
            'creation) is held: it no longer asks that attribute')
        group.ending_execution(busy)
        assert caller.call(executor, SERVED_WITHIN) is not None, broke(
            'R4', 'the executor does not serve a service once its replaced group is free')
    finally:
        caller.close()
        executor.shutdown()
        node.destroy_node()


# ---------------------------------------------------------------------------
# R5: a subscription's queue taken through its handle (DynamicsNode._drop_queued)
# ---------------------------------------------------------------------------
@pytest.mark.ros
@pytest.mark.parametrize('raw', [False, True], ids=['typed', 'raw'])
@reach('R5')
def test_take_message_gives_message_and_info_then_none(context, raw):
    node = rclpy.create_node(unique('taker'), context=context)
    topic = unique('topic')
    got: list[Any] = []
    qos = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=10,
                     reliability=ReliabilityPolicy.RELIABLE)
    sub = node.create_subscription(Int32, topic, got.append, qos, raw=raw)
    pub = node.create_publisher(Int32, topic, qos)
    try:
        assert (sub.msg_type, sub.raw) == (Int32, raw), broke(
            'R5', 'Subscription.msg_type or Subscription.raw is no longer as created')
        assert (sub.qos_profile.history, sub.qos_profile.depth) == (HistoryPolicy.KEEP_LAST, 10), \
            broke('R5', 'Subscription.qos_profile no longer gives history and depth')
        deadline = time.monotonic() + SERVED_WITHIN
        while not pub.get_subscription_count() and time.monotonic() < deadline:
            time.sleep(0.01)
        for i in range(3):
            pub.publish(Int32(data=i))
        taken: list[Any] = []
        while len(taken) < 3 and time.monotonic() < deadline:
            with sub.handle:                # the handle is a context manager
                item = sub.handle.take_message(sub.msg_type, sub.raw)
            if item is None:
                time.sleep(0.01)
                continue
            assert isinstance(item, tuple) and len(item) == 2, broke(
                'R5', f'take_message returned {type(item).__name__}, not (message, info)')
            taken.append(item[0])
        assert len(taken) == 3, broke('R5', 'take_message took fewer messages than were sent')
        if raw:
            assert all(isinstance(m, bytes) for m in taken), broke(
                'R5', 'take_message of a raw subscription no longer gives bytes')
        else:
            assert [m.data for m in taken] == [0, 1, 2], broke(
                'R5', 'take_message no longer gives the messages in order')
        with sub.handle:
            assert sub.handle.take_message(sub.msg_type, sub.raw) is None, broke(
                'R5', 'take_message of an empty queue no longer returns None')
        sub.callback(taken[0])
        assert got == [taken[0]], broke(
            'R5', 'Subscription.callback no longer calls the function given with the message')
    finally:
        node.destroy_node()


@pytest.mark.ros
@pytest.mark.parametrize('kind', EXECUTORS)
@reach('R5')
def test_the_executor_calls_nothing_for_messages_taken_through_the_handle(context, kind):
    """_drop_queued takes messages the executor has seen arrive: its events
    for them then take nothing, and call nothing.
    """
    node = rclpy.create_node(unique('drop'), context=context)
    topic = unique('drop')
    got: list[Any] = []
    sub = node.create_subscription(Int32, topic, got.append, 10)
    pub = node.create_publisher(Int32, topic, 10)
    executor = make_executor(kind, context)
    executor.add_node(node)
    try:
        spin_until([executor], pub.get_subscription_count, SERVED_WITHIN)
        for i in range(3):
            pub.publish(Int32(data=i))
        taken, deadline = 0, time.monotonic() + SERVED_WITHIN
        while taken < 3 and time.monotonic() < deadline:
            with sub.handle:
                taken += sub.handle.take_message(sub.msg_type, sub.raw) is not None
        assert taken == 3, broke('R5', f'{taken} of 3 messages taken through the handle')
        spin_until([executor], lambda: bool(got), NOT_SERVED_FOR)
        assert got == [], broke(
            'R5', f'the {kind} executor called the callback for messages already taken')
    finally:
        executor.shutdown()
        node.destroy_node()


# ---------------------------------------------------------------------------
# R6..R10: rclpy.experimental.EventsExecutor and the executors' spins
# ---------------------------------------------------------------------------
@pytest.mark.ros
@reach('R6')
def test_the_events_executor_is_the_experimental_pybind11_one(context):
    from rclpy.experimental import EventsExecutor
    executor = EventsExecutor(context=context)
    try:
        assert not isinstance(executor, Executor), broke(
            'R6', 'EventsExecutor is now an rclpy.executors.Executor: ros/node.py:spin_until '
            'would spin it with spin_once (one callback per call), not as an events executor')
        for method in ('add_node', 'create_task', 'spin_once', 'spin_until_future_complete',
                       'shutdown'):
            assert callable(getattr(executor, method, None)), broke(
                'R6', f'EventsExecutor has no {method}()')
    finally:
        executor.shutdown()


_BUSY_LOOP = """
import os, sys, threading, time
import rclpy
from rclpy.experimental import EventsExecutor
from rclpy.signals import SignalHandlerOptions
ctx = rclpy.Context()
rclpy.init(context=ctx, signal_handler_options=SignalHandlerOptions.NO)
executor = EventsExecutor(context=ctx)
threading.Thread(target=executor.spin, daemon=True).start()
time.sleep(0.1)
cpu, wall = time.process_time(), time.monotonic()
time.sleep(0.4)
print((time.process_time() - cpu) / (time.monotonic() - wall), flush=True)
os._exit(0)        # spin() cannot be stopped from another thread either
"""


@pytest.mark.ros
@reach('R7')
def test_the_events_executor_busy_loops_in_an_untimed_spin():
    """The reason every spin of the package has a timeout (a thread spinning an
    idle EventsExecutor with spin() uses a whole core). Run apart: that spin
    never ends.
    """
    out = subprocess.run([sys.executable, '-c', _BUSY_LOOP], capture_output=True, text=True,
                         timeout=60, env=dict(os.environ))
    assert out.returncode == 0, out.stderr[-2000:]
    share = float(out.stdout.split()[-1])
    assert share > 0.2, broke(
        'R7', f'an idle EventsExecutor.spin() uses {share:.0%} of a core, no longer a busy '
        'loop: the timed spins of ros/node.py:spin_until may be simplified')


@pytest.mark.ros
@reach('R7')
def test_a_timed_spin_of_the_events_executor_idles(context):
    executor = make_executor('events', context)
    try:
        cpu, wall = time.process_time(), time.monotonic()
        executor.spin_until_future_complete(rclpy.task.Future(), timeout_sec=0.3)
        wall, cpu = time.monotonic() - wall, time.process_time() - cpu
        assert 0.25 <= wall < 2.0, broke(
            'R7', f'a timed spin of an idle EventsExecutor returned after {wall:.2f} s, not 0.3')
        assert cpu < 0.5 * wall, broke(
            'R7', f'a timed spin of an idle EventsExecutor used {cpu / wall:.0%} of a core')
    finally:
        executor.shutdown()


@pytest.mark.ros
@reach('R8')
def test_the_events_executor_ends_a_timed_spin_on_its_future_not_on_time(context):
    executor = make_executor('events', context)
    counts = {'ran': 0}

    def chain(total: int, done_at: int | None, future: rclpy.task.Future | None) -> None:
        """``total`` tasks of 1 ms, each posting the next: a queue never empty."""
        def step() -> None:
            counts['ran'] += 1
            time.sleep(0.001)
            if counts['ran'] == done_at:
                future.set_result(True)
            if counts['ran'] < total:
                executor.create_task(step)
        counts['ran'] = 0
        executor.create_task(step)
    try:
        chain(200, None, None)
        start = time.monotonic()
        executor.spin_until_future_complete(rclpy.task.Future(), timeout_sec=0.02)
        assert counts['ran'] == 200, broke(
            'R8', f"a timed spin returned with a backlog ({counts['ran']} of 200 tasks run, "
            f'{time.monotonic() - start:.2f} s): process.end_spins may not be needed any more')
        future = rclpy.task.Future()
        chain(200, 10, future)
        executor.spin_until_future_complete(future, timeout_sec=SERVED_WITHIN)
        assert counts['ran'] == 10, broke(
            'R8', f"a future done in a callback ended the spin after {counts['ran']} tasks, "
            'not right after that callback: process.end_spins no longer ends a spin')
        spin_until([executor], lambda: counts['ran'] >= 200, SERVED_WITHIN)   # the rest
    finally:
        executor.shutdown()


@pytest.mark.ros
@reach('R9')
def test_the_events_executor_fails_on_a_callback_that_takes_message_info(context):
    node = rclpy.create_node(unique('info'), context=context)
    topic = unique('info')
    got: list[Any] = []
    node.create_subscription(Int32, topic, lambda msg, info: got.append(info), 10)
    pub = node.create_publisher(Int32, topic, 10)
    executor = make_executor('events', context)
    executor.add_node(node)
    failed: list[BaseException] = []
    try:
        deadline = time.monotonic() + SERVED_WITHIN
        while not failed and not got and time.monotonic() < deadline:
            pub.publish(Int32(data=1))
            try:
                executor.spin_until_future_complete(rclpy.task.Future(), timeout_sec=0.05)
            except Exception as exc:  # noqa: BLE001 - 7.1.6: SystemError
                failed.append(exc)
        assert failed and not got, broke(
            'R9', 'the EventsExecutor now calls a subscription callback that takes message '
            'info: the package may use such callbacks (the row can go)')
    finally:
        executor.shutdown()
        node.destroy_node()


@pytest.mark.ros
@reach('R10')
def test_python_executors_keep_a_done_callback_per_spin_until_future_complete(context):
    executor = SingleThreadedExecutor(context=context)
    future = rclpy.task.Future()
    try:
        before = len(future._callbacks)
        for _ in range(5):
            executor.spin_until_future_complete(future, timeout_sec=0.001)
        kept = len(future._callbacks) - before
        assert kept >= 5, broke(
            'R10', f'5 timed spin_until_future_complete kept {kept} done callbacks on the '
            'future: ros/node.py:spin_until may use it for Python executors again')
    finally:
        executor.shutdown()


# ---------------------------------------------------------------------------
# R11: the package's own stop signals (node.running, process.stop_on_signals)
# ---------------------------------------------------------------------------
@pytest.mark.ros
@reach('R11')
def test_sigint_stays_a_stop_request_with_both_executors(context):
    saved = {s: signal.getsignal(s) for s in process.STOP_SIGNALS}
    executors = [make_executor(kind, context) for kind in EXECUTORS]
    try:
        process.stop_on_signals()
        for executor in executors:      # a newer EventsExecutor takes SIGINT for itself
            spin_step(executor)
        os.kill(os.getpid(), signal.SIGINT)
        deadline = time.monotonic() + SERVED_WITHIN
        while not process.stop_requested() and time.monotonic() < deadline:
            time.sleep(0.01)
        assert process.stop_requested(), broke(
            'R11', 'SIGINT did not reach the handler of process.stop_on_signals: rclpy (an '
            'executor) installs a handler of its own')
        for executor in executors:
            spin_step(executor)
        assert context.ok(), broke('R11', 'SIGINT shut the rclpy context down')
    finally:
        for signum, handler in saved.items():
            signal.signal(signum, handler)
        process._stop.clear()
        atexit.unregister(process._ignore_stop_signals)    # pytest's exit keeps its own
        for executor in executors:
            executor.shutdown()


# ---------------------------------------------------------------------------
# R12: create_task from another thread (ServiceThread._forwarding)
# ---------------------------------------------------------------------------
@pytest.mark.ros
@pytest.mark.parametrize('kind', EXECUTORS)
@reach('R12')
def test_create_task_from_another_thread_runs_on_the_spinning_one(context, kind):
    executor = make_executor(kind, context)
    ran: list[str] = []

    def post() -> None:
        time.sleep(0.1)
        executor.create_task(lambda: ran.append(threading.current_thread().name))
    poster = threading.Thread(target=post, name='poster', daemon=True)
    try:
        poster.start()
        start = time.monotonic()
        while not ran and time.monotonic() - start < SERVED_WITHIN:
            if isinstance(executor, Executor):
                executor.spin_once(timeout_sec=0.05)
            else:
                executor.spin_until_future_complete(rclpy.task.Future(), timeout_sec=0.05)
        assert ran == [threading.current_thread().name], broke(
            'R12', f'a task created from another thread ran on {ran or "no thread"}, not on the '
            f'thread spinning the {kind} executor')
    finally:
        poster.join()
        executor.shutdown()


# ---------------------------------------------------------------------------
# R13: rclpy's private exception types (node.own_options, platform_sim)
# ---------------------------------------------------------------------------
def _raised(call: Callable[[], Any]) -> BaseException | None:
    try:
        call()
    except BaseException as exc:  # noqa: BLE001 - what it raises is the test
        return exc
    return None


@reach('R13')
def test_refused_ros_arguments_raise_a_runtime_error():
    raised = _raised(lambda: rclpy.utilities.remove_ros_args(['program', '--ros-args', '-r']))
    assert isinstance(raised, RuntimeError), broke(
        'R13', f'remove_ros_args refuses a bad ROS argument with {raised!r}, not a RuntimeError '
        '(ros/node.py:own_options turns any Exception into the error: line)')


@reach('R13')
def test_malformed_bytes_raise_a_runtime_error():
    from std_msgs.msg import String
    raised = _raised(lambda: rclpy.serialization.deserialize_message(
        b'\x00\x01\x00\x00\xff\xff\xff\x7f', String))
    assert isinstance(raised, RuntimeError), broke(
        'R13', f'deserialize_message refuses malformed bytes with {raised!r}, not a RuntimeError')


# ---------------------------------------------------------------------------
# R14: test/conftest.py wraps Context.init (an unmarked test initialising rclpy)
# ---------------------------------------------------------------------------
class _Seen(Exception):
    pass


@reach('R14')
def test_rclpy_init_goes_through_context_init(monkeypatch):
    def seen(self: Context, *args: Any, **kwargs: Any) -> None:
        raise _Seen                 # nothing initialised: no ros mark needed
    monkeypatch.setattr(Context, 'init', seen)
    raised = _raised(lambda: rclpy.init(context=Context(),
                                        signal_handler_options=SignalHandlerOptions.NO))
    assert isinstance(raised, _Seen), broke(
        'R14', 'rclpy.init no longer initialises a context through Context.init: '
        'test/conftest.py would not see a test without the ros mark initialise rclpy')
