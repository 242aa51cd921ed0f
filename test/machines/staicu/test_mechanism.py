"""The named points of the mechanism (core/mechanism.py): the joint centres of
eq. (5)-(8) in the REP-103 simulator base frame, segments as long as the
solver's leg lengths and the model's constant lengths."""
from __future__ import annotations

import numpy as np
import pytest

import flight_sim_dynamics as fsd
from flight_sim_dynamics.core.vectors import backend
from flight_sim_dynamics.machines.staicu.kinematics import inverse_geometry
from flight_sim_dynamics.machines.staicu.mechanism import (JOINTS, PLATE, PLATE_OUTLINE, SEGMENTS,
                                                           mechanism_points)

MODEL = fsd.load_model()


@pytest.mark.parametrize('q', [(0.0, 0.0, 0.0), (0.05, 0.1, 0.26), (-0.1, -0.05, -0.3)])
def test_points_of_a_pose(q):
    g = inverse_geometry(MODEL, q, backend(False))
    p = {name: np.array(v) for name, v in mechanism_points(MODEL, g).items()}
    assert set(JOINTS) | {'G'} | set(PLATE) | set(PLATE_OUTLINE) <= set(p)
    # G moves by the pose: surge forward (X), heave up (Z), never sideways
    np.testing.assert_allclose(p['G'], [q[0], 0.0, q[1]], rtol=0, atol=1e-12)
    geom = MODEL.geometry
    lengths = dict(zip(fsd.LEG_NAMES, g.length), rod=geom.h, crank_d=geom.l5,
                   crank_e=geom.l6)
    for part, (a, b) in SEGMENTS.items():
        assert abs(np.linalg.norm(p[b] - p[a]) - lengths[part]) < 1e-12, part
    # the plate: h along the rod by b across, a rectangle
    corners = [p[n] for n in PLATE_OUTLINE]
    sides = [np.linalg.norm(corners[i] - corners[i - 1]) for i in range(4)]
    np.testing.assert_allclose(sorted(sides), [geom.b, geom.b, geom.h, geom.h], atol=1e-12)
    # positive roll lowers the right (B, -Y) corner
    assert p['B4'][1] < 0 < p['C4'][1]
    assert np.sign(p['C4'][2] - p['B4'][2]) == np.sign(q[2])
