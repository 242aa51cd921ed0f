"""Statistics and log helpers, without rclpy: an answer's limits
(:func:`limit_report`), the /diagnostics counters and statistics
(:class:`CycleStats`), the log throttle and rclpy's severities
(:class:`LogThrottle`, :func:`log_at`).
"""
from __future__ import annotations

import math
from typing import Any, NamedTuple, Sequence

from ..core.machine import LimitUsage
from .messages import (ACCEL, ERROR, ERROR_REASONS, LEVEL_NAMES, OK, PITCH, PLATFORM, POSE,
                       QUIET_REASONS, REJECTION_REASONS, SWAY, TWIST, WARN, YAW)

DIAGNOSTIC_TASK = 'inverse dynamics'


def diagnostic_name(node_fqn: str, task: str = DIAGNOSTIC_TASK) -> str:
    """The node's status name in /diagnostics."""
    return f'{node_fqn}: {task}'


class LimitReport(NamedTuple):
    """One answer's level (OK, WARN, ERROR) and the names of the limits it
    exceeds and of those it is near.
    """

    level: int
    exceeded: tuple[str, ...]
    near: tuple[str, ...]


def limit_report(usage: LimitUsage, warn_fraction: float) -> LimitReport:
    """Beyond a limit (a usage above 1: the status ``limit``): ERROR, within
    ``warn_fraction`` of one: WARN (published anyway); each limit by its name
    in the machine's :class:`LimitUsage` (``force C``, ``u_joint 1``).
    """
    exceeded: list[str] = []
    near: list[str] = []
    for name, used in zip(usage.names, usage.usage.tolist()):
        if used > 1.0:
            exceeded.append(name)
        elif used >= warn_fraction:
            near.append(name)
    level = ERROR if exceeded else WARN if near else OK
    return LimitReport(level, tuple(exceeded), tuple(near))


class CycleStats:
    """/diagnostics: counters from start-up, statistics per period."""

    def __init__(self, ignorable: Sequence[str] = (SWAY, YAW, PITCH),
                 kinematic: bool = True) -> None:
        """``ignorable``: the components a machine cannot follow; ``kinematic``:
        its solutions have a kinematic condition (reported with the exact cond(Q)).
        """
        self.received = {POSE: 0, TWIST: 0, ACCEL: 0, PLATFORM: 0}   # messages
        self.rejected = {reason: 0 for reason in REJECTION_REASONS}
        self.ignored = {c: 0 for c in ignorable}
        self.kinematic = kinematic
        self.answered = self.estimated_twist = self.estimated_accel = 0
        self.limit_exceeded = self.near_limit = self.near_singular = 0
        self.parameter_changes = self.parameter_rejections = self.planner_restarts = 0
        self.stamp_check = self.last_message = ''
        self.last_cond = self.last_jacobian_cond = math.nan
        self._period_reset(None)

    def _period_reset(self, now: float | None) -> None:
        self._times: list[float] = []
        self._cond_max = 0.0
        self._jacobian_cond_max = 0.0
        self._level = OK
        self._messages: list[str] = []
        self._answered_at_start = self.answered
        self._period_start = now

    def note(self, level: int, message: str) -> None:
        if level > self._level:
            self._level = level
        if level > OK and message not in self._messages and len(self._messages) < 5:
            self._messages.append(message)

    def reject(self, reason: str, message: str) -> None:
        self.rejected[reason] += 1
        self.last_message = message
        if reason in QUIET_REASONS:
            return
        self.note(ERROR if reason in ERROR_REASONS else WARN, f'rejected ({reason})')

    def solved(self, seconds: float, cond: float, jacobian_cond: float) -> None:
        self.answered += 1
        self._times.append(seconds)
        self.last_cond = cond
        self.last_jacobian_cond = jacobian_cond
        if cond > self._cond_max:
            self._cond_max = cond
        if jacobian_cond > self._jacobian_cond_max:
            self._jacobian_cond_max = jacobian_cond

    def report(self, now: float, exact_cond: float = math.nan
               ) -> tuple[int, str, list[tuple[str, str]]]:
        """(level, message, [(key, value)]) of this period; starts the next."""
        times = sorted(self._times)
        n = len(times)
        period = (now - self._period_start) if self._period_start is not None else math.nan
        rate = (self.answered - self._answered_at_start) / period if period and period > 0 else 0.0
        total_rejected = sum(self.rejected.values())
        if n:
            mean_us = 1e6 * sum(times) / n
            median_us = 1e6 * (times[(n - 1) // 2] + times[n // 2]) / 2.0
            p99_us = 1e6 * times[min(n - 1, int(math.ceil(0.99 * n)) - 1)]
            max_us = 1e6 * times[-1]
        else:
            mean_us = median_us = p99_us = max_us = math.nan
        cond_max = self._cond_max if n else math.nan
        jacobian_cond_max = self._jacobian_cond_max if n else math.nan
        level = self._level
        if self._messages:
            message = '; '.join(self._messages)
        elif self.answered == 0:
            message = 'waiting for setpoints'
        elif n == 0:
            message = 'idle (no setpoint this period)'
        else:
            message = 'OK'
        values = [
            ('status', LEVEL_NAMES[level]),
            ('rate (Hz)', f'{rate:.1f}'),
            ('setpoints answered', str(self.answered)),
            ('solve time mean (us)', number(mean_us, '.1f')),
            ('solve time median (us)', number(median_us, '.1f')),
            ('solve time p99 (us)', number(p99_us, '.1f')),
            ('solve time max (us)', number(max_us, '.1f')),
            ('solves this period', str(n)),
            *([('cond(Q) last', number(exact_cond, '.4g')),
               ('kinematic condition last', number(self.last_cond, '.4g')),
               ('kinematic condition max this period', number(cond_max, '.4g'))]
              if self.kinematic else []),
            ('Jacobian condition last', number(self.last_jacobian_cond, '.4g')),
            ('Jacobian condition max this period', number(jacobian_cond_max, '.4g')),
            ('rejected total', str(total_rejected)),
        ]
        values += [(f'rejected {reason}', str(count)) for reason, count in self.rejected.items()]
        values += [(f'ignored {c}', str(count)) for c, count in self.ignored.items()]
        values += [
            ('limit exceeded', str(self.limit_exceeded)),
            ('near limit', str(self.near_limit)),
            ('near singular', str(self.near_singular)),
            ('received pose', str(self.received[POSE])),
            ('received twist', str(self.received[TWIST])),
            ('received accel', str(self.received[ACCEL])),
            ('received platform_setpoint', str(self.received[PLATFORM])),
            ('estimated twist', str(self.estimated_twist)),
            ('estimated accel', str(self.estimated_accel)),
            ('parameter changes accepted', str(self.parameter_changes)),
            ('parameter changes rejected', str(self.parameter_rejections)),
            ('planner restarts', str(self.planner_restarts)),
            ('stamp check', self.stamp_check),
            ('last rejection', self.last_message),
        ]
        self._period_reset(now)
        return level, message, values


def number(value: float, fmt: str) -> str:
    """Never 'nan' in /diagnostics: a monitor parsing numbers would get NaN."""
    return format(value, fmt) if math.isfinite(value) else 'no samples'


class LogThrottle:
    """At most one log line per key per ``period`` s, counting the suppressed."""

    def __init__(self, period: float = 1.0) -> None:
        self.period = float(period)
        self._last: dict[str, float] = {}
        self._suppressed: dict[str, int] = {}

    def __call__(self, key: str, now: float) -> int | None:
        """None: do not log now. Else the number suppressed since the last line."""
        last = self._last.get(key)
        if last is not None and now - last < self.period:
            self._suppressed[key] = self._suppressed.get(key, 0) + 1
            return None
        self._last[key] = now
        return self._suppressed.pop(key, 0)


def log_at(logger: Any, level: int, text: str) -> None:
    """``text`` on rclpy's ``logger`` at ``level`` (OK: INFO, WARN, ERROR).

    rclpy fixes a severity per call site (a ValueError from the second call
    at another one): one call site per severity, here, for every logging
    whose severity varies.
    """
    if level >= ERROR:
        logger.error(text)
    elif level == WARN:
        logger.warning(text)
    else:
        logger.info(text)
