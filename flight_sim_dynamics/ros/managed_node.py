"""The lifecycle the package's managed nodes (``dynamics_node``,
``motion_cueing``) share (:class:`ManagedNode`): :meth:`~ManagedNode.start`
(configure, then activate), a configure that turns any refusal into
:attr:`~ManagedNode.failure` (the executable's ``error:`` line at start-up, an
ERROR log line later), cleanup, shutdown and error transitions that release the
node's endpoints, and :attr:`~ManagedNode.finalized`, done at shutdown (the
executable's spin ends on it). Each node gives :meth:`~ManagedNode._configure`,
:meth:`~ManagedNode._configured` and :meth:`~ManagedNode._release`.
"""
from __future__ import annotations

from typing import Any

from rclpy.lifecycle import LifecycleNode, LifecycleState, TransitionCallbackReturn
from rclpy.task import Future

from ..config.errors import ParameterError
from .parameter_guard import GuardedParameters

SUCCESS, FAILURE = TransitionCallbackReturn.SUCCESS, TransitionCallbackReturn.FAILURE


class Refused(ValueError):
    """A start-up value refused, not set since."""


class ManagedNode(GuardedParameters, LifecycleNode):
    """A lifecycle node with guarded parameters (:class:`.GuardedParameters`)
    that starts unconfigured. :attr:`failure`: why configure failed (None: it
    did not); ``self._refused``: start-up values refused (name -> reason), set
    by the node when it declares its parameters.
    """

    def __init__(self, node_name: str, **kwargs: Any) -> None:
        # every given parameter declared: typos can be told apart with public API
        super().__init__(node_name, automatically_declare_parameters_from_overrides=True,
                         **kwargs)
        self.failure: str | None = None
        self.finalized = Future()
        self._starting = False
        #: True while :meth:`start` activates (configured a moment before)
        self.activating_at_start = False
        self._refused: dict[str, str] = {}

    # -- what each node gives ------------------------------------------------------
    def _configure(self) -> None:
        """Build from the parameters' values and create the endpoints; raises
        (a ParameterError, a model or planner that refuses) to fail configure.
        """
        raise NotImplementedError

    def _configured(self) -> None:
        """After a configure that succeeded: the node's log lines."""

    def _release(self) -> None:
        """Destroy the endpoints :meth:`_configure` created (idempotent)."""
        raise NotImplementedError

    # -- the lifecycle ---------------------------------------------------------------
    def start(self) -> bool:
        """Configure, then activate; False (see :attr:`failure`) if configure failed."""
        self._starting = True       # a failure is the caller's ``error:`` line, not a log
        try:
            if self.trigger_configure() != SUCCESS:
                return False
        finally:
            self._starting = False
        self.activating_at_start = True     # no time inactive: no stream ran meanwhile
        try:
            return self.trigger_activate() == SUCCESS
        finally:
            self.activating_at_start = False

    def on_configure(self, state: LifecycleState) -> TransitionCallbackReturn:
        try:
            if self._refused:
                raise Refused(next(iter(self._refused.values())))
            self._configure()
        except Exception as exc:  # noqa: BLE001 - a ParameterError, a model or planner that refuses
            reason = str(exc) if isinstance(exc, (ParameterError, Refused)) \
                else f'{type(exc).__name__}: {exc}'
            self._release()
            self.failure = f'invalid parameters: {reason}'
            if not self._starting:
                self.get_logger().error(f'configure failed, still unconfigured: {self.failure}')
            return FAILURE
        self.failure = None
        self._configured()
        return SUCCESS

    def on_cleanup(self, state: LifecycleState) -> TransitionCallbackReturn:
        self._release()
        self.get_logger().info('unconfigured: endpoints released')
        return SUCCESS

    def on_shutdown(self, state: LifecycleState) -> TransitionCallbackReturn:
        self._release()
        if not self.finalized.done():
            self.finalized.set_result(True)
        return SUCCESS

    def on_error(self, state: LifecycleState) -> TransitionCallbackReturn:
        self._release()
        return SUCCESS
