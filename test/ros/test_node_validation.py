"""Whole-machine validation at run time (issue 30), over DDS on a hexapod node
(``--params-file config/stewart_6dof.yaml``): a set that would make the home
pose near_singular (``geometry.home [0, 0, 0]``: every leg in the base plane)
and sets beyond a bound (``bodies.platform.mass 1e308``, ``geometry.home
[0, 0, 1e300]``) are refused; the node then answers a setpoint as before; and
``parameter changes rejected`` on /diagnostics counts every refused set,
whatever refused it (the request's type or bound check, rclpy's read-only and
undeclared names, the node's whole-model check; a SetParameters of several
parameters counts each one refused, a SetParametersAtomically one)."""
from __future__ import annotations

import numpy as np
import pytest
from rcl_interfaces.srv import DescribeParameters

import flight_sim_dynamics as fsd
from node_harness import ROOT, Client
import test_node_hexapod
from test_node_hexapod import answer, assert_solved, motion, publish, stamps, twist_of

pytestmark = pytest.mark.ros

HEXAPOD_FILE = ROOT / 'config' / 'stewart_6dof.yaml'
REJECTED = 'parameter changes rejected'
# the hexapod node and its client: test_node_hexapod's fixtures (one per module)
hexapod, client = test_node_hexapod.hexapod, test_node_hexapod.client


def solved_setpoint(client: Client, model) -> None:
    """One moving setpoint, answered with fsd.solve's numbers for ``model``."""
    q, qd, qdd = motion(0.3)
    twist, accel = twist_of(q, qd, qdd)
    [stamp] = stamps(1)
    publish(client, stamp, q, twist, accel)
    msgs = answer(client, stamp)
    assert msgs is not None, 'not answered' + client.explain()
    assert_solved(msgs, fsd.solve(model, q, qd, qdd))


#: (parameters of one request, atomic?, refused sets it counts, a word of the reason)
REFUSED_SETS = [
    ({'geometry.home': [0.0, 0.0, 0.0]}, False, 1, 'near_singular'),     # the home check
    ({'geometry.home': [0.0, 0.0, 0.0]}, True, 1, 'near_singular'),
    ({'limits.max_jacobian_condition': 1.0}, False, 1, 'near_singular'),
    ({'bodies.platform.mass': 1.0e308}, False, 1, '<= 100000'),          # out of range
    ({'geometry.home': [0.0, 0.0, 1.0e300]}, False, 1, '<= 100'),
    ({'bodies.platform.mass': 'heavy'}, False, 1, 'expected a number'),  # wrong type
    ({'machine': 'stewart_tsai2000'}, False, 1, 'read-only'),
    ({'no_such.parameter': 1.0}, False, 1, 'not declared'),
    # two refused in one SetParameters (sorted out: the callback runs for each try)
    ({'bodies.platform.mass': -1.0, 'geometry.home': [0.0, 0.0, 0.0]}, False, 2, '> 0'),
    ({'bodies.platform.mass': 1.0e308, 'gravity': 9.0}, True, 1, '<= 100000'),
]


def test_refused_sets_leave_the_node_as_it_was_and_are_all_counted(client):
    model = fsd.load_model(HEXAPOD_FILE)
    solved_setpoint(client, model)
    before = client.wait_diagnostics(lambda v: REJECTED in v)
    assert before[REJECTED] == '0', before
    names = ['geometry.home', 'bodies.platform.mass', 'gravity',
             'limits.max_jacobian_condition']
    values = client.get_params(names)
    expected = 0
    for params, atomic, count, word in REFUSED_SETS:
        results = client.set_params(params, atomic=atomic)
        assert all(not r.successful for r in results), (params, results)
        assert word in results[0].reason, (params, results[0].reason)
        expected += count
    after = client.get_params(names)
    assert [np.asarray(v).tolist() for v in after] == [np.asarray(v).tolist() for v in values]
    solved_setpoint(client, model)
    counted = client.wait_diagnostics(lambda v: int(v[REJECTED]) >= expected)
    assert int(counted[REJECTED]) == expected, counted
    assert counted['parameter changes accepted'] == before['parameter changes accepted']


def test_an_accepted_set_after_the_refusals_still_changes_the_model(client, tmp_path):
    [result] = client.set_params({'geometry.home': [0.0, 0.0, 1.05]})
    assert result.successful, result.reason
    path = tmp_path / 'raised.yaml'
    path.write_text('flight_sim_dynamics:\n  ros__parameters:\n    machine: stewart_6dof\n'
                    '    geometry:\n      home: [0.0, 0.0, 1.05]\n')
    solved_setpoint(client, fsd.load_model(path))
    [back] = client.set_params({'geometry.home': [0.0, 0.0, 1.0]})
    assert back.successful, back.reason


def test_the_bounds_are_declared_in_the_descriptors(client):
    """``ros2 param describe``: a double's bound is its range, an array's in
    its description (a descriptor's floating_point_range bounds doubles only)."""
    response = client.call('describe', DescribeParameters.Request(
        names=['bodies.platform.mass', 'geometry.home']))
    mass, home = response.descriptors
    assert mass.floating_point_range[0].to_value == 1.0e5
    assert 'each number in [-100, 100]' in home.description, home.description
