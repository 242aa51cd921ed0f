"""Unit tests of the rclpy-free setpoint rules (flight_sim_dynamics.ros: messages,
join, diagnostics, intake) and of the planner motions
(flight_sim_dynamics.machines.staicu.motions)."""
from __future__ import annotations

import dataclasses
import math
from types import SimpleNamespace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import flight_sim_dynamics as fsd
from flight_sim_dynamics.config import parameters as prm
from flight_sim_dynamics.config.parameters import NodeConfig
from flight_sim_dynamics.core.estimator import wrap_angle
from flight_sim_dynamics.core.machine import LimitUsage
from flight_sim_dynamics.core.motion import PlannerSequence
from flight_sim_dynamics.core.status import Status
from flight_sim_dynamics.machines.staicu.motions import MOTIONS as STAICU_MOTIONS
from flight_sim_dynamics.machines.staicu.motions import PLANNER_MOTIONS as MOTIONS
from flight_sim_dynamics.machines.staicu.motions import CUEING_DURATION, motion_cueing
from flight_sim_dynamics.ros.diagnostics import CycleStats, LogThrottle, limit_report
from flight_sim_dynamics.ros.intake import STALE_WINDOW, Runtime, SetpointIntake
from flight_sim_dynamics.ros.join import RestartRule, StampSynchroniser
from flight_sim_dynamics.ros.messages import (ABSURD_ACCELERATION, ACCEL, BAD_QUATERNION, DUPLICATE,
                                              ERROR, INACTIVE, JOINING, LATE, NO_POSE, NON_FINITE,
                                              OK, OVERFLOW, PITCH, POSE, STAMP_BACKWARDS,
                                              STAMP_REPEATED, SWAY, TWIST, WARN, YAW, SOLVER_ERROR,
                                              SetpointError, pose_input, quaternion_to_rpy,
                                              rate_input, pose_map, rpy_to_quaternion)
from flight_sim_dynamics.machines import FLIGHT_SIMULATOR

#: What the 3-DOF machine takes of the messages; a solution of parasitic pitch -0.04 rad.
POSES = pose_map(FLIGHT_SIMULATOR)
BETA = SimpleNamespace(beta=0.04)
unfollowable = POSES.unfollowable

def field_name(parameter: str) -> str:
    return parameter.replace('.', '_')


angles = st.floats(-math.pi + 1e-6, math.pi - 1e-6)


# ----------------------------------------------------------------------------
# Quaternions
# ----------------------------------------------------------------------------
@settings(max_examples=300, deadline=None)
@given(angles, st.floats(-1.5, 1.5), angles)
def test_rpy_round_trip(roll, pitch, yaw):
    r, p, y = quaternion_to_rpy(*rpy_to_quaternion(roll, pitch, yaw))
    assert abs(wrap_angle(r - roll)) < 1e-9
    assert abs(p - pitch) < 1e-9
    assert abs(wrap_angle(y - yaw)) < 1e-9


@settings(max_examples=200, deadline=None)
@given(st.floats(-1.4, 1.4), st.floats(-0.3, 0.3))
def test_parasitic_pitch_does_not_change_roll(roll, pitch):
    """Ry(pitch) Rx(roll): the ZYX roll is the roll of the roll-only quaternion."""
    with_pitch = quaternion_to_rpy(*rpy_to_quaternion(roll, pitch, 0.0))
    roll_only = quaternion_to_rpy(*rpy_to_quaternion(roll, 0.0, 0.0))
    assert with_pitch[0] == pytest.approx(roll_only[0], abs=1e-12)
    assert with_pitch[1] == pytest.approx(pitch, abs=1e-12)


def test_roll_sign_rep103():
    """Positive roll about +X (forward) lowers the right (-Y) side."""
    x, y, z, w = rpy_to_quaternion(0.2)
    # rotate the left unit vector (0, 1, 0): its z becomes +sin(roll) (left side up)
    z_of_left = 2 * (y * z + w * x)
    assert z_of_left == pytest.approx(math.sin(0.2))
    assert quaternion_to_rpy(x, y, z, w)[0] == pytest.approx(0.2)


@pytest.mark.parametrize('q, reason', [
    ((0.0, 0.0, 0.0, 0.0), BAD_QUATERNION),
    ((0.0, 0.0, 0.0, 2.0), BAD_QUATERNION),
    ((0.0, 0.0, 0.0, 0.99), BAD_QUATERNION),
    ((math.nan, 0.0, 0.0, 1.0), NON_FINITE),
    ((0.0, math.inf, 0.0, 1.0), NON_FINITE),
])
def test_bad_quaternions_rejected(q, reason):
    with pytest.raises(SetpointError) as info:
        quaternion_to_rpy(*q, tolerance=1e-3)
    assert info.value.reason == reason


def test_slightly_non_unit_quaternion_normalised():
    x, y, z, w = rpy_to_quaternion(0.3)
    assert quaternion_to_rpy(x * 1.0005, y, z, w * 1.0005, 1e-3)[0] == pytest.approx(0.3)


def test_pose_and_rate_inputs():
    pose = pose_input(0.05, 0.01, 0.1, *rpy_to_quaternion(0.2, 0.03, 0.04))
    assert pose == pytest.approx((0.05, 0.01, 0.1, 0.2, 0.03, 0.04))
    assert POSES.coordinates(pose) == pytest.approx((0.05, 0.1, 0.2))
    rates = rate_input(1.0, 2.0, 3.0, 4.0, 5.0, 6.0)
    assert rates == (1.0, 2.0, 3.0, 4.0, 5.0, 6.0)
    assert POSES.coordinates(rates) == (1.0, 3.0, 4.0)
    with pytest.raises(SetpointError):
        pose_input(math.nan, 0, 0, 0, 0, 0, 1)
    with pytest.raises(SetpointError):
        rate_input(0, 0, 0, 0, 0, math.inf)


def test_unfollowable_components():
    clean = pose_input(0, 0, 0, *rpy_to_quaternion(0.1))
    assert unfollowable(clean, None, None, BETA, 1e-3, 1e-3) == ()
    parasitic = pose_input(0, 0, 0, *rpy_to_quaternion(0.1, -0.04))
    assert unfollowable(parasitic, None, None, BETA, 1e-3, 1e-3) == ()
    other = pose_input(0, 0.1, 0, *rpy_to_quaternion(0.1, 0.2, 0.3))
    assert unfollowable(other, None, None, BETA, 1e-3, 1e-3) == (SWAY, YAW, PITCH)
    twist = rate_input(0, 0.5, 0, 0, 0, 0)
    assert unfollowable(clean, twist, None, BETA, 1e-3, 1e-3) == (SWAY,)


def test_absurd_acceleration():
    POSES.check_acceleration((1.0, -2.0, 3.0), 50.0, 100.0)
    for qdd in ((51.0, 0.0, 0.0), (0.0, -51.0, 0.0), (0.0, 0.0, 101.0)):
        with pytest.raises(SetpointError) as info:
            POSES.check_acceleration(qdd, 50.0, 100.0)
        assert info.value.reason == ABSURD_ACCELERATION


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
# Configuration, limits, diagnostics bookkeeping
# ----------------------------------------------------------------------------
def test_node_config_matches_schema_and_checks_relations():
    config = NodeConfig.from_values({})
    # (the QoS default, reliable and deep, moved to test_node_params.py:
    # test_default_qos_is_reliable_and_deep; qos.* are rclpy's qos_overrides now)
    # one field per node parameter, derived from the schema, at its default
    assert [f.name for f in dataclasses.fields(NodeConfig)] \
        == [field_name(spec.name) for spec in prm.NODE_PARAMETERS]
    for spec in prm.NODE_PARAMETERS:
        assert getattr(config, field_name(spec.name)) == spec.default, spec.name
    with pytest.raises(prm.ParameterError, match='not a node parameter'):
        NodeConfig.from_values({'qos.depth': 10})
    assert NodeConfig.from_values({'sync.max_pending': 7}).sync_max_pending == 7
    with pytest.raises(prm.ParameterError) as info:   # limits are model parameters now
        prm.validate({'limits.stroke_min': 0.7}, require_all=False)
    assert info.value.key == 'limits.stroke_min'
    with pytest.raises(prm.ParameterError):
        NodeConfig.from_values({'estimator.method': 'magic'})
    for spec in prm.NODE_PARAMETERS:
        assert spec.description and prm.check_value(spec, spec.default) == spec.default


def test_node_parameters_in_packaged_yaml():
    values = prm.read_params_file(prm.default_params_path())
    for spec in prm.NODE_PARAMETERS:
        assert values[spec.name] == spec.default, spec.name


def test_limits():
    """A limit used beyond 1: ERROR, from warn_fraction on: WARN, each by its name."""
    names = ('stroke A', 'speed A', 'force A', 'stroke B', 'speed B', 'force B')
    ok = limit_report(LimitUsage(names, np.array([0.0, 0.1, 0.3, 0.2, 0.1, 0.3])), 0.9)
    assert ok.level == OK and not ok.exceeded and not ok.near
    near = limit_report(LimitUsage(names, np.array([0.9, 0.1, 0.3, 0.2, 0.95, 1.0])), 0.9)
    assert near.level == WARN and set(near.near) == {'stroke A', 'speed B', 'force B'}
    over = limit_report(LimitUsage(names, np.array([0.0, 0.0, 0.3, 0.95, 0.0, 1.01])), 0.9)
    assert over.level == ERROR and over.exceeded == ('force B',) and over.near == ('stroke B',)


def test_limit_usages_of_the_3dof_machine():
    """A leg's stroke usage is its distance from mid-stroke over half the
    stroke, speed and force their magnitudes over the maxima."""
    model = prm.load_model()
    lim = model.limits
    sol = SimpleNamespace(stroke=np.array([lim.stroke_max, lim.stroke_min, 0.5 * (
                              lim.stroke_min + lim.stroke_max)]),
                          rate=np.array([0.0, -0.95 * lim.max_speed, 0.0]),
                          force=np.array([0.0, 0.0, -1.01 * lim.max_force]))
    usage = FLIGHT_SIMULATOR.limit_usage(model, sol)
    report = limit_report(usage, 0.9)
    assert report.exceeded == ('force C',)
    assert set(report.near) == {'stroke A', 'stroke B', 'speed B'}
    np.testing.assert_allclose(usage.usage, [1.0, 0.0, 0.0, 1.0, 0.95, 0.0, 0.0, 0.0, 1.01])


def test_cycle_stats_report():
    stats = CycleStats()
    level, message, values = stats.report(0.0)
    assert level == OK and message == 'waiting for setpoints'
    stats.solved(0.001, 12.0, 3.5)
    stats.reject(NON_FINITE, 'nan')
    level, message, values = stats.report(1.0, exact_cond=10.25)
    d = dict(values)
    assert d['cond(Q) last'] == '10.25' and d['kinematic condition last'] == '12'
    assert d['Jacobian condition max this period'] == '3.5'
    assert level == ERROR and 'non_finite' in message
    assert d['rejected non_finite'] == '1' and d['setpoints answered'] == '1'
    assert float(d['solve time mean (us)']) == pytest.approx(1000.0)
    assert float(d['solve time median (us)']) == pytest.approx(1000.0)
    level, _, values = stats.report(2.0)                       # next period: clean
    assert level == OK and dict(values)['rejected total'] == '1'


def test_cycle_stats_solve_time_figures():
    """Mean, median, p99 and max of one period's solve times; one preemption
    (a 5 ms solve among 2 us ones) moves the mean, not the median."""
    stats = CycleStats()
    times = [2e-6] * 99 + [5e-3]
    for t in times:
        stats.solved(t, 1.0, 1.0)
    d = dict(stats.report(1.0)[2])
    assert float(d['solve time median (us)']) == pytest.approx(2.0)
    assert float(d['solve time mean (us)']) == pytest.approx(1e6 * sum(times) / 100, rel=1e-3)
    assert float(d['solve time p99 (us)']) == pytest.approx(2.0)
    assert float(d['solve time max (us)']) == pytest.approx(5000.0)
    for t in (1e-6, 3e-6, 2e-6, 10e-6):       # even count: mean of the middle two
        stats.solved(t, 1.0, 1.0)
    d = dict(stats.report(2.0)[2])
    assert float(d['solve time median (us)']) == pytest.approx(2.5)
    d = dict(stats.report(3.0)[2])            # no solve this period
    assert d['solve time median (us)'] == 'no samples'


def test_log_throttle():
    throttle = LogThrottle(1.0)
    assert throttle('a', 0.0) == 0
    assert throttle('a', 0.5) is None and throttle('a', 0.6) is None
    assert throttle('b', 0.6) == 0
    assert throttle('a', 1.1) == 2


# ----------------------------------------------------------------------------
# Planner motions
# ----------------------------------------------------------------------------
def test_cueing_returns_to_neutral_and_derivatives_are_consistent():
    t = np.linspace(0.0, CUEING_DURATION, 13001)
    q, qd, qdd = motion_cueing(t)
    np.testing.assert_allclose(q[0], 0.0, atol=1e-15)
    np.testing.assert_allclose(q[-1], 0.0, atol=1e-12)
    np.testing.assert_allclose(qd[-1], 0.0, atol=1e-12)
    h = t[1] - t[0]
    np.testing.assert_allclose(np.gradient(q, h, axis=0)[1:-1], qd[1:-1], atol=1e-4)
    # (jerk jumps at segment ends: the central difference is off by ~h jerk / 2 there)
    np.testing.assert_allclose(np.gradient(qd, h, axis=0)[1:-1], qdd[1:-1], atol=2e-2)
    assert np.abs(q).max(axis=0)[2] > 0.1                     # it does roll


def test_planner_sequence_continuous():
    seq = PlannerSequence(STAICU_MOTIONS, list(MOTIONS), loop=True)
    assert seq.period == pytest.approx(3 * 4.0 + CUEING_DURATION)
    t = np.arange(0.0, 2 * seq.period, 0.005)
    q = np.array([seq.sample(x)[0] for x in t])
    assert np.abs(np.diff(q, axis=0)).max() < 5e-3            # no jumps in position
    assert not seq.finished(100.0)
    once = PlannerSequence(STAICU_MOTIONS, ['general'])
    assert once.period == 3.0 and once.finished(3.01) and not once.finished(3.0)


@pytest.mark.ros
def test_setpoint_helpers_do_not_import_rclpy():
    """The rclpy-free modules of the ROS adapter stay importable (and
    testable) without rclpy."""
    import subprocess
    import sys
    from pathlib import Path
    modules = ['messages', 'join', 'diagnostics', 'intake', 'markers']
    code = ('import sys\n' + ''.join(f'import flight_sim_dynamics.ros.{m}\n' for m in modules)
            + "print(sorted(m for m in sys.modules if m.split('.')[0] == 'rclpy'))")
    root = Path(__file__).resolve().parents[2]
    out = subprocess.run([sys.executable, '-c', code], capture_output=True, text=True,
                         check=True, cwd=root)
    assert out.stdout.strip() == '[]'


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


# -- activation: what a stream published while the node was inactive ------------
def _stamped(stamp_ns: int, **fields: float) -> SimpleNamespace:
    """A pose/twist/accel message of the shape the intake reads."""
    sec, nanosec = divmod(stamp_ns, 1_000_000_000)
    vec = SimpleNamespace(x=0.0, y=0.0, z=0.0)
    return SimpleNamespace(header=SimpleNamespace(stamp=SimpleNamespace(sec=sec, nanosec=nanosec)),
                           pose=SimpleNamespace(position=vec, orientation=SimpleNamespace(
                               x=0.0, y=0.0, z=0.0, w=1.0)),
                           twist=SimpleNamespace(linear=vec, angular=vec),
                           accel=SimpleNamespace(linear=vec, angular=vec))


def _answered(intake: SetpointIntake, stamp_ns: int, now: float) -> bool:
    answers = []
    for kind in (POSE, TWIST, ACCEL):
        answers += intake.receive(kind, _stamped(stamp_ns), now, None)[0]
    return any(a.header == divmod(stamp_ns, 1_000_000_000) for a in answers)


@pytest.mark.parametrize('stream_while_inactive, connected', [
    (True, False), (False, True), (False, False)])
def test_setpoints_stamped_before_an_activation_are_stale_for_a_while(stream_while_inactive,
                                                                       connected):
    """A stream that ran while the node was inactive (seen by the node, or only
    a planner connected: its messages delivered after the activation): for
    STALE_WINDOW s after the activation its setpoints stamped before it are
    dropped (counted inactive), later ones answered; with neither, old stamps
    are answered."""
    intake = SetpointIntake(Runtime(prm.load_model(), NodeConfig.from_values({})))
    activation = 1_700_000_000 * 1_000_000_000
    if stream_while_inactive:
        intake.receive(POSE, _stamped(activation - 10 ** 9), 0.0, None, active=False)
    intake.activate(activation, now=100.0, connected=connected)
    stale = _answered(intake, activation - 5 * 10 ** 8, 100.5)
    dropped = stream_while_inactive or connected
    assert stale != dropped
    assert intake.stats.rejected.get(INACTIVE, 0) == (
        4 if stream_while_inactive else 3 if connected else 0)
    assert _answered(intake, activation + 10 ** 6, 100.6)
    # after the window, an old stamp is judged by the usual rules only (here: it
    # precedes the last answered one)
    assert not _answered(intake, activation - 10 ** 8, 100.0 + STALE_WINDOW + 0.1)
    assert intake.stats.rejected.get(INACTIVE, 0) == (
        4 if stream_while_inactive else 3 if connected else 0)


# -- the answer first ------------------------------------------------------------------
def test_an_answer_goes_out_before_its_checks_and_statistics():
    """With a publish callback, each answer is handed over as soon as it is
    solved: the intake has not counted it yet (its limit checks and statistics
    come after, off the round trip), and the outcome carries no answers."""
    handed = []
    intake = SetpointIntake(Runtime(prm.load_model(), NodeConfig.from_values({})),
                            publish=lambda a: handed.append((a.header, intake.stats.answered)))
    stamp = 1_700_000_000 * 1_000_000_000
    outcomes = [intake.receive(kind, _stamped(stamp), 0.0, None) for kind in (POSE, TWIST, ACCEL)]
    assert handed == [(divmod(stamp, 1_000_000_000), 0)]
    assert intake.stats.answered == 1
    assert all(answers == [] for answers, _ in outcomes)


def test_an_answer_that_cannot_go_out_is_counted_and_logged():
    """A publish callback that raises: the setpoint is a ``solver_error``, and
    the outcome carries its ERROR line (the node logs it); the next is tried."""
    def refuse(answer):
        raise RuntimeError('publisher gone')
    intake = SetpointIntake(Runtime(prm.load_model(), NodeConfig.from_values({})),
                            publish=refuse)
    stamp = 1_700_000_000 * 1_000_000_000
    lines = []
    for k in range(2):
        for kind in (POSE, TWIST, ACCEL):
            lines += intake.receive(kind, _stamped(stamp + k * 10 ** 7), 0.0, None)[1]
    assert intake.stats.rejected.get(SOLVER_ERROR, 0) == 2
    assert intake.stats.answered == 0
    assert [level for level, _ in lines].count(ERROR) >= 1


# -- actuator and joint limits: the machine's own rule ----------------------------------
def _hexapod(**limits):
    """The packaged hexapod with some limits changed."""
    model = fsd.load_model('stewart_6dof')
    return dataclasses.replace(model, limits=dataclasses.replace(model.limits, **limits))


def _stats_after_home(model) -> tuple[CycleStats, list[tuple[int, str]]]:
    """The intake's statistics and log lines after one setpoint at rest at home."""
    intake = SetpointIntake(Runtime(model, NodeConfig.from_values({})))
    stamp, lines, answers = 1_700_000_000 * 1_000_000_000, [], []
    for kind in (POSE, TWIST, ACCEL):
        got, more = intake.receive(kind, _stamped(stamp), 0.0, None)
        answers += got
        lines += more
    assert len(answers) == 1                    # published anyway
    return intake.stats, lines


def test_a_hexapod_beyond_its_u_joint_limit_is_an_exceeded_limit():
    """The U-joints at home (about 0.5 rad) beyond ``limits.u_joint_max_angle``:
    the solve's status is limit, and the node counts the answer as a limit
    exceeded, at ERROR, as it does a stroke, speed or force."""
    model = _hexapod(u_joint_max_angle=0.30)
    zero = [0.0] * 6
    assert fsd.solve(model, zero, zero, zero).status is Status.LIMIT
    stats, lines = _stats_after_home(model)
    assert stats.limit_exceeded == 1 and stats.near_limit == 0
    level, _, values = stats.report(1.0)
    assert level == ERROR and dict(values)['limit exceeded'] == '1'
    assert ERROR in [lvl for lvl, _ in lines]


def test_a_hexapod_near_its_spherical_joint_limit_is_near_a_limit():
    """A joint angle within ``limits.warn_fraction`` of its limit: WARN, near limit."""
    home = fsd.solve(_hexapod(), [0.0] * 6, [0.0] * 6, [0.0] * 6).spherical_angles.max()
    stats, _ = _stats_after_home(_hexapod(spherical_joint_max_angle=home / 0.95))
    assert stats.limit_exceeded == 0 and stats.near_limit == 1
    assert stats.report(1.0)[0] == WARN
    assert _stats_after_home(_hexapod(spherical_joint_max_angle=home / 0.5))[0].near_limit == 0
