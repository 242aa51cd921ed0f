"""The hexapod's compiled kernel (machines/stewart/kernel.c) against the numpy
reference code.

The rest of the hexapod's tests (check values, the independent reference,
the power balance, hard cases) run on whatever ``solver.solve`` uses, the
kernel when it is built. Here the two implementations are compared directly:
random reachable motions, gentle and violent, both hexapods, every effect
set with friction parameters on, every status and detail, single and batch.
"""
from __future__ import annotations

import dataclasses
import itertools
import math
import os
import re
from types import SimpleNamespace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from flight_sim_dynamics.core.effects import EFFECT_NAMES, Effects
from flight_sim_dynamics.core.kernel import use_kernel
from flight_sim_dynamics.core.status import SINGULAR, Status
from flight_sim_dynamics.machines.stewart import kernel, solver
from flight_sim_dynamics.machines.stewart import model as sm

from stewart_cases import MACHINES, MOTIONS, model_of, random_motion

NAMES = sorted(MACHINES)
Z6 = (0.0,) * 6
NUMBERS = ('length', 'stroke', 'rate', 'acceleration', 'force', 'power', 'joints',
           'joint_rates', 'joint_accelerations', 'spherical_angles', 'jacobian',
           'twist_jacobian', 'jacobian_condition')
#: what does not go through J^-1: exact even at a singularity
POSITIONS = ('length', 'stroke', 'joints', 'spherical_angles', 'jacobian', 'twist_jacobian')
EVERY_EFFECTS = [Effects(**dict(zip(EFFECT_NAMES, bits)))
                 for bits in itertools.product((False, True), repeat=len(EFFECT_NAMES))]

needs_kernel = pytest.mark.skipif(
    not kernel.available() and os.environ.get('FSD_REQUIRE_KERNEL') != '1',
    reason='the hexapod kernel is not built (FSD_REQUIRE_KERNEL=1 makes this an error)')


def _rubbing(model: sm.StewartModel) -> sm.StewartModel:
    """The machine with friction parameters (the shipped files have none) and
    an off-centre payload of full inertia."""
    friction = sm.Friction(viscous=np.linspace(800.0, 1300.0, 6),
                           coulomb=np.linspace(30.0, 80.0, 6), smoothing_velocity=0.01)
    mass = 80.0 if model.name == 'stewart_6dof' else 0.7
    return dataclasses.replace(model, friction=friction).with_payload(
        mass, (0.1, -0.05, 0.4), (6.0, 0.5, -0.3, 0.5, 8.0, 0.2, -0.3, 0.2, 9.0))


MODELS = {name: _rubbing(model_of(name)) for name in NAMES}
MODEL = MODELS['stewart_6dof']


def test_the_kernel_is_built():
    """A failed build is a failure when FSD_REQUIRE_KERNEL=1 (CI, benchmarks)."""
    if not kernel.available() and os.environ.get('FSD_REQUIRE_KERNEL') != '1':
        pytest.skip(f'the hexapod kernel is not built: {kernel.IMPORT_ERROR}')
    assert kernel.available(), kernel.IMPORT_ERROR


def both(model, *args):
    """One sample through the kernel and through the numpy code."""
    with use_kernel(True):
        fast = solver.solve(model, *args)
    with use_kernel(False):
        slow = solver.solve(model, *args)
    return fast, slow


def _words(detail: str) -> str:
    return re.sub(r'[-+0-9.e]+', '#', detail)


def assert_same(fast, slow, index=None):
    """Same status and detail; every number to 1e-12 relative to its field's
    largest entry, at least 1 (a stroke at home is round-off), times cond / 100
    beyond a condition of 100 (the forces go
    through J^-1); beyond a condition of 1e12 what goes through J^-1 is
    round-off noise: the positions are compared, and the detail's words.
    """
    pick = (lambda a: a) if index is None else (lambda a: a[index])
    status, cond = pick(slow.status), float(pick(slow.jacobian_condition))
    assert pick(fast.status) == status, (pick(fast.detail), pick(slow.detail))
    names = NUMBERS
    if cond < 1e12:
        assert pick(fast.detail) == pick(slow.detail)
    else:
        assert _words(pick(fast.detail)) == _words(pick(slow.detail))
        names = POSITIONS
    rtol = 1e-12 * max(1.0, cond / 100.0)
    for name in names:
        a = np.asarray(pick(getattr(fast, name)), dtype=float)
        b = np.asarray(pick(getattr(slow, name)), dtype=float)
        assert np.all(np.isfinite(a)), name
        np.testing.assert_allclose(a, b, rtol=0, atol=rtol * max(1.0, float(np.abs(b).max())),
                                   err_msg=name)


def assert_same_rows(fast, slow):
    """:func:`assert_same` for every row of two batches, by its rule, in whole
    arrays (row by row it took most of this file's time); a row that differs
    is then reported by :func:`assert_same`."""
    n = len(slow.status)
    cond = np.asarray(slow.jacobian_condition, dtype=float).reshape(n)
    ok = np.array([a == b for a, b in zip(fast.status, slow.status)]) & (len(fast.status) == n)
    ok &= [fd == sd if c < 1e12 else _words(fd) == _words(sd)
           for fd, sd, c in zip(fast.detail, slow.detail, cond)]
    rtol = 1e-12 * np.fmax(1.0, cond / 100.0)          # fmax: max(1.0, x) of a NaN is 1.0
    for name in NUMBERS:
        a = np.asarray(getattr(fast, name), dtype=float)
        b = np.asarray(getattr(slow, name), dtype=float)
        if a.shape != b.shape:
            ok[:] = False
            break
        a, b = a.reshape(n, -1), b.reshape(n, -1)
        with np.errstate(over='ignore'):             # inf past a condition of ~1e300, as before
            atol = rtol * np.fmax(1.0, np.abs(b).max(axis=1, initial=0.0))
        close = np.all(np.isfinite(a), axis=1) & np.all(np.abs(a - b) <= atol[:, None], axis=1)
        compared = cond < 1e12 if name not in POSITIONS else np.ones(n, dtype=bool)
        ok &= close | ~compared
    for i in np.flatnonzero(~ok):
        assert_same(fast, slow, index=i)
        raise AssertionError(f'row {i}: not the same by the rule of assert_same')


# ---------------------------------------------------------------------------
# kernel == numpy
# ---------------------------------------------------------------------------

def _motion(kind: str):
    pose, rate, acc = MOTIONS[kind]
    return st.tuples(*(st.tuples(*[st.floats(-s, s)] * 6) for s in (pose, 3 * rate, 3 * acc)))


@needs_kernel
def test_any_motion_any_effects_single(sweep):
    """Random motions (gentle and violent, reachable or not), either hexapod,
    any of the 128 effect sets with friction parameters and a payload: the
    kernel's status, detail and numbers are the numpy code's."""
    @settings(max_examples=sweep(400), deadline=None)
    @given(st.sampled_from(NAMES), st.sampled_from(('gentle', 'violent')).flatmap(_motion),
           st.sampled_from(EVERY_EFFECTS))
    def check(name, motion, effects):
        model = MODELS[name].with_effects(effects)
        fast, slow = both(model, *motion)
        assert_same(fast, slow)

    check()


@needs_kernel
@pytest.mark.parametrize('name', NAMES)
@pytest.mark.parametrize('effects', EVERY_EFFECTS, ids=lambda e: '+'.join(e.enabled()) or 'none')
def test_every_effect_set_in_motion(name, effects):
    """Each effect set on 40 violent and gentle samples (a batch): kernel =
    numpy; and the forces depend on the set (none is computed as another)."""
    model = MODELS[name].with_effects(effects)
    q, qd, qdd = (np.concatenate(parts) for parts in zip(random_motion(5, 'gentle'),
                                                          random_motion(6, 'violent')))
    with use_kernel(True):
        fast = solver.solve_batch(model, q, qd, qdd)
    with use_kernel(False):
        slow = solver.solve_batch(model, q, qd, qdd)
    assert_same_rows(fast, slow)
    if not (effects.gravity or effects.platform_inertia or effects.leg_inertia
            or effects.payload or effects.friction):
        assert np.all(fast.force == 0.0)
    else:
        assert np.any(fast.force != 0.0)


@needs_kernel
def test_each_effect_changes_the_kernel_result():
    """Switching any effect with terms off changes a moving pose's forces (the
    kernel reads the bits; crank_inertia has nothing to act on)."""
    q, qd, qdd = (0.05, -0.03, 0.1, 0.1, -0.05, 0.2), (0.3, -0.2, 0.5, 0.4, 0.3, -0.2), \
        (2.0, 1.0, -3.0, 4.0, -2.0, 1.0)
    full = MODEL.with_effects(Effects(payload=True, friction=True))
    base = solver.solve(full, q, qd, qdd).force
    for name in EFFECT_NAMES:
        other = solver.solve(full.with_effects(full.effects.without(name)), q, qd, qdd).force
        if name == 'crank_inertia':
            np.testing.assert_array_equal(other, base)
        else:
            assert np.max(np.abs(other - base)) > 1e-6, name


# ---------------------------------------------------------------------------
# statuses and details
# ---------------------------------------------------------------------------

Z = (0.0,) * 6


def _row(q=Z, qd=Z, qdd=Z):
    return tuple(map(tuple, (q, qd, qdd)))


def _leg_on_its_axis(model, leg):
    target = model.base_joints[leg] + 1.2 * model.base_axes[leg]
    return tuple(target - model.home - model.platform_joints[leg]) + (0.0,) * 3


def _zero_length(model, leg):
    return tuple(model.base_joints[leg] - model.home - model.platform_joints[leg]) + (0.0,) * 3


STATUS_ROWS = [   # one per status and detail the kernel produces (default machine)
    _row((0.02, -0.01, 0.03, 0.02, -0.01, 0.05), (0.1, 0.0, -0.1, 0.05, 0.0, 0.1)),
    _row((0.0, math.nan, 0.0, 0.0, 0.0, 0.0)),
    _row(qd=(0.0, 0.0, 0.0, 0.0, math.inf, 0.0)),
    _row(qdd=(-math.inf, 0.0, 0.0, 0.0, 0.0, 0.0)),
    _row(qd=(1e200,) * 6),                                  # results overflow
    _row(_zero_length(MODEL, 3)),                           # leg 4: zero length
    _row(_leg_on_its_axis(MODEL, 0), (1.0,) * 6, (1.0,) * 6),  # leg 1: singular U-joint
    _row((1e300, 0.0, 0.0, 0.0, 0.0, 0.0)),                 # position not finite
    _row((0.0, 0.0, 0.25, 0.0, 0.0, 0.0)),                  # stroke
    _row(qd=(0.0, 0.0, 2.5, 0.0, 0.0, 0.0)),                # speed
    _row(qdd=(0.0, 0.0, 300.0, 0.0, 0.0, 0.0)),             # force
    _row((0.0, 0.0, -0.995, 0.0, 0.0, 0.0), (1.0,) * 6, (1.0,) * 6),  # near singular
    _row((0.0, 0.0, -1.0, 0.0, 0.0, 0.0), (1.0,) * 6, (1.0,) * 6),    # exact singularity
    _row((0.0, 0.0, 0.2, 0.0, math.pi / 2, 0.0), (0.1,) * 6, (0.1,) * 6),  # pitch 90 deg
    _row((0.01, 0.0, 0.0, 0.0, 0.0, 1e6), (0.1,) * 6, (0.1,) * 6),    # large yaw
    _row((1e-300, -0.0, 5e-324, 0.0, 0.0, 0.0), (5e-324,) * 6, (-1e-300,) * 6),
]


def _limited(model, **limits):
    return dataclasses.replace(model, limits=dataclasses.replace(model.limits, **limits))


JOINT_LIMITS = _limited(MODEL, u_joint_max_angle=math.radians(30.0),
                        spherical_joint_max_angle=0.7)
JOINT_ROWS = [_row((0.1, 0.0, 0.0, 0.0, 0.0, 0.0)),      # U-joint angle
              _row((0.0, 0.0, 0.0, 0.3, 0.0, 0.0))]      # spherical joint angle


@needs_kernel
@pytest.mark.parametrize('model, row', [(MODEL, r) for r in STATUS_ROWS]
                         + [(JOINT_LIMITS, r) for r in JOINT_ROWS], ids=repr)
def test_every_status_single(model, row):
    """Each status and detail is the same through the kernel and the numpy code."""
    fast, slow = both(model, *row)
    assert_same(fast, slow)


def test_status_rows_cover_every_status_and_detail():
    """STATUS_ROWS reach every status of a solve and every kind of detail."""
    solutions = [solver.solve(MODEL, *row) for row in STATUS_ROWS]
    solutions += [solver.solve(JOINT_LIMITS, *row) for row in JOINT_ROWS]
    assert {sol.status for sol in solutions} == set(Status) - {Status.NOT_CONVERGED}
    for words in ('q[1] (sway)', 'qd[4] (pitch)', 'qdd[0] (surge)', 'results are not finite',
                  'leg 4: degenerate length', "leg 1: along its U-joint's first axis",
                  'leg 1: position not finite', 'exact singularity',
                  'actuator Jacobian condition ', 'length ', 'speed ', 'force ',
                  'U-joint angle ', 'spherical joint angle '):
        assert any(words in sol.detail for sol in solutions), words


ANY = st.one_of(st.floats(-0.3, 0.3), st.floats(allow_nan=True, allow_infinity=True),
                st.sampled_from([0.0, -1.0, 1e155, -1e300, 1e308, 5e-324, math.pi / 2]))


@needs_kernel
def test_one_rule_for_any_input(sweep):
    """Any 18 floats (huge, tiny, infinite, NaN, singular): the same status and
    detail class through the kernel and the numpy code, and no NaN or infinity."""
    @settings(max_examples=sweep(400), deadline=None)
    @given(st.tuples(*[ANY] * 6), st.tuples(*[ANY] * 6), st.tuples(*[ANY] * 6))
    def check(q, qd, qdd):
        fast, slow = both(MODEL, q, qd, qdd)
        assert fast.status == slow.status, (fast.detail, slow.detail)
        assert _words(fast.detail) == _words(slow.detail)
        assert all(np.all(np.isfinite(getattr(fast, name))) for name in NUMBERS)
        if fast.status in (Status.UNREACHABLE, Status.INVALID_INPUT):
            assert all(np.all(getattr(fast, name) == 0.0) for name in NUMBERS)

    check()


@needs_kernel
@pytest.mark.parametrize('limit', [2.2009, 2.2010, 4.0, 6.8, 7.0, 100.0])
def test_the_condition_limit_judged_as_the_numpy_code(limit):
    """At home cond(J) = 2.20092 and its Frobenius bound 6.90: the kernel's
    solve skips the Jacobi sweeps only where the bound is within the limit;
    either way the status, and the condition read afterwards, are numpy's."""
    limited = dataclasses.replace(MODEL, limits=dataclasses.replace(
        MODEL.limits, max_jacobian_condition=limit))
    fast, slow = both(limited, Z6, Z6, Z6)
    assert_same(fast, slow)
    assert fast.status is (Status.NEAR_SINGULAR if limit < 2.2009183 else Status.OK)
    with use_kernel(True):
        batch = solver.solve_batch(limited, np.zeros((3, 6)), np.zeros((3, 6)),
                                   np.zeros((3, 6)))
    np.testing.assert_array_equal(batch.jacobian_condition, fast.jacobian_condition)


@needs_kernel
def test_exact_singularity_as_the_numpy_code():
    """Flat on the base: J singular, near_singular with zero forces, SINGULAR
    condition, finite positions, in both codes."""
    fast, slow = both(MODEL, (0.0, 0.0, -1.0, 0.0, 0.0, 0.0), (1.0,) * 6, (1.0,) * 6)
    for sol in (fast, slow):
        assert sol.status is Status.NEAR_SINGULAR and 'exact singularity' in sol.detail
        assert np.all(sol.force == 0.0) and sol.jacobian_condition == SINGULAR
    for name in POSITIONS:
        np.testing.assert_allclose(getattr(fast, name), getattr(slow, name), atol=1e-12)


# ---------------------------------------------------------------------------
# batch == single, bit for bit
# ---------------------------------------------------------------------------

@needs_kernel
@pytest.mark.parametrize('name', NAMES)
def test_batch_is_the_single_solve_bit_for_bit(name):
    """A batch of random motions and every status row: each row of the kernel's
    batch is its single solve, bit for bit, status and detail included; and the
    batch agrees with the numpy batch."""
    model = MODELS[name]
    rows = [tuple(map(tuple, s)) for s in zip(*random_motion(8, 'violent', n=100))]
    rows += STATUS_ROWS
    Q, Qd, Qdd = (np.array([r[k] for r in rows], dtype=float) for k in range(3))
    with use_kernel(True):
        batch = solver.solve_batch(model, Q, Qd, Qdd)
        singles = [solver.solve(model, *row) for row in rows]
    with use_kernel(False):
        slow = solver.solve_batch(model, Q, Qd, Qdd)
    for i, one in enumerate(singles):
        for field in NUMBERS:
            np.testing.assert_array_equal(getattr(one, field), getattr(batch, field)[i])
        assert one.status == batch.status[i] and one.detail == batch.detail[i]
    assert_same_rows(batch, slow)


@pytest.mark.parametrize('on', [True, False], ids=['kernel', 'numpy'])
def test_an_empty_batch_is_an_empty_solution(on):
    with use_kernel(on):
        sol = solver.solve_batch(MODEL, np.zeros((0, 6)), np.zeros((0, 6)), np.zeros((0, 6)))
    assert sol.force.shape == (0, 6) and sol.joints.shape == (0, 6, 3)
    assert sol.jacobian.shape == (0, 6, 6) and sol.status.shape == (0,) and sol.detail == ()


@needs_kernel
def test_long_batch_equals_one_by_one():
    """The rows of a long batch (shared out to several threads where the host
    has several CPUs) are the rows one by one, bitwise."""
    n = 4 * 1024 + 17
    q, qd, qdd = random_motion(11, 'violent', n=n)
    q[5] = np.nan
    q[n - 3] = _zero_length(MODEL, 2)
    with use_kernel(True):
        sol = solver.solve_batch(MODEL, q, qd, qdd)
        rows = np.array([solver.solve(MODEL, q[i], qd[i], qdd[i])._rows for i in range(n)])
        assert sol.joints.shape == (n, 6, 3)    # the batch's deferred angles, into its rows
    np.testing.assert_array_equal(sol._rows, rows)
    assert sol.status[5] is Status.INVALID_INPUT and sol.status[n - 3] is Status.UNREACHABLE


# ---------------------------------------------------------------------------
# what the kernel skips, its inputs, its contracts
# ---------------------------------------------------------------------------

def _poisoned(packed: np.ndarray, effects: Effects) -> np.ndarray:
    """The packed model with NaN for every parameter that only a disabled
    effect reads: a term multiplied by zero would carry the NaN."""
    out = packed.copy()
    layout, rigid, leg = kernel._kernel.PACKED, kernel._kernel.RIGID_ROW, kernel._kernel.LEG_ROW

    def poison(path, rows=None, names=()):
        offset, size = layout[path]
        if rows is None:
            out[offset:offset + size] = np.nan
        for name in names:
            o, n = rows[name]
            out[offset + o:offset + o + n] = np.nan

    if not effects.friction:
        for path in ('friction.viscous', 'friction.coulomb', 'friction.smoothing_velocity'):
            poison(path)
    if not effects.payload:
        poison('payload')
    if not effects.gravity:
        poison('gravity')
    if not effects.platform_inertia:
        poison('platform', rigid, ('inertia',) if effects.gravity else tuple(rigid))
    if not effects.leg_inertia:
        names = ('inertia_across', 'inertia_along') if effects.gravity else tuple(leg)
        poison('cylinder', leg, names)
        poison('rod', leg, names)
    return out


@needs_kernel
@pytest.mark.parametrize('effects', EVERY_EFFECTS, ids=lambda e: '+'.join(e.enabled()) or 'none')
def test_a_disabled_effect_is_skipped_not_multiplied_by_zero(effects):
    """The kernel never reads the parameters of a disabled effect: with NaN in
    each of them, every result is the same, bit for bit."""
    model = MODEL.with_effects(effects)
    packed, bits = kernel.prepared(model)
    q, qd, qdd = random_motion(12, 'violent', n=30)
    clean = kernel.solve_rows(model, q, qd, qdd)
    poisoned = np.empty_like(clean)
    kernel._kernel.solve_batch(_poisoned(packed, effects), bits, q, qd, qdd, poisoned)
    np.testing.assert_array_equal(poisoned, clean)


@needs_kernel
def test_no_velocity_products_are_the_forces_from_rest():
    """velocity_products off: the forces of the same accelerations from rest."""
    effects = Effects(payload=True, velocity_products=False)
    q, qd, qdd = random_motion(13, 'violent', n=30)
    sol = solver.solve_batch(MODEL.with_effects(effects), q, qd, qdd)
    rest = solver.solve_batch(MODEL.with_effects(Effects(payload=True)), q, 0 * qd, qdd)
    np.testing.assert_allclose(sol.force, rest.force, rtol=0,
                               atol=1e-12 * np.abs(rest.force).max())


@needs_kernel
@pytest.mark.parametrize('value', [[0.0] * 6, (0, 1, 2, 3, 4, 5), np.zeros(6, dtype=np.float32),
                                   np.arange(6), [np.float64(0.5)] * 6, range(6)])
def test_the_kernel_takes_any_six_numbers(value):
    """Lists and tuples of floats go to the kernel as they are; ints, numpy
    scalars, other dtypes and sequences are checked and converted first."""
    fast, slow = both(MODEL, value, Z, Z)
    assert_same(fast, slow)


@needs_kernel
@pytest.mark.parametrize('value', [[0.0] * 5, [True] + [0.0] * 5, 'abcdef', [[0.0] * 6], None,
                                   [10 ** 400] + [0.0] * 5])
def test_the_kernel_path_refuses_what_is_not_six_numbers(value):
    with use_kernel(True), pytest.raises(ValueError, match='qdd'):
        solver.solve(MODEL, Z, Z, value)


@needs_kernel
@pytest.mark.parametrize('name', NAMES)
def test_a_batch_computes_joint_angles_on_first_read_unless_a_limit_needs_them(name):
    """Without joint-angle limits the kernel's solve_batch leaves the U-joint
    and spherical angles NOT_COMPUTED in its rows; the first read of ``joints``
    or ``spherical_angles`` computes them (kernel.joint_angles), bit for bit as
    a batch whose limits need them and a single solve do, and as the numpy code
    within rounding."""
    model = MODELS[name]
    assert model.limits.u_joint_max_angle is model.limits.spherical_joint_max_angle is None
    limited = dataclasses.replace(model, limits=dataclasses.replace(
        model.limits, u_joint_max_angle=10.0, spherical_joint_max_angle=10.0))
    motion = random_motion(3, 'violent', n=200)
    offset = kernel.OUT['spherical_angles'][0]
    with use_kernel(True):
        lazy, eager = (solver.solve_batch(m, *motion) for m in (model, limited))
        single = solver.solve(model, *(a[7].tolist() for a in motion))
    assert np.all(lazy.__dict__['_rows'][:, offset] == kernel.NOT_COMPUTED)
    assert single.__dict__['_rows'][offset] != kernel.NOT_COMPUTED
    assert not np.any(eager.__dict__['_rows'][:, offset] == kernel.NOT_COMPUTED)
    np.testing.assert_array_equal(lazy.spherical_angles, eager.spherical_angles)
    np.testing.assert_array_equal(lazy.joints, eager.joints)
    np.testing.assert_array_equal(single.joints, eager.joints[7])
    assert not np.any(lazy.__dict__['_rows'][:, offset] == kernel.NOT_COMPUTED)
    with use_kernel(False):
        slow = solver.solve_batch(model, *motion)
    np.testing.assert_allclose(lazy.joints, slow.joints, rtol=0, atol=1e-13)
    np.testing.assert_allclose(lazy.spherical_angles, slow.spherical_angles, rtol=0, atol=1e-13)


@needs_kernel
def test_a_kernel_solution_is_one_row():
    """solve: one C call; its arrays are views of one result row, made on first
    access; the object reads as a StewartSolution."""
    with use_kernel(True):
        sol = solver.solve(MODEL, *STATUS_ROWS[0])
        batch = solver.solve_batch(MODEL, np.zeros((3, 6)), np.zeros((3, 6)), np.zeros((3, 6)))
    assert isinstance(sol, solver.StewartSolution) and type(sol).__name__ == 'StewartSolution'
    assert sol.force.base is sol.joints.base is not None and sol.joints.shape == (6, 3)
    assert sol.jacobian.shape == sol.twist_jacobian.shape == (6, 6)
    assert isinstance(sol.jacobian_condition, float) and sol.status is Status.OK
    np.testing.assert_array_equal(sol.pose, STATUS_ROWS[0][0])
    assert 'StewartSolution(' in repr(sol)
    assert batch.force.shape == (3, 6) and batch.joints.shape == (3, 6, 3)
    assert batch.jacobian_condition.shape == (3,) and batch.detail == ('', '', '')
    assert solver.sample(batch, 1).status is Status.OK


@pytest.mark.parametrize('on', [True, False], ids=['kernel', 'numpy'])
def test_a_solution_keeps_its_inputs(on):
    """The pose and the detail are those of the call, even if the caller then
    changes its lists; a void sample keeps its pose as given."""
    q = [0.0, math.nan, 0.0, 0.0, 0.0, 0.0]
    with use_kernel(on):
        sol = solver.solve(MODEL, q, list(Z), list(Z))
        q[1] = 0.0
        assert sol.detail.startswith('q[1] (sway) is not finite (nan)')
        assert math.isnan(sol.pose[1]) and sol.pose[0] == 0.0
        Q = np.array([q, Z])
        Q[0, 1] = math.nan
        batch = solver.solve_batch(MODEL, Q, np.zeros((2, 6)), np.zeros((2, 6)))
        Q[0, 1] = Q[1, 0] = 0.5
        assert batch.detail[0].startswith('q[1] (sway) is not finite (nan)')
    np.testing.assert_array_equal(batch.pose, [[0.0, math.nan] + [0.0] * 4, Z])


def test_numpy_code_runs_without_the_extension(monkeypatch):
    """With the extension missing, solve and solve_batch run the numpy code;
    use_kernel(False) switches the kernel off."""
    with use_kernel(False):
        assert not kernel.enabled()
        reference = solver.solve(MODEL, *STATUS_ROWS[0])
    monkeypatch.setattr(kernel, '_kernel', None)
    monkeypatch.setattr(kernel._glue, 'module', None)
    with use_kernel(True):
        assert not kernel.enabled() and not kernel.available()
        sol = solver.solve(MODEL, *STATUS_ROWS[0])
        batch = solver.solve_batch(MODEL, *(np.array([r]) for r in STATUS_ROWS[0]))
    assert type(sol) is solver.StewartSolution and type(batch) is solver.StewartSolution
    np.testing.assert_array_equal(sol.force, reference.force)
    np.testing.assert_array_equal(batch.force[0], reference.force)


@needs_kernel
def test_pack_model_follows_the_exported_layout():
    """Each attribute path the kernel declares is packed at its offset (bodies
    by their rows; a joint-angle limit that is off as +inf)."""
    from operator import attrgetter
    packed = kernel.pack_model(JOINT_LIMITS)
    assert packed.shape == (kernel._kernel.P_SIZE,) and not packed.flags.writeable
    for path, (offset, size) in kernel._kernel.PACKED.items():
        value = attrgetter(path)(JOINT_LIMITS)
        rows = {sm.RigidBody: kernel._kernel.RIGID_ROW, sm.LegBody: kernel._kernel.LEG_ROW}
        if type(value) in rows:
            for attr, (o, n) in rows[type(value)].items():
                np.testing.assert_array_equal(packed[offset + o:offset + o + n],
                                              np.ravel(getattr(value, attr)), err_msg=path)
        else:
            np.testing.assert_array_equal(packed[offset:offset + size], np.ravel(value),
                                          err_msg=path)
    off = kernel.pack_model(MODEL)
    offset = kernel._kernel.PACKED['limits.u_joint_max_angle'][0]
    assert off[offset] == math.inf
    assert sorted(kernel._kernel.EFFECTS.values()) == [1 << i for i in range(len(EFFECT_NAMES))]
    assert kernel.effect_bits(MODEL.with_effects(Effects().only('friction'))) == \
        kernel._kernel.EFFECTS['friction']


@needs_kernel
def test_the_kernel_declares_the_contracts_and_python_reads_them():
    assert kernel.contract_problems(kernel._kernel) == []
    assert [Status(name) for name in kernel._kernel.STATUS] == list(kernel.STATUS_BY_CODE)


def test_a_result_row_holds_every_array_of_a_solution():
    fields = {f.name for f in dataclasses.fields(solver.StewartSolution)}
    assert fields - {'status', 'detail', 'model'} <= set(kernel.ROW_FIELDS)


@needs_kernel
@pytest.mark.parametrize('change, words', [
    (lambda d: d['EFFECTS'].pop('friction'), 'effects'),
    (lambda d: d['EFFECTS'].update(spring=128), 'effects'),
    (lambda d: d.update(STATUS=d['STATUS'] + ('broken',)), 'statuses'),
    (lambda d: d.update(UNREACHABLE=d['UNREACHABLE'][::-1]), 'unreachable'),
    (lambda d: d['OUT'].update(force=(13, 6)), 'OUT'),
    (lambda d: d['OUT'].pop('pose'), 'result row fields'),
    (lambda d: d.update(P_SIZE=d['P_SIZE'] + 1), 'PACKED'),
    (lambda d: d['LEG_ROW'].pop('mass'), 'LEG_ROW'),
    (lambda d: d.update(RESULTS_NOT_FINITE=-2), 'RESULTS_NOT_FINITE'),
    (lambda d: d.update(U_JOINT_TOLERANCE=1e-7), 'U_JOINT_TOLERANCE'),
    (lambda d: d.update(MAX_SOLVED_CONDITION=1e16), 'MAX_SOLVED_CONDITION'),
])
def test_a_kernel_that_disagrees_is_refused(change, words):
    """A kernel built from another kernel.c is refused, naming what differs."""
    exported = {name: (dict(value) if isinstance(value, dict) else value)
                for name, value in vars(kernel._kernel).items() if name.isupper()}
    change(exported)
    problems = kernel.contract_problems(SimpleNamespace(**exported))
    assert any(words in p for p in problems), problems


@needs_kernel
@pytest.mark.parametrize('args, error', [
    (lambda p, b, o: (p, b, o, Z, Z), TypeError),
    (lambda p, b, o: (p, b, o, Z, Z, [0.0] * 5), TypeError),
    (lambda p, b, o: (p, b, o, Z, Z, [0] * 6), TypeError),
    (lambda p, b, o: (p, 1 << 12, o, Z, Z, Z), ValueError),
    (lambda p, b, o: (p, b, o[:-1], Z, Z, Z), ValueError),
    (lambda p, b, o: (p[:-1], b, o, Z, Z, Z), ValueError),
    (lambda p, b, o: (p, b, o.astype(np.float32), Z, Z, Z), ValueError),
    (lambda p, b, o: (p, b, p, Z, Z, Z), (ValueError, BufferError)),
])
def test_the_binding_refuses_bad_arguments(args, error):
    """The C binding checks what it is given: no crash, a Python error."""
    params, bits = kernel.prepared(MODEL)
    out = np.zeros(kernel.OUT_SIZE)
    with pytest.raises(error):
        kernel._kernel.solve(*args(params, bits, out))


@needs_kernel
def test_threads_reading_a_batch_s_joint_angles_at_once_see_them_whole():
    """The first read of a batch's deferred joint angles fills its rows in
    place: two threads reading at once both get every angle, never a row
    another thread is still filling (NOT_COMPUTED, or 0 in place of an angle)."""
    import threading
    motion = random_motion(5, 'violent', n=4096)
    with use_kernel(True):
        eager = solver.solve_batch(dataclasses.replace(MODEL, limits=dataclasses.replace(
            MODEL.limits, u_joint_max_angle=10.0, spherical_joint_max_angle=10.0)), *motion)
        for _ in range(150):
            sol = solver.solve_batch(MODEL, *motion)
            seen, start = [None, None], threading.Barrier(2)

            def read(k, field):
                start.wait()
                seen[k] = getattr(sol, field).copy()
            threads = [threading.Thread(target=read, args=(k, field)) for k, field in
                       enumerate(('spherical_angles', 'joints'))]
            for t in threads:
                t.start()
            for t in threads:
                t.join()
            np.testing.assert_array_equal(seen[0], eager.spherical_angles)
            np.testing.assert_array_equal(seen[1], eager.joints)
