"""The command line's column names come from each machine's record
(cli/columns.py): the 3-DOF machine's are those its files have always had,
a hexapod's those of its legs 1-6, and every machine's record names fields
its solution has."""
from __future__ import annotations

import numpy as np
import pytest

import flight_sim_dynamics as fsd
from flight_sim_dynamics.cli import columns
from flight_sim_dynamics.machines import MACHINES


def test_the_3dof_columns_are_unchanged():
    assert columns.TRAJECTORY_COLUMNS == (
        't', 'surge', 'heave', 'roll', 'surge_rate', 'heave_rate', 'roll_rate',
        'surge_acc', 'heave_acc', 'roll_acc')
    legs = [f'{field}_{leg}' for field in ('length', 'stroke', 'rate', 'force', 'power',
                                           'acceleration') for leg in 'abc']
    assert columns.OUTPUT_COLUMNS == ('t', *legs, 'beta', 'kinematic_condition',
                                      'jacobian_condition')
    assert columns.PLOT_COLUMNS == ('t', 'force_a', 'force_b', 'force_c', 'power_a',
                                    'power_b', 'power_c')
    assert columns.JOINT_COLUMNS[:3] == ('phi_10_A', 'lambda_21_A', 'phi_32_A')
    assert len(columns.JOINT_COLUMNS) == 36 and columns.JOINT_COLUMNS[-1] == 'lambda_E2_acc'


def test_a_hexapods_columns_are_its_six_coordinates_and_legs():
    hexapod = fsd.machine_of(fsd.load_model('config/stewart_6dof.yaml'))
    coordinates = ('surge', 'sway', 'heave', 'roll', 'pitch', 'yaw')
    assert columns.trajectory_columns(hexapod) == (
        't', *coordinates, *(f'{c}_rate' for c in coordinates),
        *(f'{c}_acc' for c in coordinates))
    out = columns.output_columns(hexapod)
    assert out[:7] == ('t', *(f'length_{i}' for i in range(1, 7)))
    assert len(out) == 1 + 6 * 6 + 1 and out[-1] == 'jacobian_condition'
    assert len(set(out)) == len(out)
    assert len(columns.joint_columns(hexapod)) == 3 * 18


@pytest.mark.parametrize('machine', MACHINES, ids=lambda m: m.name)
def test_every_machine_names_what_its_solution_has(machine):
    assert machine.title and len(machine.leg_labels) == len(machine.legs)
    assert set(machine.examples) <= set(machine.motions)
    model = fsd.load_model(None if machine.from_params is None
                           else f'config/{machine.parameter_files[0]}.yaml')
    assert fsd.machine_of(model) is machine
    t, q, qd, qdd = machine.motions[machine.examples[0]].sampled(10.0)
    sol = fsd.solve_batch(model, q, qd, qdd)
    for field in columns.PER_LEG_FIELDS:
        assert np.shape(getattr(sol, field)) == (t.size, len(machine.legs))
    for field in machine.sample_fields + machine.costly_fields:
        assert np.shape(getattr(sol, field)) == (t.size,)
    for field in ('joints', 'joint_rates', 'joint_accelerations'):
        assert np.size(getattr(sol, field)) == t.size * len(machine.joints)


def test_machine_of_columns_picks_the_machine_with_most_of_them():
    default, hexapod = MACHINES[0], fsd.machine_of(fsd.load_model('config/stewart_6dof.yaml'))
    assert columns.machine_of_columns(['t', 'force_a', 'force_b', 'force_c'], 'force') is default
    assert columns.machine_of_columns(['force_1', 'force_4'], 'force') is hexapod
    assert columns.machine_of_columns(['t'], 'force') is default
