"""The real-time stepper of the twin (flight_sim_dynamics.core.twin) on the hexapod:

* the home leg lengths with the static feed-forward keep the platform at rest;
* a step of the leg-length commands converges to the pose of those lengths;
* equal to ``simulate``'s closed loop for a reference it holds constant;
* several steps per call through the kernel equal the Python steps, up to a
  stop when the commands drive the platform out of the workspace;
* it stops with a status, never a NaN; bad commands are errors.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

import flight_sim_dynamics as fsd
from flight_sim_dynamics import Status
from flight_sim_dynamics.core.interpolation import Reference
from flight_sim_dynamics.core.kernel import use_kernel
from flight_sim_dynamics.core.twin import TwinStepper
from flight_sim_dynamics.machines.api import servo_for_bandwidth
from flight_sim_dynamics.machines.stewart import kernel
from flight_sim_dynamics.machines.stewart.machine import MACHINE

from stewart_cases import model_of

STEP = 1e-3
ZERO = np.zeros(6)
MODEL = model_of('stewart_6dof')
SERVO = servo_for_bandwidth(MODEL)
TARGET = np.array([0.03, -0.02, 0.04, 0.05, -0.04, 0.06])


def hold(model, q):
    """The command that holds pose ``q``: its leg lengths, zero rates, its static forces."""
    sol = fsd.solve(model, q, ZERO, ZERO)
    return sol.length, ZERO, sol.force


def test_static_feedforward_keeps_the_platform_at_rest():
    twin = TwinStepper(MACHINE, MODEL, SERVO, STEP)
    twin.command(*hold(MODEL, ZERO))
    assert twin.advance(500) == 500
    assert twin.running and twin.status is Status.OK
    np.testing.assert_allclose(twin.q, ZERO, atol=1e-12)
    np.testing.assert_allclose(twin.qd, ZERO, atol=1e-12)
    np.testing.assert_allclose(twin.force, hold(MODEL, ZERO)[2], rtol=1e-9)
    assert twin.time == pytest.approx(0.5)


def test_step_in_leg_length_converges():
    length, rate, force = hold(MODEL, TARGET)
    twin = TwinStepper(MACHINE, MODEL, SERVO, STEP)
    twin.command(length, rate, force)
    twin.advance(300)
    early = np.max(np.abs(twin.q - TARGET))
    twin.advance(2700)
    assert np.max(np.abs(twin.q - TARGET)) < 1e-6 < early
    np.testing.assert_allclose(twin.length, length, atol=1e-6)
    np.testing.assert_allclose(twin.rate, ZERO, atol=1e-5)


def test_equals_simulate_for_a_held_reference():
    def motion(t):
        n = np.atleast_1d(t).size
        return np.tile(TARGET, (n, 1)), np.zeros((n, 6)), np.zeros((n, 6))
    sim = fsd.simulate(MODEL, reference=Reference(motion, 0.0, 0.5), feedforward=MODEL,
                       servo=SERVO, initial=(ZERO, ZERO), step=STEP)
    twin = TwinStepper(MACHINE, MODEL, SERVO, STEP)
    twin.command(*hold(MODEL, TARGET))
    qs = [twin.q]
    for _ in range(len(sim.t) - 1):
        twin.advance(1)
        qs.append(twin.q)
    np.testing.assert_allclose(np.array(qs), sim.q, rtol=0, atol=1e-12)
    np.testing.assert_allclose(twin.force, sim.force[-1], rtol=1e-9)


def _run(model, commands, chunk):
    twin = TwinStepper(MACHINE, model, SERVO, STEP)
    states = []
    for length, rate, force in commands:
        twin.command(length, rate, force)
        twin.advance(chunk)
        states.append((twin.q.copy(), twin.qd.copy(), twin.length.copy(), twin.rate.copy(),
                       twin.force.copy(), twin.steps, twin.outcome, twin.detail))
    return states


@pytest.mark.skipif(not kernel.available(), reason='the hexapod kernel is not built')
@pytest.mark.parametrize('far', [False, True])
def test_compiled_steps_equal_python_steps(far):
    # far: no speed limit, whose derating switches the force on and off at the
    # limit (a chattering run, whose rows depend on every last bit)
    plant = (replace(MODEL, limits=replace(MODEL.limits, max_force=1e6, max_speed=1e3))
             if far else MODEL)
    poses = [TARGET * s for s in np.linspace(0.0, 1.0, 8)]
    commands = [hold(MODEL, q) for q in poses]
    if far:
        commands = [(length + 0.8 * np.array([1, -1, 1, -1, 1, -1]), rate, force)
                    for length, rate, force in commands]
    with use_kernel(True):
        fast = _run(plant, commands, 40)
    with use_kernel(False):
        slow = _run(plant, commands, 40)
    for a, b in zip(fast, slow):
        assert a[5:] == b[5:]
        for x, y in zip(a[:5], b[:5]):
            np.testing.assert_allclose(x, y, rtol=0, atol=1e-12 * max(np.abs(y).max(), 1.0))
    if far:
        assert fast[-1][6] in (Status.UNREACHABLE, Status.NEAR_SINGULAR)


def test_stops_with_a_status_when_it_leaves_the_workspace():
    strong = replace(MODEL, limits=replace(MODEL.limits, max_force=1e6))
    twin = TwinStepper(MACHINE, strong, SERVO, STEP)
    length, rate, force = hold(MODEL, ZERO)
    twin.command(length + 0.8 * np.array([1, -1, 1, -1, 1, -1]), rate, force)
    done = twin.advance(5000)
    assert done < 5000 and not twin.running
    assert twin.outcome in (Status.UNREACHABLE, Status.NEAR_SINGULAR)
    for value in (twin.q, twin.qd, twin.length, twin.rate, twin.force, twin.acceleration):
        assert np.all(np.isfinite(value)) and value.shape == (6,)
    np.testing.assert_array_equal(twin.qd, ZERO)
    held = twin.q.copy()
    assert twin.advance(10) == 0
    np.testing.assert_array_equal(twin.q, held)


@pytest.mark.parametrize('bad', [[1.0, 2.0, 3.0], [1.0, float('nan'), 2.0, 0, 0, 0], 'abc',
                                 [1.0, float('inf'), 0.0, 0, 0, 0]])
def test_bad_command_is_an_error(bad):
    twin = TwinStepper(MACHINE, MODEL, SERVO, STEP)
    with pytest.raises(ValueError):
        twin.command(bad, ZERO, ZERO)
    with pytest.raises(ValueError):
        twin.command(ZERO, ZERO, bad)
    assert twin.advance(2) == 2 and twin.running     # still working


@pytest.mark.parametrize('kwargs', [dict(step=0.0), dict(step=1e-3, q0=[0.0, 0.0, 0.0]),
                                    dict(step=1e-3, q0=[0, 0, float('nan'), 0, 0, 0])])
def test_bad_construction_is_an_error(kwargs):
    with pytest.raises(ValueError):
        TwinStepper(MACHINE, MODEL, SERVO, **kwargs)
    with pytest.raises(ValueError, match='servo has 3 gains'):
        TwinStepper(MACHINE, MODEL, servo_for_bandwidth(fsd.load_model()), STEP)
