"""The twin's compiled path (machines/staicu/kernel.c: ``affine``, ``integrate``) against
the Python code it replaces when the kernel is built.

* ``forward_dynamics.affine_terms``: the kernel's one-pass M and b equal the
  reference's four solves (b = solve(q, qd, 0).force, M e_j = solve(q, qd,
  e_j).force - b) to 1e-12 relative, with the same status, detail and
  solution of the state, over workspace states (property-based, the samples
  of test_workspace_properties.py), for scenes with and without velocity
  products, payload and friction, and for every effect set with inertia;
* ``core.simulation.integrate``: the RK4 loop in C gives the Python loop's rows
  (to rounding), outcome and detail, closed and open loop, on runs that end
  and on runs that stop.
"""
from __future__ import annotations

import itertools
import math
import os
from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import flight_sim_dynamics as fsd
from flight_sim_dynamics import Status
from flight_sim_dynamics.core import kernel as core_kernel
from flight_sim_dynamics.core.effects import EFFECT_NAMES, Effects
from flight_sim_dynamics.machines.staicu import forward_dynamics as fd
from flight_sim_dynamics.machines.staicu import kernel, motions
from flight_sim_dynamics.machines.staicu.model import Friction
from flight_sim_dynamics.core.interpolation import Reference
from flight_sim_dynamics.core.servo import TabulatedLaw
from flight_sim_dynamics.core.simulation import integrate
from flight_sim_dynamics.machines.api import simulate
from flight_sim_dynamics.machines.staicu.machine import MACHINE
from test_workspace_properties import batches, examples, tolerance_factor

MODEL = fsd.load_model()
FRICTION = replace(MODEL.with_effects(replace(MODEL.effects, friction=True)),
                   friction=Friction(viscous=(100.0, 120.0, 140.0), coulomb=(20.0, 30.0, 40.0)))
MODELS = {'full': MODEL, 'full+friction': FRICTION,
          'payload': fsd.load_model(scene='payload'),
          'platform_only': fsd.load_model(scene='platform_only'),
          'no velocity products': MODEL.with_effects(MODEL.effects.without('velocity_products'))}
RTOL = 1e-12
EVERY_EFFECTS = [Effects(**dict(zip(EFFECT_NAMES, bits)))
                 for bits in itertools.product((False, True), repeat=len(EFFECT_NAMES))]

needs_kernel = pytest.mark.skipif(
    not kernel.available() and os.environ.get('FSD_REQUIRE_KERNEL') == '0',
    reason='kernel not built and FSD_REQUIRE_KERNEL=0 (Python code only)')


def both(call):
    """call() through the kernel, then through the Python code."""
    with core_kernel.use_kernel(True):
        fast = call()
    with core_kernel.use_kernel(False):
        slow = call()
    return fast, slow


@needs_kernel
def test_affine_terms_kernel_equals_python_over_the_workspace(sweep) -> None:
    """The kernel's M and b (f = M q'' + b) are the Python code's over the
    workspace and beyond, for each model of MODELS (a quarter of the
    examples in the unit tier, the rest in the slow tier)."""
    @settings(max_examples=sweep(examples(0.5)), report_multiple_bugs=False)
    @given(batches(), st.sampled_from(sorted(MODELS)))
    def check(batch, name) -> None:
        model = MODELS[name]
        q, qd, _ = batch
        for i in range(len(q)):
            (M, b, base), (M_py, b_py, base_py) = both(lambda: fd.affine_terms(model, q[i], qd[i]))
            where = f'{name}: q={q[i].tolist()} qd={qd[i].tolist()}'
            assert base.status == base_py.status and base.detail == base_py.detail, where
            np.testing.assert_array_equal(b, base.force, err_msg=where)
            assert M.shape == (3, 3) and b.shape == (3,)
            assert np.all(np.isfinite(M)) and np.all(np.isfinite(b)), where
            np.testing.assert_allclose(base.length, base_py.length, rtol=RTOL, err_msg=where)
            np.testing.assert_allclose(base.rate, base_py.rate, rtol=RTOL, atol=1e-15,
                                       err_msg=where)
            if base.status in (Status.UNREACHABLE, Status.INVALID_INPUT):
                assert np.all(M == 0.0) and np.all(b == 0.0), where
                continue
            # rounding of the reference's differences solve(e_j) - b: relative to |b| too
            factor = tolerance_factor(max(base.kinematic_condition, base.jacobian_condition))
            scale = max(np.abs(M_py).max(), np.abs(b_py).max(), 1.0)
            assert np.abs(M - M_py).max() <= RTOL * factor * scale, (where, M, M_py)
            assert np.abs(b - b_py).max() <= RTOL * factor * scale, (where, b, b_py)

    check()


@needs_kernel
@pytest.mark.parametrize('effects', [e for e in EVERY_EFFECTS if e.any_inertia],
                         ids=lambda e: '+'.join(e.enabled()))
def test_affine_terms_kernel_equals_python_for_every_effect_set(effects):
    """Each effect set with some inertia (M != 0), with a payload body: the
    kernel's M (from the bodies' velocity Jacobians) is the recursion's."""
    model = MODELS['payload'].with_effects(effects)
    for q, qd in (((0.05, 0.1, 0.2), (0.3, -0.2, 0.5)), ((-0.1, 0.25, -0.4), (-0.5, 0.4, 1.0))):
        (M, b, base), (M_py, b_py, base_py) = both(lambda: fd.affine_terms(model, q, qd))
        assert base.status == base_py.status and base.status in (Status.OK, Status.LIMIT)
        scale = max(np.abs(M_py).max(), np.abs(b_py).max(), 1.0)
        assert np.abs(M - M_py).max() <= RTOL * scale, (M, M_py)
        assert np.abs(b - b_py).max() <= RTOL * scale, (b, b_py)
        assert np.abs(M).max() > 0.1     # crank inertia alone: 0.67 kg


@needs_kernel
def test_affine_terms_kernel_keeps_the_api():
    with pytest.raises(ValueError, match='q must be 3 numbers'):
        fd.affine_terms(MODEL, (0, 0), (0, 0, 0))
    M, b, base = fd.affine_terms(MODEL, (0, math.nan, 0), (0, 0, 0))
    assert base.status == Status.INVALID_INPUT and 'q[1] (heave)' in base.detail
    assert np.all(M == 0.0) and np.all(b == 0.0)
    M, b, base = fd.affine_terms(FRICTION, (0.0, 0.1, 0.0), (0.05, 0.2, -0.1))
    qdd = np.array([1.5, -2.0, 3.0])    # friction is in b: f stays affine in qdd
    np.testing.assert_allclose(M @ qdd + b, fsd.solve(FRICTION, (0.0, 0.1, 0.0),
                                                      (0.05, 0.2, -0.1), qdd).force, rtol=1e-12)


def assert_same_run(fast: tuple, slow: tuple) -> None:
    """Rows to rounding (the LU solves differ in their last bits), the same
    outcome and detail."""
    assert fast[5] == slow[5] and fast[6] == slow[6], (fast[5:], slow[5:])
    assert len(fast[0]) == len(slow[0])
    np.testing.assert_array_equal(fast[0], slow[0])
    for a, b in zip(fast[1:5], slow[1:5]):
        scale = max(np.abs(b).max(), 1.0)
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-9 * scale)


@needs_kernel
@pytest.mark.parametrize('name, start', [
    ('general', 0.0), pytest.param('violent', 1.1, marks=pytest.mark.slow)])
def test_closed_loop_kernel_equals_python(name, start):
    """200 steps of the closed loop (the Python loop is slow) with the full
    feed-forward and with none (the violent motion in the slow tier)."""
    reference = replace(Reference.from_motion(motions.get(name)), start=start, end=start + 0.2)
    for feedforward in (MODEL, None):
        fast, slow = both(lambda: simulate(MODEL, reference=reference, feedforward=feedforward))
        assert fast.outcome == slow.outcome == Status.OK
        assert len(fast.t) == len(slow.t) == 201
        for field in ('q', 'qd', 'qdd', 'force', 'length', 'pose_error', 'length_error'):
            a, b = getattr(fast, field), getattr(slow, field)
            np.testing.assert_allclose(a, b, rtol=0, atol=1e-9 * max(np.abs(b).max(), 1.0),
                                       err_msg=field)
        assert [str(s) for s in fast.status] == [str(s) for s in slow.status]


@needs_kernel
def test_open_loop_kernel_equals_python_up_to_the_stop():
    """Constant forces far above the platform's weight drive it out of the
    workspace: both loops stop at the same step, with the same status and
    detail (the kernel hands the stopping step to the Python code)."""
    steps = 400
    rest = fsd.solve(MODEL, (0, 0, 0), (0, 0, 0), (0, 0, 0)).force
    force = np.tile(rest + np.array([400.0, 300.0, -300.0]), (2 * steps + 1, 1))
    law = TabulatedLaw(force, force, force, np.zeros(3), np.zeros(3))
    run = (MACHINE, MODEL, 0.0, 1e-3, steps, np.zeros(3), np.zeros(3), law)
    fast, slow = both(lambda: integrate(*run))
    assert fast[5] in (Status.UNREACHABLE, Status.NEAR_SINGULAR), fast[5:]
    assert len(fast[0]) < steps + 1
    assert_same_run(fast, slow)
    # a plain callable law is integrated by the Python loop, with the same rows
    plain = integrate(*run[:-1], lambda j, base: force[j])
    assert_same_run(fast, plain)


@needs_kernel
def test_forces_too_large_stop_both_loops_alike():
    steps = 50
    force = np.full((2 * steps + 1, 3), 1e300)
    law = TabulatedLaw(force, force, force, np.zeros(3), np.zeros(3))
    fast, slow = both(lambda: integrate(MACHINE, MODEL, 0.0, 1e-3, steps, np.zeros(3),
                                        np.zeros(3), law))
    assert fast[5] != Status.OK
    assert_same_run(fast, slow)


def test_tabulated_law_checks_its_tables():
    with pytest.raises(ValueError, match='kp has shape'):
        TabulatedLaw(np.zeros((5, 3)), np.zeros((5, 3)), np.zeros((5, 3)), np.zeros(2),
                     np.zeros(3))
    with pytest.raises(ValueError, match='rate_ref has shape'):
        TabulatedLaw(np.zeros((5, 3)), np.zeros((5, 3)), np.zeros((4, 3)), np.zeros(3),
                     np.zeros(3))


def held(heave_after: float, at: float, end: float) -> Reference:
    """Rest at the centre, then from ``at`` on a heave of ``heave_after``."""
    def motion(t):
        q = np.zeros((np.size(t), 3))
        q[:, 1] = np.where(np.asarray(t) >= at, heave_after, 0.0)
        return q, np.zeros_like(q), np.zeros_like(q)
    return Reference(motion, 0.0, end)


def fields(sim) -> dict:
    return {name: getattr(sim, name) for name in
            ('t', 'q', 'qd', 'qdd', 'force', 'length', 'rate', 'pose_error', 'length_error')}


@needs_kernel
def test_a_closed_loop_that_stops_early():
    """A run that stops (the kernel hands the stopping step to the Python
    code) equals the Python loop; and a reference that cannot be followed
    after the stop is still refused, as before the run."""
    initial = ((0.0, 0.0, 1.0), (0.0, 0.0, 3.0))     # rolling into the singularity
    fast, slow = both(lambda: simulate(MODEL, reference=held(0.0, 1.0, 1.0),
                                       feedforward=MODEL, initial=initial))
    assert fast.outcome == slow.outcome == Status.NEAR_SINGULAR
    assert fast.outcome_detail == slow.outcome_detail and len(fast.t) == len(slow.t) < 100
    for name, value in fields(fast).items():
        np.testing.assert_allclose(value, fields(slow)[name], rtol=0,
                                   atol=1e-9 * max(np.abs(value).max(), 1.0), err_msg=name)
    for on in (True, False):
        with core_kernel.use_kernel(on), pytest.raises(
                ValueError, match=r'the reference motion at t = 0\.9 s: unreachable'):
            simulate(MODEL, reference=held(-0.8, 0.9, 1.0), feedforward=MODEL, initial=initial)
