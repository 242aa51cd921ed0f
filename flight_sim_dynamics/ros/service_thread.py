"""Some of a node's services taken on a thread of their own.

rclpy converts a request to Python objects before any callback sees it, on
the thread that takes it: a SetParameters request of 100,000 parameters holds
that thread for seconds. Taken here, on a thread with a wait-set executor of
its own, the conversion leaves the node's executor answering setpoints (the
two threads share the GIL, which Python hands over every few milliseconds).
Each request is then handled on the node's executor, where all of the node's
state lives, unless ``check`` refuses it at once (a check that reads nothing
of the node).
"""
from __future__ import annotations

import threading
from typing import Any, Callable, Sequence

from rclpy.callback_groups import MutuallyExclusiveCallbackGroup
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor

Handler = Callable[[Any, Any], Any]
#: (request, response, reason) -> the response refusing the request
Refuse = Callable[[Any, Any, str], Any]


class _Host:
    """What an executor reads of a node, holding only ``services`` (an rclpy
    internal, pinned: docs/design/rclpy.md R3).
    """

    def __init__(self, context: Any, services: Sequence[Any]) -> None:
        self.context = context
        self.services = list(services)
        self.subscriptions = self.timers = self.clients = self.guards = self.waitables = ()
        self.executor = None


class ServiceThread:
    """Takes ``services`` on its own thread; hands each request to ``executor``
    (the node's), unless ``check(request)`` gives a reason to refuse it
    (answered by ``refuse`` at once).
    """

    #: s between two looks at a stop request (a request waiting for its answer too)
    STEP = 0.1

    def __init__(self, context: Any, services: Sequence[Any], executor: Any,
                 check: Callable[[Any], str | None], refuse: Refuse, logger: Any) -> None:
        self.services = frozenset(services)
        self._executor = executor
        self._check, self._refuse, self._logger = check, refuse, logger
        self._stopping = threading.Event()
        # a group of their own: a wait-set executor on the node holds the node's
        # default group while a callback runs (this one waits for the node's executor);
        # callback and group replaced after creation: docs/design/rclpy.md R1, R4
        group = MutuallyExclusiveCallbackGroup()
        for service in services:
            service.callback = self._forwarding(service)
            service.callback_group = group
            group.add_entity(service)
        self._own = SingleThreadedExecutor(context=context)
        self._own.add_node(_Host(context, services))
        self._thread = threading.Thread(target=self._spin, name='services', daemon=True)
        self._thread.start()

    def _spin(self) -> None:
        while not self._stopping.is_set() and self._own.context.ok():
            try:
                self._own.spin_once(timeout_sec=self.STEP)
            except (ExternalShutdownException, KeyboardInterrupt):
                return
            except Exception as exc:  # noqa: BLE001 - the services must outlive one request
                self._logger.error(f'parameter services: {type(exc).__name__}: {exc}',
                                   throttle_duration_sec=2.0)

    def _forwarding(self, service: Any) -> Handler:
        handler = service.callback

        def forward(request: Any, response: Any) -> Any:
            problem = self._check(request)
            if problem is not None:
                self._logger.warn(f'{service.srv_name}: {problem}', throttle_duration_sec=2.0)
                return self._refuse(request, response, problem)
            done = threading.Event()
            answers: list[Any] = []

            def run() -> None:
                try:
                    answers.append(handler(request, response))
                finally:
                    done.set()
            self._executor.create_task(run)     # from this thread: docs/design/rclpy.md R12
            while not done.wait(self.STEP):
                if self._stopping.is_set():     # the node's executor no longer runs
                    return self._refuse(request, response, 'the node is stopping')
            return answers[0] if answers else response
        return forward

    def stop(self) -> None:
        """End the thread, once it has sent what it is sending (before the node
        is destroyed; the executable bounds the whole teardown).
        """
        self._stopping.set()
        self._thread.join()
        self._own.shutdown()


__all__ = ['ServiceThread']
