"""The limiter (flight_sim_dynamics/cueing/limiter.py) against the design's
guarantees (/work/shared/design/cueing.md, "What the limiter must guarantee"),
on both machines with their packaged params files, for random and adversarial
desired trajectories (multi-g spikes, steps, crashes, NaN, huge sines):

- every output sample within the machine's limits by the package's solve
  (status ok) AND by an independent model (test/reference: the 3-DOF
  reference model, the hexapod's pinocchio reference), whose lengths, rates
  and forces are compared with the limits of the params file;
- smooth: every sample is the continuation of the one before by the
  limiter's integration rule (exactly where the limiter integrates; within
  its catch-up tolerance where it passes the washout's sample on);
- invisible where the washout fits: the output is the input, bit for bit;
- braking (given up = 1) from any state the limiter produced stays within
  the limits down to rest;
- given_up and limit reported when limiting.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import reference_model as ref3
import stewart_reference as ref6
from flight_sim_dynamics import load_model, solve_batch
from flight_sim_dynamics.config.machine_files import load_cueing
from flight_sim_dynamics.cueing import limiter as lm
from flight_sim_dynamics.config.cueing import cueing_params, defaults
from flight_sim_dynamics.config.files import PACKAGED_SECTION
from flight_sim_dynamics.core.machine import narrowed_limits
from flight_sim_dynamics.machines import FLIGHT_SIMULATOR, MACHINES, STEWART
from flight_sim_dynamics.machines.api import machine_of

CONFIG = Path(__file__).resolve().parents[2] / 'config'
FILES = {FLIGHT_SIMULATOR.name: CONFIG / 'flight_sim_dynamics.yaml',
         STEWART.name: CONFIG / 'stewart_6dof.yaml'}
LIMIT_NAMES = {'stroke', 'speed', 'force', 'joint_angle', 'condition', 'unreachable',
               'overflow', lm.INPUT}
G = 9.80665


class Setup:
    """A machine's model, cueing params and independent reference, from its params file."""

    def __init__(self, machine) -> None:
        path = FILES[machine.name]
        self.machine = machine
        self.model = load_model(str(path))
        with open(path, encoding='utf-8') as stream:
            data = yaml.safe_load(stream)
        self.params = load_cueing(path).replace(limiter='inverse_dynamics')
        self.dt = 1.0 / self.params.rate
        self.dof = machine.dof
        self.linear = np.array([u == 'm' for u in machine.units])
        limits = machine.actuator_limits(self.model)
        self.limits = limits
        if machine is STEWART:
            self.ref = ref6.machine_from_dict(data)
            lim = data[PACKAGED_SECTION]['ros__parameters']['limits']
            self.length_range = (lim['length_min'], lim['length_max'])
        else:
            self.ref = ref3.load_reference_params(path)

    def limiter(self) -> lm.InverseDynamicsLimiter:
        made = lm.make_limiter(self.model, self.params)
        assert isinstance(made, lm.InverseDynamicsLimiter)
        return made


SETUPS = {m.name: Setup(m) for m in MACHINES}


@pytest.fixture(params=[m.name for m in MACHINES])
def setup(request) -> Setup:
    return SETUPS[request.param]


def run(limiter, q, qd, qdd):
    """The limiter over desired samples (N, dof): outputs (q, qd, qdd, given_up, limit)."""
    n = len(q)
    out = [limiter.step(q[k], qd[k], qdd[k]) for k in range(n)]
    return (np.array([o.q for o in out]).reshape(n, -1),
            np.array([o.qd for o in out]).reshape(n, -1),
            np.array([o.qdd for o in out]).reshape(n, -1),
            np.array([o.given_up for o in out]), [o.limit for o in out])


def distinct(rows: np.ndarray, q, qd, qdd) -> np.ndarray:
    """The indices ``rows`` less those whose (q, qd, qdd) repeats an earlier one's."""
    _, first = np.unique(np.hstack([q[rows], qd[rows], qdd[rows]]), axis=0, return_index=True)
    return rows[np.sort(first)]


def check_within_limits(s: Setup, q, qd, qdd) -> None:
    """Every sample ok by the package's solve and within the limits by the
    independent reference (all samples for the 3-DOF machine; for the
    hexapod's slower pinocchio reference the samples nearest to a limit by
    the package's numbers, and every 20th). A sample equal to one already
    checked (the platform held at rest, or at the desired pose once caught up)
    is the same check: the reference sees each distinct sample once.
    """
    assert np.isfinite(q).all() and np.isfinite(qd).all() and np.isfinite(qdd).all()
    sol = solve_batch(s.model, q, qd, qdd)
    bad = [(k, str(sol.status[k]), sol.detail[k]) for k in np.flatnonzero(
        np.array([str(x) != 'ok' for x in sol.status]))]
    assert not bad, bad[:3]
    lim = s.limits
    tol = 1e-9
    if s.machine is STEWART:
        use = np.maximum.reduce([np.abs(sol.force).max(1) / lim.max_force,
                                 np.abs(sol.rate).max(1) / lim.max_speed,
                                 np.maximum(sol.stroke / lim.stroke_max,
                                            sol.stroke / lim.stroke_min).max(1)])
        pick = distinct(np.union1d(np.argsort(use)[-60:], np.arange(0, len(q), 20)),
                        q, qd, qdd)
        length = ref6.leg_lengths(s.ref, q[pick])
        rate = ref6.leg_rates(s.ref, q[pick], qd[pick])
        force = ref6.forces_pinocchio(s.ref, q[pick], qd[pick], qdd[pick])
        low, high = s.length_range
        assert (length >= low - tol).all() and (length <= high + tol).all()
    else:
        pick = distinct(np.arange(len(q)), q, qd, qdd)
        q, qd, qdd = q[pick], qd[pick], qdd[pick]
        r = ref3.reference_solve(s.ref, q, qd, qdd)
        assert ref3.reachable(s.ref, q).all()
        stroke, rate, force = r['stroke'], r['rate'], r['force']
        assert (stroke >= lim.stroke_min - tol).all() and (stroke <= lim.stroke_max + tol).all()
    assert (np.abs(rate) <= lim.max_speed + tol).all()
    assert (np.abs(force) <= lim.max_force * (1 + tol)).all()


def check_smooth(s: Setup, q, qd, qdd) -> None:
    """Each sample the continuation of the one before (from home at rest) by the
    limiter's rule: within the catch-up tolerance (the limiter passes the
    washout's own sample on only within it, angles within the wider one that
    lets the washout's tilt-rate steps through; its own samples are exact).
    """
    n = len(q)
    q0 = np.vstack([np.zeros(s.dof), q[:-1]])
    qd0 = np.vstack([np.zeros(s.dof), qd[:-1]])
    a0 = np.vstack([np.zeros(s.dof), qdd[:-1]])
    pq, pqd = lm.advance(q0, qd0, a0, qdd, s.dt)
    slack = 1e-12 * (1.0 + np.abs(q) + np.abs(qd))
    tol_q = np.where(s.linear, lm.CATCH_UP_POSITION, lm.TRACK_ANGLE)
    tol_qd = np.where(s.linear, lm.CATCH_UP_RATE, lm.TRACK_ANGLE_RATE)
    assert (np.abs(q - pq) <= tol_q + slack).all(), n
    assert (np.abs(qd - pqd) <= tol_qd + slack).all(), n


def check_reports(given_up, limit) -> None:
    assert ((given_up >= 0.0) & (given_up <= 1.0)).all()
    assert set(limit) <= LIMIT_NAMES | {''}
    assert all((g > 0.0) == bool(name) for g, name in zip(given_up, limit))


# -- desired trajectories ---------------------------------------------------------

def sines(s: Setup, n: int, amplitude, omega, phase):
    """Analytic sines per coordinate (amplitude in m or rad), desired samples (N, dof)."""
    t = np.arange(1, n + 1)[:, None] * s.dt
    arg = omega * t + phase
    return (amplitude * (np.sin(arg) - np.sin(phase)), amplitude * omega * np.cos(arg),
            -amplitude * omega * omega * np.sin(arg))


@st.composite
def violent(draw, s: Setup, n_min: int = 400, n_max: int = 1200):
    """A desired trajectory: huge sines plus steps, multi-g spikes, crashes, NaN."""
    n = draw(st.integers(n_min, n_max))
    dof = s.dof
    amp = np.array(draw(st.lists(st.floats(0.0, 2.0), min_size=dof, max_size=dof)))
    omega = np.array(draw(st.lists(st.floats(0.5, 30.0), min_size=dof, max_size=dof)))
    phase = np.array(draw(st.lists(st.floats(0.0, 6.3), min_size=dof, max_size=dof)))
    q, qd, qdd = sines(s, n, amp, omega, phase)
    events = draw(st.lists(st.tuples(
        st.sampled_from(['step', 'spike', 'crash', 'nan', 'huge']),
        st.integers(0, n - 1), st.integers(1, 200), st.integers(0, dof - 1),
        st.floats(-1.0, 1.0)), max_size=5))
    for kind, start, length, axis, value in events:
        window = slice(start, start + length)
        if kind == 'step':          # the desired pose jumps (and stays)
            q[start:, axis] += value
        elif kind == 'spike':       # up to 10 g for a few samples
            qdd[window, axis] += 10.0 * G * value
        elif kind == 'crash':       # a crash in the log: everything large at once
            q[window] *= 1.0 + 50.0 * abs(value)
            qd[window] += 20.0 * value
            qdd[window] += 100.0 * G * value
        elif kind == 'nan':
            [q, qd, qdd][axis % 3][window, axis] = math.nan
        else:
            qdd[window, axis] = 1e300 * (value or 1.0)
    return q, qd, qdd


# -- the guarantees -------------------------------------------------------------

@pytest.mark.parametrize('name', [m.name for m in MACHINES])
def test_every_output_within_limits_smooth_and_reported(name, sweep) -> None:
    s = SETUPS[name]

    @settings(max_examples=sweep(24), suppress_health_check=[HealthCheck.too_slow])
    @given(data=st.data())
    def check(data) -> None:
        q, qd, qdd = data.draw(violent(s))
        oq, oqd, oqdd, given_up, limit = run(s.limiter(), q, qd, qdd)
        check_within_limits(s, oq, oqd, oqdd)
        check_smooth(s, oq, oqd, oqdd)
        check_reports(given_up, limit)
    check()


@pytest.mark.parametrize('name', [m.name for m in MACHINES])
def test_braking_from_any_state_it_produced_stays_within_limits(name, sweep) -> None:
    """The fallback (given up = 1: braking) from wherever the limiter is: a
    violent prefix, then nothing to follow (NaN) until the platform is at rest.
    """
    s = SETUPS[name]
    rest = 5000    # > the longest braking (max rate / braking deceleration) and its tail
    nan = np.full((rest, s.dof), math.nan)

    @settings(max_examples=sweep(16), suppress_health_check=[HealthCheck.too_slow])
    @given(data=st.data())
    def check(data) -> None:
        q, qd, qdd = data.draw(violent(s, 100, 800))
        oq, oqd, oqdd, given_up, limit = run(s.limiter(), np.vstack([q, nan]),
                                             np.vstack([qd, nan]), np.vstack([qdd, nan]))
        check_within_limits(s, oq, oqd, oqdd)
        check_smooth(s, oq, oqd, oqdd)
        assert (given_up[-rest:] == 1.0).all() and set(limit[-rest:]) == {lm.INPUT}
        # at rest, held (the last periods' rates decay geometrically, by 2^-1/2 a period)
        assert (np.abs(oqd[-1]) < 1e-12).all() and (np.abs(oqdd[-1]) < 1e-9).all()
        assert np.abs(oq[-1] - oq[-2]).max() < 1e-15
    check()


def test_a_huge_sine_on_every_coordinate_stays_within_limits(setup) -> None:
    """0.5 m and 0.5 rad at 2 rad/s on every coordinate at once, starting at
    full rate: far beyond the workspace (on the 3-DOF machine a braking whose
    stop point was not checked beyond its end reached an unreachable pose).
    """
    s = setup
    q, qd, qdd = sines(s, 3000, np.full(s.dof, 0.5), np.full(s.dof, 2.0), np.zeros(s.dof))
    oq, oqd, oqdd, given_up, limit = run(s.limiter(), q, qd, qdd)
    check_within_limits(s, oq, oqd, oqdd)
    check_smooth(s, oq, oqd, oqdd)
    check_reports(given_up, limit)
    assert given_up.max() > 0.0


def test_limiting_is_reported_with_the_limit_that_made_it(setup) -> None:
    """Desired 10 g surge for 0.1 s: a limit (force, speed or stroke) makes
    the limiter give up part of it, and says so; nothing before it.
    """
    s = setup
    n = 300
    q, qd, qdd = np.zeros((n, s.dof)), np.zeros((n, s.dof)), np.zeros((n, s.dof))
    qdd[50:150, 0] = 10.0 * G
    oq, oqd, oqdd, given_up, limit = run(s.limiter(), q, qd, qdd)
    check_within_limits(s, oq, oqd, oqdd)
    first = np.flatnonzero(given_up > 0.0)[0]
    assert 50 <= first < 150 and limit[first] in LIMIT_NAMES - {lm.INPUT}
    assert (given_up[:50] == 0.0).all()
    check_reports(given_up, limit)


@pytest.mark.parametrize('n', [pytest.param(2000, id='the step'),
                               pytest.param(20000, id='caught up', marks=pytest.mark.slow)])
def test_a_desired_step_gives_a_smooth_output(setup, n) -> None:
    """A jump of the desired pose by 5 cm: no jump in the output (the state
    follows it through the pull-back), and it catches up: the output is the
    input again, bit for bit. The unit tier runs the step's first 2 s (the
    pull-back followed smoothly, within the limits); the slow tier the whole
    20 s simulation, caught up (both machines: at 13.6 s).
    """
    s = setup
    q, qd, qdd = np.zeros((n, s.dof)), np.zeros((n, s.dof)), np.zeros((n, s.dof))
    q[100:, 0] = 0.05
    oq, oqd, oqdd, given_up, limit = run(s.limiter(), q, qd, qdd)
    check_within_limits(s, oq, oqd, oqdd)
    check_smooth(s, oq, oqd, oqdd)
    assert abs(oq[100, 0] - oq[99, 0]) < 1e-6
    if n == 20000:
        assert np.array_equal(oq[-100:], q[-100:]) and np.array_equal(oqd[-100:], qd[-100:])
    assert (given_up == 0.0).all()
    assert not np.array_equal(oq[100:200], q[100:200])     # it did not jump there


# -- invisible where the washout fits ----------------------------------------------

def test_invisible_where_the_washout_fits(setup) -> None:
    """Gentle sines from rest, within every limit with the margins: the
    output is the input, bit for bit, and nothing is given up.
    """
    s = setup
    n = 4000
    amplitude = np.where(s.linear, 0.02, 0.02)     # m, rad
    t = np.arange(1, n + 1)[:, None] * s.dt
    w = 2.0 * math.pi * 0.5
    # from rest at home: q = A (1 - cos w t)
    q = amplitude * (1.0 - np.cos(w * t))
    qd = amplitude * w * np.sin(w * t)
    qdd = amplitude * w * w * np.cos(w * t)
    oq, oqd, oqdd, given_up, limit = run(s.limiter(), q, qd, qdd)
    assert np.array_equal(oq, q) and np.array_equal(oqd, qd) and np.array_equal(oqdd, qdd)
    assert (given_up == 0.0).all() and set(limit) == {''}


def test_invisible_on_a_gentle_vehicle_log(setup) -> None:
    """The planner on a gentle manoeuvre: limiter inverse_dynamics gives the
    same samples as limiter none, bit for bit.
    """
    from flight_sim_dynamics.cueing.planner import run as cue
    s = setup
    t = np.arange(0.0, 6.0, 0.01)
    f = np.tile([0.0, 0.0, G], (len(t), 1))
    f[:, 0] += 0.2 * np.sin(0.8 * t)
    f[:, 1] += 0.2 * np.sin(1.3 * t)
    f[:, 2] += 0.2 * np.sin(2.0 * t)
    omega = np.zeros((len(t), 3))
    omega[:, 0] = 0.05 * np.sin(1.1 * t)
    limited = cue(s.model, s.params, t, f, omega)
    pure = cue(s.model, s.params.replace(limiter='none'), t, f, omega)
    assert np.array_equal(limited.q, pure.q) and np.array_equal(limited.qd, pure.qd)
    assert np.array_equal(limited.qdd, pure.qdd)
    assert (limited.given_up == 0.0).all()
    assert np.abs(pure.q).max() > 0.01       # it moves


@pytest.mark.parametrize('vehicle, duration', [
    pytest.param('turbulence', 6.0, id='turbulence-6s'),
    pytest.param('turbulence', 20.0, id='turbulence-20s', marks=pytest.mark.slow)])
def test_invisible_on_a_vehicle_log_the_washout_fits(setup, vehicle, duration) -> None:
    """A vehicle log whose pure washout fits the machine (its rate-limited tilt
    steps its rate): limiter inverse_dynamics gives limiter none's samples,
    bit for bit. The unit tier cues the log's first 6 s (the 2 s onset and 4 s
    of turbulence: every sample of the 20 s whose tilt is rate-limited, 115 on
    the 3-DOF machine and 238 on the hexapod, from 3.1 s on), the slow tier the
    whole 20 s simulation.
    """
    from flight_sim_dynamics.cueing.planner import run as cue
    from flight_sim_dynamics.cueing.vehicles import vehicle_log
    s = setup
    v = vehicle_log(vehicle, 100.0, duration)
    pure = cue(s.model, s.params.replace(limiter='none'), v.t, v.f, v.omega)
    assert all(str(x) == 'ok' for x in solve_batch(s.model, pure.q, pure.qd, pure.qdd).status)
    limited = cue(s.model, s.params, v.t, v.f, v.omega)
    assert np.array_equal(limited.q, pure.q) and np.array_equal(limited.qd, pure.qd)
    assert np.array_equal(limited.qdd, pure.qdd) and (limited.given_up == 0.0).all()


@pytest.mark.slow       # 34 s of cueing at 1 kHz, 7 s of it limited
def test_after_a_limited_moment_the_washout_is_passed_on_again(setup) -> None:
    """Turbulence with a 2 g push at 5 s, which the limiter limits: once the
    washout fits again, its state catches up with the washout (the angles'
    residue under the pull-back within their catch-up tolerance, L1) and
    passes the washout's own samples on again, bit for bit, over the last 5 s
    (from 26 s on the 3-DOF machine, 28 s on the hexapod; with the
    translations' tolerances for the angles, from 30.4 s and never).
    """
    from flight_sim_dynamics.cueing.planner import run as cue
    from flight_sim_dynamics.cueing.vehicles import vehicle_log
    s = setup
    params = settings_of(s.params, **{'preview.slope': 0.0})     # as the node runs
    v = vehicle_log('turbulence', 100.0, 34.0)
    f = v.f.copy()
    f[(v.t > 5.0) & (v.t < 5.5), 0] += 2.0 * G
    c = cue(s.model, params, v.t, f, v.omega)
    limited = np.flatnonzero(c.given_up > 0.0)
    assert c.t[limited[0]] < 5.1 and c.t[limited[-1]] < 20.0
    last = c.t > c.t[-1] - 5.0
    assert np.array_equal(c.q[last], c.desired_q[last])
    assert np.array_equal(c.qd[last], c.desired_qd[last])
    assert np.array_equal(c.qdd[last], c.desired_qdd[last])
    assert np.abs(c.desired_q[last]).max() > 1e-3        # it moves


# -- the parts -------------------------------------------------------------------

def test_a_block_is_judged_as_each_of_its_samples_alone(setup) -> None:
    """``fits_rows`` (the offline run's judge of a block) is ``fits`` of each
    row, bit for bit: a violent log's washout scaled by random factors, pairs
    of its samples scaled to either side of the edge of the limits (2^-40
    apart: any change of the rule's numbers moves some edge), random samples
    over the coordinates' ranges at up to 1.5 m/s or rad/s (brakings long
    enough for interior poses), zero, NaN, infinite and 1e300 rows; an empty
    block.
    """
    from flight_sim_dynamics.cueing.planner import run as cue
    from flight_sim_dynamics.cueing.vehicles import vehicle_log
    s = setup
    limiter, dof = s.limiter(), s.dof
    rng = np.random.default_rng(11)
    v = vehicle_log('violent', 100.0, 12.0)
    pure = cue(s.model, s.params.replace(limiter='none'), v.t, v.f, v.omega)
    k = rng.uniform(0.0, 2.0, (len(pure.t), 1))
    edges = []
    for i in rng.choice(len(pure.t), 150, replace=False):
        sample = [x[i].tolist() for x in (pure.q, pure.qd, pure.qdd)]
        below, above = 0.0, 4.0
        if limiter.fits(*([4.0 * v for v in x] for x in sample)):
            continue
        for _ in range(40):
            mid = 0.5 * (below + above)
            if limiter.fits(*([mid * v for v in x] for x in sample)):
                below = mid
            else:
                above = mid
        edges += [[below * np.array(x) for x in sample], [above * np.array(x) for x in sample]]
    n = 1500
    low, high = np.array(limiter.low), np.array(limiter.high)
    rows = [np.vstack([k * pure.q, [e[0] for e in edges],
                       rng.uniform(1.3 * low, 1.3 * high, (n, dof)), np.zeros((4, dof))]),
            np.vstack([k * pure.qd, [e[1] for e in edges], rng.uniform(-1.5, 1.5, (n, dof)),
                       np.zeros((4, dof))]),
            np.vstack([k * pure.qdd, [e[2] for e in edges], rng.normal(0.0, 4.0, (n, dof)),
                       np.zeros((4, dof))])]
    for j, bad in enumerate((math.nan, math.inf, 1e300)):
        rows[j % 3][-1 - j, j % dof] = bad
    interior = []
    refused = limiter._refused
    limiter._refused = lambda *sample: interior.append(1) or refused(*sample)
    got = limiter.fits_rows(*rows)
    limiter._refused = refused
    want = [limiter.fits(*(r[i].tolist() for r in rows)) for i in range(len(rows[0]))]
    assert got.dtype == bool and got.tolist() == want
    assert 0.2 < np.mean(want) < 0.8 and want[-4] and not any(want[-3:])
    assert len(interior) > 10           # rows whose braking has interior poses
    assert len(edges) > 200
    assert limiter.fits_rows(*(r[:0] for r in rows)).shape == (0,)

def test_none_passes_the_sample_through(setup) -> None:
    made = lm.make_limiter(setup.model, setup.params.replace(limiter='none'))
    q = np.full(setup.dof, 5.0)
    out = made.step(q, q, q)
    assert out.q is q and out.given_up == 0.0 and out.limit == ''


def test_reset_returns_home_at_rest(setup) -> None:
    s = setup
    limiter = s.limiter()
    for _ in range(200):
        limiter.step(np.full(s.dof, 0.3), np.zeros(s.dof), np.full(s.dof, 3.0))
    limiter.reset()
    out = limiter.step(np.zeros(s.dof), np.zeros(s.dof), np.zeros(s.dof))
    assert not out.q.any() and not out.qd.any() and out.limit == ''


def test_tightened_limits_keep_the_margins(setup) -> None:
    """The margins as the machine's actuator limits see them; the solve of
    the tightened model refuses what the model accepts in the margin.
    """
    s = setup
    tight = s.machine.tightened(s.model, 0.01, 0.1)
    a, b = s.machine.actuator_limits(s.model), s.machine.actuator_limits(tight)
    assert np.allclose(b.stroke_min, a.stroke_min + 0.01)
    assert np.allclose(b.stroke_max, a.stroke_max - 0.01)
    assert b.max_speed == pytest.approx(0.9 * a.max_speed)
    assert b.max_force == pytest.approx(0.9 * a.max_force)


def test_tightened_refuses_an_unknown_limit_and_no_travel(setup) -> None:
    from dataclasses import make_dataclass
    s = setup
    with pytest.raises(ValueError, match='stroke'):
        s.machine.tightened(s.model, 10.0, 0.0)
    with pytest.raises(ValueError, match='cueing.margin'):      # named by the limiter
        lm.InverseDynamicsLimiter(s.model, dict(s.params.limiter_settings,
                                                **{'margin.stroke': 10.0}), 100.0)
    odd = make_dataclass('Limits', [('low', float), ('high', float),
                                    ('max_temperature', float)])(0.0, 1.0, 1.0)
    with pytest.raises(ValueError, match='max_temperature'):
        narrowed_limits(odd, ('low', 'high'), ('max_speed',), 0.0, 0.0)
    assert narrowed_limits(odd, ('low', 'high'), ('max_temperature',), 0.1, 0.5) == \
        type(odd)(0.1, 0.9, 0.5)


def test_a_machine_without_margins_runs_no_inverse_dynamics_limiter(setup, monkeypatch):
    from dataclasses import replace
    s = setup
    monkeypatch.setattr(lm, 'machine_of', lambda model: replace(s.machine, tightened=None))
    with pytest.raises(ValueError, match='limiter none'):
        lm.InverseDynamicsLimiter(s.model, s.params.limiter_settings, 100.0)


def test_limiter_keys_are_read_from_the_cueing_group() -> None:
    p = cueing_params({'margin': {'stroke': 0.02}, 'braking': [2.0, 3.0]})
    assert p.limiter_settings['margin.stroke'] == 0.02
    assert list(p.limiter_settings['braking']) == [2.0, 3.0]
    assert defaults().limiter_settings['margin.fraction'] == 0.05
    limiter = lm.make_limiter(load_model(str(FILES[STEWART.name])), p)
    assert limiter.tight.limits.length_min == pytest.approx(
        load_model(str(FILES[STEWART.name])).limits.length_min + 0.02)
    assert machine_of(limiter.model) is STEWART


def takeoff(duration: float):
    """The first ``duration`` s of the take-off log (t, f, omega) at 100 Hz."""
    from flight_sim_dynamics.cueing.vehicles import vehicle_log
    v = vehicle_log('takeoff', 100.0)
    keep = v.t <= duration
    return v.t[keep], v.f[keep], v.omega[keep]


def settings_of(params, **changed):
    """``params`` with the limiter's settings ``changed`` (dotted names)."""
    return params.replace(limiter_settings={**params.limiter_settings, **changed})


def felt_rmse(cues, params) -> list[float]:
    """The RMSE of the felt specific force at the head of each run of
    ``cues`` but the last, against the last (the pure washout).
    """
    from flight_sim_dynamics.cueing.metrics import felt, six

    def force(c):
        return felt(*(six(c.coordinates, x) for x in (c.q, c.qd, c.qdd)), params.head)[0]

    wanted = force(cues[-1])
    return [float(np.sqrt(np.mean(np.sum((force(c) - wanted) ** 2, axis=1))))
            for c in cues[:-1]]


def test_the_look_ahead_lowers_the_cue_before_the_limit_and_gives_up_less():
    """(L7) On the 3-DOF machine's take-off (the washout's surge runs past its
    range for a moment): with the look-ahead the gain is lowered before the
    limit comes, every output ok, and less of the felt specific force is given
    up than by the governor alone (gain.ahead 0).
    """
    from flight_sim_dynamics.cueing.planner import run as cue
    s = SETUPS[FLIGHT_SIMULATOR.name]
    log = takeoff(8.0)
    causal = settings_of(s.params, **{'preview.slope': 0.0})    # as when streaming
    alone = settings_of(causal, **{'gain.ahead': 0.0})
    runs = [cue(s.model, p, *log) for p in (causal, alone, s.params.replace(limiter='none'))]
    errors = felt_rmse(runs, s.params)
    first = [int(np.argmax(c.given_up > 0)) for c in runs[:2]]
    assert runs[1].given_up.any() and first[0] < first[1]
    assert errors[0] < errors[1]
    assert all(str(x) == 'ok' for x in solve_batch(s.model, runs[0].q, runs[0].qd,
                                                    runs[0].qdd).status)


# -- the preview of an offline run (L8) -------------------------------------------

def test_the_preview_envelope_is_the_largest_gain_below_k_within_its_slope_and_lead():
    """envelope(k) against its definition, g[n] = min over m of
    k[m] + slope d(n, m), d = max(0, m - n - lead) for m ahead of n, n - m
    behind it, on random gains (brute force).
    """
    from flight_sim_dynamics.cueing.preview import envelope
    rng = np.random.default_rng(3)
    for lead in (0, 1, 2, 7, 8):
        k = np.where(rng.random(300) < 0.05, rng.random(300), 1.0)
        slope = 0.01
        n = np.arange(len(k))
        ahead = n[None, :] - n[:, None]             # m - n
        far = np.where(ahead >= 0, np.maximum(0, ahead - lead), -ahead)
        want = (k[None, :] + slope * far).min(axis=1)
        np.testing.assert_allclose(envelope(k, slope, lead), want, rtol=0, atol=1e-12)


def test_the_preview_at_a_constant_gain_is_every_washout_gain_times_it():
    """The vehicle's motion scaled about its rest by g (preview.scaled) gives
    the washout whose translation, tilt and rotation gains are times g (the
    usual practice); the samples at g = 1 are left as they are, bit for bit.
    """
    from flight_sim_dynamics.cueing.planner import run as cue
    from flight_sim_dynamics.cueing.preview import scaled
    s = SETUPS[STEWART.name]
    t, f, omega = takeoff(4.0)
    u = np.hstack([f, omega])
    ones = scaled(u, np.ones(len(t)))
    assert np.array_equal(ones, u)
    g = 0.6
    half = scaled(u, np.full(len(t), g))
    pure = s.params.replace(limiter='none')
    lowered = pure.replace(translation_gain=pure.translation_gain * g,
                           tilt_gain=pure.tilt_gain * g, rotation_gain=pure.rotation_gain * g)
    a = cue(s.model, pure, t, half[:, :3], half[:, 3:])
    b = cue(s.model, lowered, t, f, omega)
    assert np.abs(b.q).max() > 0.05
    for x, y in ((a.q, b.q), (a.qd, b.qd), (a.qdd, b.qdd)):
        np.testing.assert_allclose(x, y, rtol=0, atol=1e-9)


def vehicle_crash(n_seconds: float = 6.0, rate: float = 100.0):
    """A vehicle log (t, f, omega) of gusts, a 3 g push, a 10 g crash, NaN
    samples and a 1e300 spike: what no machine takes at full gain.
    """
    t = np.arange(0.0, n_seconds, 1.0 / rate)
    f = np.tile([0.0, 0.0, G], (len(t), 1))
    f[:, 0] += 1.5 * np.sin(2.6 * t) + 3.0 * G * ((t > 1.0) & (t < 1.6))
    f[:, 1] += 2.0 * np.sin(1.4 * t)
    f[(t > 2.5) & (t < 2.65), 0] -= 10.0 * G
    f[(t > 2.5) & (t < 2.65), 2] += 4.0 * G
    omega = np.column_stack([0.3 * np.sin(1.8 * t), 0.2 * np.sin(3.4 * t),
                             0.1 * np.sin(1.0 * t)])
    f[(t > 3.5) & (t < 3.6), 1] = math.nan
    omega[(t > 4.5) & (t < 4.55), 0] = 1e300
    return t, f, omega


def test_the_preview_keeps_every_output_within_limits_and_reports_it(setup) -> None:
    """An offline run with the preview (preview.slope 1/s) of a log with a
    crash, NaN and a 1e300 spike: every output ok by the package's solve and
    within the limits by the independent reference; smooth; every sample that
    gives up cue names a limit; the full-gain washout kept as the desired one.
    """
    from flight_sim_dynamics.cueing.planner import run as cue
    s = setup
    params = settings_of(s.params, **{'preview.slope': 1.0, 'preview.lead': 1.0})
    log = vehicle_crash()
    stages = []
    c = cue(s.model, params, *log, progress=lambda k, n, stage: stages.append((stage, k, n)))
    n = len(c.t)
    assert ('preview pass 1', n, n) in stages and stages[-1] == ('', n, n)
    check_within_limits(s, c.q, c.qd, c.qdd)
    check_smooth(s, c.q, c.qd, c.qdd)
    check_reports(c.given_up, list(c.limit))
    pure = cue(s.model, s.params.replace(limiter='none'), *log)
    assert np.array_equal(c.desired_q, pure.q) and np.array_equal(c.desired_qdd, pure.qdd)
    assert c.given_up.max() > 0.0 and c.held == pure.held > 0


def test_the_preview_lowers_the_cue_ahead_and_gives_up_less_than_the_look_ahead():
    """(L8) On the 3-DOF machine's take-off: the preview (its params file's)
    lowers the gain before the first moment the full-gain washout does not
    fit, every output ok, and gives up less felt specific force than the
    look-ahead (the same file, preview.slope 0: as when streaming).
    """
    from flight_sim_dynamics.cueing.planner import Planner, run as cue
    s = SETUPS[FLIGHT_SIMULATOR.name]
    assert s.params.limiter_settings['preview.slope'] > 0.0
    log = takeoff(8.0)
    causal = settings_of(s.params, **{'preview.slope': 0.0})
    runs = [cue(s.model, p, *log) for p in (s.params, causal, s.params.replace(limiter='none'))]
    errors = felt_rmse(runs, s.params)
    assert errors[0] < errors[1]
    limiter = Planner(s.model, s.params).limiter
    pure = runs[2]
    misfit = next(k for k in range(len(pure.t)) if not limiter.fits(
        pure.q[k].tolist(), pure.qd[k].tolist(), pure.qdd[k].tolist()))
    lowered = int(np.argmax(runs[0].given_up > 0))
    assert lowered < misfit - int(0.5 * s.params.rate)
    assert all(str(x) == 'ok' for x in solve_batch(s.model, runs[0].q, runs[0].qd,
                                                    runs[0].qdd).status)
