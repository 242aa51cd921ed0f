"""The digital twin's integrator (flight_sim_dynamics.core.simulation) on the
hexapod, through ``fsd.simulate`` with 6-vectors:

* the open-loop round trip: the inverse-dynamics forces of a motion, sampled
  at 1 kHz, give the motion back (both hexapods);
* closed loop with servos: the full feed-forward tracks to rounding, none
  leaves the servos' error; plant != controller (a payload the controller
  does not know): the feed-forward error is seen, and the plant still tracks;
* a run that leaves the workspace stops with an outcome, never a NaN;
* the RK4 loop in the kernel (machines/stewart/kernel.c ``integrate``) gives
  the Python loop's rows to rounding, the same outcome and detail, on runs
  that end, that saturate and that stop;
* bad arguments (sizes, numbers that are not finite, a 3-DOF feed-forward)
  are clear ValueErrors.
"""
from __future__ import annotations

import os
from dataclasses import replace

import numpy as np
import pytest

import flight_sim_dynamics as fsd
from flight_sim_dynamics import Status
from flight_sim_dynamics.core.effects import Effects
from flight_sim_dynamics.core.interpolation import ForceHistory, Reference
from flight_sim_dynamics.core.kernel import use_kernel
from flight_sim_dynamics.core import simulation
from flight_sim_dynamics.core.servo import Servo, TabulatedLaw
from flight_sim_dynamics.machines.stewart import kernel
from flight_sim_dynamics.machines.stewart.machine import MACHINE as STEWART

from stewart_cases import MACHINES, model_of

MODEL = model_of('stewart_6dof')
ZERO = np.zeros(6)
#: amplitudes (m, rad) and frequencies (Hz) of a gentle and a harsher motion about home
GENTLE = ([0.05, 0.04, 0.03, 0.06, 0.05, 0.08], [0.7, 0.9, 1.1, 0.8, 1.3, 0.6])
HARSH = ([0.04, 0.03, 0.025, 0.05, 0.04, 0.06], [1.7, 2.3, 2.9, 2.1, 2.6, 1.9])

needs_kernel = pytest.mark.skipif(
    not kernel.available() and os.environ.get('FSD_REQUIRE_KERNEL') != '1',
    reason='the hexapod kernel is not built (FSD_REQUIRE_KERNEL=1 makes this an error)')


def sines(amplitude, hz, scale: float = 1.0):
    """q, qd, qdd (each (N, 6)) of a sum of sines about home, one per coordinate."""
    a = scale * np.asarray(amplitude, dtype=float)
    w = 2.0 * np.pi * np.asarray(hz, dtype=float)

    def motion(t):
        t = np.atleast_1d(np.asarray(t, dtype=float))[:, None]
        return a * np.sin(w * t), a * w * np.cos(w * t), -a * w * w * np.sin(w * t)
    return motion


def reference(motion, duration: float) -> Reference:
    return Reference(motion, 0.0, duration)


def with_payload(model):
    """The model with an off-centre payload, its effect on."""
    mass = 80.0 if model.name == 'stewart_6dof' else 0.5
    loaded = model.with_payload(mass, (0.1, -0.05, 0.3), np.diag([6.0, 8.0, 9.0]).ravel())
    return loaded.with_effects(Effects(payload=True))


@pytest.mark.parametrize('name', sorted(MACHINES))
def test_open_loop_round_trip_recovers_the_motion(name):
    model = model_of(name)
    scale = 1.0 if name == 'stewart_6dof' else 0.5
    motion = sines(*GENTLE, scale=scale)
    t = np.linspace(0.0, 0.5, 501)
    q, qd, qdd = motion(t)
    force = fsd.solve_batch(model, q, qd, qdd).force
    sim = fsd.simulate(model, forces=(t, force), initial=(q[0], qd[0]))
    assert sim.outcome is Status.OK and len(sim.t) == 501
    assert sim.q.shape == sim.qd.shape == sim.force.shape == (501, 6)
    np.testing.assert_allclose(sim.q, q, rtol=0, atol=1e-8)
    np.testing.assert_allclose(sim.qd, qd, rtol=0, atol=1e-6)
    np.testing.assert_allclose(sim.force, force, rtol=1e-6, atol=1e-6 * np.abs(force).max())
    assert np.abs(q).max() > 0.01        # not vacuous: the platform moves


def test_closed_loop_tracks_and_the_feedforward_matters():
    ref = reference(sines(*HARSH), 1.0)
    exact = fsd.simulate(MODEL, reference=ref, feedforward=MODEL)
    none = fsd.simulate(MODEL, reference=ref)
    assert exact.outcome is none.outcome is Status.OK
    assert exact.pose_error.shape == (1001, 6) and exact.length_error.shape == (1001, 6)
    assert set(exact.tracking()) == {f'{c}_{k}' for c in fsd.machine_of(MODEL).coordinates
                                     + ('length',) for k in ('max', 'rms')}
    assert exact.tracking()['length_max'] < 1e-8
    assert 1e-4 < none.tracking()['length_max'] < 0.05


def test_plant_unlike_the_controller_still_tracks():
    """A payload in the plant only: the controller's feed-forward misses its
    inertia and weight; the error is seen and the servos keep it small."""
    plant = with_payload(MODEL)
    ref = reference(sines(*GENTLE), 2.0)
    exact = fsd.simulate(plant, reference=ref, feedforward=plant).tracking()
    wrong = fsd.simulate(plant, reference=ref, feedforward=MODEL).tracking()
    none = fsd.simulate(plant, reference=ref).tracking()
    assert exact['length_max'] < 1e-8
    assert 100 * exact['length_max'] < wrong['length_max'] < none['length_max'] < 0.05


def test_saturated_actuators_are_seen_in_the_tracking():
    """A force limit below what the motion needs: deliver clips the servos and
    the error grows, still no NaN."""
    weak = replace(MODEL, limits=replace(MODEL.limits, max_force=600.0))
    ref = reference(sines(*HARSH), 1.0)
    strong = fsd.simulate(MODEL, reference=ref, feedforward=MODEL)
    clipped = fsd.simulate(weak, reference=ref, feedforward=weak)
    assert np.abs(clipped.force).max() <= 600.0 + 1e-9
    assert clipped.tracking()['length_max'] > 100 * strong.tracking()['length_max']
    assert np.all(np.isfinite(clipped.q))


def assert_no_nan(sim) -> None:
    for name in ('t', 'q', 'qd', 'qdd', 'length', 'rate', 'force'):
        assert np.all(np.isfinite(getattr(sim, name))), name


def flying(model, steps: int = 600):
    """Constant forces far above the weight, from rest at home."""
    rest = fsd.solve(model, ZERO, ZERO, ZERO).force
    push = rest + np.array([3000.0, -2000.0, 4000.0, 3000.0, -1000.0, 2000.0])
    return (np.array([0.0, steps * 1e-3]), np.tile(push, (2, 1)))


def test_a_run_that_leaves_the_workspace_stops_with_an_outcome():
    sim = fsd.simulate(MODEL, forces=flying(MODEL))
    assert sim.outcome in (Status.UNREACHABLE, Status.NEAR_SINGULAR), sim.outcome_detail
    assert 't = ' in sim.outcome_detail and len(sim.t) < 601
    assert_no_nan(sim)
    assert sim.status[-1] is sim.outcome or sim.status[-1] in (Status.OK, Status.LIMIT)


def through_the_u_joint(model, extent: float = 1.2) -> np.ndarray:
    """A pose (no rotation) that puts leg 1 along its U-joint's first axis a_1:
    a singular direction of the joint (S5), unreachable."""
    d = extent * np.asarray(model.base_axes[0])
    return np.concatenate([np.asarray(model.base_joints[0]) + d - np.asarray(model.home)
                           - np.asarray(model.platform_joints[0]), np.zeros(3)])


def test_a_stage_at_an_unreachable_pose_stops_at_once():
    q = through_the_u_joint(MODEL)
    assert fsd.solve(MODEL, q, ZERO, ZERO).status is Status.UNREACHABLE
    for run in (dict(forces=([0.0, 0.1], np.zeros((2, 6))), initial=(q, ZERO)),
                dict(reference=reference(sines(*GENTLE), 0.1), initial=(q, ZERO))):
        sim = fsd.simulate(MODEL, **run)
        assert sim.outcome is Status.UNREACHABLE and len(sim.t) == 1
        assert 't = 0 s' in sim.outcome_detail
        assert_no_nan(sim)


def test_the_platform_in_the_base_plane_stops_near_the_singularity():
    q = np.array([0.0, 0.0, -MODEL.home[2], 0.0, 0.0, 0.0])
    sim = fsd.simulate(MODEL, forces=([0.0, 0.1], np.zeros((2, 6))), initial=(q, ZERO))
    assert sim.outcome is Status.NEAR_SINGULAR and len(sim.t) == 1
    assert_no_nan(sim)


def both(call):
    with use_kernel(True):
        fast = call()
    with use_kernel(False):
        slow = call()
    return fast, slow


def assert_same(fast, slow) -> None:
    """Rows to rounding (the LU solves and M's sums differ in their last bits),
    the same outcome and detail."""
    assert fast.outcome is slow.outcome and fast.outcome_detail == slow.outcome_detail
    assert len(fast.t) == len(slow.t)
    np.testing.assert_array_equal(fast.t, slow.t)
    for name in ('q', 'qd', 'qdd', 'force', 'length', 'rate'):
        a, b = getattr(fast, name), getattr(slow, name)
        scale = max(np.abs(b).max(), 1.0)
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-12 * scale, err_msg=name)
    assert list(fast.status) == list(slow.status)


@needs_kernel
@pytest.mark.parametrize('steps', [50, pytest.param(200, marks=pytest.mark.slow)])
@pytest.mark.parametrize('name', sorted(MACHINES))
def test_closed_loop_kernel_equals_python(name, steps):
    """50 steps in the unit tier, 200 in the slow one (the Python loop is
    slow), full feed-forward and none, a payload the controller does not know,
    and actuators that saturate."""
    model = model_of(name)
    scale = 1.0 if name == 'stewart_6dof' else 0.5
    ref = reference(sines(*HARSH, scale=scale), steps * 1e-3)
    plant = with_payload(model)
    weak = replace(plant, limits=replace(plant.limits, max_force=0.9 * np.abs(
        fsd.solve(plant, ZERO, ZERO, ZERO).force).max(), max_speed=0.2))
    for plant_, feedforward in ((model, model), (model, None), (plant, model), (weak, weak)):
        fast, slow = both(lambda: fsd.simulate(plant_, reference=ref, feedforward=feedforward))
        assert fast.outcome is Status.OK and len(fast.t) == steps + 1
        assert_same(fast, slow)
        np.testing.assert_allclose(fast.length_error, slow.length_error, rtol=0, atol=1e-12)


@needs_kernel
@pytest.mark.parametrize('limit', [None, 600.0])
def test_the_kernel_takes_every_step_of_a_run_that_ends(limit):
    """Not vacuous: the comparisons above are of the kernel's own steps (a
    saturating servo law too), not of steps it left to the Python code."""
    plant = MODEL if limit is None else replace(MODEL, limits=replace(MODEL.limits,
                                                                      max_force=limit))
    steps = 200
    times = 0.5 * 1e-3 * np.arange(2 * steps + 1)
    q, qd, qdd = sines(*HARSH)(times)
    length, rate, force = simulation.reference_tables(STEWART, plant, q, qd, qdd, times, 'ref')
    law = TabulatedLaw.servo_law(STEWART, plant, Servo.for_bandwidth(STEWART, plant), force,
                                 length, rate)
    rows = tuple(np.zeros((steps + 1, 6)) for _ in range(4))
    rows[0][0], rows[1][0] = q[0], qd[0]
    assert kernel.integrate_rows(plant, law.tables(), 1e-3, 0, steps, rows) == steps + 1
    assert np.all(np.isfinite(rows[0])) and np.abs(rows[0] - q[::2]).max() > 0
    if limit is not None:
        assert np.abs(rows[3]).max() == pytest.approx(limit)     # deliver clipped


@needs_kernel
def test_open_loop_kernel_equals_python_up_to_the_stop():
    fast, slow = both(lambda: fsd.simulate(MODEL, forces=flying(MODEL)))
    assert fast.outcome in (Status.UNREACHABLE, Status.NEAR_SINGULAR)
    assert_same(fast, slow)


@needs_kernel
def test_kernel_integrate_checks_its_buffers():
    tables = (np.zeros((5, 6)),) * 3 + (np.zeros(6), np.zeros(6), 1.0, 1.0, True)
    rows = tuple(np.zeros((3, 6)) for _ in range(4))
    assert kernel.integrate_rows(MODEL, tables, 1e-3, 0, 2, rows) in (0, 1, 2, 3)
    with pytest.raises(ValueError):
        kernel.integrate_rows(MODEL, tables, 1e-3, 0, 3, rows)      # tables of 2 steps
    with pytest.raises(ValueError):
        kernel.integrate_rows(MODEL, tables, 1e-3, 0, 2, rows[:3] + (np.zeros((3, 3)),))


@pytest.mark.parametrize('kwargs, message', [
    (dict(forces=([0, 1], np.zeros((2, 3)))), r'force must have shape \(2, 6\)'),
    (dict(forces=ForceHistory([0, 1], np.zeros((2, 3)))), 'the machine 6 legs'),
    (dict(forces=([0, 1], [[0] * 6, [0, 0, np.nan, 0, 0, 0]])), r'force\[1, 2\] is not finite'),
    (dict(forces=([0, 1], np.zeros((2, 6))), initial=(ZERO[:3], ZERO[:3])), 'initial q'),
    (dict(forces=([0, 1], np.zeros((2, 6))), initial=(ZERO, [0, 0, 0, np.inf, 0, 0])),
     'initial qd'),
    (dict(forces=([0, 1], np.zeros((2, 6))), initial=ZERO), 'initial must be'),
    (dict(reference=Reference(lambda t: (np.zeros((np.size(t), 3)),) * 3, 0.0, 1.0)),
     "reference motion's q has shape"),
    (dict(reference=reference(sines(*GENTLE), 1.0), servo=Servo((1.0,) * 3, (1.0,) * 3)),
     'servo has 3 gains'),
    (dict(reference=reference(sines(*GENTLE), 1.0), feedforward=fsd.load_model()),
     'both must be of one machine'),
    (dict(reference=Reference(lambda t: (np.full((np.size(t), 6), np.nan),) * 3, 0.0, 1.0)),
     'the reference motion at t = 0 s: invalid_input'),
])
def test_bad_arguments_are_clear_errors(kwargs, message):
    with pytest.raises(ValueError, match=message):
        fsd.simulate(MODEL, **kwargs)


def test_a_scene_without_inertia_cannot_be_simulated():
    static = MODEL.with_effects(Effects(platform_inertia=False, leg_inertia=False))
    with pytest.raises(ValueError, match='computes no inertia'):
        fsd.simulate(static, forces=([0, 1], np.zeros((2, 6))))


def test_default_gains_are_a_critically_damped_leg_at_the_bandwidth():
    servo = fsd.servo_for_bandwidth(MODEL, 4.0, 0.8)
    base = fsd.solve(MODEL, ZERO, ZERO, ZERO)
    # leg-space mass: the force per unit leg acceleration, M J_L^-1, from six solves
    mass = np.array([fsd.solve(MODEL, ZERO, ZERO, np.linalg.solve(base.jacobian, e)).force
                     - base.force for e in np.eye(6)]).T
    w = 2 * np.pi * 4.0
    np.testing.assert_allclose(servo.kp, np.diag(mass) * w ** 2, rtol=1e-9)
    np.testing.assert_allclose(servo.kd, 2.0 * 0.8 * np.diag(mass) * w, rtol=1e-9)
    assert len(servo.kp) == 6 and min(servo.kp) > 0
