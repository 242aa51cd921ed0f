"""The digital twin's integrator (flight_sim_dynamics.core.simulation) on the 3-DOF machine.

* energy: friction off, gravity on, the mechanism's T + V from the
  independent reference model (test/reference/reference_model.py):
  - zero actuator force: conserved to 1e-6 (relative to the peak kinetic
    energy) for as long as the falling mechanism stays in the workspace
    (from rest at heave 1.0 m: 0.56 s; a free fall of 1 s is 4.9 m, more than
    the reachable heave range of 1.4 m), and the run then stops with a status;
  - legs as undamped springs (P servos, no feed-forward: conservative forces,
    potential 1/2 kp (L - L_ref)^2): T + V + springs conserved to 1e-6 over 1 s;
* the open-loop round trip of the paper's three motions (inverse-dynamics
  forces at 1 kHz back in, RK4 at 1 kHz) to 1e-6 m and rad over 3 s;
* closed loop, full feed-forward, exact plant: the violent motion tracked to
  1e-4 m (with a speed limit above its 1.22 m/s peak; at the packaged 1 m/s the
  actuators saturate, and that is seen in the tracking error);
* interpolation orders, statuses at the workspace's edge, bad arguments.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

import flight_sim_dynamics as fsd
import reference_model as rm
from flight_sim_dynamics import Status
from flight_sim_dynamics.core.interpolation import node_slopes
from flight_sim_dynamics.machines.staicu import motions
from flight_sim_dynamics.core.interpolation import ForceHistory, Reference
from flight_sim_dynamics.core.servo import Servo, deliver
from flight_sim_dynamics.machines.api import servo_for_bandwidth, simulate

MODEL = fsd.load_model()
PARAMS = rm.load_reference_params()
CENTRE_LENGTH = fsd.solve(MODEL, (0, 0, 0), (0, 0, 0), (0, 0, 0)).length
FAST = replace(MODEL, limits=replace(MODEL.limits, max_speed=2.0))   # violent peaks at 1.22 m/s


def rest_reference(duration: float) -> Reference:
    return Reference(lambda t: (np.zeros((np.size(t), 3)),) * 3, 0.0, duration)


def energy_drift(sim, extra: np.ndarray | float = 0.0) -> float:
    """max |E - E(0)| / max T, E = T + V (reference model) + extra."""
    energy = rm.reference_energy(PARAMS, sim.q, sim.qd) + extra
    kinetic = rm.reference_solve(PARAMS, sim.q, sim.qd, sim.qdd)['kinetic']
    assert kinetic.max() > 0.1      # not vacuous: the mechanism moves
    return float(np.max(np.abs(energy - energy[0])) / kinetic.max())


def test_energy_is_conserved_with_zero_actuator_force_until_the_mechanism_leaves():
    assert MODEL.effects.gravity and not MODEL.effects.friction
    sim = simulate(MODEL, forces=([0.0, 1.0], np.zeros((2, 3))),
                   initial=((0.0, 1.0, 0.0), (0.0, 0.0, 0.0)))
    assert sim.outcome == Status.UNREACHABLE and 'loop' in sim.outcome_detail
    assert 0.5 < sim.t[-1] < 1.0
    assert np.all(np.isfinite(sim.q)) and np.all(sim.force == 0.0)
    assert sim.q[-1, 1] < 0.0            # it fell through the centre
    assert energy_drift(sim) < 1e-6


def test_energy_is_conserved_with_undamped_spring_legs_over_one_second():
    kp = 2000.0
    sim = simulate(MODEL, reference=rest_reference(1.0), servo=Servo((kp,) * 3, (0.0,) * 3),
                   initial=((0.0, 0.0, 0.02), (0.02, 0.0, 0.0)))
    assert sim.outcome == Status.OK and sim.t[-1] == pytest.approx(1.0)
    assert len(sim.t) == 1001
    springs = 0.5 * kp * np.sum((sim.length - CENTRE_LENGTH) ** 2, axis=1)
    np.testing.assert_allclose(sim.force, -kp * (sim.length - CENTRE_LENGTH), rtol=1e-12, atol=1e-9)
    assert energy_drift(sim, springs) < 1e-6
    assert energy_drift(sim) > 1e-2      # the springs' energy matters: the check has teeth


@pytest.mark.parametrize('name', ['vertical', 'rectilinear', 'general'])
def test_open_loop_round_trip_of_the_paper_motions(name):
    t, q, qd, qdd = motions.get(name).sampled(1000.0)
    force = fsd.solve_batch(MODEL, q, qd, qdd).force
    sim = simulate(MODEL, forces=(t, force))
    assert sim.outcome == Status.OK and len(sim.t) == len(t)
    np.testing.assert_allclose(sim.t, t, rtol=0, atol=1e-12)
    assert np.max(np.abs(sim.q - q)) < 1e-6
    assert np.max(np.abs(sim.qd - qd)) < 1e-5
    # the rows hold the forces applied, and the lengths and rates of the motion
    np.testing.assert_allclose(sim.force, force, rtol=0, atol=1e-9)
    solved = fsd.solve_batch(MODEL, sim.q, sim.qd, sim.qdd)
    np.testing.assert_allclose(solved.force, sim.force, rtol=0, atol=1e-9)
    np.testing.assert_array_equal(sim.length, solved.length)
    assert set(map(str, sim.status)) == {'ok'}


@pytest.mark.slow
def test_closed_loop_with_full_feedforward_and_exact_plant_tracks_the_violent_motion():
    sim = simulate(FAST, reference=motions.get('violent'), feedforward=FAST)
    assert sim.outcome == Status.OK
    errors = sim.tracking()
    assert max(errors['surge_max'], errors['heave_max'], errors['length_max']) < 1e-4
    assert errors['roll_max'] < 1e-4
    assert np.max(np.abs(sim.rate)) > 1.2         # it did move at the motion's peak speed
    # without feed-forward the same servos lag by centimetres
    none = simulate(FAST, reference=motions.get('violent')).tracking()
    assert none['length_max'] > 100 * errors['length_max'] and none['length_max'] > 1e-3


@pytest.mark.slow
def test_the_speed_limit_saturates_the_actuators():
    sim = simulate(MODEL, reference=motions.get('violent'), feedforward=MODEL)
    assert MODEL.limits.max_speed == 1.0
    # no actuator drives a leg beyond 1 m/s (the motion asks 1.22 m/s); what
    # passes it is gravity, against the full braking force allowed
    fast = np.abs(sim.rate) > MODEL.limits.max_speed
    assert fast.any() and np.all(sim.force[fast] * sim.rate[fast] <= 0.0)
    driving = sim.force * sim.rate > 0.0
    line = MODEL.limits.max_force * (1.0 - np.abs(sim.rate) / MODEL.limits.max_speed)
    assert driving.any() and np.all(np.abs(sim.force[driving]) <= line[driving] + 1e-9)
    assert sim.tracking()['length_max'] > 1e-3
    limits = replace(MODEL.limits, max_force=40.0)   # general peaks at 43 N
    weak = simulate(replace(MODEL, limits=limits), reference=motions.get('general'),
                    feedforward=MODEL)
    assert np.max(np.abs(weak.force)) == 40.0


@pytest.mark.slow
def test_a_heavier_plant_than_the_controller_thinks_is_tracked_less_well():
    controller = fsd.load_model(scene='payload')             # 140 kg cab and occupant
    plant = replace(controller, payload=replace(controller.payload, mass=180.0))
    motion = motions.get('general')
    exact = simulate(plant, reference=motion, feedforward=plant).tracking()
    wrong = simulate(plant, reference=motion, feedforward=controller).tracking()
    none = simulate(plant, reference=motion).tracking()
    assert exact['length_max'] < 1e-6 < wrong['length_max'] < none['length_max']


def test_deliver_saturates_force_and_drives_no_faster_than_the_speed_limit():
    f = deliver(np.array([3000.0, -3000.0, 500.0, 500.0, 500.0, -500.0]),
                np.array([0.0, 0.0, 0.5, 1.0, -2.0, 0.9]), 2000.0, 1.0)
    assert f.tolist() == pytest.approx([2000.0, -2000.0, 500.0, 0.0, 500.0, -500.0])
    f = deliver(np.array([1900.0, -1900.0]), np.array([0.5, -0.25]), 2000.0, 1.0)
    assert f.tolist() == pytest.approx([1000.0, -1500.0])


def test_node_slopes_are_exact_for_quartics_on_an_uneven_grid():
    t = np.cumsum(np.random.default_rng(3).uniform(0.01, 0.02, 40))
    for degree in range(5):
        y = np.column_stack([t ** degree, 2 * t ** degree, -t ** degree])
        exact = degree * t ** max(degree - 1, 0) if degree else np.zeros_like(t)
        np.testing.assert_allclose(node_slopes(t, y)[:, 0], exact, rtol=1e-8, atol=1e-8)
    two = node_slopes(np.array([0.0, 2.0]), np.array([[1.0, 2.0, 3.0], [3.0, 2.0, 1.0]]))
    assert two.tolist() == [[1.0, 0.0, -1.0]] * 2


def test_force_history_reproduces_cubics_and_converges_at_fourth_order():
    t = np.cumsum(np.r_[0.0, np.random.default_rng(4).uniform(0.05, 0.1, 30)])
    cubic = lambda x: np.column_stack([x ** 3 - x, 2 * x ** 2, np.ones_like(x)])  # noqa: E731
    between = 0.5 * (t[1:] + t[:-1])
    np.testing.assert_allclose(ForceHistory(t, cubic(t))(between), cubic(between), atol=1e-12)
    errors = []
    for n in (50, 100, 200):
        grid = np.linspace(0.0, 3.0, n + 1)
        history = ForceHistory(grid, np.sin(grid)[:, None] * np.ones(3))
        mid = 0.5 * (grid[1:] + grid[:-1])
        errors.append(np.max(np.abs(history(mid)[:, 0] - np.sin(mid))))
    orders = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert np.all(orders > 3.7), orders
    with pytest.raises(ValueError, match=r'spans \[0, 3\] s'):
        history(np.array([3.5]))


def test_reference_from_samples_is_exact_at_the_rows_and_for_quintics():
    t = np.linspace(0.0, 1.0, 11)
    c = np.array([0.3, -0.2, 0.5, 0.1, -0.4, 0.2])     # a quintic, per coordinate scaled

    def quintic(x: np.ndarray) -> tuple:
        x = x[:, None] * np.ones(3) * np.array([1.0, 0.5, -1.0])
        p = sum(c[k] * x ** k for k in range(6))
        dp = sum(k * c[k] * x ** (k - 1) for k in range(1, 6)) * np.array([1.0, 0.5, -1.0])
        ddp = sum(k * (k - 1) * c[k] * x ** (k - 2) for k in range(2, 6)) * np.array(
            [1.0, 0.25, 1.0])
        return p, dp, ddp

    ref = Reference.from_samples(t, *quintic(t))
    x = np.linspace(0.0, 1.0, 97)
    for got, want in zip(ref.motion(x), quintic(x)):
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-12)
    assert (ref.start, ref.end) == (0.0, 1.0)


@pytest.mark.slow
def test_closed_loop_from_csv_like_samples_matches_the_exact_motion():
    motion = motions.get('violent')
    t, q, qd, qdd = motion.sampled(1000.0)
    sampled = simulate(FAST, reference=Reference.from_samples(t, q, qd, qdd), feedforward=FAST)
    exact = simulate(FAST, reference=motion, feedforward=FAST)
    assert np.max(np.abs(sampled.q - exact.q)) < 1e-6
    assert sampled.tracking()['length_max'] < 1e-4


def test_open_loop_stops_with_a_status_when_the_motion_leaves_the_workspace():
    t = np.array([0.0, 2.0])
    push = np.tile([40.0, 300.0, 300.0], (2, 1))      # about 8 times the weight on B, C
    sim = simulate(MODEL, forces=(t, push))
    assert sim.outcome in (Status.UNREACHABLE, Status.NEAR_SINGULAR), sim.outcome_detail
    assert sim.outcome_detail.startswith('step from t = ') and sim.t[-1] < 2.0
    for name in ('q', 'qd', 'qdd', 'length', 'rate', 'force'):
        assert np.all(np.isfinite(getattr(sim, name))), name
    assert len(sim.status) == len(sim.t) == len(sim.detail)


def test_open_loop_stops_near_the_roll_singularity():
    hold = fsd.solve(MODEL, (0, 0, 1.0), (0, 0, 0), (0, 0, 0)).force
    sim = simulate(MODEL, forces=([0.0, 1.0], np.tile(hold, (2, 1))),
                   initial=((0.0, 0.0, 1.0), (0.0, 0.0, 1.0)))
    assert sim.outcome == Status.NEAR_SINGULAR and 'condition' in sim.outcome_detail
    assert sim.t[-1] < 0.2 and np.all(np.isfinite(sim.qdd))


def test_a_state_that_is_unreachable_stops_at_once():
    sim = simulate(MODEL, forces=([0.0, 1.0], np.zeros((2, 3))),
                   initial=((0.0, -0.8, 0.0), (0.0, 0.0, 0.0)))
    assert sim.outcome == Status.UNREACHABLE and sim.outcome_detail.startswith('t = 0 s: loop')
    assert len(sim.t) == 1 and sim.status[0] == Status.UNREACHABLE
    assert np.all(sim.qdd == 0.0) and np.all(sim.force == 0.0)


@pytest.mark.parametrize('kwargs, message', [
    (dict(), 'give either forces'),
    (dict(forces=([0, 1], np.zeros((2, 3))), reference=rest_reference(1.0)), 'give either'),
    (dict(forces=([0, 1], np.zeros((2, 3))), feedforward=MODEL), 'closed loop'),
    (dict(forces=([0, 1], np.zeros((2, 3))), servo=Servo((1,) * 3, (1,) * 3)), 'closed loop'),
    (dict(forces=([0, 1], [[0, 0, 0], [0, np.nan, 0]])), r'force\[1, 1\] is not finite'),
    (dict(forces=([0, 1], np.zeros((2, 2)))), r'force must have shape \(2, 3\)'),
    (dict(forces=([0, 0], np.zeros((2, 3)))), 'times must increase strictly'),
    (dict(forces=([0], np.zeros((1, 3)))), 'at least 2'),
    (dict(forces=([0, 1], np.zeros((2, 3))), step=0.0), 'step must be a positive'),
    (dict(forces=([0, 1], np.zeros((2, 3))), step=2.0), 'less than one step'),
    (dict(forces=([0, 1], np.zeros((2, 3))), initial=((0, 0, np.inf), (0, 0, 0))),
     'initial q'),
    (dict(forces=([0, 1], np.zeros((2, 3))), initial=(0, 0, 0)), 'initial must be'),
    (dict(reference=object()), 'reference must be a Reference or a motion'),
    (dict(reference=Reference(lambda t: (np.tile([0, -0.8, 0], (np.size(t), 1)),
                                         np.zeros((np.size(t), 3)),
                                         np.zeros((np.size(t), 3))), 0.0, 1.0)),
     'the reference motion at t = 0 s: unreachable'),
])
def test_bad_arguments_are_clear_errors(kwargs, message):
    with pytest.raises(ValueError, match=message):
        simulate(MODEL, **kwargs)


def test_a_plant_without_inertia_cannot_be_simulated_and_gains_are_checked():
    with pytest.raises(ValueError, match="scene 'quasi_static' computes no inertia"):
        simulate(fsd.load_model(scene='quasi_static'), forces=([0, 1], np.zeros((2, 3))))
    with pytest.raises(ValueError, match='servo kd must be 3 finite numbers >= 0'):
        Servo((1.0, 1.0, 1.0), (1.0, -1.0, 1.0))
    with pytest.raises(ValueError, match='servo bandwidth must be > 0 Hz'):
        servo_for_bandwidth(MODEL, 0.0)


def test_default_gains_are_a_critically_damped_leg_at_the_documented_bandwidth():
    servo = servo_for_bandwidth(MODEL)
    rest = (0.0, 0.0, 0.0)
    base = fsd.solve(MODEL, rest, rest, rest)
    # leg-space mass: the force per unit leg acceleration, M J^-1, from three solves
    mass = np.array([fsd.solve(MODEL, rest, rest, np.linalg.solve(base.jacobian, e)).force
                     - base.force for e in np.eye(3)]).T
    w = 2 * np.pi * 5.0
    np.testing.assert_allclose(servo.kp, np.diag(mass) * w ** 2, rtol=1e-12)
    np.testing.assert_allclose(servo.kd, 2.0 * np.diag(mass) * w, rtol=1e-12)
    assert 5.0 < mass[0, 0] < 10.0 and 2.0 < mass[1, 1] < 5.0    # kg
