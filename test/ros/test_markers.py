"""The mechanism's markers (ros/markers.py, issue 15): every drawn point is
a joint position of the solver (eq. 5-8, mechanism.md "Points") in the
REP-103 simulator base frame, colours are colours, no NaN for any status,
and the array is the same messages with the same namespaces and ids at
every update."""
from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st
from visualization_msgs.msg import Marker, MarkerArray

import flight_sim_dynamics as fsd
from flight_sim_dynamics.core import kernel as core_kernel
from flight_sim_dynamics.ros.markers import (JOINTS, NAMESPACES, PLATE, SEGMENTS, MarkerBuilder,
                                             force_colour)


MODEL = fsd.load_model()
ZERO = [0.0, 0.0, 0.0]
VOID = (fsd.Status.UNREACHABLE, fsd.Status.INVALID_INPUT)


def expected_points(sol: fsd.Solution) -> dict[str, np.ndarray]:
    """The solver's joint positions (paper axes, origin A1) moved to the
    REP-103 simulator base (origin at G's central position, Y = -z0, Z = y0).
    """
    geom, g = sol.model.geometry, sol.geometric
    origin = np.array([geom.d2 + geom.d3 + geom.d4, geom.h_G, 0.0])
    paper = {'A1': geom.A1, 'A3': g.A3, 'B1': geom.B1, 'B4': g.B4, 'C1': geom.C1,
             'C4': g.C4, 'D1': geom.D1, 'D2': g.D2, 'E1': geom.E1, 'E2': g.E2, 'G': g.G}
    half_t = np.subtract(g.B4, g.G)
    paper['A3_right'] = np.add(g.A3, half_t)
    paper['A3_left'] = np.subtract(g.A3, half_t)
    out = {}
    for name, p in paper.items():
        x, y, z = np.asarray(p, dtype=float) - origin
        out[name] = np.array([x, -z, y])
    return out


def xyz(point) -> np.ndarray:
    return np.array([point.x, point.y, point.z])


def by_ns(array: MarkerArray) -> dict[str, Marker]:
    return {m.ns: m for m in array.markers}


def every_number(marker: Marker) -> list[float]:
    values = [*xyz(marker.pose.position), marker.pose.orientation.x, marker.pose.orientation.y,
              marker.pose.orientation.z, marker.pose.orientation.w, *xyz(marker.scale),
              marker.color.r, marker.color.g, marker.color.b, marker.color.a]
    for p in marker.points:
        values += list(xyz(p))
    for c in marker.colors:
        values += [c.r, c.g, c.b, c.a]
    return values


def check_well_formed(array: MarkerArray) -> None:
    assert [m.ns for m in array.markers] == list(NAMESPACES)
    for m in array.markers:
        assert m.id == 0 and m.action == Marker.ADD
        assert all(math.isfinite(v) for v in every_number(m)), m.ns
        for c in [m.color, *m.colors]:
            assert all(0.0 <= v <= 1.0 for v in (c.r, c.g, c.b, c.a)), m.ns


def check_points(array: MarkerArray, sol: fsd.Solution) -> None:
    want = expected_points(sol)
    markers = by_ns(array)
    for ns, (a, b) in SEGMENTS.items():
        got = markers[ns].points
        assert len(got) == 2
        np.testing.assert_allclose(xyz(got[0]), want[a], rtol=0, atol=1e-9, err_msg=ns)
        np.testing.assert_allclose(xyz(got[1]), want[b], rtol=0, atol=1e-9, err_msg=ns)
    for p, name in zip(markers['joints'].points, JOINTS, strict=True):
        np.testing.assert_allclose(xyz(p), want[name], rtol=0, atol=1e-9, err_msg=name)
    for p, name in zip(markers['platform'].points, PLATE, strict=True):
        np.testing.assert_allclose(xyz(p), want[name], rtol=0, atol=1e-9, err_msg=name)
    # the legs are the solver's leg lengths, the rod and the cranks their constant lengths
    for i, ns in enumerate(fsd.LEG_NAMES):
        p, q = markers[ns].points
        assert abs(np.linalg.norm(xyz(q) - xyz(p)) - sol.length[i]) < 1e-9
    geom = sol.model.geometry
    for ns, length in (('rod', geom.h), ('crank_d', geom.l5), ('crank_e', geom.l6)):
        p, q = markers[ns].points
        assert abs(np.linalg.norm(xyz(q) - xyz(p)) - length) < 1e-9, ns


poses = st.tuples(st.floats(-0.15, 0.15), st.floats(-0.15, 0.2), st.floats(-0.4, 0.4))
rates = st.tuples(*[st.floats(-0.5, 0.5)] * 3)


@pytest.mark.parametrize('use_kernel', [True, False], ids=['kernel', 'python'])
@settings(max_examples=60)
@given(q=poses, qd=rates, qdd=rates)
def test_points_are_the_solver_joint_positions(use_kernel, q, qd, qdd):
    with core_kernel.use_kernel(use_kernel):
        sol = fsd.solve(MODEL, q, qd, qdd)
    assume(sol.status not in VOID)
    builder = MarkerBuilder(MODEL, 'simulator_base')
    array = builder.update(sol, 7, 11)
    check_well_formed(array)
    check_points(array, sol)
    assert all(m.header.stamp.sec == 7 and m.header.stamp.nanosec == 11
               and m.header.frame_id == 'simulator_base' for m in array.markers)


def test_central_configuration_points_in_the_base_frame():
    """q = 0: G at the origin, legs B and C mirror images, A1 below and behind."""
    sol = fsd.solve(MODEL, ZERO, ZERO, ZERO)
    m = by_ns(MarkerBuilder(MODEL, 'base').update(sol, 0, 0))
    np.testing.assert_allclose(xyz(m['rod'].points[1]), [0, 0, 0], atol=1e-12)
    geom = MODEL.geometry
    np.testing.assert_allclose(xyz(m['leg_a'].points[0]),
                               [-(geom.d2 + geom.d3 + geom.d4), 0, -geom.h_G], atol=1e-12)
    b, c = xyz(m['leg_b'].points[1]), xyz(m['leg_c'].points[1])
    np.testing.assert_allclose(b * [1, -1, 1], c, atol=1e-12)
    assert b[1] < 0 < c[1]            # B on the right: -Y in REP-103


def test_positive_roll_lowers_the_right_corner():
    sol = fsd.solve(MODEL, [0.0, 0.0, 0.2], ZERO, ZERO)
    m = by_ns(MarkerBuilder(MODEL, 'base').update(sol, 0, 0))
    assert m['leg_b'].points[1].z < m['leg_c'].points[1].z


@pytest.mark.parametrize('q', [[0.0, 5.0, 0.0], [float('nan'), 0.0, 0.0],
                               [0.0, 0.0, float('inf')], [3.0, -2.0, 1.0]])
def test_void_solution_redraws_the_last_pose_grey(q):
    builder = MarkerBuilder(MODEL, 'simulator_base')
    good = fsd.solve(MODEL, [0.05, 0.1, 0.1], ZERO, ZERO)
    before = [[tuple(xyz(p)) for p in m.points] for m in builder.update(good, 1, 0).markers]
    bad = fsd.solve(MODEL, q, ZERO, ZERO)
    assert bad.status in VOID
    array = builder.update(bad, 2, 0)
    check_well_formed(array)
    assert [[tuple(xyz(p)) for p in m.points] for m in array.markers] == before
    markers = by_ns(array)
    for ns in NAMESPACES[:-1]:
        c = markers[ns].color
        assert c.r == c.g == c.b and c.a < 1, ns
    assert markers['status'].text.startswith(str(bad.status))
    # the next reachable solution is drawn and coloured again
    array = builder.update(good, 3, 0)
    check_points(array, good)
    assert by_ns(array)['leg_a'].color.g > 0.5 and by_ns(array)['status'].text == 'ok'


def test_void_first_solution_draws_the_central_configuration():
    builder = MarkerBuilder(MODEL, 'simulator_base')
    array = builder.update(fsd.solve(MODEL, [0.0, 9.0, 0.0], ZERO, ZERO), 0, 0)
    check_well_formed(array)
    check_points(array, fsd.solve(MODEL, ZERO, ZERO, ZERO))


def test_leg_colours_follow_force_and_status():
    assert force_colour(0.0) == (0.0, 1.0, 0.0, 1.0)
    assert force_colour(0.5) == (1.0, 1.0, 0.0, 1.0)
    assert force_colour(1.0) == force_colour(7.0) == force_colour(float('nan'))
    assert force_colour(-1.0) == force_colour(0.0)
    builder = MarkerBuilder(MODEL, 'simulator_base')
    sol = fsd.solve(MODEL, ZERO, ZERO, ZERO)
    legs = [by_ns(builder.update(sol, 0, 0))[ns].color for ns in fsd.LEG_NAMES]
    for c, f in zip(legs, sol.force):
        assert (c.r, c.g, c.b) == pytest.approx(force_colour(abs(f) / 2000.0)[:3], abs=1e-6)
    # a force over the limit: the leg red, status limit
    low = replace(MODEL, limits=replace(MODEL.limits, max_force=35.0))
    sol = fsd.solve(low, ZERO, ZERO, ZERO)
    assert sol.status is fsd.Status.LIMIT
    m = by_ns(builder.update(sol, 0, 0))
    assert (m['leg_a'].color.r, m['leg_a'].color.g) == (1.0, 0.0)     # 38.6 N > 35 N
    assert m['leg_b'].color.g > 0.0                                   # 33.2 N < 35 N
    assert m['status'].text.startswith('limit')


def test_near_singular_legs_are_magenta():
    strict = replace(MODEL, limits=replace(MODEL.limits, max_kinematic_condition=1.0))
    sol = fsd.solve(strict, [0.05, 0.1, 0.1], ZERO, ZERO)
    assert sol.status is fsd.Status.NEAR_SINGULAR
    array = MarkerBuilder(MODEL, 'simulator_base').update(sol, 0, 0)
    check_well_formed(array)
    check_points(array, sol)
    c = by_ns(array)['leg_c'].color
    assert (c.r, c.g, c.b) == (1.0, 0.0, 1.0)


def test_same_messages_same_ids_across_updates():
    builder = MarkerBuilder(MODEL, 'simulator_base')
    first = builder.update(fsd.solve(MODEL, ZERO, ZERO, ZERO), 0, 0)
    objects = [id(m) for m in first.markers]
    keys = [(m.ns, m.id, m.type) for m in first.markers]
    assert len(set((ns, i) for ns, i, _ in keys)) == len(keys)
    for k, q in enumerate(([0.1, 0.0, 0.2], [0.0, 9.0, 0.0], [-0.1, 0.1, -0.3])):
        array = builder.update(fsd.solve(MODEL, q, ZERO, ZERO), k, 0)
        assert array is first
        assert [id(m) for m in array.markers] == objects
        assert [(m.ns, m.id, m.type) for m in array.markers] == keys
    builder.frame_id = 'elsewhere'
    assert all(m.header.frame_id == 'elsewhere' for m in first.markers)
    clear = builder.clear()
    assert [m.action for m in clear.markers] == [Marker.DELETEALL]
    assert clear.markers[0].header.frame_id == 'elsewhere'


def test_batch_solution_is_refused():
    batch = fsd.solve_batch(MODEL, np.zeros((2, 3)), np.zeros((2, 3)), np.zeros((2, 3)))
    with pytest.raises(ValueError, match='batch'):
        MarkerBuilder(MODEL, 'simulator_base').update(batch, 0, 0)


def test_the_array_serialises():
    """What the node will publish: rclpy's serialisation reads it back equal."""
    from rclpy.serialization import deserialize_message, serialize_message

    array = MarkerBuilder(MODEL, 'simulator_base').update(
        fsd.solve(MODEL, [0.05, 0.1, 0.2], ZERO, ZERO), 5, 6)
    back = deserialize_message(serialize_message(array), MarkerArray)
    assert len(back.markers) == len(array.markers)
    for got, sent in zip(back.markers, array.markers):
        assert (got.ns, got.id, got.type, got.text, got.header) == (
            sent.ns, sent.id, sent.type, sent.text, sent.header)
        # colours are float32 on the wire, everything else float64
        numbers = every_number(sent)
        np.testing.assert_allclose(every_number(got), numbers, rtol=1e-7, atol=0)
        assert [xyz(p).tolist() for p in got.points] == [xyz(p).tolist() for p in sent.points]
