"""The compiled kernel (machines/staicu/kernel.c) against the Python reference code.

The kernel is a transcription of kinematics.py / dynamics.py / the status
rules of solver.py; the rest of the suite (power balance, the independent
jet-based reference, statics, symmetry, hard cases) runs on whatever
``fsd.solve`` uses, the kernel by default. Here the two implementations are
compared directly: every effect combination, random reachable poses, every
status, single and batch. Set FSD_KERNEL=0 to run the whole suite on the
Python code instead.
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

import flight_sim_dynamics as fsd
from flight_sim_dynamics.core import kernel as core_kernel
from flight_sim_dynamics.core.effects import EFFECT_NAMES, Effects
from flight_sim_dynamics.core.status import Status
from flight_sim_dynamics.machines.staicu import kernel

MODEL = fsd.load_model()
PAYLOAD_MODEL = fsd.load_model(scene='payload')
NUMBERS = ('length', 'stroke', 'rate', 'acceleration', 'force', 'power', 'joints',
           'joint_rates', 'joint_accelerations', 'jacobian', 'beta', 'kinematic_condition',
           'jacobian_condition')
EVERY_EFFECTS = [Effects(**dict(zip(EFFECT_NAMES, bits)))
                 for bits in itertools.product((False, True), repeat=len(EFFECT_NAMES))]

needs_kernel = pytest.mark.skipif(
    not kernel.available() and os.environ.get('FSD_REQUIRE_KERNEL') == '0',
    reason='kernel not built and FSD_REQUIRE_KERNEL=0 (Python code only)')


def test_the_kernel_is_built():
    """A failed build is a failure, not a silent fall back to the slow path
    (unless the caller says FSD_REQUIRE_KERNEL=0: a machine without a C compiler)."""
    if not kernel.available() and os.environ.get('FSD_REQUIRE_KERNEL') == '0':
        pytest.skip(f'FSD_REQUIRE_KERNEL=0 and the kernel is not built: {kernel.IMPORT_ERROR}')
    assert kernel.available(), kernel.IMPORT_ERROR


def both(model, *args):
    with core_kernel.use_kernel(True):
        fast = fsd.solve(model, *args)
    with core_kernel.use_kernel(False):
        slow = fsd.solve(model, *args)
    return fast, slow


def _words(detail: str) -> str:
    return re.sub(r'[-+0-9.e]+', '#', detail)


def assert_same(fast, slow, rtol=1e-12, index=None):
    """Same status, detail and numbers (to round-off of the largest entry; at an
    exact singularity the condition numbers in the detail are round-off noise,
    so only its words are compared)."""
    pick = (lambda a: a) if index is None else (lambda a: a[index])
    assert pick(fast.status) == pick(slow.status), (pick(fast.detail), pick(slow.detail))
    names = NUMBERS
    if pick(slow.kinematic_condition) < 1e12 and pick(slow.jacobian_condition) < 1e12:
        assert pick(fast.detail) == pick(slow.detail)
    else:   # what goes through the inverse of a singular matrix is round-off noise
        assert _words(pick(fast.detail)) == _words(pick(slow.detail))
        names = ('length', 'stroke', 'joints', 'jacobian', 'beta')
    for name in names:
        a = np.asarray(pick(getattr(fast, name)), dtype=float)
        b = np.asarray(pick(getattr(slow, name)), dtype=float)
        scale = max(1.0, float(np.max(np.abs(b))) if b.size else 1.0)
        assert np.all(np.isfinite(a)), name
        np.testing.assert_allclose(a, b, rtol=0, atol=rtol * scale, err_msg=name)


POSE = st.tuples(st.floats(-0.25, 0.25), st.floats(-0.25, 0.5), st.floats(-1.0, 1.0))
RATE = st.tuples(*[st.floats(-2.0, 2.0)] * 3)
ACCELERATION = st.tuples(*[st.floats(-20.0, 20.0)] * 3)


@needs_kernel
def test_any_pose_any_effects_single(sweep):
    """Any pose of the working region (reachable or not), any rates, any of the
    128 effect combinations, with or without a payload body: the kernel gives
    the Python code's status, detail and numbers."""
    @settings(max_examples=sweep(300))
    @given(POSE, RATE, ACCELERATION, st.sampled_from(EVERY_EFFECTS), st.booleans())
    def check(q, qd, qdd, effects, payload):
        model = (PAYLOAD_MODEL if payload else MODEL).with_effects(effects)
        fast, slow = both(model, q, qd, qdd)
        assert_same(fast, slow)

    check()


@needs_kernel
@pytest.mark.parametrize('effects', EVERY_EFFECTS, ids=lambda e: '+'.join(e.enabled()) or 'none')
def test_every_effect_combination_in_motion(effects):
    """Each of the 128 effect sets (with a payload body) on the paper's general
    motion: kernel = Python code, and the forces really depend on the effects
    (no set is computed as another)."""
    model = PAYLOAD_MODEL.with_effects(effects)
    Q, Qd, Qdd = fsd.trajectories.paper_example('general', np.linspace(0.0, 3.0, 7))
    for q, qd, qdd in zip(Q, Qd, Qdd):
        fast, slow = both(model, q, qd, qdd)
        assert_same(fast, slow)
    if not effects.gravity and not effects.any_inertia and not effects.friction:
        assert np.all(fast.force == 0.0)     # nothing simulated: no force
    else:
        assert np.any(fast.force != 0.0)


def test_effects_change_the_kernel_result():
    """Switching any single effect off changes the force of a moving pose
    (the kernel reads the effect bits, it does not compute the full model)."""
    q, qd, qdd = (0.05, 0.1, 0.2), (0.3, -0.2, 0.5), (1.0, 2.0, -3.0)
    full = PAYLOAD_MODEL.with_effects(Effects(payload=True, friction=True))
    base = fsd.solve(full, q, qd, qdd).force
    for name in EFFECT_NAMES:
        other = fsd.solve(full.with_effects(full.effects.without(name)), q, qd, qdd).force
        assert np.max(np.abs(other - base)) > 1e-6, name


STATUS_ROWS = [   # one per status and detail the kernel produces
    ((0.05, 0.1, 0.2), (0.1, -0.1, 0.2), (1.0, -1.0, 2.0)),
    ((0.0, math.nan, 0.0), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)),
    ((0.0, 0.0, 0.0), (0.0, 0.0, math.inf), (0.0, 0.0, 0.0)),
    ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0), (-math.inf, 0.0, 0.0)),
    ((0.0, 0.0, 0.0), (1e308, 0.0, 0.0), (0.0, 0.0, 0.0)),
    ((0.0, 5.0, 0.0), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)),
    ((0.0, -0.4, 0.0), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)),
    ((0.3, 0.0, 0.0), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)),
    ((0.0, 0.0, 1.0608370074727034), (0.1, 0.0, 0.0), (0.0, 0.0, 0.0)),
    ((0.0, 0.8, 0.0), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)),
    ((-0.05, 0.05, -0.3), (2.0, 0.0, 0.0), (0.0, 0.0, 0.0)),
    ((0.05, 0.1, 0.2), (0.1, -0.1, 0.2), (0.0, 0.0, 1e200)),
    ((1e-12, 1e-12, 1e-12), (5e-324, 0.0, 0.0), (0.0, -0.0, 1e-300)),
    ((1e300, 0.0, 0.0), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)),
    ((0.0, 0.0, 1e6), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)),
    ((0.21919782270065014, -0.2574550431971696, 3.8245351651214303), (0.0,) * 3, (0.0,) * 3),
    ((0.0, 0.0, 1.06), (1e155, 0.0, 0.0), (0.0, 0.0, 0.0)),
]


@needs_kernel
@pytest.mark.parametrize('row', STATUS_ROWS, ids=repr)
def test_every_status_single(row):
    """Each status and detail is the same through the kernel's single solve, the
    Python single solve and the Python batch code on that one row: one status
    rule (status.sample_status) in all three, the Python single solve handing a
    sample its float arithmetic refuses (e.g. 1e300 m of surge, an exact
    singularity) to the IEEE array code, as the kernel computes it."""
    with core_kernel.use_kernel(True):
        fast = fsd.solve(MODEL, *row)
    with core_kernel.use_kernel(False):
        slow = fsd.solve_batch(MODEL, *([r] for r in row))
        scalar = fsd.solve(MODEL, *row)
    one = SimpleNamespace(**{name: getattr(slow, name)[0]
                             for name in NUMBERS + ('status', 'detail')})
    rtol = 1e-12 * max(1.0, min(one.kinematic_condition, 1e6))
    assert_same(fast, one, rtol=rtol)
    assert_same(fast, scalar, rtol=rtol)
    assert_same(scalar, one, rtol=rtol)
    assert fast.status == scalar.status


def test_status_rows_cover_every_status_and_detail():
    """STATUS_ROWS reach every status and every kind of detail the rule gives
    on the real mechanism (loops A, B, C cannot open before D or E: their
    words are checked in test_status_rule.py)."""
    solutions = [fsd.solve(MODEL, *row) for row in STATUS_ROWS]
    assert {sol.status for sol in solutions} == set(Status) - {Status.NOT_CONVERGED}
    for words in ('loop D:', 'loop E:', 'loop E2 on rod:', 'results are not finite', 'q[1]',
                  'qd[2]', 'qdd[0]', 'exact singularity', 'kinematic condition ',
                  'actuator Jacobian condition ', 'stroke B ', 'speed A ', 'force A '):
        assert any(sol.detail.startswith(words) for sol in solutions), words


GARBAGE = st.one_of(st.floats(-0.3, 0.6), st.floats(allow_nan=True, allow_infinity=True),
                    st.sampled_from([0.0, 1e155, -1e300, 1e308, 5e-324, 1.0608370074727034]))


@needs_kernel
def test_one_rule_for_any_input(sweep):
    """Any nine floats (huge, tiny, infinite, NaN, the singular roll): the kernel's
    single solve, the Python single solve (floats) and the Python batch code
    (arrays) give the same status and the same detail, and no NaN or infinity."""
    @settings(max_examples=sweep(400))
    @given(st.tuples(GARBAGE, GARBAGE, GARBAGE), st.tuples(GARBAGE, GARBAGE, GARBAGE),
           st.tuples(GARBAGE, GARBAGE, GARBAGE))
    def check(q, qd, qdd):
        with core_kernel.use_kernel(True):
            fast = fsd.solve(MODEL, q, qd, qdd)
        with core_kernel.use_kernel(False):
            scalar = fsd.solve(MODEL, q, qd, qdd)
            batch = fsd.solve_batch(MODEL, [q], [qd], [qdd])
        assert fast.status == scalar.status == batch.status[0], (fast.detail, scalar.detail)
        assert _words(fast.detail) == _words(scalar.detail) == _words(batch.detail[0])
        for sol in (fast, scalar):
            assert all(np.all(np.isfinite(getattr(sol, name))) for name in NUMBERS)

    check()


@needs_kernel
def test_batch_kernel_equals_batch_python_and_single():
    """The batch through the kernel = the vectorised Python batch code = the
    single solves, row by row, statuses and details included."""
    rng = np.random.default_rng(7)
    good = [(tuple(rng.uniform([-0.2, -0.2, -0.8], [0.2, 0.4, 0.8])),
             tuple(rng.normal(0.0, 0.5, 3)), tuple(rng.normal(0.0, 5.0, 3)))
            for _ in range(200)]
    rows = good + STATUS_ROWS
    Q, Qd, Qdd = (np.array([r[k] for r in rows], dtype=float) for k in range(3))
    with core_kernel.use_kernel(True):
        fast = fsd.solve_batch(MODEL, Q, Qd, Qdd)
    with core_kernel.use_kernel(False):
        slow = fsd.solve_batch(MODEL, Q, Qd, Qdd)
    for i, row in enumerate(rows):
        assert_same(fast, slow, rtol=1e-12 * max(1.0, min(slow.kinematic_condition[i], 1e6)),
                    index=i)
        with core_kernel.use_kernel(True):
            one = fsd.solve(MODEL, *row)
        assert one.status == fast.status[i] and one.detail == fast.detail[i]
        np.testing.assert_array_equal(one.force, fast.force[i])   # the same code: bitwise


@needs_kernel
def test_long_batch_equals_one_by_one():
    """The rows of a long batch are the same as one by one (bitwise)."""
    n = 2065
    rng = np.random.default_rng(3)
    Q = rng.uniform([-0.2, -0.2, -0.8], [0.2, 0.4, 0.8], (n, 3))
    Qd, Qdd = rng.normal(0.0, 0.5, (n, 3)), rng.normal(0.0, 5.0, (n, 3))
    Q[5] = np.nan
    Q[n - 3] = (0.0, 5.0, 0.0)
    with core_kernel.use_kernel(True):
        sol = fsd.solve_batch(MODEL, Q, Qd, Qdd)
    for i in (0, 5, n // 2 - 1, n // 2, n // 2 + 1, n - 3, n - 1):
        with core_kernel.use_kernel(True):
            one = fsd.solve(MODEL, Q[i], Qd[i], Qdd[i])
        assert one.status == sol.status[i] and one.detail == sol.detail[i]
        np.testing.assert_array_equal(one.joints, sol.joints[i])
        np.testing.assert_array_equal(one.force, sol.force[i])


@needs_kernel
def test_diagnostics_of_a_kernel_solution():
    """Q and cond(Q) (recomputed on demand from the pose) match the Python
    code's, single and batch; unreachable rows give zeros."""
    q, qd, qdd = (0.05, 0.1, 0.2), (0.1, -0.1, 0.2), (1.0, -1.0, 2.0)
    fast, slow = both(MODEL, q, qd, qdd)
    np.testing.assert_allclose(fast.Q, slow.Q, rtol=0, atol=1e-14)
    assert fast.cond == pytest.approx(slow.cond, rel=1e-12)
    Q = np.array([q, (0.0, 5.0, 0.0), (math.nan, 0.0, 0.0)])
    with core_kernel.use_kernel(True):
        batch = fsd.solve_batch(MODEL, Q, np.zeros((3, 3)), np.zeros((3, 3)))
    np.testing.assert_allclose(batch.Q[0], slow.Q, rtol=0, atol=1e-14)
    assert np.all(batch.Q[1:] == 0.0) and batch.cond[0] == pytest.approx(slow.cond, rel=1e-12)
    assert list(batch.cond[1:]) == [0.0, 0.0]
    unreachable, _ = both(MODEL, (0.0, 5.0, 0.0), (0.0,) * 3, (0.0,) * 3)
    assert unreachable.geometric is None and np.all(unreachable.Q == 0.0)


def test_python_code_runs_without_the_extension(monkeypatch):
    """With the extension missing (a machine without a C compiler), solve and
    solve_batch run the Python code and never touch the kernel."""
    class Missing:
        def __getattr__(self, name):
            raise AssertionError('the kernel was called')
    monkeypatch.setattr(kernel, '_kernel', Missing())
    monkeypatch.setattr(kernel, 'enabled', lambda: False)
    sol = fsd.solve(MODEL, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0))
    assert [round(f, 4) for f in sol.force] == [38.6066, 33.2041, 33.2041]
    batch = fsd.solve_batch(MODEL, np.zeros((2, 3)), np.zeros((2, 3)), np.zeros((2, 3)))
    np.testing.assert_allclose(batch.force[1], sol.force, rtol=1e-15)
    monkeypatch.undo()
    monkeypatch.setattr(kernel, '_kernel', None)
    monkeypatch.setattr(kernel._glue, 'module', None)
    with core_kernel.use_kernel(True):      # cannot switch on what is not there
        assert not kernel.enabled() and not kernel.available()
        assert fsd.solve(MODEL, (0.0,) * 3, (0.0,) * 3, (0.0,) * 3).status == Status.OK


@needs_kernel
def test_packed_model_layout():
    """pack_model writes what the kernel's P_* offsets read (machines/staicu/kernel.c)."""
    packed = kernel.pack_model(PAYLOAD_MODEL)
    geom = PAYLOAD_MODEL.geometry
    assert packed.shape == (kernel.P_SIZE,) and not packed.flags.writeable
    assert packed[0] == geom.d1 and packed[16] == geom.s_C
    assert list(packed[17:20]) == list(geom.L0)
    assert list(packed[20:32]) == list(PAYLOAD_MODEL.central.joint_zero)
    assert packed[32] == PAYLOAD_MODEL.gravity
    platform = PAYLOAD_MODEL.bodies['platform']
    row = packed[33 + 3 * 13:33 + 4 * 13]
    assert row[0] == platform.mass and list(row[4:]) == list(np.ravel(platform.inertia))
    assert packed[33 + 10 * 13] == PAYLOAD_MODEL.payload.mass
    assert list(packed[-6:]) == [PAYLOAD_MODEL.limits.stroke_min, PAYLOAD_MODEL.limits.stroke_max,
                                 PAYLOAD_MODEL.limits.max_speed, PAYLOAD_MODEL.limits.max_force,
                                 PAYLOAD_MODEL.limits.max_kinematic_condition,
                                 PAYLOAD_MODEL.limits.max_jacobian_condition]
    assert kernel.effect_bits(PAYLOAD_MODEL) == 1 + 2 + 4 + 8 + 16 + 32 + kernel.HAS_PAYLOAD
    assert kernel.effect_bits(PAYLOAD_MODEL.with_effects(Effects().only('friction'))) == (
        64 + kernel.HAS_PAYLOAD)


@needs_kernel
def test_the_kernel_declares_the_contracts_and_python_reads_them():
    """Every layout, enum and list is declared once, in machines/staicu/kernel.c, exported by
    the extension and read here: sizes, the result row, the effect bits, the
    body, loop and status names match the package's own lists."""
    from flight_sim_dynamics.machines.staicu import _kernel
    from flight_sim_dynamics.machines.staicu.kinematics import LOOPS
    from flight_sim_dynamics.machines.staicu.model import BODY_NAMES
    assert kernel.contract_problems(_kernel) == []
    assert (kernel.P_SIZE, kernel.OUT_SIZE, kernel.BODY_SIZE) == (
        _kernel.P_SIZE, _kernel.OUT_SIZE, _kernel.BODY_SIZE)
    assert set(_kernel.EFFECTS) == set(EFFECT_NAMES)
    assert sorted(_kernel.EFFECTS.values()) == [1 << i for i in range(len(EFFECT_NAMES))]
    assert kernel.HAS_PAYLOAD == 1 << len(EFFECT_NAMES)
    assert set(_kernel.BODIES) == set(BODY_NAMES) | {'payload'}
    assert _kernel.LOOPS == LOOPS
    assert [Status(name) for name in _kernel.STATUS] == list(kernel.STATUS_BY_CODE)
    for name, (offset, size) in _kernel.OUT.items():
        assert kernel.OUT[name] == (slice(offset, offset + size) if size > 1 else offset)


@needs_kernel
def test_pack_model_follows_the_exported_layout():
    """Each attribute path the kernel declares is packed at its offset, each body
    at its place in the kernel's body order; a model without a payload packs
    zeros there."""
    from operator import attrgetter
    packed = kernel.pack_model(PAYLOAD_MODEL)
    for path, (offset, size) in kernel.PACKED.items():
        if path == 'bodies':
            continue
        np.testing.assert_array_equal(packed[offset:offset + size],
                                      np.ravel(attrgetter(path)(PAYLOAD_MODEL)), err_msg=path)
    start = kernel.PACKED['bodies'][0]
    for i, name in enumerate(kernel.BODIES):
        body = PAYLOAD_MODEL.payload if name == 'payload' else PAYLOAD_MODEL.bodies[name]
        row = packed[start + i * kernel.BODY_SIZE:start + (i + 1) * kernel.BODY_SIZE]
        for attr, (offset, size) in kernel.BODY_ROW.items():
            np.testing.assert_array_equal(row[offset:offset + size],
                                          np.ravel(getattr(body, attr)), err_msg=(name, attr))
    bare = kernel.pack_model(dataclasses.replace(MODEL, payload=None))
    i = kernel.BODIES.index('payload')
    assert np.all(bare[start + i * kernel.BODY_SIZE:start + (i + 1) * kernel.BODY_SIZE] == 0.0)


@needs_kernel
@pytest.mark.parametrize('change, words', [
    (lambda d: d['EFFECTS'].pop('friction'), 'friction'),
    (lambda d: d['EFFECTS'].update(spring=128), 'spring'),
    (lambda d: d.update(BODIES=d['BODIES'][:-2] + ('payload',)), 'crank_e'),
    (lambda d: d.update(LOOPS=tuple(reversed(d['LOOPS']))), 'loop'),
    (lambda d: d.update(STATUS=d['STATUS'] + ('broken',)), 'broken'),
    (lambda d: d['OUT'].update(force=(13, 3)), 'OUT'),
    (lambda d: d.update(P_SIZE=190), 'PACKED'),
    (lambda d: d.update(RESULTS_NOT_FINITE=-2), 'RESULTS_NOT_FINITE'),
])
def test_a_kernel_that_disagrees_is_refused(change, words):
    """A kernel built from another machines/staicu/kernel.c (or one lacking an effect or a
    body the Python code has) is refused, the problem naming what differs."""
    from flight_sim_dynamics.machines.staicu import _kernel
    exported = {name: (dict(value) if isinstance(value, dict) else value)
                for name, value in vars(_kernel).items() if name.isupper()}
    change(exported)
    problems = kernel.contract_problems(SimpleNamespace(**exported))
    assert any(words in p for p in problems), problems
