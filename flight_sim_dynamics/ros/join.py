"""The three-topic join, without rclpy: :class:`StampSynchroniser` joins pose,
twist and accel by stamp and releases the :class:`Setpoint` s in stamp order
(or :class:`Rejected` s); :class:`RestartRule` tells a restarted stream from
its stamps (the node's setpoints, the twin's commands). Stamps in integer ns.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, NamedTuple

from .messages import (ACCEL, DUPLICATE, JOINING, KINDS, LATE, NO_POSE, OVERFLOW, PLATFORM,
                       POSE, STAMP_BACKWARDS, STAMP_REPEATED, TWIST, fmt_stamp)

RESTART_CONFIRMATIONS = 3          # setpoints in a row far behind: a planner restart


@dataclass(slots=True)
class Setpoint:
    """The messages with one stamp (twist / accel None: estimated): three
    messages' :data:`Motion` s, or from PLATFORM the machine's q, qd, qdd.
    """

    stamp_ns: int
    pose: Any = None
    twist: Any = None
    accel: Any = None
    header: Any = None
    first_arrival: float = 0.0
    source: str = POSE        # the input that carried it: POSE (three topics) or PLATFORM


class Rejected(NamedTuple):
    reason: str
    kind: str
    stamp_ns: int
    message: str


class RestartRule:
    """A restarted stream told from its stamps, one rule for the node's
    setpoints and the twin's commands: :data:`RESTART_CONFIRMATIONS` stamps in
    a row, in increasing order, each more than ``jump_ns`` before the last
    accepted one. Fewer, or out of order, are stray old messages.
    """

    def __init__(self, jump_ns: int = 0) -> None:
        self.jump_ns = int(jump_ns)
        self._behind: list[int] = []       # the confirmations so far, in a row

    def confirms(self, stamp_ns: int, last_ns: int) -> bool:
        """Whether ``stamp_ns`` (not after ``last_ns``) completes a restart."""
        behind = self._behind
        if last_ns - stamp_ns <= self.jump_ns:
            behind.clear()
            return False
        if behind and stamp_ns <= behind[-1]:
            behind.clear()
        behind.append(stamp_ns)
        if len(behind) < RESTART_CONFIRMATIONS:
            return False
        behind.clear()
        return True

    def clear(self) -> None:
        """A stamp accepted in order: the confirmations start again."""
        self._behind.clear()


class StampSynchroniser:
    """Join pose, twist and accel by exact stamp (bounded wait); release in
    stamp order, once the pose and every active stream are there (a stream
    waited for ``wait`` s in vain is inactive until its next message); older
    incomplete ones first. Setpoints more than ``restart_jump`` s behind are a
    planner restart by :class:`RestartRule` (:meth:`_restarted`: on either
    input); at most ``max_pending`` stamps wait; for ``join_window`` s partial
    setpoints are ``joining``. Methods return (released, rejected); poll faster
    than ``wait``.
    """

    def __init__(self, wait: float = 0.05, max_pending: int = 64,
                 restart_jump: float = 0.0, join_window: float = 0.0) -> None:
        self.wait = float(wait)
        self.join_window = float(join_window)
        self.max_pending = int(max_pending)
        self.restart = RestartRule(round(float(restart_jump) * 1e9))
        self.restarts = 0
        self._heard: dict[str, float] = {}     # input (POSE, PLATFORM) -> its last message's time
        self._pending: dict[int, Setpoint] = {}
        self.last_released: int | None = None
        self._last_source: str | None = None     # the input of last_released
        self.active = {TWIST: True, ACCEL: True}
        self._newest: dict[str, int | None] = {TWIST: None, ACCEL: None}
        self._discarded: dict[int, set[str]] = {}   # rejected stamp -> kinds seen (bounded)
        self._join_until: float | None = None
        self._first_pose: int | None = None
        self._in_join = False
        self._stream_join_until: dict[str, float] = {}   # each twist/accel topic's own window

    @property
    def pending(self) -> int:
        return len(self._pending)

    def reset(self) -> None:
        """Forget pending setpoints and stamp history (streams stay as they are)."""
        self._pending.clear()
        self.last_released = None
        self._discarded.clear()
        self.restart.clear()
        self._newest = {TWIST: None, ACCEL: None}
        self._first_pose = None

    def withdraw(self, setpoint: Setpoint, answered: int | None) -> None:
        """Undo a released setpoint the caller could not answer."""
        self.discard(setpoint.stamp_ns, POSE, setpoint)
        last = self.last_released
        if last is not None and last == setpoint.stamp_ns:
            self.last_released = answered

    def discard(self, stamp_ns: int, kind: str, entry: Setpoint | None = None) -> None:
        """Drop the stamp of a rejected message; its other messages are ignored."""
        pending = self._pending.pop(stamp_ns, None)
        entry = pending if pending is not None else entry
        seen = self._discarded.setdefault(stamp_ns, set())
        seen.add(kind)
        if entry is not None:
            seen.update(k for k in KINDS if getattr(entry, k) is not None)
        while len(self._discarded) > 4 * max(self.max_pending, 1):
            del self._discarded[next(iter(self._discarded))]

    def add(self, kind: str, stamp_ns: int, data: Any, now: float, header: Any = None
            ) -> tuple[list[Setpoint], list[Rejected]]:
        """Add one message of ``kind`` (``pose``, ``twist`` or ``accel``)."""
        released: list[Setpoint] = []
        rejected: list[Rejected] = []
        self._heard[POSE] = now
        joining = self._joining(now)
        stream_joining = kind != POSE and self._stream_joining(kind, now)
        seen = self._discarded.get(stamp_ns)
        if seen is not None:
            if kind in seen:
                rejected.append(Rejected(DUPLICATE, kind, stamp_ns,
                                         f'second {kind} for the rejected stamp '
                                         f'{fmt_stamp(stamp_ns)} (ignored)'))
            seen.add(kind)
            return released, rejected
        last = self.last_released
        if last is not None and stamp_ns <= last:
            if kind != POSE:
                # an old message proves its stream alive; it is not its newest stamp
                if stream_joining and self._newest[kind] is None:
                    rejected.append(_joined(kind, stamp_ns, 'its topic matched after the pose '
                                                            'topic; its setpoint was answered'))
                else:
                    rejected.append(Rejected(LATE, kind, stamp_ns,
                                             f'{kind} stamped {fmt_stamp(stamp_ns)} arrived '
                                             'after its setpoint was answered (or after a '
                                             'newer one)'))
                self.active[kind] = True
                return released, rejected
            if not self._restarted(stamp_ns, last, POSE, now):
                rejected.append(_not_after_last(kind, stamp_ns, last))
                return released, rejected
        pending = self._pending
        first = self._first_pose
        if kind == POSE and first is None:
            self._first_pose = stamp_ns
            if joining:
                self._drop_before_first_pose(stamp_ns, rejected)
        elif joining and first is not None and stamp_ns < first and kind != POSE:
            rejected.append(_joined(kind, stamp_ns, 'stamped before the first pose'))
            return released, rejected
        entry = pending.get(stamp_ns)
        if entry is None:
            if len(pending) >= self.max_pending:
                self._evict_oldest(released, rejected, joining and first is None)
            entry = Setpoint(stamp_ns, first_arrival=now)
            pending[stamp_ns] = entry
        if getattr(entry, kind) is not None:
            rejected.append(Rejected(DUPLICATE, kind, stamp_ns,
                                     f'second {kind} for stamp {fmt_stamp(stamp_ns)} (ignored)'))
            return released, rejected
        setattr(entry, kind, data)
        if kind == POSE:
            entry.header = header
            self._streams_seen(entry)
        elif entry.pose is not None:
            self._streams_seen(entry)
        if len(pending) == 1:          # the usual case: only this stamp is pending
            if self._complete(entry):
                del pending[stamp_ns]
                self._release(entry, released, rejected)
            return released, rejected
        newest_complete = None
        complete = self._complete
        for stamp, other in pending.items():
            if (newest_complete is None or stamp > newest_complete) and complete(other):
                newest_complete = stamp
        if newest_complete is not None:
            self._release_through(newest_complete, released, rejected)
        return released, rejected

    def add_complete(self, stamp_ns: int, pose: Any, twist: Any, accel: Any, now: float,
                     header: Any = None, kind: str = PLATFORM
                     ) -> tuple[list[Setpoint], list[Rejected]]:
        """A whole setpoint in one message, under the stamp rules of :meth:`add`."""
        released: list[Setpoint] = []
        rejected: list[Rejected] = []
        self._heard[PLATFORM] = now
        last = self.last_released
        if (last is not None and stamp_ns <= last
                and not self._restarted(stamp_ns, last, kind, now)):
            rejected.append(_not_after_last(kind, stamp_ns, last))
            return released, rejected
        pending = self._pending
        if stamp_ns in pending or stamp_ns in self._discarded:
            rejected.append(Rejected(DUPLICATE, kind, stamp_ns,
                                     f'{kind} for stamp {fmt_stamp(stamp_ns)}, for which '
                                     'pose/twist/accel messages came too (ignored)'))
            return released, rejected
        self._joining(now)
        if pending:
            self._release_through(stamp_ns, released, rejected)
        self._release(Setpoint(stamp_ns, pose, twist, accel, header, now, kind), released,
                      rejected)
        return released, rejected

    def poll(self, now: float) -> tuple[list[Setpoint], list[Rejected]]:
        """Release or reject the setpoints that waited ``wait`` seconds."""
        released: list[Setpoint] = []
        rejected: list[Rejected] = []
        if not self._pending:
            return released, rejected
        expired = [s for s, e in self._pending.items() if now - e.first_arrival >= self.wait]
        if expired:
            self._joining(now)
            newest = max(expired)
            for stamp in sorted(s for s in self._pending if s <= newest):
                entry = self._pending[stamp]
                if entry.pose is not None:
                    for kind in (TWIST, ACCEL):
                        if getattr(entry, kind) is None:
                            self.active[kind] = False
            # newer setpoints that waited for the streams just found silent
            for stamp in self._pending:
                if stamp > newest and self._complete(self._pending[stamp]):
                    newest = stamp
            self._release_through(newest, released, rejected)
        return released, rejected

    def _joining(self, now: float) -> bool:
        if self._join_until is None:
            self._join_until = now + self.join_window
        self._in_join = now < self._join_until
        return self._in_join

    def _stream_joining(self, kind: str, now: float) -> bool:
        until = self._stream_join_until.setdefault(kind, now + self.join_window)
        return now < until

    def _restarted(self, stamp_ns: int, last: int, source: str, now: float) -> bool:
        """This setpoint (not after ``last``), arrived at ``now`` on ``source``,
        confirms a planner restart (:class:`RestartRule`). On another input
        than the one that carried ``last``, only once that one has been silent
        for ``restart_jump`` s: an input lagging behind a live one is refused,
        so outputs stay in stamp order.
        """
        rule = self.restart
        jump = rule.jump_ns
        if not jump or (source != self._last_source and now - self._heard.get(
                self._last_source, -math.inf) < jump * 1e-9):
            rule.clear()
            return False
        if not rule.confirms(stamp_ns, last):
            return False
        self.reset()
        self.restarts += 1
        return True

    def _streams_seen(self, entry: Setpoint) -> None:
        stamp = entry.stamp_ns
        for kind in (TWIST, ACCEL):
            if getattr(entry, kind) is not None:
                self.active[kind] = True
                newest = self._newest[kind]
                if newest is None or stamp > newest:
                    self._newest[kind] = stamp

    def _expected(self, kind: str, stamp_ns: int) -> bool:
        newest = self._newest[kind]
        return self.active[kind] and (newest is None or newest < stamp_ns)

    def _complete(self, entry: Setpoint) -> bool:
        if entry.pose is None:
            return False
        if entry.twist is None and self._expected(TWIST, entry.stamp_ns):
            return False
        return entry.accel is not None or not self._expected(ACCEL, entry.stamp_ns)

    def _release_through(self, stamp_ns: int, released: list, rejected: list) -> None:
        for stamp in sorted(s for s in self._pending if s <= stamp_ns):
            entry = self._pending.pop(stamp)
            self._release(entry, released, rejected)

    def _release(self, entry: Setpoint, released: list, rejected: list) -> None:
        if entry.pose is None:
            kinds = '+'.join(k for k in (TWIST, ACCEL) if getattr(entry, k) is not None)
            if self._in_join and self._first_pose is None:
                rejected.append(_joined(kinds, entry.stamp_ns, 'no pose yet (its topic has '
                                                               'not matched)'))
                return
            rejected.append(Rejected(NO_POSE, kinds, entry.stamp_ns,
                                     f'{kinds} stamped {fmt_stamp(entry.stamp_ns)} '
                                     'has no pose with the same stamp'))
            return
        self.last_released, self._last_source = entry.stamp_ns, entry.source
        self.restart.clear()
        released.append(entry)

    def _drop_before_first_pose(self, first: int, rejected: list) -> None:
        for stamp in sorted(s for s in self._pending if s < first):
            entry = self._pending.pop(stamp)
            rejected.append(_joined('+'.join(k for k in (TWIST, ACCEL)
                                             if getattr(entry, k) is not None),
                                    stamp, 'stamped before the first pose'))

    def _evict_oldest(self, released: list, rejected: list, joining: bool = False) -> None:
        oldest = min(self._pending)
        entry = self._pending.pop(oldest)
        if entry.pose is None and joining:
            rejected.append(_joined('twist/accel', oldest, 'no pose yet (its topic has not '
                                                           'matched)'))
        elif entry.pose is None:
            rejected.append(Rejected(OVERFLOW, 'twist/accel', oldest,
                                     f'more than {self.max_pending} incomplete stamps pending; '
                                     f'dropped stamp {fmt_stamp(oldest)}'))
        else:
            self._release_through(oldest, released, rejected)
            self._release(entry, released, rejected)


def _joined(kind: str, stamp_ns: int, why: str) -> Rejected:
    return Rejected(JOINING, kind, stamp_ns,
                    f'{kind} stamped {fmt_stamp(stamp_ns)} dropped while joining the running '
                    f'stream ({why})')


def _not_after_last(kind: str, stamp_ns: int, last: int) -> Rejected:
    repeated = stamp_ns == last
    return Rejected(STAMP_REPEATED if repeated else STAMP_BACKWARDS, kind, stamp_ns,
                    f'{kind} stamp {fmt_stamp(stamp_ns)} '
                    f'{"repeats" if repeated else "precedes"} the last answered stamp '
                    f'{fmt_stamp(last)}')
