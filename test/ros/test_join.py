"""Unit tests of the three-topic join and the restart rule
(flight_sim_dynamics.ros.join)."""
from __future__ import annotations


import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from flight_sim_dynamics.ros.join import RestartRule, StampSynchroniser
from flight_sim_dynamics.ros.messages import (ACCEL, DUPLICATE, JOINING, LATE, NO_POSE, OVERFLOW,
                                              POSE, STAMP_BACKWARDS, STAMP_REPEATED, TWIST,
                                              SetpointError)


# ----------------------------------------------------------------------------
# Synchroniser
# ----------------------------------------------------------------------------
def stamps(released):
    return [s.stamp_ns for s in released]


@pytest.mark.parametrize('order', ['pta', 'pat', 'tpa', 'tap', 'apt', 'atp'])
def test_sync_any_order_releases_once_complete(order):
    sync = StampSynchroniser(wait=0.05)
    kinds = {'p': POSE, 't': TWIST, 'a': ACCEL}
    out = []
    for i, key in enumerate(order):
        released, rejected = sync.add(kinds[key], 100, key, now=0.0)
        assert not rejected
        out += released
        if i < 2:
            assert not released, 'released before complete'
    assert stamps(out) == [100]
    assert (out[0].pose, out[0].twist, out[0].accel) == ('p', 't', 'a')


def test_sync_pose_only_stream_waits_once():
    sync = StampSynchroniser(wait=0.05)
    assert sync.add(POSE, 1, 'p1', now=0.0) == ([], [])
    released, _ = sync.poll(now=0.04)
    assert released == []
    released, _ = sync.poll(now=0.051)
    assert stamps(released) == [1] and released[0].twist is None
    assert sync.active == {TWIST: False, ACCEL: False}
    released, _ = sync.add(POSE, 2, 'p2', now=0.06)           # no more waiting
    assert stamps(released) == [2]


def test_sync_pose_twist_stream():
    sync = StampSynchroniser(wait=0.05)
    sync.add(POSE, 1, 'p', now=0.0)
    assert sync.add(TWIST, 1, 't', now=0.0) == ([], [])       # still waits for accel
    released, _ = sync.poll(now=0.06)
    assert stamps(released) == [1] and released[0].twist == 't' and released[0].accel is None
    sync.add(POSE, 2, 'p', now=0.07)
    released, _ = sync.add(TWIST, 2, 't', now=0.07)
    assert stamps(released) == [2]


def test_sync_lost_message_released_when_stream_moves_on():
    sync = StampSynchroniser(wait=10.0)
    sync.add(POSE, 1, 'p', now=0.0)
    sync.add(TWIST, 1, 't', now=0.0)                          # accel 1 lost
    sync.add(POSE, 2, 'p', now=0.0)
    sync.add(TWIST, 2, 't', now=0.0)
    released, rejected = sync.add(ACCEL, 2, 'a', now=0.0)
    assert stamps(released) == [1, 2] and released[0].accel is None and not rejected


def test_sync_stamp_rules():
    sync = StampSynchroniser(wait=0.05)
    sync.active = {TWIST: False, ACCEL: False}
    assert stamps(sync.add(POSE, 10, 'p', now=0.0)[0]) == [10]
    _, rejected = sync.add(POSE, 10, 'p', now=0.0)
    assert [r.reason for r in rejected] == [STAMP_REPEATED]
    _, rejected = sync.add(POSE, 5, 'p', now=0.0)
    assert [r.reason for r in rejected] == [STAMP_BACKWARDS]
    _, rejected = sync.add(TWIST, 10, 't', now=0.0)
    assert [r.reason for r in rejected] == [LATE]


def reasons(result):
    return [r.reason for r in result[1]]


def test_sync_joining_a_stream_whose_pose_topic_matched_last():
    """Issue 15 #7: twist and accel stamps from before the pose topic matched
    are ``joining`` (quiet), pushed out, expired or dropped at the first pose;
    the first setpoint with all three is answered; out of the window, the
    same is overflow / no_pose as before."""
    sync = StampSynchroniser(wait=0.05, max_pending=4, join_window=1.0)
    for k in range(6):                                   # 6 stamps > max_pending 4
        assert reasons(sync.add(TWIST, k, 't', now=0.0)) in ([], [JOINING])
        assert reasons(sync.add(ACCEL, k, 'a', now=0.0)) == []
    assert reasons(sync.poll(now=0.03)) == []            # not yet expired
    released, rejected = sync.add(POSE, 6, 'p', now=0.04)   # the pose topic matched
    assert released == [] and set(r.reason for r in rejected) <= {JOINING}
    assert sync.pending == 1                             # only 6: the older ones are dropped
    assert reasons(sync.add(TWIST, 5, 't', now=0.04)) == [JOINING]     # stamped before it
    sync.add(TWIST, 6, 't', now=0.04)
    released, rejected = sync.add(ACCEL, 6, 'a', now=0.04)
    assert stamps(released) == [6] and rejected == []
    # after the window: the rules of a running stream
    sync = StampSynchroniser(wait=0.05, max_pending=4, join_window=1.0)
    sync.add(POSE, 0, 'p', now=0.0)
    sync.add(TWIST, 0, 't', now=0.0)
    sync.add(ACCEL, 0, 'a', now=0.0)
    for k in range(1, 6):
        sync.add(TWIST, k, 't', now=2.0)
    assert OVERFLOW in reasons(sync.add(TWIST, 6, 't', now=2.0)) + reasons(
        sync.add(TWIST, 7, 't', now=2.0))


def test_sync_joining_a_stream_whose_twist_topic_matched_last():
    """The pose topic matched first: its setpoints go out without the twist
    (found silent after ``wait``); the twist's first messages, for setpoints
    already answered, are ``joining``, not ``late``, for a window from the
    twist topic's own first message (it may match more than a window after
    the pose topic: seen in CI); once the twist stream counts (or after its
    window), a late twist is late."""
    for first, now, expected in ((0.1, 0.1, JOINING), (1.5, 1.5, JOINING),
                                 (1.5, 2.4, JOINING), (1.5, 2.6, LATE)):
        sync = StampSynchroniser(wait=0.05, join_window=1.0)
        sync.active[ACCEL] = False
        sync.add(POSE, 0, 'p', now=0.0)
        released, _ = sync.poll(now=0.06)                    # twist found silent
        assert stamps(released) == [0]
        assert stamps(sync.add(POSE, 1, 'p', now=0.07)[0]) == [1]
        assert reasons(sync.add(TWIST, 0, 't', now=first)) == [JOINING]   # its first
        assert reasons(sync.add(TWIST, 1, 't', now=now)) == [expected]
    sync = StampSynchroniser(wait=0.05, join_window=1.0)
    sync.active[ACCEL] = False
    sync.add(POSE, 0, 'p', now=0.0)
    assert stamps(sync.add(TWIST, 0, 't', now=0.0)[0]) == [0]   # the twist stream counts
    sync.add(POSE, 1, 'p', now=0.01)
    sync.poll(now=0.07)
    assert reasons(sync.add(TWIST, 1, 't', now=0.08)) == [LATE]


def test_sync_orphans_and_duplicates():
    sync = StampSynchroniser(wait=0.05)
    sync.add(TWIST, 7, 't', now=0.0)
    _, rejected = sync.add(TWIST, 7, 't', now=0.0)
    assert [r.reason for r in rejected] == [DUPLICATE]
    released, rejected = sync.poll(now=0.1)
    assert released == [] and [r.reason for r in rejected] == [NO_POSE]
    # an orphan older than a complete setpoint is rejected when that one goes out
    sync.add(ACCEL, 8, 'a', now=0.2)
    sync.add(POSE, 9, 'p', now=0.2)
    sync.add(TWIST, 9, 't', now=0.2)
    released, rejected = sync.add(ACCEL, 9, 'a', now=0.2)
    assert stamps(released) == [9] and [r.reason for r in rejected] == [NO_POSE]


def test_sync_discard_drops_the_rest_of_a_rejected_setpoint():
    sync = StampSynchroniser(wait=0.05)
    sync.add(TWIST, 3, 't', now=0.0)
    sync.discard(3, POSE)                                      # e.g. a NaN pose
    assert sync.pending == 0
    assert sync.add(ACCEL, 3, 'a', now=0.0) == ([], [])       # dropped silently
    assert sync.poll(now=1.0) == ([], [])
    _, rejected = sync.add(POSE, 3, 'p', now=1.0)              # the pose again: reported
    assert [r.reason for r in rejected] == [DUPLICATE]
    _, rejected = sync.add(TWIST, 3, 't', now=1.0)
    assert [r.reason for r in rejected] == [DUPLICATE]


def test_sync_bounded():
    sync = StampSynchroniser(wait=1.0, max_pending=4)
    rejected = []
    for s in range(10):
        rejected += sync.add(TWIST, s, 't', now=0.0)[1]
    assert sync.pending == 4
    assert {r.reason for r in rejected} == {OVERFLOW} and len(rejected) == 6


def test_sync_add_complete_alone():
    """One-message setpoints (platform_setpoint) are released at once, with
    their header and None for what is to be estimated; stamps must increase."""
    sync = StampSynchroniser(wait=0.05)
    released, rejected = sync.add_complete(10, 'p', None, 'a', now=1.0, header=(0, 10))
    assert not rejected and stamps(released) == [10]
    sp = released[0]
    assert (sp.pose, sp.twist, sp.accel, sp.header, sp.first_arrival) == \
        ('p', None, 'a', (0, 10), 1.0)
    assert sync.last_released == 10 and sync.pending == 0
    _, rejected = sync.add_complete(10, 'p', None, None, now=1.0)
    assert [r.reason for r in rejected] == [STAMP_REPEATED]
    assert 'platform_setpoint stamp 0.000000010 repeats' in rejected[0].message
    _, rejected = sync.add_complete(5, 'p', None, None, now=1.0)
    assert [r.reason for r in rejected] == [STAMP_BACKWARDS]
    assert stamps(sync.add_complete(11, 'p', 't', 'a', now=1.0)[0]) == [11]
    # the twist and accel streams are not touched
    assert sync.active == {TWIST: True, ACCEL: True} and sync.poll(now=9.0) == ([], [])


def test_sync_add_complete_shares_the_stamp_order_with_the_three_topics():
    sync = StampSynchroniser(wait=0.05)
    sync.active = {TWIST: False, ACCEL: False}                 # a pose-only stream
    assert stamps(sync.add(POSE, 10, 'p', now=0.0)[0]) == [10]
    assert [r.reason for r in sync.add_complete(10, 'p', None, None, now=0.0)[1]] == \
        [STAMP_REPEATED]
    assert [r.reason for r in sync.add_complete(9, 'p', None, None, now=0.0)[1]] == \
        [STAMP_BACKWARDS]
    assert stamps(sync.add_complete(20, 'p', None, None, now=0.0)[0]) == [20]
    assert [r.reason for r in sync.add(POSE, 20, 'p', now=0.0)[1]] == [STAMP_REPEATED]
    assert [r.reason for r in sync.add(POSE, 15, 'p', now=0.0)[1]] == [STAMP_BACKWARDS]
    assert [r.reason for r in sync.add(TWIST, 20, 't', now=0.0)[1]] == [LATE]
    assert sync.add(POSE, 21, 'p', now=0.0) == ([], [])        # the twist stream is back
    assert stamps(sync.add(TWIST, 21, 't', now=0.0)[0]) == [21]


def test_sync_add_complete_releases_older_pending_setpoints_first():
    """Pending three-topic setpoints older than the one-message setpoint go out
    first, in stamp order, with what they have (no pose: no_pose); newer ones
    stay pending."""
    sync = StampSynchroniser(wait=10.0)
    sync.add(POSE, 2, 'p2', now=0.0)
    sync.add(TWIST, 2, 't2', now=0.0)                          # waits for its accel
    sync.add(POSE, 1, 'p1', now=0.0)                           # waits for twist, accel
    sync.add(TWIST, 3, 't3', now=0.0)                          # no pose (yet)
    sync.add(POSE, 9, 'p9', now=0.0)                           # newer: stays
    released, rejected = sync.add_complete(5, 'p5', 't5', 'a5', now=0.0)
    assert stamps(released) == [1, 2, 5]
    assert [(s.pose, s.twist, s.accel) for s in released] == [
        ('p1', None, None), ('p2', 't2', None), ('p5', 't5', 'a5')]
    assert [(r.reason, r.stamp_ns) for r in rejected] == [(NO_POSE, 3)]
    assert sync.pending == 1 and sync.last_released == 5
    assert [r.reason for r in sync.add(ACCEL, 2, 'a2', now=0.0)[1]] == [LATE]
    sync.add(TWIST, 9, 't9', now=0.0)
    assert stamps(sync.add(ACCEL, 9, 'a9', now=0.0)[0]) == [9]


def test_sync_add_complete_for_a_pending_or_rejected_stamp_is_a_duplicate():
    sync = StampSynchroniser(wait=10.0)
    sync.add(POSE, 4, 'p', now=0.0)
    released, rejected = sync.add_complete(4, 'p', 't', 'a', now=0.0)
    assert released == [] and [r.reason for r in rejected] == [DUPLICATE]
    assert 'platform_setpoint for stamp' in rejected[0].message
    sync.add(TWIST, 4, 't', now=0.0)
    released, _ = sync.add(ACCEL, 4, 'a', now=0.0)            # the pending one completes
    assert stamps(released) == [4] and released[0].pose == 'p'
    sync.discard(6, TWIST)                                     # e.g. a NaN twist
    released, rejected = sync.add_complete(6, 'p', None, None, now=0.0)
    assert released == [] and [r.reason for r in rejected] == [DUPLICATE]
    assert stamps(sync.add_complete(7, 'p', None, None, now=0.0)[0]) == [7]


@settings(max_examples=300, deadline=None)
@given(st.lists(st.tuples(st.integers(1, 12), st.sampled_from((POSE, TWIST, ACCEL))),
                max_size=12, unique=True),
       st.integers(1, 13))
def test_sync_add_complete_releases_like_three_messages(pending, stamp):
    """Whatever is pending (or already released), a one-message setpoint
    releases and rejects the older setpoints exactly as its pose, twist and
    accel sent as three messages would, and is released last itself."""
    one, three = StampSynchroniser(wait=10.0), StampSynchroniser(wait=10.0)
    for sync in (one, three):
        for s, kind in pending:
            sync.add(kind, s, f'{kind}{s}', now=0.0)
    last = one.last_released
    released, rejected = one.add_complete(stamp, 'P', 'T', 'A', now=0.0)
    if last is not None and stamp <= last:
        assert released == [] and [r.reason for r in rejected] == [
            STAMP_REPEATED if stamp == last else STAMP_BACKWARDS]
        return
    if stamp in {s for s, _ in pending}:
        assert released == [] and [r.reason for r in rejected] == [DUPLICATE]
        return
    released3, rejected3 = [], []
    for kind, data in ((POSE, 'P'), (TWIST, 'T'), (ACCEL, 'A')):
        r, j = three.add(kind, stamp, data, now=0.0)
        released3 += r
        rejected3 += j

    def older(items):
        return [(s.stamp_ns, s.pose, s.twist, s.accel) for s in items if s.stamp_ns < stamp]
    assert older(released) == older(released3)
    assert [s.stamp_ns for s in released if s.stamp_ns >= stamp] == [stamp]
    assert (released[-1].pose, released[-1].twist, released[-1].accel) == ('P', 'T', 'A')
    # (three messages may answer the stamp before its twist/accel: those are late)
    assert [(r.reason, r.stamp_ns) for r in rejected] == \
        [(r.reason, r.stamp_ns) for r in rejected3 if r.stamp_ns != stamp]
    assert one.last_released == three.last_released == stamp
    assert one.pending == three.pending


# ----------------------------------------------------------------------------
# Restarts
# ----------------------------------------------------------------------------
def test_sync_a_lagging_second_input_is_no_restart():
    """Three-topic setpoints 2 s behind the platform_setpoint points of the same
    planner: refused as backwards, never a restart (outputs stay in stamp
    order); a restart is told only from the input that carried the last
    answered stamp."""
    second = 1_000_000_000
    sync = StampSynchroniser(wait=10.0, restart_jump=0.5)
    out = []
    for k in range(10):     # the inputs interleave in bursts: one platform point, then 3
        t = 100 * second + k * 30_000_000
        released, _ = sync.add_complete(t, 'p', 't', 'a', now=0.0)
        out += released
        for j in range(3):
            for kind in (POSE, TWIST, ACCEL):
                released, _ = sync.add(kind, t - 2 * second + j * 10_000_000, kind, now=0.0)
                out += released
    assert sync.restarts == 0
    assert stamps(out) == sorted(stamps(out))
    # the same input rewound: a restart after the confirmations
    rewound = [stamps(sync.add_complete(50 * second + k, 'p', 't', 'a', now=0.0)[0])
               for k in range(3)]
    assert sync.restarts == 1 and rewound[-1] == [50 * second + 2]


def test_sync_a_restart_on_the_other_input_is_recognised():
    """100 platform_setpoint points at wall-clock stamps, then a restarted
    planner on pose/twist/accel stamped from 1 s after the epoch: once the
    platform input has been silent for ``restart_jump`` s, a restart, told as
    on the same input (the third setpoint on); while it is live, the other
    input lagging behind it is refused (test above)."""
    second = 1_000_000_000
    wall = 1_764_000_000 * second
    sync = StampSynchroniser(wait=10.0, restart_jump=1.0)
    out = []
    for k in range(100):
        out += sync.add_complete(wall + k * 10_000_000, 'p', 't', 'a', now=k * 0.01)[0]
    assert stamps(out) == [wall + k * 10_000_000 for k in range(100)]

    def restarted(start: float) -> list[int]:
        sent, got = [second + k * 10_000_000 for k in range(300)], []
        for k, stamp in enumerate(sent):
            for kind in (POSE, TWIST, ACCEL):
                got += stamps(sync.add(kind, stamp, kind, now=start + k * 0.01)[0])
        return sent, got
    # the restarted planner starts 0.5 s after the last platform point (0.99 s):
    # its setpoints of the first 0.5 s are refused; the silence is 1 s from the
    # 50th (at 1.995 s), which with the next two confirms the restart
    sent, got = restarted(1.495)
    assert sync.restarts == 1 and got == sent[52:]
    # restarted once more, later than restart_jump after the last point: 298 of 300
    sent, got = restarted(10.0)
    assert sync.restarts == 2 and got == sent[2:]


@pytest.mark.parametrize('jump_ns', [0, 5])
def test_restart_rule(jump_ns):
    """Three stamps in a row, increasing, each more than the jump before the
    last accepted one; a repeated or decreasing one starts the count again."""
    rule = RestartRule(jump_ns)
    last = 100
    assert [rule.confirms(s, last) for s in (10, 11, 12)] == [False, False, True]
    assert [rule.confirms(s, last) for s in (10, 11, 11, 12, 13)] == [False] * 4 + [True]
    assert [rule.confirms(s, last) for s in (10, 11, 100 - jump_ns, 12, 13, 14)] == \
        [False] * 5 + [True]
    rule.clear()
    assert [rule.confirms(s, last) for s in (10, 11)] == [False, False]
    rule.clear()                       # a stamp accepted in order: the count starts again
    assert [rule.confirms(s, last) for s in (12, 13, 14)] == [False, False, True]


def test_the_twin_tells_a_restart_of_its_commands_by_the_same_rule():
    """platform_sim's commands: three in a row, increasing, before the last
    accepted one are a restart (accepted, counted); a repeated stamp is not."""
    from flight_sim_dynamics.ros.platform_sim import CommandStats
    stats = CommandStats()

    def outcome(stamp: int) -> str:
        try:
            stats.stamp(stamp)
        except SetpointError as exc:
            return exc.reason
        return 'accepted'
    assert outcome(100) == 'accepted'
    assert [outcome(100) for _ in range(3)] == [STAMP_REPEATED] * 3
    assert [outcome(s) for s in (10, 11, 12, 13)] == [STAMP_BACKWARDS] * 2 + ['accepted'] * 2
    assert stats.restarts == 1 and stats.last_stamp == 13
