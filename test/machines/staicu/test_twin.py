"""The real-time stepper of the twin (flight_sim_dynamics.core.twin) on the 3-DOF machine.

* rest: the central configuration's leg lengths with the static
  feed-forward keep the platform at rest (to rounding);
* a step of the leg-length references converges to the pose of those
  lengths (error below 1e-6 m after 3 s at the default 5 Hz bandwidth);
* equal to :func:`simulate`'s closed loop for a reference it holds constant
  (the same RK4 and servo law: 1e-12), and within the zero-order hold's
  O(h) of it on a moving reference, the command refreshed every step;
* it stops with a status, never NaN, when it leaves the workspace; bad
  commands are errors.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

import flight_sim_dynamics as fsd
from flight_sim_dynamics import Status
from flight_sim_dynamics.core import kernel as core_kernel
from flight_sim_dynamics.machines.staicu import kernel, motions
from flight_sim_dynamics.core.interpolation import Reference
from flight_sim_dynamics.core.twin import TwinStepper
from flight_sim_dynamics.machines.api import servo_for_bandwidth, simulate
from flight_sim_dynamics.machines.staicu.machine import MACHINE

STEP = 1e-3
ZERO = np.zeros(3)


@pytest.fixture(scope='module')
def model():
    return fsd.load_model()


@pytest.fixture(scope='module')
def servo(model):
    return servo_for_bandwidth(model)


def hold(model, q):
    """The command that holds pose ``q``: its leg lengths, zero rates, the
    static forces of the model there.
    """
    sol = fsd.solve(model, q, ZERO, ZERO)
    return sol.length, ZERO, sol.force


def test_static_feedforward_keeps_the_platform_at_rest(model, servo):
    twin = TwinStepper(MACHINE, model, servo, STEP)
    twin.command(*hold(model, ZERO))
    assert twin.advance(500) == 500
    assert twin.running and twin.status is Status.OK
    np.testing.assert_allclose(twin.q, ZERO, atol=1e-12)
    np.testing.assert_allclose(twin.qd, ZERO, atol=1e-12)
    np.testing.assert_allclose(twin.force, hold(model, ZERO)[2], rtol=1e-9)
    assert twin.time == pytest.approx(0.5)


def test_step_in_leg_length_converges(model, servo):
    target = np.array([0.04, -0.03, 0.06])
    length, rate, force = hold(model, target)
    twin = TwinStepper(MACHINE, model, servo, STEP)
    twin.command(length, rate, force)
    twin.advance(300)
    early = np.max(np.abs(twin.q - target))
    twin.advance(2700)
    assert np.max(np.abs(twin.q - target)) < 1e-6 < early
    np.testing.assert_allclose(twin.length, length, atol=1e-6)
    np.testing.assert_allclose(twin.rate, ZERO, atol=1e-5)


def test_no_feedforward_sags_under_gravity(model, servo):
    """Without the feed-forward, the P servo must carry the weight: a
    steady-state error f_static / kp per leg, to first order.
    """
    length, rate, _ = hold(model, ZERO)
    twin = TwinStepper(MACHINE, model, servo, STEP)
    twin.command(length, rate, ZERO)
    twin.advance(3000)
    sag = length - twin.length
    expected = hold(model, ZERO)[2] / np.array(servo.kp)
    np.testing.assert_allclose(sag, expected, rtol=0.05)


def constant(q):
    q = np.asarray(q, dtype=float)

    def motion(t):
        n = np.atleast_1d(t).size
        return np.tile(q, (n, 1)), np.zeros((n, 3)), np.zeros((n, 3))
    return Reference(motion, 0.0, 1.0)


def test_equals_simulate_for_a_held_reference(model, servo):
    target = [0.03, 0.02, -0.04]
    sim = simulate(model, reference=constant(target), feedforward=model, servo=servo,
                   initial=(ZERO, ZERO), step=STEP)
    twin = TwinStepper(MACHINE, model, servo, STEP)
    twin.command(*hold(model, target))
    qs = [twin.q]
    for _ in range(len(sim.t) - 1):
        twin.advance(1)
        qs.append(twin.q)
    np.testing.assert_allclose(np.array(qs), sim.q, rtol=0, atol=1e-12)
    np.testing.assert_allclose(twin.force, sim.force[-1], rtol=1e-9)


def test_follows_simulate_on_a_moving_reference(model, servo):
    """The paper's general motion, the command of each step its reference at
    the step's start (what the node holds between commands): within the
    zero-order hold's error of the exact closed loop.
    """
    motion = motions.get('general')
    reference = Reference(motion.trajectory, 0.0, 1.0)
    sim = simulate(model, reference=reference, feedforward=model, servo=servo, step=STEP)
    t = sim.t
    q_ref, qd_ref, qdd_ref = motion.trajectory(t)
    ref = fsd.solve_batch(model, q_ref, qd_ref, qdd_ref)
    twin = TwinStepper(MACHINE, model, servo, STEP, q0=q_ref[0])
    twin.qd = qd_ref[0].copy()
    qs = [twin.q]
    for k in range(len(t) - 1):
        twin.command(ref.length[k], ref.rate[k], ref.force[k])
        twin.advance(1)
        qs.append(twin.q)
    error = np.max(np.abs(np.array(qs) - sim.q))
    amplitude = np.max(np.abs(sim.q - sim.q[0]))
    assert error < 0.02 * amplitude, (error, amplitude)


def test_stops_with_a_status_when_it_leaves_the_workspace(model, servo):
    """Leg lengths far beyond the strokes, actuators strong enough to get
    there: the platform is driven out until the mechanism cannot be
    assembled (or nears a singularity); the stepper stops and holds the last
    state reached, at rest.
    """
    strong = replace(model, limits=replace(model.limits, max_force=1e6))
    twin = TwinStepper(MACHINE, strong, servo, STEP)
    length, rate, force = hold(model, ZERO)
    twin.command(length + np.array([1.0, -1.0, 1.0]), rate, force)    # far beyond the strokes
    done = twin.advance(5000)
    assert done < 5000 and not twin.running
    assert twin.outcome in (Status.UNREACHABLE, Status.NEAR_SINGULAR)
    assert 't = ' in twin.detail
    for value in (twin.q, twin.qd, twin.length, twin.rate, twin.force, twin.acceleration):
        assert np.all(np.isfinite(value))
    np.testing.assert_array_equal(twin.qd, ZERO)
    held = twin.q.copy()
    assert twin.advance(10) == 0
    np.testing.assert_array_equal(twin.q, held)
    # a held state is one the plant can be solved at: its lengths are its own
    np.testing.assert_allclose(twin.length, fsd.solve(model, held, ZERO, ZERO).length)


@pytest.mark.parametrize('bad', [[1.0, 2.0], [1.0, float('nan'), 2.0], 'abc',
                                 [1.0, float('inf'), 0.0]])
def test_bad_command_is_an_error(model, servo, bad):
    twin = TwinStepper(MACHINE, model, servo, STEP)
    with pytest.raises(ValueError):
        twin.command(bad, ZERO, ZERO)
    with pytest.raises(ValueError):
        twin.command(ZERO, ZERO, bad)


@pytest.mark.parametrize('kwargs', [dict(step=0.0), dict(step=float('nan')),
                                    dict(step=1e-3, q0=[0, float('nan'), 0])])
def test_bad_construction_is_an_error(model, servo, kwargs):
    with pytest.raises(ValueError):
        TwinStepper(MACHINE, model, servo, **kwargs)


def test_unreachable_start_is_a_status(model, servo):
    twin = TwinStepper(MACHINE, model, servo, STEP, q0=[0.0, 5.0, 0.0])
    assert not twin.running and twin.outcome is Status.UNREACHABLE
    assert twin.advance(3) == 0
    assert np.all(np.isfinite(twin.length))


def _run_stepper(model, servo, commands, chunk):
    """The stepper fed ``commands`` (one per ``chunk`` steps): its states."""
    twin = TwinStepper(MACHINE, model, servo, STEP)
    states = []
    for length, rate, force in commands:
        twin.command(length, rate, force)
        twin.advance(chunk)
        states.append((twin.q.copy(), twin.qd.copy(), twin.length.copy(), twin.rate.copy(),
                       twin.force.copy(), twin.steps, twin.outcome))
    return states


@pytest.mark.skipif(not kernel.available(), reason='compiled kernel not built')
@pytest.mark.parametrize('far', [False, pytest.param(True, marks=pytest.mark.slow)])
def test_compiled_steps_equal_python_steps(model, servo, far):
    """Several steps per call (as the node ticks) through the kernel equal the
    Python loop: on a moving reference, and (slow tier) up to the stop and the
    state held when the commands drive the platform out of the workspace."""
    plant = replace(model, limits=replace(model.limits, max_force=1e6)) if far else model
    motion = motions.get('general')
    # far: until it stops (at 0.39 s), then 0.2 s of the state held
    t = np.arange(0.0, 0.6 if far else 0.4, 4 * STEP)
    ref = fsd.solve_batch(model, *motion.trajectory(t))
    push = np.array([1.0, -1.0, 1.0]) * (t[:, None] if far else 0.0)
    commands = list(zip(ref.length + push, ref.rate, ref.force))
    with core_kernel.use_kernel(True):
        compiled = _run_stepper(plant, servo, commands, 4)
    with core_kernel.use_kernel(False):
        python = _run_stepper(plant, servo, commands, 4)
    assert [s[5:] for s in compiled] == [s[5:] for s in python]
    if far:
        assert python[-1][6] is not Status.OK       # it did stop
    # q, qd, lengths, rates, forces, each to 1e-9 of its largest value in the run
    # too: a force crossing zero near the stop carries the roundoff the stop's
    # conditioning amplifies (5e-9 N at -3.9 N, with servo gains 2e-15 apart)
    for field in range(5):
        scale = max(float(np.abs(s[field]).max()) for s in python)
        for got, want in zip(compiled, python):
            np.testing.assert_allclose(got[field], want[field], rtol=1e-9,
                                       atol=1e-9 * scale + 1e-12)
