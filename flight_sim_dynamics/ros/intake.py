"""The node's setpoint pipeline, without rclpy: from the fields of setpoint
messages to answers and rejections.

:class:`SetpointIntake` checks each message (:mod:`.inputs`), joins and
orders the setpoints (:mod:`.synchroniser`), fills in what the planner did
not send (:mod:`.estimator`), solves and checks each (:mod:`.cycle`), hands
the numbers to the caller's ``publish`` and keeps the counters of the
diagnostics (:mod:`.diagnostics`). The ROS node
(:mod:`.dynamics_node`) reads the serialized messages, publishes, logs and
owns the clocks; the rules are all here.

Stamp policy (docs/node.md, "Stamps"): a stamp more than ``input.max_future``
ahead of the node's clock is ``future_stamp`` and leaves no state behind;
setpoints far behind the last answered one, sustained, are a planner restart
(:class:`.StampSynchroniser`); a setpoint the node rejects leaves no trace in
the stamp order or the estimator's history.
"""
from __future__ import annotations

import time
from typing import Any, Callable, Sequence

from .cycle import Runtime, assess, outputs_of, rates_of, solve_setpoint
from .diagnostics import ERROR, OK, WARN, CycleStats, LogThrottle
from ..core.estimator import DerivativeEstimator
from .inputs import (ACCEL, PLATFORM, QUIET_REASONS, SOLVER_ERROR, TWIST, UNREACHABLE,
                     WARMING_UP, PoseInput, RateInput, SetpointError, Trajectory,
                     check_acceleration, check_not_future, platform_setpoints, pose_input,
                     rate_input)
from .node_config import NodeConfig
from .synchroniser import (JOIN_WINDOW, RESTART_CONFIRMATIONS, Rejected, Setpoint,
                           StampSynchroniser)

#: Log level below WARN (the diagnostics levels have no INFO).
INFO = OK

#: ``publish(setpoint, length, rate, force, joints, joint_rates)``: the answer.
Publish = Callable[[Setpoint, list, list, list, list, list], None]
#: ``emit(level, message)``: one log line (already throttled).
Emit = Callable[[int, str], None]


def new_estimator(config: NodeConfig) -> DerivativeEstimator:
    """The node's estimator: ``estimator.*``, warming up (never estimates from
    a rest it assumed).
    """
    return DerivativeEstimator(config.estimator_method, config.estimator_max_gap,
                               warm_up=True)


class SetpointIntake:
    """Setpoint messages in, answers out (see the module's docstring).

    ``runtime``: the model and node parameters (the caller swaps it with
    :meth:`reconfigure`); ``publish``: called once per answered setpoint;
    ``emit``: writes a log line; ``latest_stamp()``: the latest stamp accepted
    now (ns), None for no check; ``alive()``: False once the node's context is
    shut down (an error then, e.g. a publish that fails, is the shutdown's, not
    an internal error: nothing is reported). Nothing raises out of the public
    methods.
    """

    def __init__(self, runtime: Runtime, publish: Publish, emit: Emit,
                 latest_stamp: Callable[[], int | None],
                 alive: Callable[[], bool] | None = None) -> None:
        config = runtime.config
        self.runtime = runtime
        self.stats = CycleStats()
        self.throttle = LogThrottle(config.diagnostics_log_throttle)
        self.sync: StampSynchroniser[PoseInput, RateInput] = StampSynchroniser(
            config.sync_wait, config.sync_max_pending, config.input_restart_jump,
            join_window=JOIN_WINDOW)    # quiet start next to a running planner (issue 15 #7)
        self.estimator = new_estimator(config)
        self.last_solution: Any = None      # of the last answered setpoint
        self.last_header: tuple[int, int] = (0, 0)   # its stamp (sec, nanosec)
        self._answered: int | None = None  # stamp of the last setpoint answered
        self._restarts = 0                 # planner restarts handled
        self._publish = publish
        self._emit = emit
        self._latest_stamp = latest_stamp
        self._alive = alive

    # -- messages ----------------------------------------------------------------
    def check_pose(self, values: Sequence[float]) -> PoseInput:
        return pose_input(*values, self.runtime.config.input_quaternion_tolerance)

    @staticmethod
    def check_twist(values: Sequence[float]) -> RateInput:
        return rate_input(*values, TWIST)

    def check_accel(self, values: Sequence[float]) -> RateInput:
        rates = rate_input(*values, ACCEL)
        config = self.runtime.config
        check_acceleration(rates.q, config.input_max_linear_acceleration,
                           config.input_max_angular_acceleration)
        return rates

    def stamped(self, kind: str, fields: tuple[int, int, Sequence[float]],
                check: Callable[[Sequence[float]], Any], now: float) -> None:
        """One pose, twist or accel message (``fields``: sec, nanosec, the
        numbers): checked (``check``: raises SetpointError), then handed to
        the synchroniser.
        """
        try:
            sec, nanosec, values = fields
            stamp_ns = sec * 1_000_000_000 + nanosec
            try:
                check_not_future(stamp_ns, self._latest_stamp())
            except SetpointError as exc:     # no state: not even discarded
                self.reject(exc.reason, f'{kind} rejected: {exc}')
                return
            try:
                item = check(values)
            except SetpointError as exc:
                self.sync.discard(stamp_ns, kind)
                self.reject(exc.reason, f'{kind} rejected: {exc}')
                return
            released, rejected = self.sync.add(kind, stamp_ns, item, now, (sec, nanosec))
            if released or rejected:
                self.dispatch(released, rejected)
        except Exception as exc:  # noqa: BLE001 - nothing escapes a callback
            self.internal_error(exc)

    def platform(self, fields: Trajectory, now: float) -> None:
        """Whole setpoints, one per point of a JointTrajectory over surge, heave,
        roll (stamp = header.stamp + time_from_start): checked point by point
        (:func:`.inputs.platform_setpoints`), ordered with the three-topic
        setpoints by the synchroniser (:meth:`.StampSynchroniser.add_complete`),
        then solved like them.
        """
        try:
            config = self.runtime.config
            try:
                points = platform_setpoints(fields, config.input_max_linear_acceleration,
                                            config.input_max_angular_acceleration,
                                            self._latest_stamp())
            except SetpointError as exc:
                self.reject(exc.reason, f'{PLATFORM} rejected: {exc}')
                return
            add_complete = self.sync.add_complete
            for point in points:
                if isinstance(point, SetpointError):
                    self.reject(point.reason, f'{PLATFORM} rejected: {point}')
                    continue
                released, rejected = add_complete(point.stamp_ns, point.pose, point.twist,
                                                  point.accel, now, point.header)
                self.dispatch(released, rejected)
        except Exception as exc:  # noqa: BLE001
            self.internal_error(exc)

    def poll(self, now: float) -> None:
        """Release the setpoints whose bounded wait expired (call periodically)."""
        try:
            if self.sync.pending:
                self.dispatch(*self.sync.poll(now))
        except Exception as exc:  # noqa: BLE001
            self.internal_error(exc)

    def dispatch(self, released: list[Setpoint], rejected: list[Rejected]) -> None:
        if self.sync.restarts != self._restarts:
            self._planner_restarted()
        for item in rejected:
            self.reject(item.reason, item.message)
        for setpoint in released:
            try:
                self.process(setpoint)
            except Exception as exc:  # noqa: BLE001 - one failure must not skip the others
                self.internal_error(exc)

    def _planner_restarted(self) -> None:
        """The synchroniser saw a planner restart (stamps far back, sustained):
        the estimator history goes too; logged at every restart, counted.
        """
        self._restarts = self.sync.restarts
        self.stats.planner_restarts = self._restarts
        self.estimator.reset()
        self._answered = None
        self._emit(WARN, f'planner restart: {RESTART_CONFIRMATIONS} setpoints in a row stamped '
                         f'more than input.restart_jump = '
                         f'{self.runtime.config.input_restart_jump:g} s before the last '
                         'answered one; stamp and estimator history reset')

    # -- one cycle -----------------------------------------------------------------
    def process(self, sp: Setpoint) -> None:
        """Estimate what is missing, check, solve, publish: one setpoint
        (:mod:`.cycle`). The outputs go out as soon as the solution is known
        to be finite; the bookkeeping for the diagnostics comes after.
        """
        runtime = self.runtime            # read once: a parameter change applies next cycle
        stats = self.stats
        try:
            qd, qdd = rates_of(sp, runtime.config, self.estimator, stats)
            t0 = time.perf_counter()
            sol = solve_setpoint(runtime.model, sp.pose.q, qd, qdd)
            elapsed = time.perf_counter() - t0
            length, rate, force, joints, joint_rates = outputs_of(sol)
        except SetpointError as exc:
            self._unanswered(sp, exc.reason, f'setpoint rejected: {exc}')
            return
        self._answered = sp.stamp_ns
        self.estimator.commit()
        self._publish(sp, length, rate, force, joints, joint_rates)
        for level, key, message in assess(sol, sp, runtime, stats, elapsed, rate, force):
            self.log(level, key, message)
        self.last_solution, self.last_header = sol, sp.header

    def _unanswered(self, sp: Setpoint, reason: str, message: str) -> None:
        """A released setpoint the node does not answer. Warming up: its pose
        is history the next estimates need. Else it leaves no trace.
        """
        if reason == WARMING_UP:
            self.estimator.commit()
        else:
            self.sync.withdraw(sp, self._answered)
        self.reject(reason, message)

    # -- parameters ----------------------------------------------------------------
    def reconfigure(self, runtime: Runtime) -> None:
        """Swap in new parameters (already validated): from the next cycle."""
        old, new = self.runtime.config, runtime.config
        self.runtime = runtime
        if (new.estimator_method, new.estimator_max_gap) != (old.estimator_method,
                                                             old.estimator_max_gap):
            self.estimator = new_estimator(new)
        self.sync.wait = new.sync_wait
        self.sync.max_pending = new.sync_max_pending
        self.sync.restart_jump = new.input_restart_jump
        self.throttle.period = new.diagnostics_log_throttle

    def reset(self) -> int:
        """Forget the pending setpoints, the stamp order and the estimator's
        history (deactivate, cleanup: what was pending is never answered
        later). Returns how many pending setpoints were dropped.
        """
        dropped = self.sync.pending
        self.sync.reset()
        self.estimator.reset()
        self._answered = None
        return dropped

    # -- rejection and logging -------------------------------------------------
    def reject(self, reason: str, message: str) -> None:
        """Count a rejection under ``reason`` and log it (throttled)."""
        self.stats.reject(reason, message)
        level = (ERROR if reason in (UNREACHABLE, SOLVER_ERROR)
                 else INFO if reason in QUIET_REASONS else WARN)
        self.log(level, reason, message)

    def internal_error(self, exc: BaseException) -> None:
        try:
            if self._alive is not None and not self._alive():
                return      # shutting down: a publish after shutdown is not an error
            self.reject(SOLVER_ERROR, f'internal error: {type(exc).__name__}: {exc}')
        except Exception:  # noqa: BLE001 - even reporting failed: stay up
            pass

    def log(self, level: int, key: str, message: str | Callable[[], str]) -> None:
        """Log ``message`` (or what the callable returns: built only when the
        line is not throttled) at most once per ``diagnostics.log_throttle``
        per ``key``.
        """
        skipped = self.throttle(key, time.monotonic())
        if skipped is None:
            return
        if not isinstance(message, str):
            message = message()
        if skipped:
            message += f' ({skipped} more since the last such message)'
        self._emit(level, message)
