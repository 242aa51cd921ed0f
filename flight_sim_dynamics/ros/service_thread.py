"""Some of a node's services taken on a thread of their own.

rclpy converts a request to Python objects before any callback sees it, on
the thread that takes it: a SetParameters request of 100,000 parameters holds
that thread for seconds. Taken here, on a thread with a wait-set executor of
its own, the conversion leaves the node's executor answering setpoints (the
two threads share the GIL, which Python hands over every few milliseconds).
Each request is then handled on the node's executor, where all of the node's
state lives, unless ``answer_here`` answers it at once (a refusal that reads
nothing of the node).
"""
from __future__ import annotations

import threading
from typing import Any, Callable, Sequence

from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor

Handler = Callable[[Any, Any], Any]


class _Host:
    """What an executor reads of a node, holding only ``services``."""

    def __init__(self, context: Any, services: Sequence[Any]) -> None:
        self.context = context
        self.services = list(services)
        self.subscriptions = self.timers = self.clients = self.guards = self.waitables = ()
        self.executor = None


class ServiceThread:
    """Takes ``services`` on its own thread; hands each request to ``executor``
    (the node's), or answers it with ``answer_here`` when that returns a response.
    """

    #: s between two looks at a stop request (a request waiting for its answer too)
    STEP = 0.1

    def __init__(self, context: Any, services: Sequence[Any], executor: Any,
                 answer_here: Handler) -> None:
        self.services = frozenset(services)
        self._executor = executor
        self._answer_here = answer_here
        self._stopping = threading.Event()
        for service in services:
            service.callback = self._forwarding(service.callback)
        self._own = SingleThreadedExecutor(context=context)
        self._own.add_node(_Host(context, services))
        self._thread = threading.Thread(target=self._spin, name='services', daemon=True)
        self._thread.start()

    def _spin(self) -> None:
        try:
            while not self._stopping.is_set() and self._own.context.ok():
                self._own.spin_once(timeout_sec=self.STEP)
        except (ExternalShutdownException, KeyboardInterrupt):
            pass

    def _forwarding(self, handler: Handler) -> Handler:
        def forward(request: Any, response: Any) -> Any:
            answer = self._answer_here(request, response)
            if answer is not None:
                return answer
            done = threading.Event()
            answers: list[Any] = []

            def run() -> None:
                try:
                    answers.append(handler(request, response))
                finally:
                    done.set()
            self._executor.create_task(run)
            while not done.wait(self.STEP):
                if self._stopping.is_set():     # the node's executor no longer runs
                    return response
            return answers[0] if answers else response
        return forward

    def stop(self, timeout: float = 2.0) -> None:
        """End the thread (before the node is destroyed)."""
        self._stopping.set()
        self._thread.join(timeout)
        self._own.shutdown(timeout_sec=timeout)


__all__ = ['ServiceThread']
