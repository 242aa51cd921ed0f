"""Exact-stamp synchroniser of the node's setpoints, without ROS.

:class:`StampSynchroniser` joins pose, twist and acceleration messages that
carry the same header stamp (exact match, bounded wait), and orders the
one-message setpoints among them (:meth:`StampSynchroniser.add_complete`).
Stamps are integer nanoseconds; the caller passes the time (monotonic s).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Generic, TypeVar

from .inputs import (ACCEL, DUPLICATE, JOINING, KINDS, LATE, NO_POSE, OVERFLOW, PLATFORM,
                     POSE, STAMP_BACKWARDS, STAMP_REPEATED, TWIST, fmt_stamp)

#: Setpoints in a row far behind the last released one that make a planner restart.
RESTART_CONFIRMATIONS = 3
#: The node's ``join_window``: seconds after the first message during which the partial
#: setpoints of a stream joined mid-way are ``joining`` (quiet), not late/overflow/no_pose.
JOIN_WINDOW = 1.0

P = TypeVar('P')
R = TypeVar('R')



@dataclass(slots=True)
class Setpoint(Generic[P, R]):
    """One setpoint: the pose, twist and acceleration carrying ``stamp_ns``.
    ``twist``/``accel`` are None when their stream did not deliver them in
    time (they are then estimated). ``header`` is whatever the caller passed
    with the pose (the node keeps the ROS stamp message there).
    """

    stamp_ns: int
    pose: P | None = None
    twist: R | None = None
    accel: R | None = None
    header: Any = None
    first_arrival: float = 0.0


@dataclass(frozen=True, slots=True)
class Rejected:
    """A message the synchroniser dropped: ``reason`` in REJECTION_REASONS."""

    reason: str
    kind: str
    stamp_ns: int
    message: str


class StampSynchroniser(Generic[P, R]):
    """Join pose, twist and acceleration messages with the same header stamp.

    * A setpoint is *complete* when its pose and the message of every
      *expected* optional stream (twist, accel) are there; it is then released
      at once, whatever order the three arrived in.
    * An optional stream is expected for a stamp if it is active and has not
      yet delivered a newer stamp (each topic is in order, so once it has,
      its message for this stamp is lost or was never sent).
    * An optional stream is active until a setpoint waited ``wait`` seconds for
      it in vain; it becomes active again as soon as it delivers a message.
      So a pose-only or pose+twist stream costs one bounded wait at start-up
      and none afterwards, and a full stream is never answered without its
      twist/accel unless one is lost or more than ``wait`` late.
    * Setpoints are released in stamp order: when a setpoint is complete,
      older incomplete ones are released first (with what they have; those
      without a pose are rejected as ``no_pose``).
    * Stamps must increase: a pose whose stamp equals or precedes the last
      released one is rejected (``stamp_repeated`` / ``stamp_backwards``), a
      twist/accel for a released stamp is ``late``. A stamp the caller
      rejected (:meth:`discard`) drops the other messages with that stamp
      silently.
    * A planner restart (its clock rewound: sim time, time since start) is
      told from a stray old message by persistence: when
      :data:`RESTART_CONFIRMATIONS` setpoints in a row, in increasing stamp
      order, are all more than ``restart_jump`` seconds behind the last
      released stamp, the stamp history is reset (:meth:`reset`), the last of
      them is taken as the first setpoint of the new stream and
      :attr:`restarts` counts it (the ones before it are
      ``stamp_backwards``). ``restart_jump`` 0: never.
    * A message that is rejected leaves no trace: a twist or accel counts for
      its stream (active, newest stamp) only once the pose with its stamp is
      there, so one without a pose (stamped far ahead, say) neither delays
      nor drops later setpoints; the caller withdraws a released setpoint it
      could not answer with :meth:`withdraw`.
    * At most ``max_pending`` stamps wait at once (the oldest is released or
      rejected as ``overflow``).
    * Joining a running stream (issue 15 #7): the three subscriptions match
      the planner's publishers at different moments, so the first stamps
      lack the messages published before their topic matched. For
      ``join_window`` s after the first message (the node's:
      :data:`JOIN_WINDOW`; 0, the default: never), such partial setpoints
      are ``joining`` (a quiet reason), not faults: a twist or accel whose
      stream has not yet counted (no setpoint has had one) arriving for a
      setpoint already released (not ``late``; the window is its own topic's,
      from that topic's first message: on a loaded host a topic can match
      more than a window after the others), a twist or accel stamped
      before the first pose (never completed: the pose topic is in order;
      not ``no_pose``) and, before any pose, a pose-less stamp pushed out
      (not ``overflow``).
    * A setpoint that arrives whole in one message (:meth:`add_complete`)
      follows the same stamp rules against the same last released stamp, and
      releases the older pending setpoints first, so the two inputs can be
      mixed without answering out of order.

    :meth:`add`, :meth:`add_complete` and :meth:`poll` return ``(released,
    rejected)`` lists; the
    caller passes the time ``now`` (monotonic seconds), so the class has no
    clock and no thread of its own: call :meth:`poll` periodically (faster
    than ``wait``).
    """

    def __init__(self, wait: float = 0.05, max_pending: int = 64,
                 restart_jump: float = 0.0, join_window: float = 0.0) -> None:
        self.wait = float(wait)
        self.join_window = float(join_window)
        self.max_pending = int(max_pending)
        self.restart_jump = restart_jump
        self.restarts = 0                  # planner restarts detected
        self._behind: list[int] = []       # stamps of the setpoints in a row far behind
        self._pending: dict[int, Setpoint[P, R]] = {}
        self._last_released: int | None = None
        self.active = {TWIST: True, ACCEL: True}
        self._newest: dict[str, int | None] = {TWIST: None, ACCEL: None}
        # stamps the caller rejected -> kinds already seen (insertion-ordered, bounded)
        self._discarded: dict[int, set[str]] = {}
        self._join_until: float | None = None   # end of the joining window (monotonic s)
        self._first_pose: int | None = None     # stamp of the first pose since start / reset
        self._in_join = False                   # the last call was in the joining window
        # end of each twist/accel topic's own joining window (its first message opens it)
        self._stream_join_until: dict[str, float] = {}

    # -- public --------------------------------------------------------------
    @property
    def last_released(self) -> int | None:
        """Stamp (ns) of the last released setpoint, None before the first."""
        return self._last_released

    @property
    def restart_jump(self) -> float:
        """Backward jump (s) beyond which persistent setpoints are a restart."""
        return self._restart_jump_ns * 1e-9

    @restart_jump.setter
    def restart_jump(self, seconds: float) -> None:
        self._restart_jump_ns = int(round(float(seconds) * 1e9))

    @property
    def pending(self) -> int:
        return len(self._pending)

    def reset(self) -> None:
        """Forget pending setpoints and stamp history (streams stay as they are)."""
        self._pending.clear()
        self._last_released = None
        self._discarded.clear()
        self._behind.clear()
        self._newest = {TWIST: None, ACCEL: None}
        self._first_pose = None

    def withdraw(self, setpoint: Setpoint[P, R], answered: int | None) -> None:
        """The caller could not answer the released ``setpoint``: it leaves no
        trace. Its stamp is discarded (its other messages, still to come, are
        dropped silently) and, if it was the last released, the stamp order
        goes back to ``answered`` (the last stamp the caller answered, None
        for none), so later setpoints are not refused because of it.
        """
        self.discard(setpoint.stamp_ns, POSE, setpoint)
        last = self._last_released
        if last is not None and last == setpoint.stamp_ns:
            self._last_released = answered

    def discard(self, stamp_ns: int, kind: str, entry: Setpoint[P, R] | None = None) -> None:
        """The caller rejected the ``kind`` message with this stamp: drop the
        pending setpoint and ignore the other kinds' messages with the stamp
        (a second message of a kind already seen is reported as a duplicate).
        ``entry``: the setpoint, if it was already released.
        """
        pending = self._pending.pop(stamp_ns, None)
        entry = pending if pending is not None else entry
        seen = self._discarded.setdefault(stamp_ns, set())
        seen.add(kind)
        if entry is not None:
            seen.update(k for k in KINDS if getattr(entry, k) is not None)
        while len(self._discarded) > 4 * max(self.max_pending, 1):
            del self._discarded[next(iter(self._discarded))]

    def add(self, kind: str, stamp_ns: int, data: Any, now: float, header: Any = None
            ) -> tuple[list[Setpoint[P, R]], list[Rejected]]:
        """Add one message of ``kind`` (``pose``, ``twist`` or ``accel``)."""
        released: list[Setpoint[P, R]] = []
        rejected: list[Rejected] = []
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
        last = self._last_released
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
            if not self._restarted(stamp_ns, last):
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
                     ) -> tuple[list[Setpoint[P, R]], list[Rejected]]:
        """Add a whole setpoint that came in one message (``kind``, for the
        messages): pose, twist and acceleration (None: to be estimated).

        It obeys the stamp rules of :meth:`add`: a stamp equal to the last
        released one is ``stamp_repeated``, an older one ``stamp_backwards``.
        A stamp that is pending (some of its three messages are here) or was
        rejected (:meth:`discard`) is a second setpoint for that stamp:
        ``duplicate``, and this one is dropped (the pending one stays). Else
        the pending setpoints with older stamps are released first, in stamp
        order and with what they have (those without a pose are rejected as
        ``no_pose``), exactly as when a newer three-message setpoint
        completes; then this one. The stream state (active, newest stamps) of
        the twist and accel topics is not touched.
        """
        released: list[Setpoint[P, R]] = []
        rejected: list[Rejected] = []
        last = self._last_released
        if last is not None and stamp_ns <= last and not self._restarted(stamp_ns, last):
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
        self._release(Setpoint(stamp_ns, pose, twist, accel, header, now), released, rejected)
        return released, rejected

    def poll(self, now: float) -> tuple[list[Setpoint[P, R]], list[Rejected]]:
        """Release or reject the setpoints that waited ``wait`` seconds."""
        released: list[Setpoint[P, R]] = []
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

    # -- internals -----------------------------------------------------------
    def _joining(self, now: float) -> bool:
        """Whether ``now`` is in the joining window (which the first message opens)."""
        if self._join_until is None:
            self._join_until = now + self.join_window
        self._in_join = now < self._join_until
        return self._in_join

    def _stream_joining(self, kind: str, now: float) -> bool:
        """Whether ``now`` is in the joining window of the ``kind`` topic."""
        until = self._stream_join_until.setdefault(kind, now + self.join_window)
        return now < until

    def _restarted(self, stamp_ns: int, last: int) -> bool:
        """A setpoint (pose or whole) stamped ``stamp_ns`` <= ``last``: True
        when it confirms a planner restart (the state is then reset and it is
        accepted), False when it is to be refused.
        """
        behind = self._behind
        if not self._restart_jump_ns or last - stamp_ns <= self._restart_jump_ns:
            behind.clear()
            return False
        if behind and stamp_ns <= behind[-1]:
            behind.clear()
        behind.append(stamp_ns)
        if len(behind) < RESTART_CONFIRMATIONS:
            return False
        self.reset()
        self.restarts += 1
        return True

    def _streams_seen(self, entry: Setpoint[P, R]) -> None:
        """The twist/accel of a setpoint that has its pose count for their
        streams: active, and their newest stamp.
        """
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

    def _complete(self, entry: Setpoint[P, R]) -> bool:
        if entry.pose is None:
            return False
        if entry.twist is None and self._expected(TWIST, entry.stamp_ns):
            return False
        return entry.accel is not None or not self._expected(ACCEL, entry.stamp_ns)

    def _release_through(self, stamp_ns: int, released: list, rejected: list) -> None:
        for stamp in sorted(s for s in self._pending if s <= stamp_ns):
            entry = self._pending.pop(stamp)
            self._release(entry, released, rejected)

    def _release(self, entry: Setpoint[P, R], released: list, rejected: list) -> None:
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
        self._last_released = entry.stamp_ns
        if self._behind:
            self._behind.clear()
        released.append(entry)

    def _drop_before_first_pose(self, first: int, rejected: list) -> None:
        """The pose-less stamps before the ``first`` pose: never completed."""
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
    """A message of a stream joined mid-way that completes no setpoint."""
    return Rejected(JOINING, kind, stamp_ns,
                    f'{kind} stamped {fmt_stamp(stamp_ns)} dropped while joining the running '
                    f'stream ({why})')


def _not_after_last(kind: str, stamp_ns: int, last: int) -> Rejected:
    """The rejection of a setpoint (its pose, or a whole one) whose stamp is
    not later than the last answered ``last``: ``stamp_repeated`` or
    ``stamp_backwards``.
    """
    repeated = stamp_ns == last
    return Rejected(STAMP_REPEATED if repeated else STAMP_BACKWARDS, kind, stamp_ns,
                    f'{kind} stamp {fmt_stamp(stamp_ns)} '
                    f'{"repeats" if repeated else "precedes"} the last answered stamp '
                    f'{fmt_stamp(last)}')

