"""The hexapod's drawing (machines/stewart/drawing.py): its points are where
the kinematics puts the joints (B_i fixed, P_i of the pose, written here from
stewart.md's definitions), each leg a cylinder and a rod from B_i to P_i that
split where the rod leaves the cylinder, the plates polygons through the
joints; and every machine's drawing joins its legs' joints as far apart as
solve's leg lengths."""
from __future__ import annotations

import math

import numpy as np
import pytest

import flight_sim_dynamics as fsd
from flight_sim_dynamics.machines.stewart.drawing import JOINTS, SEGMENTS, hexapod_points

HEXAPODS = {name: fsd.load_model(f'config/{name}.yaml')
            for name in ('stewart_6dof', 'stewart_tsai2000')}
POSES = [(0.0,) * 6, (0.1, -0.05, 0.08, 0.1, -0.15, 0.3), (-0.12, 0.1, -0.1, -0.2, 0.1, -1.0)]


def platform_joints(model, q) -> np.ndarray:
    """P_i = home + (surge, sway, heave) + Rz(yaw) Ry(pitch) Rx(roll) p_i (stewart.md)."""
    roll, pitch, yaw = q[3:]
    rx = np.array([[1, 0, 0], [0, math.cos(roll), -math.sin(roll)],
                   [0, math.sin(roll), math.cos(roll)]])
    ry = np.array([[math.cos(pitch), 0, math.sin(pitch)], [0, 1, 0],
                   [-math.sin(pitch), 0, math.cos(pitch)]])
    rz = np.array([[math.cos(yaw), -math.sin(yaw), 0], [math.sin(yaw), math.cos(yaw), 0],
                   [0, 0, 1]])
    return model.home + np.asarray(q[:3]) + model.platform_joints @ (rz @ ry @ rx).T


@pytest.mark.parametrize('name', HEXAPODS)
@pytest.mark.parametrize('q', POSES)
def test_points_are_the_joints_of_the_pose(name, q):
    model = HEXAPODS[name]
    drawing = fsd.machine_of(model).drawing(model)
    p = {k: np.array(v) for k, v in drawing.points(q).items()}
    assert set(JOINTS) <= set(p)
    want = platform_joints(model, q)
    length = fsd.solve(model, q, [0.0] * 6, [0.0] * 6).length
    for i in range(6):
        np.testing.assert_allclose(p[f'B{i + 1}'], model.base_joints[i], rtol=0, atol=0)
        np.testing.assert_allclose(p[f'P{i + 1}'], want[i], rtol=0, atol=1e-12)
        cylinder, rod = drawing.legs[i]
        a, s = SEGMENTS[cylinder]
        s2, b = SEGMENTS[rod]
        assert (a, s2, b) == (f'B{i + 1}', s, f'P{i + 1}')
        # the cylinder as long as the shortest leg (at most the leg), the rod the
        # rest, on one line
        cylinder_length = min(model.limits.length_min, length[i])
        assert np.linalg.norm(p[s] - p[a]) == pytest.approx(cylinder_length, abs=1e-12)
        assert np.linalg.norm(p[b] - p[s]) == pytest.approx(length[i] - cylinder_length,
                                                            abs=1e-12)
        assert np.linalg.norm(np.cross(p[s] - p[a], p[b] - p[a])) < 1e-12


def test_the_rod_extends_with_the_stroke():
    model = HEXAPODS['stewart_6dof']
    low, high = (hexapod_points(model, np.array([[0.0, 0.0, h, 0.0, 0.0, 0.0]]))
                 for h in (-0.1, 0.1))
    for i in range(1, 7):
        np.testing.assert_allclose(low[f'S{i}'] - low[f'B{i}'], high[f'S{i}'] - high[f'B{i}'],
                                   atol=0.2)       # the cylinder turns, keeps its length
        rod = [np.linalg.norm(pts[f'P{i}'] - pts[f'S{i}'])[()] for pts in (low, high)]
        assert rod[1] > rod[0] + 0.05
    # a leg shorter than the shortest allowed is all cylinder, ending at P_i
    short = hexapod_points(model, np.array([[0.0, 0.0, -0.5, 0.0, 0.0, 0.0]]))
    L = np.linalg.norm(short['P1'] - short['B1'])
    assert L < model.limits.length_min
    np.testing.assert_allclose(short['S1'], short['P1'], atol=1e-12)


@pytest.mark.parametrize('name', HEXAPODS)
def test_plates_go_round_their_joints(name):
    model = HEXAPODS[name]
    drawing = fsd.machine_of(model).drawing(model)
    p = drawing.points((0.0, 0.0, 0.0, 0.0, 0.0, 0.5))
    for plate, letter in (('base', 'B'), ('platform', 'P')):
        corners = drawing.plates[plate]
        assert sorted(corners) == [f'{letter}{i}' for i in range(1, 7)]
        xy = np.array([p[c][:2] for c in corners])
        # the turn at every corner has one sign: a convex polygon, not crossing itself
        edges = np.roll(xy, -1, axis=0) - xy
        after = np.roll(edges, -1, axis=0)
        turns = edges[:, 0] * after[:, 1] - edges[:, 1] * after[:, 0]
        assert np.all(turns > 0) or np.all(turns < 0)


def test_a_pose_without_a_drawing_is_a_value_error():
    model = HEXAPODS['stewart_6dof']
    drawing = fsd.machine_of(model).drawing(model)
    with pytest.raises(ValueError, match='no drawing'):
        drawing.points((math.nan, 0.0, 0.0, 0.0, 0.0, 0.0))


@pytest.mark.parametrize('model', [fsd.load_model(), HEXAPODS['stewart_6dof']],
                         ids=['3dof', 'hexapod'])
def test_every_machine_draws_its_legs_as_long_as_solve_says(model):
    machine = fsd.machine_of(model)
    drawing = machine.drawing(model)
    q = [0.05] * machine.dof
    p = drawing.points(q)
    length = fsd.solve(model, q, [0.0] * machine.dof, [0.0] * machine.dof).length
    assert len(drawing.legs) == len(drawing.leg_names) == len(machine.legs)
    for k, parts in enumerate(drawing.legs):
        first, last = SEGMENTS_OF(drawing, parts)
        assert np.linalg.norm(np.subtract(p[last], p[first])) == pytest.approx(length[k],
                                                                               abs=1e-9)
        assert drawing.leg_of(parts[0]) == k
    assert set(drawing.joints) <= set(p)
    assert all(set(c) <= set(p) for c in drawing.plates.values())
    assert set(drawing.styles) == set(drawing.segments)


def SEGMENTS_OF(drawing, parts) -> tuple[str, str]:
    """The first and last point of a chain of line parts."""
    return drawing.segments[parts[0]][0], drawing.segments[parts[-1]][1]
