"""The shared shape of a workspace survey (core/workspace.py): the two sets of
a map, areas, near_singular shares and boundary shares, on a grid whose
answers are known by hand."""
from __future__ import annotations

import numpy as np
import pytest

from flight_sim_dynamics.core.workspace import (INSIDE, Cause, PlaneMap, angles_check,
                                                cell_centres, check_extent)

WALL = Cause('wall', 'unreachable: a wall', singular=True)
STROKE = Cause('stroke', 'beyond a limit', reachable=True)


def grid_map() -> PlaneMap:
    """4 x 4 cells of 1 m: columns 0-1 inside, column 2 beyond a limit, column 3 a wall."""
    cause = np.tile(np.array([0, 0, 2, 1]), (4, 1))
    near = np.zeros((4, 4), dtype=bool)
    near[0, 0] = True
    return PlaneMap(title='t', names=('x', 'y'), units=('m', 'm'), x=cell_centres(0, 4, 4),
                    y=cell_centres(0, 4, 4), cause=cause, causes=(INSIDE, WALL, STROKE),
                    condition=np.where(cause == 1, np.nan, 2.0), near_singular=near)


def test_sets_areas_and_near_singular_shares():
    plane = grid_map()
    assert plane.inside(0).sum() == 12 and plane.inside(1).sum() == 8
    assert plane.area(0) == 12.0 and plane.area(1) == 8.0
    assert plane.near_singular_share(1) == pytest.approx(1 / 8)
    plane.areas = {1: 7.5}                       # measured more finely: taken as given
    assert plane.area(1) == 7.5 and plane.area(0) == 12.0


def test_boundary_shares_name_the_cause_beyond_each_edge_and_the_map_edge():
    plane = grid_map()
    # set 1: 4 m against the stroke column; 2 m along the top, 2 m the bottom, 4 m the left
    assert plane.boundary_shares(1) == pytest.approx(
        {'edge of the map': 8 / 12, 'stroke': 4 / 12})
    # set 0: 4 m against the wall; 3 m top, 3 m bottom, 4 m left
    assert plane.boundary_shares(0) == pytest.approx(
        {'edge of the map': 10 / 14, 'wall': 4 / 14})


@pytest.mark.parametrize('extent', [(0, 1, 1, 1), (1, 0, 0, 1), (0, float('nan'), 0, 1)])
def test_bad_extents_are_refused(extent):
    with pytest.raises(ValueError, match='MIN < MAX'):
        check_extent(extent)


def test_angle_checks_count_and_bound():
    angles_check(2)([0.0, 180.0])
    for bad in ([], [0.0, 1.0, 2.0], [181.0], [float('inf')]):
        with pytest.raises(ValueError, match='1 to 2 finite angles'):
            angles_check(2)(bad)
