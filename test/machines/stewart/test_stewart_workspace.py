"""The hexapod's workspace at rest (machines/stewart/workspace.py): a cell is
reachable exactly when its own solve is solvable with every leg length (and
joint angle, when limited) within the limits; each range's ends sit on the
limit its cause names; the maps carry solve's condition of J."""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

import flight_sim_dynamics as fsd
from flight_sim_dynamics.machines.stewart import workspace as ws

MODEL = fsd.load_model('config/stewart_6dof.yaml')
TSAI = fsd.load_model('config/stewart_tsai2000.yaml')
ZERO = [0.0] * 6


def within(model, q) -> bool:
    """Reachable by the definition, from one fsd.solve."""
    sol = fsd.solve(model, q, ZERO, ZERO)
    lim = model.limits
    if sol.status in (fsd.Status.UNREACHABLE, fsd.Status.INVALID_INPUT):
        return False
    ok = bool(np.all((sol.length >= lim.length_min) & (sol.length <= lim.length_max)))
    if lim.u_joint_max_angle is not None:
        ok &= bool(np.abs(sol.joints[:, :2]).max() <= lim.u_joint_max_angle)
    return ok


@pytest.mark.parametrize('model', [MODEL, TSAI], ids=['default', 'tsai'])
def test_map_cells_are_reachable_exactly_when_their_solve_says(model):
    plane = ws.surge_heave_map(model, (0.05, 5.0, -3.0, 10.0), (-0.8, 0.8, -0.6, 0.6), 24)
    assert plane.inside(0).any() and not plane.inside(0).all()
    for i in range(0, 24, 3):
        for j in range(0, 24, 3):
            q = np.array([plane.x[j], 0.05, plane.y[i]] + [math.radians(a)
                                                          for a in (5.0, -3.0, 10.0)])
            assert plane.inside(0)[i, j] == within(model, q), (i, j)
            if plane.inside(0)[i, j]:
                cond = fsd.solve(model, q, ZERO, ZERO).jacobian_condition
                assert plane.condition[i, j] == pytest.approx(cond, rel=1e-9)
            else:
                assert math.isnan(plane.condition[i, j])


def test_roll_pitch_map_is_in_degrees_at_home_position():
    plane = ws.roll_pitch_map(MODEL, 20.0, (-40.0, 40.0, -40.0, 40.0), 20)
    assert plane.names == ('roll', 'pitch') and plane.units == ('deg', 'deg')
    i, j = 5, 14
    q = [0.0, 0.0, 0.0, math.radians(plane.x[j]), math.radians(plane.y[i]), math.radians(20.0)]
    assert plane.inside(0)[i, j] == within(MODEL, q)


@pytest.mark.parametrize('axis', range(6))
def test_range_ends_sit_on_the_limit_they_name(axis):
    lo, hi = ws.line_range(MODEL, axis)
    assert lo.value < 0.0 < hi.value
    scale = math.radians(1.0) if axis in ws.ANGLES else 1.0
    lim = MODEL.limits
    for end, sign in ((lo, -1.0), (hi, 1.0)):
        q = np.zeros(6)
        q[axis] = end.value * scale
        assert within(MODEL, q)
        q[axis] += sign * 1e-6 * scale
        assert not within(MODEL, q)
        length = fsd.solve(MODEL, q, ZERO, ZERO).length
        legs = [int(k) for k in end.cause.split(' at ')[0].split(' ', 1)[1].split(', ')]
        bound = lim.length_max if 'longest' in end.cause else lim.length_min
        for k in legs:
            assert length[k - 1] == pytest.approx(bound, abs=1e-5)
        # the legs it does not name are not at that limit
        others = [k for k in range(1, 7) if k not in legs]
        assert all(abs(length[k - 1] - bound) > 1e-6 for k in others)


def test_the_default_machine_is_symmetric_in_sway_roll_yaw_and_ranges_agree_with_the_map():
    r = {name: ws.line_range(MODEL, k) for k, name in enumerate(ws.COORDINATES)}
    for name in ('sway', 'roll', 'yaw'):
        assert r[name][0].value == pytest.approx(-r[name][1].value, abs=1e-9)
    assert r['heave'][0].cause == 'legs 1, 2, 3, 4, 5, 6 at their shortest'
    heave = ws.surge_heave_map(MODEL, (0.0, 0.0, 0.0, 0.0), (-0.001, 0.001, -0.5, 0.5), 101)
    inside = (heave.y >= r['heave'][0].value) & (heave.y <= r['heave'][1].value)
    assert np.array_equal(heave.inside(0)[:, 50], inside)


def test_joint_angle_limits_shrink_the_region_and_are_named():
    limited = dataclasses.replace(MODEL, limits=dataclasses.replace(
        MODEL.limits, u_joint_max_angle=math.radians(35.0)))
    free = ws.roll_pitch_map(MODEL, 0.0, (-40.0, 40.0, -40.0, 40.0), 30)
    tight = ws.roll_pitch_map(limited, 0.0, (-40.0, 40.0, -40.0, 40.0), 30)
    assert tight.inside(0).sum() < free.inside(0).sum()
    assert not (tight.inside(0) & ~free.inside(0)).any()
    assert any('U-joint' in name for name in tight.boundary_shares(0))
    i, j = np.argwhere(free.inside(0) & ~tight.inside(0))[0]
    q = [0.0, 0.0, 0.0, math.radians(tight.x[j]), math.radians(tight.y[i]), 0.0]
    assert not within(limited, q) and within(MODEL, q)


def test_unreachable_and_invalid_poses_are_causes_not_errors():
    q = np.array([[math.nan] + [0.0] * 5, [0.0, 0.0, -1.0, 0.0, 0.0, 0.0]])
    code, legs = ws.causes(MODEL, ws.at_rest(MODEL, q))
    assert code[0] == ws.UNREACHABLE and legs[0] == 0
    assert code[1] == ws.SHORT and ws.cause_text(int(code[1]), int(legs[1])).startswith('legs')


def test_survey_maps_cover_the_ranges():
    s = ws.survey(MODEL, resolution=20, yaws=(0.0, 15.0))
    assert [p.title.split(' at ')[0] for p in s.planes] == ['surge-heave', 'roll-pitch',
                                                             'roll-pitch']
    assert ws.home_condition(MODEL) == pytest.approx(2.20, abs=0.01)       # stewart.md
    surge, heave = s.ranges[0].intervals[0], s.ranges[2].intervals[0]
    x, y = s.planes[0].x, s.planes[0].y
    assert x[0] < surge[0].value and surge[1].value < x[-1]
    assert y[0] < heave[0].value and heave[1].value < y[-1]
    assert not s.planes[0].boundary_shares(0).get('edge of the map')
