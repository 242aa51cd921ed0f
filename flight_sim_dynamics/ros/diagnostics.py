"""Diagnostics of the node, without ROS: the levels, the actuator-limit
report of each solution, the counters and per-period statistics of the
``/diagnostics`` message, and the log throttle.
"""
from __future__ import annotations

import math
from typing import NamedTuple, Sequence

from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue

from ..core.model import Limits
from .inputs import (ACCEL, ERROR_REASONS, PLATFORM, POSE, QUIET_REASONS, REJECTION_REASONS,
                     TWIST, UNFOLLOWABLE_COMPONENTS)

#: The task in the node's status name: ``<fully qualified node name>: <task>``
#: (diagnostic_updater's convention), so that two instances (namespaces) are
#: two entries under an aggregator.
DIAGNOSTIC_TASK = 'inverse dynamics'


def diagnostic_name(node_fqn: str, task: str = DIAGNOSTIC_TASK) -> str:
    """The status name of the node ``node_fqn`` (doing ``task``) in /diagnostics."""
    return f'{node_fqn}: {task}'


class DiagnosticsOutput:
    """A node's /diagnostics message: one DiagnosticArray holding its one
    status (``name``, ``hardware_id``), reused every period.
    """

    def __init__(self, name: str, hardware_id: str = '') -> None:
        self.status = DiagnosticStatus(name=name, hardware_id=hardware_id)
        self.msg = DiagnosticArray(status=[self.status])

    def fill(self, level: int, message: str, values: Sequence[tuple[str, str]],
             stamp: Time) -> DiagnosticArray:
        """The message of this period: ``level``, ``message``, the key/values."""
        status = self.status
        status.level = bytes([level])
        status.message = message
        status.values = [KeyValue(key=k, value=v) for k, v in values]
        self.msg.header.stamp = stamp
        return self.msg


# Diagnostic levels (same numbers as diagnostic_msgs/DiagnosticStatus).
OK, WARN, ERROR = 0, 1, 2
LEVEL_NAMES = {OK: 'OK', WARN: 'WARN', ERROR: 'ERROR'}

_NOTHING: tuple[str, ...] = ()


# ----------------------------------------------------------------------------
# Limits
# ----------------------------------------------------------------------------
class LimitReport(NamedTuple):
    """Outcome of :func:`check_limits`: the level and what caused it.

    ``usage`` is the largest ratio value/limit over stroke, speed and force
    (1.0 = at a limit).
    """

    level: int
    exceeded: tuple[str, ...]
    near: tuple[str, ...]
    usage: float


_LIMIT_NAMES = tuple((f'stroke {leg}', f'speed {leg}', f'force {leg}') for leg in 'ABC')


def check_limits(stroke: Sequence[float], rate: Sequence[float], force: Sequence[float],
                 limits: Limits, warn_fraction: float) -> LimitReport:
    """Compare one solution with the actuator limits (``limits.*``, the model's:
    the solver's status says ``limit`` beyond them). Beyond a limit is ERROR,
    within ``warn_fraction`` of it WARN. The solution is still published: the
    numbers are what the commanded motion requires; the status says it is unsafe.

    Usage of a limit: |force| / max_force, |rate| / max_speed and, for the
    stroke, its distance from the middle of [stroke_min, stroke_max] over the
    half-range (1.0 at either end).
    """
    mid = 0.5 * (limits.stroke_max + limits.stroke_min)
    half = 0.5 * (limits.stroke_max - limits.stroke_min)
    max_speed, max_force = limits.max_speed, limits.max_force
    s0, s1, s2 = stroke
    r0, r1, r2 = rate
    f0, f1, f2 = force
    # the usual case first: plain arithmetic, no per-leg containers
    usage = max(abs(s0 - mid) / half, abs(s1 - mid) / half, abs(s2 - mid) / half,
                abs(r0) / max_speed, abs(r1) / max_speed, abs(r2) / max_speed,
                abs(f0) / max_force, abs(f1) / max_force, abs(f2) / max_force)
    if usage < warn_fraction:       # the usual case: no strings
        return LimitReport(OK, _NOTHING, _NOTHING, usage)
    usages = [(abs(stroke[i] - mid) / half, abs(rate[i]) / max_speed,
               abs(force[i]) / max_force) for i in range(3)]
    exceeded: list[str] = []
    near: list[str] = []
    for names, values in zip(_LIMIT_NAMES, usages):
        for name, u in zip(names, values):
            if u > 1.0:
                exceeded.append(name)
            elif u >= warn_fraction:
                near.append(name)
    level = ERROR if exceeded else WARN if near else OK
    return LimitReport(level, tuple(exceeded), tuple(near), usage)


# ----------------------------------------------------------------------------
# Diagnostics bookkeeping
# ----------------------------------------------------------------------------
class CycleStats:
    """Counters and per-period statistics for the diagnostics message.

    Totals (received, answered, rejections by reason, ignored components,
    limit events) accumulate from start-up; solve times, condition extremes
    and the worst level are per reporting period and reset by :meth:`report`.
    Per cycle only the solver's cheap condition figures are recorded; the exact
    cond(Q) of the last solution (an SVD) is computed once per report.
    """

    def __init__(self) -> None:
        self.received = {POSE: 0, TWIST: 0, ACCEL: 0, PLATFORM: 0}   # messages
        self.answered = 0
        self.estimated_twist = 0
        self.estimated_accel = 0
        self.rejected = {reason: 0 for reason in REJECTION_REASONS}
        self.ignored = {c: 0 for c in UNFOLLOWABLE_COMPONENTS}
        self.limit_exceeded = 0
        self.near_limit = 0
        self.near_singular = 0
        self.parameter_changes = 0
        self.parameter_rejections = 0
        self.wire_fallbacks = 0          # samples (de)serialized by rclpy, not wire.py's CDR path
        self.planner_restarts = 0        # stamp history reset (StampSynchroniser.restarts)
        self.stamp_check = ''            # how stamps are checked against the clock
        self.last_message = ''
        self.last_cond = math.nan
        self.last_jacobian_cond = math.nan
        self.last_force: tuple[float, float, float] | None = None
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
        """Raise this period's level to ``level`` and remember why."""
        if level > self._level:
            self._level = level
        if level > OK and message not in self._messages and len(self._messages) < 5:
            self._messages.append(message)

    def reject(self, reason: str, message: str) -> None:
        self.rejected[reason] += 1
        self.last_message = message
        if reason in QUIET_REASONS:         # expected: counted and shown, the level stays
            return
        self.note(ERROR if reason in ERROR_REASONS else WARN, f'rejected ({reason})')

    def solved(self, seconds: float, cond: float, jacobian_cond: float,
               force: tuple[float, float, float]) -> None:
        """One answered setpoint: solve time, the solver's kinematic condition
        (of Q) and actuator-Jacobian condition, the forces.
        """
        self.answered += 1
        self._times.append(seconds)
        self.last_cond = cond
        self.last_jacobian_cond = jacobian_cond
        self.last_force = force
        if cond > self._cond_max:
            self._cond_max = cond
        if jacobian_cond > self._jacobian_cond_max:
            self._jacobian_cond_max = jacobian_cond

    def report(self, now: float, exact_cond: float = math.nan
               ) -> tuple[int, str, list[tuple[str, str]]]:
        """(level, message, [(key, value), ...]) for this period; starts a new one.
        ``exact_cond``: cond(Q) of the last solution (SVD), if known.
        """
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
            ('cond(Q) last', number(exact_cond, '.4g')),
            ('kinematic condition last', number(self.last_cond, '.4g')),
            ('kinematic condition max this period', number(cond_max, '.4g')),
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
            ('wire fallbacks', str(self.wire_fallbacks)),
            ('planner restarts', str(self.planner_restarts)),
            ('stamp check', self.stamp_check),
            ('last rejection', self.last_message),
        ]
        self._period_reset(now)
        return level, message, values


#: What a statistic without samples reads in /diagnostics (never 'nan': a
#: monitor parsing numbers would get NaN).
NO_SAMPLES = 'no samples'


def number(value: float, fmt: str) -> str:
    """``value`` formatted with ``fmt``, or :data:`NO_SAMPLES` when it is not
    finite (a statistic of an empty period).
    """
    return format(value, fmt) if math.isfinite(value) else NO_SAMPLES


class LogThrottle:
    """At most one log line per ``key`` per ``period`` seconds; counts the
    suppressed ones so the next line can say how many were skipped.
    """

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
