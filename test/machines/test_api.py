"""The public API serves both machines through one interface: fsd.load_model,
solve, solve_batch, forward_kinematics, forward_dynamics, machine_of; the
results are the machine's own, bit for bit (the 3-DOF machine's unchanged)."""
from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

import flight_sim_dynamics as fsd
from flight_sim_dynamics.config.machine_files import packaged_path
from flight_sim_dynamics.core.kernel import use_kernel
from flight_sim_dynamics.core.machine import Machine
from flight_sim_dynamics.machines import FLIGHT_SIMULATOR, MACHINES, STEWART
from flight_sim_dynamics.machines.staicu import forward_dynamics as staicu_fd
from flight_sim_dynamics.machines.staicu import forward_kinematics as staicu_fk
from flight_sim_dynamics.machines.staicu import solver as staicu_solver
from flight_sim_dynamics.machines.staicu.model import Model
from flight_sim_dynamics.machines.stewart import forward_dynamics as stewart_fd
from flight_sim_dynamics.machines.stewart import kinematics as stewart_kinematics
from flight_sim_dynamics.machines.stewart import solver as stewart_solver
from flight_sim_dynamics.machines.stewart.model import StewartModel

CONFIG = Path(__file__).resolve().parents[2] / 'config'
DOC = (Path(__file__).resolve().parents[2] / 'docs' / 'design' / 'stewart.md').read_text()
HEXAPODS = ('stewart_6dof', 'stewart_tsai2000')


def hexapod(name: str = 'stewart_6dof', scene: str | None = None) -> StewartModel:
    return fsd.load_model(CONFIG / f'{name}.yaml', scene=scene)


def motions(dof: int, n: int, seed: int, scale: float = 0.05) -> tuple[np.ndarray, ...]:
    """n random samples (q, qd, qdd) about home, small enough to be reachable."""
    rng = np.random.default_rng(seed)
    return (scale * rng.uniform(-1, 1, (n, dof)), 10 * scale * rng.uniform(-1, 1, (n, dof)),
            100 * scale * rng.uniform(-1, 1, (n, dof)))


def same(a: object, b: object) -> bool:
    """Equal, floats bit for bit (NaN equal to itself, -0.0 not equal to 0.0)."""
    if isinstance(a, (np.ndarray, float, np.floating)) and np.asarray(a).dtype.kind == 'f':
        x, y = np.asarray(a), np.asarray(b)
        return x.shape == y.shape and x.dtype == y.dtype and x.tobytes() == y.tobytes()
    if isinstance(a, np.ndarray):
        return a.shape == np.shape(b) and a.tolist() == np.asarray(b).tolist()
    return type(a) is type(b) and a == b


def same_model(a: object, b: object) -> bool:
    """Two models (or their parts) equal field by field, arrays bit for bit."""
    if dataclasses.is_dataclass(a):
        return type(a) is type(b) and all(same_model(getattr(a, f.name), getattr(b, f.name))
                                           for f in dataclasses.fields(a))
    return same(a, b) if isinstance(a, (np.ndarray, float)) else a == b


def assert_same(a: object, b: object) -> None:
    """Two results of the same type, every field the same (the model aside)."""
    assert type(a) is type(b)
    for f in dataclasses.fields(a):
        if f.name != 'model':
            assert same(getattr(a, f.name), getattr(b, f.name)), f.name


# -- the user story ---------------------------------------------------------------
def test_the_user_story_of_the_hexapod(monkeypatch):
    monkeypatch.chdir(CONFIG.parent)
    hexa = fsd.load_model('config/stewart_6dof.yaml')
    assert isinstance(hexa, StewartModel) and hexa.name == 'stewart_6dof'
    zero = [0.0] * 6
    sol = fsd.solve(hexa, zero, zero, zero)
    assert sol.status == fsd.Status.OK and sol.force.shape == (6,)
    q, qd, qdd = motions(6, 20, seed=1)
    batch = fsd.solve_batch(hexa, q, qd, qdd)
    assert batch.force.shape == (20, 6) and all(s == fsd.Status.OK for s in batch.status)
    fk = fsd.forward_kinematics(hexa, batch.length[3], zero)
    assert fk.status == fsd.Status.OK
    np.testing.assert_allclose(fk.pose, q[3], atol=1e-9)
    fd = fsd.forward_dynamics(hexa, q[3], qd[3], batch.force[3])
    np.testing.assert_allclose(fd.acceleration, qdd[3], rtol=1e-8, atol=1e-8)
    m3 = fsd.load_model()
    assert isinstance(m3, Model)
    assert_same(fsd.solve(m3, [0, 0, 0], [0, 0, 0], [0, 0, 0]),
                staicu_solver.solve(m3, [0, 0, 0], [0, 0, 0], [0, 0, 0]))


def test_the_check_values_through_the_api():
    """stewart.md's forces at rest at home, scene full (no payload)."""
    text = DOC.split('## Check values', 1)[1]
    full = text.split('`f = (', 1)[1].split(')', 1)[0]
    expected = [float(x) for x in full.split(',')]
    sol = fsd.solve(hexapod(), [0.0] * 6, [0.0] * 6, [0.0] * 6)
    np.testing.assert_allclose(sol.force, expected, atol=1e-6)


@pytest.mark.parametrize('name', HEXAPODS)
def test_the_installed_file_is_the_machine_of_the_same_name(name):
    """The packaged file found as the installed one (next to the 3-DOF file)."""
    assert packaged_path(name).is_file()
    model = fsd.load_model(packaged_path(name))
    assert same_model(model, hexapod(name))
    assert model.name == name


# -- the machines -----------------------------------------------------------------
def test_machine_of_finds_each_models_machine():
    assert fsd.machine_of(fsd.load_model()) is FLIGHT_SIMULATOR
    assert fsd.machine_of(hexapod()) is STEWART
    assert isinstance(fsd.machine_of(hexapod()), fsd.Machine)


@pytest.mark.parametrize('thing', [None, 'config/stewart_6dof.yaml', {'machine': 'x'}, 3.0])
def test_anything_but_a_model_is_refused_naming_what_it_got(thing):
    for call in (lambda: fsd.machine_of(thing),
                 lambda: fsd.solve(thing, [0] * 3, [0] * 3, [0] * 3),
                 lambda: fsd.solve_batch(thing, np.zeros((1, 3)), np.zeros((1, 3)),
                                         np.zeros((1, 3))),
                 lambda: fsd.forward_kinematics(thing, [1.0] * 3),
                 lambda: fsd.forward_dynamics(thing, [0] * 3, [0] * 3, [0] * 3)):
        with pytest.raises(TypeError, match=type(thing).__name__):
            call()


def test_a_subclass_of_a_model_belongs_to_its_machine():
    class Mine(StewartModel):
        pass

    base = hexapod()
    mine = Mine(**{f.name: getattr(base, f.name) for f in dataclasses.fields(base) if f.init})
    assert fsd.machine_of(mine) is STEWART
    assert_same(fsd.solve(mine, [0.01] * 6, [0.0] * 6, [0.0] * 6),
                stewart_solver.solve(mine, [0.01] * 6, [0.0] * 6, [0.0] * 6))


@pytest.mark.parametrize('machine, model', [(FLIGHT_SIMULATOR, fsd.load_model()),
                                            (STEWART, hexapod())], ids=['3dof', 'hexapod'])
def test_each_machine_describes_its_solutions(machine: Machine, model):
    """Names and sizes the shared layer relies on, as the machine's solutions have them."""
    assert machine.dof == len(machine.coordinates) == len(machine.units) == len(machine.legs)
    assert set(machine.units) <= {'m', 'rad'}
    assert len(set(machine.joints)) == len(machine.joints)
    zero = [0.0] * machine.dof
    sol = fsd.solve(model, zero, zero, zero)
    assert sol.force.shape == sol.length.shape == (len(machine.legs),)
    assert sol.joints.size == len(machine.joints)
    limits = machine.actuator_limits(model)
    assert limits.stroke_min.shape == limits.stroke_max.shape == (len(machine.legs),)
    assert np.all(limits.stroke_min < sol.stroke) and np.all(sol.stroke < limits.stroke_max)


@pytest.mark.parametrize('machine, model', [(FLIGHT_SIMULATOR, fsd.load_model()),
                                            (STEWART, hexapod())], ids=['3dof', 'hexapod'])
def test_actuator_limits_are_where_the_status_turns_to_limit(machine: Machine, model):
    """Heave the platform at rest through the strokes: a reachable pose has the
    status limit exactly when a stroke is outside the machine's actuator limits."""
    limits = machine.actuator_limits(model)
    q = np.zeros((400, machine.dof))
    q[:, machine.coordinates.index('heave')] = np.linspace(-0.6, 0.8, 400)
    rest = np.zeros_like(q)
    sol = fsd.solve_batch(model, q, rest, rest)
    outside = ((sol.stroke < limits.stroke_min) | (sol.stroke > limits.stroke_max)).any(axis=1)
    judged = np.array([s in (fsd.Status.OK, fsd.Status.LIMIT) for s in sol.status])
    at_limit = np.array([s == fsd.Status.LIMIT for s in sol.status])
    assert outside[judged].any() and not outside[judged].all()
    assert np.array_equal(at_limit[judged], outside[judged])


def test_the_3dof_joint_names_are_the_nodes():
    assert FLIGHT_SIMULATOR.joints == fsd.JOINT_NAMES and FLIGHT_SIMULATOR.legs == fsd.LEG_NAMES


def test_every_machine_is_registered_once_by_its_model_type():
    types = [m.model_type for m in MACHINES]
    assert len(set(types)) == len(types) and MACHINES[0] is FLIGHT_SIMULATOR


# -- dispatch: the machine's own results, bit for bit ----------------------------------
def cases(dof: int) -> list[tuple]:
    """Samples (q, qd, qdd) as lists: random reachable ones, then a pose out of
    reach, a violent motion and non-finite numbers (each with its own status)."""
    q, qd, qdd = motions(dof, 12, seed=dof)
    rows = list(zip(q.tolist(), qd.tolist(), qdd.tolist()))
    far, fast, bad = [0.0] * dof, [0.0] * dof, [0.0] * dof
    far[1], fast[0], bad[-1] = 3.0, 500.0, float('nan')
    return rows + [(far, [0.0] * dof, [0.0] * dof), ([0.0] * dof, fast, fast),
                   ([0.0] * dof, bad, [0.0] * dof)]


DIRECT = {'3dof': (fsd.load_model, staicu_solver, staicu_fk.forward_kinematics,
                   staicu_fd.forward_dynamics),
          'hexapod': (hexapod, stewart_solver, stewart_kinematics.forward_kinematics,
                      stewart_fd.forward_dynamics)}


@pytest.mark.parametrize('kernel', [True, False], ids=['kernel', 'python'])
@pytest.mark.parametrize('machine', sorted(DIRECT))
def test_solve_is_the_machines_solve_bit_for_bit(machine, kernel):
    load, solver, _, _ = DIRECT[machine]
    model = load()
    dof = fsd.machine_of(model).dof
    statuses = set()
    with use_kernel(kernel):
        for q, qd, qdd in cases(dof):
            sol = fsd.solve(model, q, qd, qdd)
            assert_same(sol, solver.solve(model, q, qd, qdd))
            statuses.add(sol.status)
        q, qd, qdd = (np.array(a) for a in zip(*cases(dof)))
        assert_same(fsd.solve_batch(model, q, qd, qdd), solver.solve_batch(model, q, qd, qdd))
    assert {fsd.Status.OK, fsd.Status.INVALID_INPUT} <= statuses and len(statuses) >= 3


@pytest.mark.parametrize('machine', sorted(DIRECT))
def test_forward_kinematics_and_dynamics_are_the_machines_bit_for_bit(machine):
    load, solver, forward_kinematics, forward_dynamics = DIRECT[machine]
    model = load()
    dof = fsd.machine_of(model).dof
    for q, qd, qdd in cases(dof)[:4]:
        sol = solver.solve(model, q, qd, qdd)
        start = [0.01] * dof
        assert_same(fsd.forward_kinematics(model, sol.length),
                    forward_kinematics(model, sol.length))
        assert_same(fsd.forward_kinematics(model, sol.length, start, tolerance=1e-10),
                    forward_kinematics(model, sol.length, start, tolerance=1e-10))
        assert_same(fsd.forward_kinematics(model, sol.length, initial=start, max_iterations=2),
                    forward_kinematics(model, sol.length, initial=start, max_iterations=2))
        assert_same(fsd.forward_dynamics(model, q, qd, sol.force),
                    forward_dynamics(model, q, qd, sol.force))


@pytest.mark.parametrize('machine', sorted(DIRECT))
def test_arguments_of_the_other_machines_size_are_the_machines_value_error(machine):
    model = DIRECT[machine][0]()
    other = 9 - fsd.machine_of(model).dof          # 3 numbers for a hexapod, 6 for the 3-DOF
    wrong, rows = [0.0] * other, np.zeros((2, other))
    for call in (lambda: fsd.solve(model, wrong, wrong, wrong),
                 lambda: fsd.solve_batch(model, rows, rows, rows),
                 lambda: fsd.forward_kinematics(model, [1.0] * other),
                 lambda: fsd.forward_dynamics(model, wrong, wrong, wrong)):
        with pytest.raises(ValueError):
            call()


@pytest.mark.parametrize('machine', sorted(DIRECT))
@pytest.mark.parametrize('options', [
    {'tolerance': float('inf')}, {'tolerance': float('nan')}, {'tolerance': 0.0},
    {'tolerance': -1e-9}, {'tolerance': None}, {'tolerance': '1e-9'}, {'tolerance': True},
    {'max_iterations': -5}, {'max_iterations': 0}, {'max_iterations': None},
    {'max_iterations': 2.0}, {'max_iterations': True}, {'max_iterations': '10'},
], ids=repr)
def test_bad_forward_kinematics_options_are_a_value_error_on_either_machine(machine, options):
    """Issue 29: tolerance=inf returned ok for any lengths, a negative max_iterations
    reported "after -5 iterations", None raised TypeError."""
    load, solver, forward_kinematics, _ = DIRECT[machine]
    model = load()
    dof = fsd.machine_of(model).dof
    lengths = solver.solve(model, [0.01] * dof, [0.0] * dof, [0.0] * dof).length
    for call in (fsd.forward_kinematics, forward_kinematics):
        with pytest.raises(ValueError) as info:
            call(model, lengths, **options)
        assert type(info.value) is ValueError
        assert next(iter(options)) in str(info.value)
    # the same call with good options of the same kinds solves
    good = {'tolerance': 1e-10, 'max_iterations': 50}
    assert fsd.forward_kinematics(model, lengths, **good).status == fsd.Status.OK
