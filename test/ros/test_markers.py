"""The markers of a machine's drawing (ros/markers.py): every drawn point is a
point of the machine's drawing at the solved pose, for the 3-DOF machine the
solver's joint positions (eq. 5-8, mechanism.md "Points") and for the hexapod
its joints (S1), (S4), in the setpoints' frame (REP-103 simulator base, origin
at the platform's home position: where the setpoints and the twin's poses put
it); legs coloured by force and status, no NaN for any status, the same
messages with the same namespaces and ids at every update."""
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
from flight_sim_dynamics.machines.api import machine_of
from flight_sim_dynamics.ros.markers import (GREY, MAGENTA, RED, MarkerBuilder, force_colour,
                                             snapshot, triangles)
from flight_sim_dynamics.ros.messages import pose_map

MODEL = fsd.load_model()
HEXAPOD = fsd.load_model('config/stewart_6dof.yaml')
ZERO = [0.0, 0.0, 0.0]
ZERO6 = [0.0] * 6
VOID = (fsd.Status.UNREACHABLE, fsd.Status.INVALID_INPUT)


def builder(model=MODEL, frame: str = 'simulator_base') -> MarkerBuilder:
    return MarkerBuilder(machine_of(model), model, frame)


def update(b: MarkerBuilder, sol, sec: int = 0, nanosec: int = 0) -> MarkerArray:
    return b.update(snapshot(b.machine, b.model, sol), sec, nanosec)


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


def check_well_formed(array: MarkerArray, b: MarkerBuilder) -> None:
    assert [m.ns for m in array.markers] == list(b.namespaces)
    for m in array.markers:
        assert m.id == 0 and m.action == Marker.ADD
        assert all(math.isfinite(v) for v in every_number(m)), m.ns
        for c in [m.color, *m.colors]:
            assert all(0.0 <= v <= 1.0 for v in (c.r, c.g, c.b, c.a)), m.ns


def check_points(array: MarkerArray, b: MarkerBuilder, want: dict) -> None:
    """Every part's points are the named points ``want`` of the drawing."""
    markers = by_ns(array)
    drawing = b.drawing
    for ns, (first, second) in drawing.segments.items():
        got = markers[ns].points
        assert len(got) == 2
        np.testing.assert_allclose(xyz(got[0]), want[first], rtol=0, atol=1e-9, err_msg=ns)
        np.testing.assert_allclose(xyz(got[1]), want[second], rtol=0, atol=1e-9, err_msg=ns)
    for p, name in zip(markers['joints'].points, drawing.joints, strict=True):
        np.testing.assert_allclose(xyz(p), want[name], rtol=0, atol=1e-9, err_msg=name)
    for ns, corners in drawing.plates.items():
        for p, name in zip(markers[ns].points, triangles(corners), strict=True):
            np.testing.assert_allclose(xyz(p), want[name], rtol=0, atol=1e-9, err_msg=name)


def check_3dof(array: MarkerArray, b: MarkerBuilder, sol: fsd.Solution) -> None:
    check_points(array, b, expected_points(sol))
    markers = by_ns(array)
    # the legs are the solver's leg lengths, the rod and the cranks their constant lengths
    for i, ns in enumerate(fsd.LEG_NAMES):
        p, q = markers[ns].points
        assert abs(np.linalg.norm(xyz(q) - xyz(p)) - sol.length[i]) < 1e-9
    geom = sol.model.geometry
    for ns, length in (('rod', geom.h), ('crank_d', geom.l5), ('crank_e', geom.l6)):
        p, q = markers[ns].points
        assert abs(np.linalg.norm(xyz(q) - xyz(p)) - length) < 1e-9, ns


def rotation_zyx(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """R = Rz(yaw) Ry(pitch) Rx(roll)."""
    cr, sr, cp, sp, cy, sy = (np.cos(roll), np.sin(roll), np.cos(pitch), np.sin(pitch),
                              np.cos(yaw), np.sin(yaw))
    return np.array([[cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
                     [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
                     [-sp, cp * sr, cp * cr]])


def hexapod_points(sol) -> dict[str, np.ndarray]:
    """B_i fixed, P_i = p + R p_i (S1), (S4), S_i on the leg at the cylinder's
    length (or P_i on a shorter leg), in the base frame moved to the platform's
    home position (origin at ``home``, where the poses put it)."""
    model, q = sol.model, np.asarray(sol.pose, dtype=float)
    R = rotation_zyx(*q[3:])
    out = {}
    for i in range(6):
        B = np.asarray(model.base_joints[i])
        P = model.home + q[:3] + R @ np.asarray(model.platform_joints[i])
        u = (P - B) / np.linalg.norm(P - B)
        out[f'B{i + 1}'], out[f'P{i + 1}'] = B, P
        out[f'S{i + 1}'] = B + min(model.limits.length_min, np.linalg.norm(P - B)) * u
    return {name: p - model.home for name, p in out.items()}


poses = st.tuples(st.floats(-0.15, 0.15), st.floats(-0.15, 0.2), st.floats(-0.4, 0.4))
rates = st.tuples(*[st.floats(-0.5, 0.5)] * 3)
poses6 = st.tuples(*[st.floats(-0.1, 0.1)] * 3, *[st.floats(-0.2, 0.2)] * 3)
rates6 = st.tuples(*[st.floats(-0.5, 0.5)] * 6)


@pytest.mark.parametrize('use_kernel', [True, False], ids=['kernel', 'python'])
@settings(max_examples=60)
@given(q=poses, qd=rates, qdd=rates)
def test_3dof_points_are_the_solver_joint_positions(use_kernel, q, qd, qdd):
    with core_kernel.use_kernel(use_kernel):
        sol = fsd.solve(MODEL, q, qd, qdd)
    assume(sol.status not in VOID)
    b = builder()
    array = update(b, sol, 7, 11)
    check_well_formed(array, b)
    check_3dof(array, b, sol)
    assert all(m.header.stamp.sec == 7 and m.header.stamp.nanosec == 11
               and m.header.frame_id == 'simulator_base' for m in array.markers)


@settings(max_examples=60)
@given(q=poses6, qd=rates6, qdd=rates6)
def test_hexapod_markers_are_its_joints_at_the_solved_pose(q, qd, qdd):
    sol = fsd.solve(HEXAPOD, q, qd, qdd)
    assume(sol.status not in VOID)
    b = builder(HEXAPOD)
    array = update(b, sol, 3, 4)
    check_well_formed(array, b)
    check_points(array, b, hexapod_points(sol))
    markers = by_ns(array)
    assert {f'cylinder_{i}' for i in range(1, 7)} | {f'rod_{i}' for i in range(1, 7)} \
        | {'base', 'platform', 'joints', 'status'} == set(markers)
    for i in range(6):   # cylinder + rod: the solver's leg length, the rod the extension
        cylinder, rod = markers[f'cylinder_{i + 1}'].points, markers[f'rod_{i + 1}'].points
        assert np.linalg.norm(xyz(rod[1]) - xyz(cylinder[0])) == pytest.approx(
            sol.length[i], abs=1e-9)
        assert np.linalg.norm(xyz(rod[1]) - xyz(rod[0])) == pytest.approx(
            max(sol.length[i] - HEXAPOD.limits.length_min, 0.0), abs=1e-9)
        # both parts of a leg in its force colour
        assert markers[f'cylinder_{i + 1}'].color == markers[f'rod_{i + 1}'].color
    assert all(m.header.stamp.sec == 3 and m.header.stamp.nanosec == 4 for m in array.markers)


@pytest.mark.parametrize('model', [MODEL, HEXAPOD], ids=['3dof', 'hexapod'])
@pytest.mark.parametrize('pose', [(0.0,) * 6, (0.05, -0.03, 0.08, 0.2, -0.1, 0.15),
                                  (-0.1, 0.0, -0.05, -0.3, 0.0, 0.0)])
def test_markers_and_poses_share_one_origin(model, pose):
    """The platform as the markers draw it is where a pose message of the same
    q puts it (a setpoint, the twin's ``platform_pose``; all in
    ``simulator_base``): the 3-DOF platform point G at the position; the
    hexapod's platform joints at position + R p_i. At home the platform is at
    the origin (the hexapod's was drawn 1 m up, at ``geometry.home``)."""
    machine = machine_of(model)
    poses = pose_map(machine)
    full = dict(zip(('surge', 'sway', 'heave', 'roll', 'pitch', 'yaw'), pose))
    q = [full[c] for c in machine.coordinates]
    sol = fsd.solve(model, q, [0.0] * len(q), [0.0] * len(q))
    assert sol.status not in VOID
    x, y, z, roll, pitch, yaw = poses.message(q)
    markers = by_ns(update(builder(model), sol))
    if model is MODEL:
        drawn = {'G': xyz(markers['rod'].points[1])}
        want = {'G': np.array([x, y, z])}
    else:
        drawn = dict(zip(machine.drawing(model).joints,
                         (xyz(p) for p in markers['joints'].points)))
        R = rotation_zyx(roll, pitch, yaw)
        want = {f'P{i + 1}': np.array([x, y, z]) + R @ np.asarray(p)
                for i, p in enumerate(model.platform_joints)}
    for name, point in want.items():
        np.testing.assert_allclose(drawn[name], point, rtol=0, atol=1e-9, err_msg=name)


def test_hexapod_platform_moves_with_heave_and_roll():
    b = builder(HEXAPOD)
    home = by_ns(update(b, fsd.solve(HEXAPOD, ZERO6, ZERO6, ZERO6)))
    z_home = [p.z for p in home['platform'].points]
    base_home = [tuple(xyz(p)) for p in home['base'].points]
    up = by_ns(update(b, fsd.solve(HEXAPOD, [0, 0, 0.05, 0, 0, 0], ZERO6, ZERO6)))
    assert [p.z for p in up['platform'].points] == pytest.approx([z + 0.05 for z in z_home])
    assert [tuple(xyz(p)) for p in up['base'].points] == base_home
    rolled = update(b, fsd.solve(HEXAPOD, [0, 0, 0, 0.1, 0, 0], ZERO6, ZERO6))
    heights = {tuple(xyz(p))[1] > 0: xyz(p)[2] for p in by_ns(rolled)['joints'].points[6:]}
    assert heights[True] > heights[False]     # positive roll lifts the left (+Y) side


def test_3dof_central_configuration_points_in_the_base_frame():
    """q = 0: G at the origin, legs B and C mirror images, A1 below and behind."""
    m = by_ns(update(builder(MODEL, 'base'), fsd.solve(MODEL, ZERO, ZERO, ZERO)))
    np.testing.assert_allclose(xyz(m['rod'].points[1]), [0, 0, 0], atol=1e-12)
    geom = MODEL.geometry
    np.testing.assert_allclose(xyz(m['leg_a'].points[0]),
                               [-(geom.d2 + geom.d3 + geom.d4), 0, -geom.h_G], atol=1e-12)
    b, c = xyz(m['leg_b'].points[1]), xyz(m['leg_c'].points[1])
    np.testing.assert_allclose(b * [1, -1, 1], c, atol=1e-12)
    assert b[1] < 0 < c[1]            # B on the right: -Y in REP-103


def test_3dof_positive_roll_lowers_the_right_corner():
    m = by_ns(update(builder(), fsd.solve(MODEL, [0.0, 0.0, 0.2], ZERO, ZERO)))
    assert m['leg_b'].points[1].z < m['leg_c'].points[1].z


@pytest.mark.parametrize('model, good, bad', [
    (MODEL, [0.05, 0.1, 0.1], [0.0, 5.0, 0.0]),
    (MODEL, [0.05, 0.1, 0.1], [float('nan'), 0.0, 0.0]),
    (MODEL, [0.05, 0.1, 0.1], [3.0, -2.0, 1.0]),
    (HEXAPOD, [0.02, 0, 0.03, 0.05, 0, 0], [0, 0, float('inf'), 0, 0, 0]),
    (HEXAPOD, [0.02, 0, 0.03, 0.05, 0, 0], [0, 0, 0, 0, 0, float('nan')])],
    ids=['3dof-unreachable', '3dof-nan', '3dof-far', 'hexapod-inf', 'hexapod-nan'])
def test_void_solution_redraws_the_last_pose_grey(model, good, bad):
    b, zero = builder(model), [0.0] * len(good)
    good_sol = fsd.solve(model, good, zero, zero)
    before = [[tuple(xyz(p)) for p in m.points] for m in update(b, good_sol, 1).markers]
    bad_sol = fsd.solve(model, bad, zero, zero)
    assert bad_sol.status in VOID
    array = update(b, bad_sol, 2)
    check_well_formed(array, b)
    assert [[tuple(xyz(p)) for p in m.points] for m in array.markers] == before
    markers = by_ns(array)
    for ns in b.namespaces[:-1]:
        c = markers[ns].color
        assert (c.r, c.g, c.b, c.a) == pytest.approx(GREY), ns
    assert markers['status'].text.startswith(str(bad_sol.status))
    # the next reachable solution is drawn and coloured again
    array = update(b, good_sol, 3)
    assert [[tuple(xyz(p)) for p in m.points] for m in array.markers] == before
    leg = b.drawing.legs[0][0]
    assert by_ns(array)[leg].color.g > 0.5 and by_ns(array)['status'].text == 'ok'


def test_void_first_solution_draws_home():
    for model in (MODEL, HEXAPOD):
        b, zero = builder(model), [0.0] * machine_of(model).dof
        bad = [float('nan')] + zero[1:]
        array = update(b, fsd.solve(model, bad, zero, zero))
        check_well_formed(array, b)
        home = {k: np.subtract(v, b.drawing.origin) for k, v in b.drawing.points(zero).items()}
        check_points(array, b, home)


def test_leg_colours_follow_force_limits_and_status():
    assert force_colour(0.0) == (0.0, 1.0, 0.0, 1.0)
    assert force_colour(0.5) == (1.0, 1.0, 0.0, 1.0)
    assert force_colour(1.0) == force_colour(7.0) == force_colour(float('nan')) == RED
    assert force_colour(-1.0) == force_colour(0.0)
    b = builder()
    sol = fsd.solve(MODEL, ZERO, ZERO, ZERO)
    legs = [by_ns(update(b, sol))[ns].color for ns in fsd.LEG_NAMES]
    for c, f in zip(legs, sol.force):
        assert (c.r, c.g, c.b) == pytest.approx(force_colour(abs(f) / 2000.0)[:3], abs=1e-6)
    # a force over the limit: the leg red, status limit
    low = replace(MODEL, limits=replace(MODEL.limits, max_force=35.0))
    sol = fsd.solve(low, ZERO, ZERO, ZERO)
    assert sol.status is fsd.Status.LIMIT
    m = by_ns(update(MarkerBuilder(machine_of(low), low, 'simulator_base'), sol))
    assert (m['leg_a'].color.r, m['leg_a'].color.g) == (1.0, 0.0)     # 38.6 N > 35 N
    assert m['leg_b'].color.g > 0.0                                   # 33.2 N < 35 N
    assert m['status'].text.startswith('limit')


def test_hexapod_leg_past_its_stroke_is_red_the_others_by_force():
    b = builder(HEXAPOD)
    sol = fsd.solve(HEXAPOD, [0.0, 0.0, 0.0, 0.0, 0.0, 0.0], ZERO6, ZERO6)
    markers = by_ns(update(b, sol))
    max_force = HEXAPOD.limits.max_force
    for i in range(6):
        c = markers[f'cylinder_{i + 1}'].color
        assert (c.r, c.g, c.b) == pytest.approx(force_colour(abs(sol.force[i]) / max_force)[:3])
    # a pose beyond the strokes: status limit, the legs out of their stroke red
    q = [0.0, 0.0, 0.0, 0.0, 0.0, 0.0]
    heave = 0.0
    while sol.status is not fsd.Status.LIMIT and heave < 1.0:
        heave += 0.01
        q[2] = heave
        sol = fsd.solve(HEXAPOD, q, ZERO6, ZERO6)
    assert sol.status is fsd.Status.LIMIT, sol.detail
    limits = machine_of(HEXAPOD).actuator_limits(HEXAPOD)
    out = [not (limits.stroke_min[i] <= sol.stroke[i] <= limits.stroke_max[i]) for i in range(6)]
    assert any(out)
    markers = by_ns(update(b, sol))
    for i in range(6):
        c = markers[f'rod_{i + 1}'].color
        if out[i]:
            assert (c.r, c.g, c.b, c.a) == RED
        else:
            assert (c.r, c.g, c.b) == pytest.approx(
                force_colour(abs(sol.force[i]) / HEXAPOD.limits.max_force)[:3])


def test_near_singular_legs_are_magenta():
    strict = replace(MODEL, limits=replace(MODEL.limits, max_kinematic_condition=1.0))
    sol = fsd.solve(strict, [0.05, 0.1, 0.1], ZERO, ZERO)
    assert sol.status is fsd.Status.NEAR_SINGULAR
    b = builder()
    array = update(b, sol)
    check_well_formed(array, b)
    check_3dof(array, b, sol)
    c = by_ns(array)['leg_c'].color
    assert (c.r, c.g, c.b, c.a) == MAGENTA
    hexapod = replace(HEXAPOD, limits=replace(HEXAPOD.limits, max_jacobian_condition=1.0))
    sol = fsd.solve(hexapod, [0.02, 0, 0.03, 0.05, 0, 0], ZERO6, ZERO6)
    assert sol.status is fsd.Status.NEAR_SINGULAR
    markers = by_ns(update(builder(hexapod), sol))
    assert all((markers[ns].color.r, markers[ns].color.g, markers[ns].color.b) == (1, 0, 1)
               for parts in builder(hexapod).drawing.legs for ns in parts)


def test_same_messages_same_ids_across_updates():
    b = builder()
    first = update(b, fsd.solve(MODEL, ZERO, ZERO, ZERO))
    objects = [id(m) for m in first.markers]
    keys = [(m.ns, m.id, m.type) for m in first.markers]
    assert len(set((ns, i) for ns, i, _ in keys)) == len(keys)
    for k, q in enumerate(([0.1, 0.0, 0.2], [0.0, 9.0, 0.0], [-0.1, 0.1, -0.3])):
        array = update(b, fsd.solve(MODEL, q, ZERO, ZERO), k)
        assert array is first
        assert [id(m) for m in array.markers] == objects
        assert [(m.ns, m.id, m.type) for m in array.markers] == keys
    b.frame_id = 'elsewhere'
    assert all(m.header.frame_id == 'elsewhere' for m in first.markers)
    clear = b.clear()
    assert [m.action for m in clear.markers] == [Marker.DELETEALL]
    assert clear.markers[0].header.frame_id == 'elsewhere'


def test_a_leg_beyond_its_joint_limit_is_red_by_the_machines_limit_rule():
    """Red is the machine's limit usage above 1 (the status rule), a joint's
    too: a hexapod whose universal joints exceed ``u_joint_max_angle`` on some
    legs and not on others, its strokes, speeds and forces well within theirs."""
    q = [0.02, -0.03, 0.05, 0.08, -0.05, 0.1]
    angles = np.abs(fsd.solve(HEXAPOD, q, ZERO6, ZERO6).joints[:, :2]).max(axis=1)
    low, high = sorted(angles)[2:4]
    assert high > low
    tight = replace(HEXAPOD, limits=replace(HEXAPOD.limits, u_joint_max_angle=0.5 * (low + high)))
    sol = fsd.solve(tight, q, ZERO6, ZERO6)
    assert sol.status is fsd.Status.LIMIT
    assert np.abs(sol.force).max() < 0.9 * tight.limits.max_force
    markers = by_ns(update(builder(tight), sol))
    for leg, angle in enumerate(angles, start=1):
        for ns in (f'cylinder_{leg}', f'rod_{leg}'):
            colour = markers[ns].color
            assert ((colour.r, colour.g) == (1.0, 0.0)) == (angle > 0.5 * (low + high)), (ns, angle)


def test_a_batch_solution_is_refused():
    batch = fsd.solve_batch(MODEL, np.zeros((2, 3)), np.zeros((2, 3)), np.zeros((2, 3)))
    with pytest.raises(ValueError, match='batch'):
        snapshot(machine_of(MODEL), MODEL, batch)


def test_the_3dof_namespaces_are_the_documented_ones():
    assert set(builder().namespaces) == {'leg_a', 'leg_b', 'leg_c', 'rod', 'platform',
                                         'crank_d', 'crank_e', 'joints', 'status'}


@pytest.mark.parametrize('model', [MODEL, HEXAPOD], ids=['3dof', 'hexapod'])
def test_the_array_serialises(model):
    """What the node publishes: rclpy's serialisation reads it back equal."""
    from rclpy.serialization import deserialize_message, serialize_message

    zero = [0.0] * machine_of(model).dof
    q = [0.05] + [0.0] * (len(zero) - 1)
    array = update(builder(model), fsd.solve(model, q, zero, zero), 5, 6)
    back = deserialize_message(serialize_message(array), MarkerArray)
    assert len(back.markers) == len(array.markers)
    for got, sent in zip(back.markers, array.markers):
        assert (got.ns, got.id, got.type, got.text, got.header) == (
            sent.ns, sent.id, sent.type, sent.text, sent.header)
        # colours are float32 on the wire, everything else float64
        numbers = every_number(sent)
        np.testing.assert_allclose(every_number(got), numbers, rtol=1e-7, atol=0)
        assert [xyz(p).tolist() for p in got.points] == [xyz(p).tolist() for p in sent.points]
