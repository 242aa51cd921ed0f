"""Whole-machine validation (issue 30), for every registered machine: every
number a machine's file gives is bounded (a mass of 1e308 kg is refused by its
bound, naming its key), and a model whose home pose (q = 0, at rest) does not
solve ok or limit is refused by ``load_model`` and by the node's parameter
path (:meth:`NodeSchema.model`), naming the parameter(s) that make it so and
the file. The hexapods' degenerate geometries of the issue: joints all at one
point, collinear joints, two identical legs, home in the base plane."""
from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml

import flight_sim_dynamics as fsd
from flight_sim_dynamics.config.errors import ParameterError
from flight_sim_dynamics.config.files import PACKAGED_SECTION
from flight_sim_dynamics.config.node_schema import node_schema
from flight_sim_dynamics.config.validation import nested
from flight_sim_dynamics.core.machine import Machine
from flight_sim_dynamics.core.status import Status
from flight_sim_dynamics.machines import MACHINES, STEWART

ROOT = Path(__file__).resolve().parents[2]
CONFIG = ROOT / 'config'
NUMERIC = ('double', 'double_array', 'integer')


def packaged_file(machine: Machine) -> str:
    """The first packaged parameter file of ``machine`` (the 3-DOF machine's:
    config/flight_sim_dynamics.yaml, whose files name no machine)."""
    return machine.parameter_files[0] if machine.parameter_files else 'flight_sim_dynamics'


def schema_of(machine: Machine):
    """The declarations the node and the loaders check ``machine``'s values by."""
    return node_schema(machine.parameter_files[0] if machine.from_params is not None else None)


def write(tmp_path: Path, machine: Machine, values: dict[str, Any], name: str = 'p.yaml',
          packaged: str | None = None) -> Path:
    """A partial file over ``machine``'s packaged file (``packaged``: another of
    them) giving ``values`` (dotted names)."""
    flat = dict(values)
    if machine.from_params is not None:
        flat['machine'] = packaged or packaged_file(machine)
    path = tmp_path / name
    path.write_text(yaml.safe_dump({'flight_sim_dynamics': {'ros__parameters': nested(flat)}}))
    return path


def refused(path: Path) -> ParameterError:
    """load_model(path)'s ParameterError, which names the file."""
    with pytest.raises(ParameterError) as info:
        fsd.load_model(path)
    assert str(path) in str(info.value), str(info.value)
    return info.value


def home(model: Any) -> Any:
    zero = [0.0] * fsd.machine_of(model).dof
    return fsd.solve(model, zero, zero, zero)


# -- bounds -------------------------------------------------------------------------
@pytest.mark.parametrize('machine', MACHINES, ids=lambda m: m.name)
def test_every_number_of_every_machine_has_finite_bounds(machine):
    specs = [s for s in schema_of(machine).model_specs if s.kind in NUMERIC]
    unbounded = [s.name for s in specs
                 if s.minimum is None or s.maximum is None
                 or not (math.isfinite(s.minimum) and math.isfinite(s.maximum))]
    assert specs and not unbounded, unbounded


def _beyond(spec, sign: float) -> Any:
    value = sign * 1.0e308
    return [value] * (spec.length or 1) if spec.kind == 'double_array' else value


@pytest.mark.parametrize('machine', MACHINES, ids=lambda m: m.name)
def test_an_overflowing_value_is_refused_naming_its_key(tmp_path, machine):
    """1e308 (and -1e308 where negative values are allowed): the home pose
    would answer nothing but invalid_input, 0 N."""
    for spec in schema_of(machine).model_specs:
        if spec.kind not in ('double', 'double_array'):
            continue
        for sign in (1.0, -1.0) if spec.minimum is None or spec.minimum < 0 else (1.0,):
            error = refused(write(tmp_path, machine, {spec.name: _beyond(spec, sign)}))
            assert error.key == spec.name, str(error)


@pytest.mark.parametrize('key, value', [
    ('bodies.platform.mass', 1.0e308), ('bodies.cylinder.mass', 1.0e6),
    ('payload.mass', 1.0e308), ('geometry.home', [0.0, 0.0, 1.0e300]),
    ('geometry.platform_joints', [1.0e300] * 18), ('bodies.rod.inertia_across', 1.0e300),
    ('limits.max_force', 1.0e300), ('gravity', 1.0e300)])
def test_a_hexapod_of_overflowing_mass_or_size_is_refused(tmp_path, key, value):
    for name in STEWART.parameter_files:
        error = refused(write(tmp_path, STEWART, {key: value}, packaged=name))
        assert error.key == key, str(error)


# -- the home pose --------------------------------------------------------------------
@pytest.mark.parametrize('machine', MACHINES, ids=lambda m: m.name)
def test_every_packaged_machine_solves_its_home(machine):
    for name in machine.parameter_files or ('flight_sim_dynamics',):
        assert home(fsd.load_model(name)).status == Status.OK, name


@pytest.mark.parametrize('machine', MACHINES, ids=lambda m: m.name)
def test_a_threshold_that_makes_home_near_singular_is_refused(tmp_path, machine):
    """A near-singularity threshold below the home's own condition: every
    solve near_singular."""
    assert 'limits.max_jacobian_condition' in machine.home_parameters
    assert home(fsd.load_model(packaged_file(machine))).jacobian_condition > 1.0
    error = refused(write(tmp_path, machine, {'limits.max_jacobian_condition': 1.0}))
    assert error.key == 'limits.max_jacobian_condition', str(error)
    assert 'near_singular' in error.reason


@pytest.mark.parametrize('machine', MACHINES, ids=lambda m: m.name)
def test_a_home_beyond_a_force_limit_is_accepted(tmp_path, machine):
    """Limits are the user's to choose: the status says limit, the model loads."""
    model = fsd.load_model(write(tmp_path, machine, {'limits.max_force': 0.001}))
    assert home(model).status == Status.LIMIT


def _hexapod(name: str) -> dict[str, np.ndarray]:
    geometry = yaml.safe_load((CONFIG / f'{name}.yaml').read_text())[
        PACKAGED_SECTION]['ros__parameters']['geometry']
    return {key: np.array(value, dtype=float) for key, value in geometry.items()}


def _degenerate(name: str, case: str) -> tuple[dict[str, list], str]:
    """(the geometry of the issue's degenerate hexapod ``case`` over the packaged
    ``name``, the key its refusal names)."""
    g = _hexapod(name)
    base, plat = g['base_joints'].reshape(6, 3), g['platform_joints'].reshape(6, 3)
    if case == 'joints_at_one_point':
        return {'geometry.base_joints': np.tile(base.mean(axis=0), 6)}, 'geometry.base_joints'
    if case == 'collinear_joints':
        line = np.zeros((6, 3))
        line[:, 0] = np.linspace(-1.0, 1.0, 6)
        line[:, 2] = base[:, 2].mean()
        return {'geometry.base_joints': line.ravel()}, 'geometry.base_joints'
    if case == 'two_identical_legs':
        base[1], plat[1] = base[0], plat[0]
        return ({'geometry.base_joints': base.ravel(), 'geometry.platform_joints': plat.ravel()},
                'geometry')
    assert case == 'home_in_the_base_plane'
    at = g['home'].copy()
    at[2] = base[:, 2].mean() - plat[:, 2].mean()
    return {'geometry.home': at}, 'geometry.home'


CASES = ('joints_at_one_point', 'collinear_joints', 'two_identical_legs',
         'home_in_the_base_plane')


@pytest.mark.parametrize('case', CASES)
@pytest.mark.parametrize('name', STEWART.parameter_files)
def test_a_degenerate_hexapod_is_refused_by_load_model(tmp_path, name, case):
    values, key = _degenerate(name, case)
    path = write(tmp_path, STEWART, {k: v.tolist() for k, v in values.items()},
                 packaged=name)
    error = refused(path)
    assert error.key == key, str(error)
    assert 'near_singular' in error.reason


@pytest.mark.parametrize('case', CASES)
def test_a_degenerate_hexapod_of_ones_own_names_its_geometry(tmp_path, case):
    """A machine of one's own gives every value: its geometry is blamed."""
    tree = yaml.safe_load((CONFIG / 'stewart_6dof.yaml').read_text())
    params = tree[PACKAGED_SECTION]['ros__parameters']
    params['machine'] = 'stewart'       # a hexapod of one's own: its kind's name
    values, _ = _degenerate('stewart_6dof', case)
    for key, value in values.items():
        params['geometry'][key.split('.')[1]] = value.tolist()
    path = tmp_path / 'mine.yaml'
    path.write_text(yaml.safe_dump(tree))
    assert refused(path).key == 'geometry'


@pytest.mark.parametrize('case', CASES)
def test_a_degenerate_runtime_set_is_refused_naming_the_set_parameter(case):
    """The node's parameter path (NodeSchema.model with the names a set
    changes): the packaged values with the set applied."""
    schema = node_schema('stewart_6dof')
    values, key = _degenerate('stewart_6dof', case)
    new = {**schema.defaults, **{k: v.tolist() for k, v in values.items()}}
    with pytest.raises(ParameterError) as info:
        schema.model(new, list(values))
    assert info.value.key == key, str(info.value)
    assert "the node's parameters" in str(info.value)
    schema.model(dict(schema.defaults), list(values))    # the values before: a model


@pytest.mark.parametrize('machine', MACHINES, ids=lambda m: m.name)
def test_a_runtime_threshold_making_home_near_singular_is_refused(machine):
    schema = schema_of(machine)
    values = {**schema.defaults, 'limits.max_jacobian_condition': 1.0}
    with pytest.raises(ParameterError) as info:
        schema.model(values, ['limits.max_jacobian_condition'])
    assert info.value.key == 'limits.max_jacobian_condition', str(info.value)
