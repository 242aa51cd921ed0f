"""Hard cases of the solver: the workspace boundaries approached from inside,
the actuator-Jacobian singularities, tiny and large motions, and garbage at
the Python API (solve, solve_batch, forward_kinematics).

Boundaries, found numerically by bisection along rays from the central
configuration (the machine at rest; the last reachable double is s*):

=================  ==================  =====================  ==================
boundary           ray                 last reachable s*      near_singular from
=================  ==================  =====================  ==================
crank D closure    heave up            1.1863726730347348 m   1.18430766 m
crank E closure    surge forward       0.2287424373301412 m   0.22829660 m
E2 on rod          heave down          0.3062746066806231 m   (never: ok up to s*)
E2 on rod          surge backward      0.42041684766872855 m  (never: ok up to s*)
=================  ==================  =====================  ==================

and along three oblique rays from the end pose of the paper's general example
(0.05 m, 0.1 m, pi/12): s (-0.2, 1, 0) meets the crank D closure at
s* = 1.0985985020217934, s (0.3, -1, 0.2) the crank E closure at
s* = 0.5781780214150806, s (0.5, 1, 0) the E2-on-rod limit at
s* = 0.9507292419772296.

Approaching them, the forces at rest behave as the geometry says: at the
crank D closure they converge (differences ~ sqrt(distance): the rod pitch
beta(q) has a square-root branch point but the statics stay bounded); at the
crank E closure they diverge like distance^-1/2 (crank E and the rod line
become tangent: the loop locks and its internal force grows without bound);
at the E2-on-rod limits (the slider reaches the end of the rod) nothing is
singular and the forces are smooth (differences ~ distance) up to s*. Beyond
every s* the status is unreachable, the loop named, every number 0.

Roll has no closure limit (the platform roll enters no loop; the U-joint
singularity, leg B or C along z0, lies outside any pose: it would need
|t_y| > 1). Large roll ends at an actuator-Jacobian singularity: det J = 0 at
roll* = +-1.0608370074727034 rad (surge = heave = 0; near_singular from
|roll| = 1.04227491 rad) where the forces have a simple pole,
|f| ~ 31.674 N rad / |roll - roll*| (1e6 N at 3e-5 rad, 1e17 N at the closest
double), changing sign across it. Another Jacobian singularity (the previous
investigation's): surge = -0.0887 m, heave = 0.3663 m, roll* = 1.377038825541547
rad (|f| = 9e5 N at 3e-5 rad from it, near_singular within ~0.02 rad).
The near-singular threshold of either condition figure is model.limits
(100 by default): below it the status is ok or limit and the power balance
holds to 1e-9; above it near_singular, the numbers as computed (finite,
power balance to 1e-9 x condition / 100).

Tests named ``test_regression_*`` (end of the file) pin the production bugs
found while writing this suite, each with its input, the expected and the
actual result at the time it was found; all are fixed, and the tests keep
them fixed.
"""
from __future__ import annotations

import math
import re

import numpy as np
import pytest
from hypothesis import Phase, given, settings
from hypothesis import strategies as st

import flight_sim_dynamics as fsd
import reference_model as rm
from flight_sim_dynamics import Status
from flight_sim_dynamics.machines.staicu.kinematics import LOOP_REASONS

MODEL = fsd.load_model()
PARAMS = rm.load_reference_params()
LIM = MODEL.limits
REST = (0.0, 0.0, 0.0)
STANDARD_G = 9.80665
RTOL = 1e-9
COND_THRESHOLD = max(LIM.max_kinematic_condition, LIM.max_jacobian_condition)
# a generic moving state for the approach tests (qd, qdd)
MOTION = ((0.05, -0.04, 0.1), (0.3, -0.2, 0.5))

NUMBER_FIELDS = ('length', 'stroke', 'rate', 'acceleration', 'force', 'power', 'joints',
                 'joint_rates', 'joint_accelerations', 'jacobian', 'beta',
                 'kinematic_condition', 'jacobian_condition', 'cond')
VOID = (Status.UNREACHABLE, Status.INVALID_INPUT)


def examples(fraction: float = 1.0) -> int:
    """max_examples: a fraction of the loaded Hypothesis profile's (conftest.py)."""
    return max(5, int(settings.default.max_examples * fraction))


# ----------------------------------------------------------------------------
# helpers
# ----------------------------------------------------------------------------
def solve_rest(q) -> fsd.Solution:
    return fsd.solve(MODEL, tuple(map(float, q)), REST, REST)


def finite_problems(sol) -> list[str]:
    """Names of the fields of a solution (single or batch) holding a NaN or inf."""
    return [name for name in NUMBER_FIELDS
            if not np.all(np.isfinite(np.asarray(getattr(sol, name), dtype=float)))]


def assert_finite(sol, what: str = '') -> None:
    bad = finite_problems(sol)
    assert not bad, f'{what}: non-finite {bad} (status {sol.status}, {sol.detail})'


def assert_void(sol, i: int | None = None) -> None:
    """Every number 0 (unreachable, invalid_input)."""
    for name in ('length', 'stroke', 'rate', 'acceleration', 'force', 'power', 'joints',
                 'joint_rates', 'joint_accelerations', 'jacobian', 'beta',
                 'kinematic_condition', 'jacobian_condition'):
        value = np.asarray(getattr(sol, name) if i is None else getattr(sol, name)[i])
        assert np.all(value == 0.0), (name, value)


def conditions(sol) -> np.ndarray:
    return np.maximum(np.asarray(sol.kinematic_condition), np.asarray(sol.jacobian_condition))


def near_flag(sol) -> np.ndarray:
    """Where a condition figure exceeds its threshold (from the reported numbers)."""
    return ~((np.asarray(sol.kinematic_condition) <= LIM.max_kinematic_condition)
             & (np.asarray(sol.jacobian_condition) <= LIM.max_jacobian_condition))


def balance_errors(sol, q, qd, qdd, keep=None) -> tuple[np.ndarray, np.ndarray]:
    """Power-balance error of each sample of a batch (the rows ``keep``)
    relative to max(|dE/dt|, sum |P|, 1 W), and the allowed error: 1e-9, times
    condition / 100 above the near-singularity threshold."""
    keep = np.ones(len(q), dtype=bool) if keep is None else keep
    ref = {'dE_dt': reference_energy_rate(q[keep], qd[keep], qdd[keep])}
    power = np.atleast_2d(sol.power)[keep]
    scale = np.maximum(np.maximum(np.abs(ref['dE_dt']), np.abs(power).sum(axis=1)), 1.0)
    error = np.abs(power.sum(axis=1) - ref['dE_dt']) / scale
    allowed = RTOL * np.maximum(1.0, conditions(sol)[keep] / COND_THRESHOLD)
    return error, allowed


def reference_energy_rate(q, qd, qdd) -> np.ndarray:
    """dE/dt of the reference. reference_solve also solves J^T f = tau, which
    raises where J is singular to the last bit: the batch is then split until
    the culprit rows are alone, and for those dE/dt is averaged over two poses
    1e-9 rad away (dE/dt is smooth there; only f has a pole)."""
    with np.errstate(all='ignore'):
        try:
            return rm.reference_solve(PARAMS, q, qd, qdd)['dE_dt']
        except np.linalg.LinAlgError:
            if len(q) > 1:
                half = len(q) // 2
                return np.concatenate([reference_energy_rate(q[:half], qd[:half], qdd[:half]),
                                       reference_energy_rate(q[half:], qd[half:], qdd[half:])])
        h = np.array([0.0, 0.0, 1e-9])
        two = rm.reference_solve(PARAMS, [q[0] - h, q[0] + h], [qd[0]] * 2, [qdd[0]] * 2)
        return np.array([0.5 * two['dE_dt'].sum()])


def bisect(inside, a: float, b: float) -> tuple[float, float]:
    """inside(a) and not inside(b): adjacent doubles (a, b) at the change."""
    assert inside(a) and not inside(b)
    while True:
        c = 0.5 * (a + b)
        if c <= a or c >= b:
            return a, b
        if inside(c):
            a = c
        else:
            b = c


def ray(origin, direction, s) -> np.ndarray:
    return np.asarray(origin, dtype=float) + np.multiply.outer(s, np.asarray(direction, float))


# ----------------------------------------------------------------------------
# closure boundaries
# ----------------------------------------------------------------------------
GENERAL = (0.05, 0.1, math.pi / 12)     # end pose of the paper's general example
# name: (origin, direction, far point (unreachable), loop named, documented s*,
#        singular: a near_singular band precedes s*, order of approach of the
#        forces at rest: successive differences at distances 2^-k scale as 2^-k*order)
BOUNDARIES = {
    'crank D, heave up': ((0, 0, 0), (0, 1, 0), 1.3, 'D', 1.1863726730347348, True, 0.5),
    'crank E, surge forward': ((0, 0, 0), (1, 0, 0), 0.3, 'E', 0.2287424373301412, True, -0.5),
    'E2 on rod, heave down': ((0, 0, 0), (0, -1, 0), 0.5, 'E2 on rod', 0.3062746066806231,
                              False, 1.0),
    'E2 on rod, surge backward': ((0, 0, 0), (-1, 0, 0), 0.5, 'E2 on rod',
                                  0.42041684766872855, False, 1.0),
    # from the end pose of the paper's general example, along oblique rays
    'crank D, general pose': (GENERAL, (-0.2, 1, 0), 1.2, 'D', 1.0985985020217934, True, 0.5),
    'crank E, general pose': (GENERAL, (0.3, -1, 0.2), 0.7, 'E', 0.5781780214150806, True, -0.5),
    'E2 on rod, general pose': (GENERAL, (0.5, 1, 0), 1.0, 'E2 on rod', 0.9507292419772296,
                                False, 1.0),
}
_FOUND: dict[str, tuple[float, float]] = {}


def boundary(name: str) -> tuple[float, float]:
    """(last reachable, first unreachable) double along the ray (cached)."""
    if name not in _FOUND:
        origin, direction, far = BOUNDARIES[name][:3]
        _FOUND[name] = bisect(
            lambda s: solve_rest(ray(origin, direction, s)).status != Status.UNREACHABLE,
            0.0, far)
    return _FOUND[name]


@pytest.mark.parametrize('name', sorted(BOUNDARIES))
def test_boundary_location_and_beyond(name):
    origin, direction, far, loop, documented, singular, _ = BOUNDARIES[name]
    s_in, s_out = boundary(name)
    assert s_in == pytest.approx(documented, abs=1e-9)
    # the reachable part of the ray is [0, s*]: one boundary, no island
    s = np.linspace(0.0, far, 801)
    Q = ray(origin, direction, s)
    zero = np.zeros_like(Q)
    batch = fsd.solve_batch(MODEL, Q, zero, zero)
    assert np.array_equal(batch.status == Status.UNREACHABLE, s > s_in)
    # the independent reference puts the boundary at the same place
    with np.errstate(all='ignore'):
        assert rm.reachable(PARAMS, ray(origin, direction, [s_in - 1e-7]))[0]
        assert not rm.reachable(PARAMS, ray(origin, direction, [s_in + 1e-7]), margin=0.0)[0]
    # at and beyond: unreachable, the loop named (farther out another loop may
    # open first), every number 0, at rest or moving
    beyond = np.concatenate([[s_out, np.nextafter(s_out, np.inf)],
                             s_in + 10.0 ** -np.arange(15.0, 0.0, -1.0), [far]])
    Q = ray(origin, direction, beyond)
    detail = f'loop {loop}: {LOOP_REASONS[loop]}'
    for qd, qdd in (((0, 0, 0), (0, 0, 0)), MOTION):
        Qd, Qdd = np.tile(qd, (len(Q), 1)), np.tile(qdd, (len(Q), 1))
        batch = fsd.solve_batch(MODEL, Q, Qd, Qdd)
        assert_finite(batch)
        for i, q in enumerate(Q):
            one = fsd.solve(MODEL, q, qd, qdd)
            assert one.status == batch.status[i] == Status.UNREACHABLE, (q, one.detail)
            assert one.detail == batch.detail[i]
            if beyond[i] <= s_in + 1e-3:
                assert one.detail == detail
            else:
                assert one.detail.startswith('loop ')
            assert_void(one)
            assert_void(batch, i)
            assert one.cond == 0.0


def approach_points(name: str) -> np.ndarray:
    """s* - 2^-k, k = 3..52, then s* itself: from inside to the last reachable double."""
    s_in, _ = boundary(name)
    s = s_in - 2.0 ** -np.arange(3.0, 53.0)
    return np.unique(np.concatenate([s[s < s_in], [s_in]]))


@pytest.mark.parametrize('name', sorted(BOUNDARIES))
def test_approach_from_inside_finite_balanced_and_right_status(name):
    """From 1/8 m (or rad) inside up to the last reachable double, at rest and
    moving: finite numbers; ok or limit exactly while both condition figures
    are within their thresholds, then near_singular to the boundary (never
    for the E2-on-rod limits); power balance; solve == solve_batch."""
    origin, direction, _, _, _, singular, _ = BOUNDARIES[name]
    s = approach_points(name)
    Q = ray(origin, direction, s)
    for qd, qdd in (((0, 0, 0), (0, 0, 0)), MOTION):
        Qd, Qdd = np.tile(qd, (len(Q), 1)), np.tile(qdd, (len(Q), 1))
        batch = fsd.solve_batch(MODEL, Q, Qd, Qdd)
        assert_finite(batch, name)
        near = near_flag(batch)
        status = batch.status
        assert np.all(status != Status.UNREACHABLE) and np.all(status != Status.INVALID_INPUT)
        assert np.array_equal(status == Status.NEAR_SINGULAR, near), list(zip(s, status))
        # once near_singular, near_singular up to the boundary
        if near.any():
            assert near[np.argmax(near):].all()
        assert near.any() == singular
        assert np.all(np.isin(status[~near], [Status.OK, Status.LIMIT]))
        # the numbers grow, but stay as computed (forces 0 only at an exact singularity)
        assert np.all(np.abs(batch.force).max(axis=1) > 0.0)
        # power balance against the reference wherever it can assemble the pose
        with np.errstate(all='ignore'):
            ok_ref = rm.reachable(PARAMS, Q)
        assert ok_ref[s <= s[-1] - 1e-6].all()           # the reference's margin is 1e-9
        error, allowed = balance_errors(batch, Q, Qd, Qdd, ok_ref)
        worst = np.argmax(error / allowed)
        assert error[worst] <= allowed[worst], (name, s[ok_ref][worst], error[worst])
        # the per-cycle entry point agrees, to rounding: near a closure limit the
        # forces are a square-root branch, so their rounding grows like eps cond^2
        for i in range(0, len(s), 5):
            one = fsd.solve(MODEL, Q[i], qd, qdd)
            assert_finite(one, f'{name} s={s[i]!r}')
            assert one.status == status[i]
            scale = max(float(np.abs(batch.force[i]).max()), 1.0)
            cond = max(1.0, float(conditions(batch)[i]))
            tol = 1e-12 * cond + 1e-14 * cond * cond
            assert np.abs(one.force - batch.force[i]).max() <= tol * scale, (s[i], cond)


@pytest.mark.parametrize('name', sorted(BOUNDARIES))
def test_forces_continuous_up_to_the_threshold(name):
    """At rest, on a uniform grid from the centre to the last point before the
    near-singularity threshold (or s*): halving the step halves the largest
    jump of the forces between neighbouring points (no jump anywhere)."""
    origin, direction, _, _, _, singular, _ = BOUNDARIES[name]
    s_in, _ = boundary(name)
    end = s_in
    if singular:
        end, _ = bisect(lambda s: not near_flag(solve_rest(ray(origin, direction, s))), 0.0, s_in)
        assert solve_rest(ray(origin, direction, end)).status in (Status.OK, Status.LIMIT)
    s = np.linspace(0.0, end, 513)
    mid = 0.5 * (s[1:] + s[:-1])
    zero = np.zeros((len(s), 3))
    f = fsd.solve_batch(MODEL, ray(origin, direction, s), zero, zero).force
    f_mid = fsd.solve_batch(MODEL, ray(origin, direction, mid), zero[1:], zero[1:]).force
    jump = np.abs(np.diff(f, axis=0)).max()
    jump_half = np.abs(f_mid - f[:-1]).max()
    assert np.all(np.isfinite(f)) and np.all(np.isfinite(f_mid))
    assert jump_half <= 0.6 * jump, (jump, jump_half)


@pytest.mark.parametrize('name', sorted(BOUNDARIES))
def test_forces_approach_the_boundary_as_the_geometry_says(name):
    """At rest, at distances 2^-k from s*: successive force differences scale
    like 2^-k*order: order 1 (smooth) at the E2-on-rod limits, 1/2 at the
    crank D closure (forces converge, sqrt branch), -1/2 at the crank E
    closure (forces diverge like distance^-1/2)."""
    origin, direction, _, _, _, _, order = BOUNDARIES[name]
    s_in, _ = boundary(name)
    k = np.arange(18.0, 41.0)          # 4e-6 .. 1e-12 from the boundary
    Q = ray(origin, direction, s_in - 2.0 ** -k)
    zero = np.zeros_like(Q)
    f = fsd.solve_batch(MODEL, Q, zero, zero).force
    diff = np.abs(np.diff(f, axis=0)).max(axis=1)
    observed = np.log2(diff[:-1] / diff[1:])
    assert np.all(np.abs(observed - order) < 0.05), observed
    if order > 0:    # converges: the last reachable pose has the limit forces,
        end = solve_rest(ray(origin, direction, s_in))    # unless Q is singular to
        assert_finite(end)                                 # rounding (cond ~ 1/eps)
        if conditions(end) < 1e12:
            bound = 2.0 * diff[-1] / (1.0 - 2.0 ** -order)
            assert np.abs(end.force - f[-1]).max() <= bound
        else:
            assert end.status == Status.NEAR_SINGULAR


# ----------------------------------------------------------------------------
# actuator-Jacobian singularities
# ----------------------------------------------------------------------------
def det_j(q) -> float:
    return float(np.linalg.det(solve_rest(q).jacobian))


# name: (surge, heave, sign of roll, bracket [lo, hi] of |roll|, documented roll*)
SINGULARITIES = {
    'pure roll': (0.0, 0.0, 1.0, (1.0, 1.1), 1.0608370074727034),
    'pure roll, negative': (0.0, 0.0, -1.0, (1.0, 1.1), -1.0608370074727034),
    'surge -0.0887, heave 0.3663': (-0.0887, 0.3663, 1.0, (1.37, 1.39), 1.377038825541547),
}
_ROLL_STAR: dict[str, float] = {}


def roll_star(name: str) -> float:
    """The last roll before det J changes sign, coming from the centre's side."""
    if name not in _ROLL_STAR:
        surge, heave, sign, (lo, hi), _ = SINGULARITIES[name]
        det_lo = np.sign(det_j((surge, heave, sign * lo)))
        t, _ = bisect(lambda t: np.sign(det_j((surge, heave, sign * t))) == det_lo, lo, hi)
        _ROLL_STAR[name] = sign * t
    return _ROLL_STAR[name]


@pytest.mark.parametrize('name', sorted(SINGULARITIES))
def test_jacobian_singularity_approach(name):
    """Approaching det J = 0 in roll from the centre's side and leaving it on
    the other: status near_singular exactly while the Jacobian condition
    exceeds its threshold, forces finite but huge (a simple pole: |f| x
    distance constant, and opposite forces on the two sides), power balanced
    to 1e-9 x condition / 100, never zeroed (that is for exact singularities)."""
    surge, heave, side, _, documented = SINGULARITIES[name]
    r_star = roll_star(name)
    if documented is not None:
        assert r_star == pytest.approx(documented, abs=1e-9)
    delta = 2.0 ** -np.arange(3.0, 46.0)
    rolls = np.concatenate([r_star - side * delta, [r_star], r_star + side * delta[::-1]])
    Q = np.column_stack([np.full(len(rolls), surge), np.full(len(rolls), heave), rolls])
    for qd, qdd in (((0, 0, 0), (0, 0, 0)), MOTION):
        Qd, Qdd = np.tile(qd, (len(Q), 1)), np.tile(qdd, (len(Q), 1))
        batch = fsd.solve_batch(MODEL, Q, Qd, Qdd)
        assert_finite(batch, name)
        near = near_flag(batch)
        assert np.array_equal(batch.status == Status.NEAR_SINGULAR, near)
        assert np.all(np.isin(batch.status[~near], [Status.OK, Status.LIMIT]))
        assert near[len(delta) - 8:len(delta) + 9].all()     # within 2^-37.. of roll*
        assert not any('exact singularity' in d for d in batch.detail)
        error, allowed = balance_errors(batch, Q, Qd, Qdd)
        worst = np.argmax(error / allowed)
        assert error[worst] <= allowed[worst], (rolls[worst], error[worst], allowed[worst])
        for i in range(0, len(Q), 7):
            one = fsd.solve(MODEL, Q[i], qd, qdd)
            assert_finite(one)
            assert one.status == batch.status[i]
    # at rest: a simple pole of the forces, changing sign across roll*
    zero = np.zeros((len(delta), 3))
    inside = fsd.solve_batch(MODEL, Q[:len(delta)], zero, zero).force
    outside = fsd.solve_batch(MODEL, Q[len(delta) + 1:][::-1], zero, zero).force
    k = slice(12, 36)       # 2.4e-4 .. 6e-12 rad from roll*
    residue = inside[k] * delta[k, None]
    size = np.abs(residue[-1]).max()
    assert np.abs(residue - residue[-1]).max() <= 2e-3 * size, residue
    assert np.abs(outside[k] * delta[k, None] + residue[-1]).max() <= 2e-3 * size
    assert np.abs(inside[k]).max() > 1e6          # forces of 1e6 N and more, reported
    assert solve_rest(Q[len(delta)]).status == Status.NEAR_SINGULAR


def test_near_singular_band_of_pure_roll():
    """The near_singular band around roll* is where the Jacobian condition
    exceeds 100: from |roll| = 1.04227491 rad to just over roll*; the
    kinematic condition (of Q) does not depend on roll."""
    r_star = roll_star('pure roll')
    start, _ = bisect(lambda r: solve_rest((0, 0, r)).status != Status.NEAR_SINGULAR,
                      0.0, r_star)
    assert start == pytest.approx(1.04227491, abs=1e-7)
    below, above = solve_rest((0, 0, start)), solve_rest((0, 0, np.nextafter(start, 2)))
    assert below.jacobian_condition <= LIM.max_jacobian_condition < above.jacobian_condition
    assert below.kinematic_condition == pytest.approx(above.kinematic_condition, rel=1e-12)
    # the other side of the band: ok or limit again by roll* + 0.05
    assert solve_rest((0, 0, r_star + 0.05)).status in (Status.OK, Status.LIMIT)
    # the mirror image: same band at negative roll, legs B and C swapped
    mirror = solve_rest((0, 0, -start))
    np.testing.assert_allclose(mirror.force, below.force[[0, 2, 1]], rtol=1e-12)


def test_roll_is_periodic_and_huge_roll_is_fine():
    """Roll enters no loop: any finite roll is a pose, and roll + 2 pi k gives
    the same machine (to the rounding of the angle)."""
    base = fsd.solve(MODEL, (0.05, 0.1, 0.4), (0.1, 0.1, 0.3), (1.0, 1.0, 2.0))
    for k in (1, -3, 1000):
        other = fsd.solve(MODEL, (0.05, 0.1, 0.4 + 2 * math.pi * k), (0.1, 0.1, 0.3),
                          (1.0, 1.0, 2.0))
        np.testing.assert_allclose(other.force, base.force, rtol=1e-9 * max(1, abs(k)))
        assert other.status == base.status
    for roll in (1e6, -1e12, 1e300, 1.7976931348623157e308):
        sol = fsd.solve(MODEL, (0, 0, roll), REST, REST)
        assert_finite(sol)
        assert sol.status in (Status.OK, Status.LIMIT, Status.NEAR_SINGULAR)


# ----------------------------------------------------------------------------
# tiny motions
# ----------------------------------------------------------------------------
POSES = [(0.0, 0.0, 0.0), (0.05, 0.1, math.pi / 12), (-0.1, 0.2, 0.5), (0.1, -0.15, -0.6)]
TINY = [1e-12, -1e-12, 1e-15, 1e-200, -1e-300, 5e-324, -0.0]


@pytest.mark.parametrize('pose', POSES)
def test_tiny_motions_are_continuous_with_rest(pose):
    """1e-12 m (rad) displacements, rates and accelerations, and subnormal
    ones: the forces equal those at rest to 1e-9 N; the leg rates are exactly
    proportional to the tiny pose rates (no cancellation)."""
    rest = fsd.solve(MODEL, pose, REST, REST)
    assert rest.status == Status.OK
    cases = []
    for eps in TINY:
        for i in range(3):
            e = np.zeros(3)
            e[i] = eps
            cases += [(np.add(pose, e), REST, REST), (pose, e, REST), (pose, REST, e)]
        cases.append((np.add(pose, eps), (eps,) * 3, (eps,) * 3))
    Q, Qd, Qdd = (np.array([c[k] for c in cases], dtype=float) for k in range(3))
    batch = fsd.solve_batch(MODEL, Q, Qd, Qdd)
    assert_finite(batch)
    assert np.all(batch.status == Status.OK)
    assert np.abs(batch.force - rest.force).max() <= 1e-9
    for i in range(len(cases)):
        one = fsd.solve(MODEL, Q[i], Qd[i], Qdd[i])
        assert one.status == Status.OK
        assert np.abs(one.force - rest.force).max() <= 1e-9
    # rates: J qd, exactly proportional for tiny qd (down to 1e-300)
    direction = np.array([0.3, -0.5, 0.8])
    ref_rate = rest.jacobian @ direction
    for eps in (1e-12, 1e-200, 1e-300):
        sol = fsd.solve(MODEL, pose, eps * direction, REST)
        np.testing.assert_allclose(sol.rate / eps, ref_rate, rtol=1e-12)
        np.testing.assert_allclose(sol.power, sol.force * sol.rate, rtol=1e-15, atol=0)


# ----------------------------------------------------------------------------
# large motions
# ----------------------------------------------------------------------------
LARGE_POSES = POSES + [(0.0, 0.6, 0.3), (0.15, 0.9, -0.2)]


def _sign_grid(magnitudes) -> np.ndarray:
    signs = np.array(np.meshgrid(*[[-1.0, 1.0]] * 3, indexing='ij')).reshape(3, -1).T
    return signs * np.asarray(magnitudes, dtype=float)


@pytest.mark.parametrize('pose', LARGE_POSES)
@pytest.mark.parametrize('scale', [1.0, 1e3, 1e50, 1e100])
def test_large_motions_are_finite_and_power_balanced(pose, scale):
    """5 m/s, 10 rad/s, 10 g and 20 rad/s^2 in every sign combination (and
    the same scaled by up to 1e100, as long as the powers stay finite): the
    speed limit is reported, the numbers are finite, the power balance holds
    to 1e-9 and the forces agree with the reference's."""
    rates = _sign_grid((5.0, 5.0, 10.0))
    accs = _sign_grid((10 * STANDARD_G, 10 * STANDARD_G, 20.0))
    Qd = np.repeat(rates, len(accs), axis=0) * scale
    Qdd = np.tile(accs, (len(rates), 1)) * scale
    # plus single-axis motions
    Qd = np.vstack([Qd, np.diag((5.0, 5.0, 10.0)) * scale, np.zeros((3, 3))])
    Qdd = np.vstack([Qdd, np.zeros((3, 3)), np.diag(accs[-1]) * scale])
    Q = np.tile(pose, (len(Qd), 1))
    batch = fsd.solve_batch(MODEL, Q, Qd, Qdd)
    assert_finite(batch)
    moving = np.abs(Qd).max(axis=1) > 0
    assert np.all(batch.status[moving] == Status.LIMIT)
    assert all('speed' in d for d, m in zip(batch.detail, moving) if m)
    assert np.all(np.isin(batch.status[~moving], [Status.OK, Status.LIMIT]))
    error, allowed = balance_errors(batch, Q, Qd, Qdd)
    assert np.all(allowed == RTOL)
    assert error.max() <= RTOL, error.max()
    with np.errstate(all='ignore'):
        ref = rm.reference_solve(PARAMS, Q, Qd, Qdd)
    force_scale = np.abs(ref['force']).max(axis=1, keepdims=True)
    assert np.all(np.abs(batch.force - ref['force']) <= RTOL * force_scale)
    for i in range(0, len(Q), 9):
        one = fsd.solve(MODEL, Q[i], Qd[i], Qdd[i])
        assert_finite(one)
        assert one.status == batch.status[i]
        np.testing.assert_allclose(one.force, batch.force[i], rtol=1e-12)


# ----------------------------------------------------------------------------
# garbage at the API: solve
# ----------------------------------------------------------------------------
GOOD = ((0.05, 0.1, 0.2), (0.1, -0.1, 0.2), (1.0, -1.0, 2.0))


@pytest.mark.parametrize('argument', [0, 1, 2])
@pytest.mark.parametrize('garbage', [
    None, 0.5, 'abc', b'abc', '', [], [0.0, 0.0], [0.0, 0.0, 0.0, 0.0], [[0.0, 0.0, 0.0]],
    [[0.0], [0.0], [0.0]], np.zeros((3, 1)), np.zeros((1, 3)), np.float64(1.0), {0, 1, 2},
    {'surge': 0, 'heave': 0, 'roll': 0}, (x for x in (0.0, 0.0, 0.0)), [0.0, None, 0.0],
    [0.0, 'x', 0.0], [1j, 0.0, 0.0], [0.0, object(), 0.0],
], ids=lambda v: re.sub(r' at 0x[0-9a-f]+', '', repr(v)))   # one id in every process (xdist)
def test_solve_wrong_shape_or_type_is_a_clear_error(argument, garbage):
    args = list(GOOD)
    args[argument] = garbage
    name = ('q', 'qd', 'qdd')[argument]
    with pytest.raises(ValueError, match=rf'^{name} must (be|have)'):
        fsd.solve(MODEL, *args)


@pytest.mark.parametrize('value', [math.nan, math.inf, -math.inf])
@pytest.mark.parametrize('argument', [0, 1, 2])
@pytest.mark.parametrize('index', [0, 1, 2])
def test_solve_non_finite_input_is_invalid_input_naming_the_field(value, argument, index):
    args = [list(a) for a in GOOD]
    args[argument][index] = value
    name = ('q', 'qd', 'qdd')[argument]
    coordinate = ('surge', 'heave', 'roll')[index]
    for sol in (fsd.solve(MODEL, *args), fsd.solve_batch(MODEL, *[[a] for a in args])):
        status = sol.status if isinstance(sol.status, Status) else sol.status[0]
        detail = sol.detail if isinstance(sol.detail, str) else sol.detail[0]
        assert status == Status.INVALID_INPUT
        assert detail.startswith(f'{name}[{index}] ({coordinate}) is not finite')
        assert_finite(sol)
        assert_void(sol, None if isinstance(sol.status, Status) else 0)


HUGE = [1e308, -1e308, 1.7976931348623157e308, 1e200, 1e155, 1e150, 1e100]


@pytest.mark.parametrize('argument', [0, 1, 2])
@pytest.mark.parametrize('value', HUGE)
def test_solve_huge_input_never_gives_a_non_finite_number(argument, value):
    """Huge but finite inputs: whatever the status, no NaN or infinity, and
    solve agrees with solve_batch (see also test_regression_*)."""
    for index in range(3):
        args = [list(a) for a in GOOD]
        args[argument][index] = value
        one = fsd.solve(MODEL, *args)
        batch = fsd.solve_batch(MODEL, *[[a] for a in args])
        assert not finite_problems(one), (args, one.status, one.detail, finite_problems(one))
        assert_finite(batch)
        assert one.status == batch.status[0], (args, one.detail, batch.detail[0])
        if one.status in VOID:
            assert_void(one)


GARBAGE_FLOATS = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from(HUGE + [5e-324, -0.0, 2.2250738585072014e-308, 1.0608370074727034]),
    st.floats(-1.5, 1.5))


# No shrink phase: shrinking nine floats drawn from one_of() costs 10-25 s per
# failure; a failure still prints its nine inputs, and the test_regression_* tests
# below pin minimal ones.
@settings(max_examples=examples(3.0), report_multiple_bugs=False,
          phases=[Phase.explicit, Phase.reuse, Phase.generate])
@given(st.tuples(*[st.tuples(GARBAGE_FLOATS, GARBAGE_FLOATS, GARBAGE_FLOATS)] * 3))
def test_garbage_numbers_never_give_a_non_finite_number(args):
    """Any floats at all (NaN, inf, huge, subnormal, ordinary): solve and
    solve_batch return a status, no NaN or infinity, and agree on the status;
    a non-finite input is invalid_input naming the first such field.
    (Minimal failing inputs found so far: test_regression_solve_*.)"""
    one = fsd.solve(MODEL, *args)
    batch = fsd.solve_batch(MODEL, *[[a] for a in args])
    assert not finite_problems(one), (one.status, one.detail, finite_problems(one))
    assert_finite(batch)
    assert one.status == batch.status[0], (one.detail, batch.detail[0])
    flat = [v for a in args for v in a]
    if not all(math.isfinite(v) for v in flat):
        first = next(k for k, v in enumerate(flat) if not math.isfinite(v))
        name, index = ('q', 'qd', 'qdd')[first // 3], first % 3
        assert one.status == Status.INVALID_INPUT
        assert one.detail.startswith(f'{name}[{index}]')
    if one.status in VOID:
        assert_void(one)
        assert_void(batch, 0)


# ----------------------------------------------------------------------------
# garbage at the API: solve_batch
# ----------------------------------------------------------------------------
R_STAR = 1.0608370074727034
MIXED_ROWS = [   # (q, qd, qdd, expected status, words in detail)
    (GOOD[0], GOOD[1], GOOD[2], Status.OK, ''),
    ((0.0, math.nan, 0.0), GOOD[1], GOOD[2], Status.INVALID_INPUT, 'q[1] (heave) is not finite'),
    (GOOD[0], (0.0, 0.0, math.inf), GOOD[2], Status.INVALID_INPUT, 'qd[2] (roll) is not finite'),
    (GOOD[0], GOOD[1], (-math.inf, 0.0, 0.0), Status.INVALID_INPUT,
     'qdd[0] (surge) is not finite'),
    (GOOD[0], (1e308, 0.0, 0.0), GOOD[2], Status.INVALID_INPUT, 'input too large'),
    ((0.0, 5.0, 0.0), GOOD[1], GOOD[2], Status.UNREACHABLE, 'loop D'),
    ((0.0, -0.4, 0.0), GOOD[1], GOOD[2], Status.UNREACHABLE, 'loop E2 on rod'),
    ((0.3, 0.0, 0.0), GOOD[1], GOOD[2], Status.UNREACHABLE, 'loop E:'),
    ((0.0, 0.0, R_STAR), GOOD[1], GOOD[2], Status.NEAR_SINGULAR, 'actuator Jacobian'),
    ((0.0, 0.0, 0.0), REST, REST, Status.OK, ''),
    ((0.0, 0.8, 0.0), REST, REST, Status.LIMIT, 'stroke'),
    ((-0.05, 0.05, -0.3), (2.0, 0.0, 0.0), REST, Status.LIMIT, 'speed A'),
    (GOOD[0], GOOD[1], (0.0, 0.0, 1e200), Status.LIMIT, 'force'),
    ((1e-12, 1e-12, 1e-12), (5e-324, 0.0, 0.0), (0.0, -0.0, 1e-300), Status.OK, ''),
]


def _mixed_arrays(rows):
    return tuple(np.array([r[k] for r in rows], dtype=float) for k in range(3))


def test_solve_batch_mixed_good_and_bad_rows():
    """Every row gets its own status; a bad row never affects the others: each
    row equals the same row solved alone, in any order of the rows."""
    Q, Qd, Qdd = _mixed_arrays(MIXED_ROWS)
    batch = fsd.solve_batch(MODEL, Q, Qd, Qdd)
    assert_finite(batch)
    for i, (q, qd, qdd, status, words) in enumerate(MIXED_ROWS):
        assert batch.status[i] == status, (i, batch.detail[i])
        assert words in batch.detail[i], (i, batch.detail[i])
        assert (batch.detail[i] == '') == (status == Status.OK)
        alone = fsd.solve_batch(MODEL, Q[i:i + 1], Qd[i:i + 1], Qdd[i:i + 1])
        assert alone.status[0] == status and alone.detail[0] == batch.detail[i]
        for name in ('length', 'rate', 'acceleration', 'force', 'power', 'joints'):
            np.testing.assert_allclose(getattr(batch, name)[i], getattr(alone, name)[0],
                                       rtol=1e-13 * max(1.0, conditions(batch)[i]), atol=0)
        if status in VOID:
            assert_void(batch, i)
    assert np.all(np.isfinite(batch.cond)) and np.all(batch.cond[[1, 2, 3, 4, 5]] == 0.0)
    # any order of the rows
    perm = np.random.default_rng(1).permutation(len(MIXED_ROWS))
    shuffled = fsd.solve_batch(MODEL, Q[perm], Qd[perm], Qdd[perm])
    assert list(shuffled.status) == list(batch.status[perm])
    assert shuffled.detail == tuple(batch.detail[i] for i in perm)
    sane = conditions(batch)[perm] < 1e6       # the row at roll* has condition ~1e16
    np.testing.assert_allclose(shuffled.force[sane], batch.force[perm][sane], rtol=1e-13, atol=0)


@settings(max_examples=examples(1.0))
@given(st.lists(st.sampled_from(range(len(MIXED_ROWS))), min_size=1, max_size=40))
def test_solve_batch_any_mix_of_rows(picks):
    """Any mix of the rows above, repeated and in any order: each row's status
    and detail are its own, the numbers finite, void rows zero."""
    rows = [MIXED_ROWS[i] for i in picks]
    batch = fsd.solve_batch(MODEL, *_mixed_arrays(rows))
    assert_finite(batch)
    for i, row in enumerate(rows):
        assert batch.status[i] == row[3]
        assert row[4] in batch.detail[i]
        if row[3] in VOID:
            assert_void(batch, i)


BATCH_GARBAGE = [   # (a bad argument, words of the error)
    (None, r'shape \(N, 3\)'),
    (np.zeros(3), r'shape \(N, 3\)'),
    (np.zeros((4, 2)), r'shape \(N, 3\)'),
    (np.zeros((4, 3, 1)), r'shape \(N, 3\)'),
    (np.zeros((4, 0)), r'shape \(N, 3\)'),
    ('abc', 'must be numbers'),
    ([[0.0, 0.0, 0.0], [0.0, 0.0]], 'must be numbers'),
    ([[0.0, 0.0, 0.0], [0.0, 'x', 0.0]], 'must be numbers'),
    ([[1j, 0.0, 0.0]] * 4, 'must be numbers'),
    (np.zeros((3, 3)), 'has 3 rows, q has 4'),
    (np.zeros((5, 3)), 'has 5 rows, q has 4'),
]


# q sets N: a row count cannot mismatch it
@pytest.mark.parametrize('garbage, words, argument', [
    (g, w, a) for g, w in BATCH_GARBAGE for a in (0, 1, 2) if not (a == 0 and 'rows' in w)],
    ids=repr)
def test_solve_batch_wrong_shape_or_type_is_a_clear_error(garbage, words, argument):
    args = [np.zeros((4, 3)), np.zeros((4, 3)), np.zeros((4, 3))]
    args[argument] = garbage
    name = ('q', 'qd', 'qdd')[argument]
    with pytest.raises(ValueError, match=words):
        fsd.solve_batch(MODEL, *args)
    with pytest.raises(ValueError, match=rf'^{name} '):
        fsd.solve_batch(MODEL, *args)


def test_solve_batch_of_no_rows():
    zero = np.zeros((0, 3))
    batch = fsd.solve_batch(MODEL, zero, zero, zero)
    assert batch.force.shape == batch.length.shape == (0, 3)
    assert batch.joints.shape == (0, 12) and batch.jacobian.shape == (0, 3, 3)
    assert len(batch.status) == 0 and batch.detail == ()


# ----------------------------------------------------------------------------
# garbage at the API: forward kinematics
# ----------------------------------------------------------------------------
L_CENTRE = tuple(MODEL.central.length)


@pytest.mark.parametrize('lengths, words', [
    ([math.nan, 1.3, 1.3], 'finite'),
    ([1.1, math.inf, 1.3], 'finite'), ([1.1, 1.3, -math.inf], 'finite'),
    ([0.0, 1.3, 1.3], 'positive'), ([-0.0, 1.3, 1.3], 'positive'),
    ([1.1, -1.3, 1.3], 'positive'),
], ids=repr)
def test_forward_kinematics_garbage_is_invalid_input(lengths, words):
    result = fsd.forward_kinematics(MODEL, lengths)
    assert result.status == Status.INVALID_INPUT
    assert words in result.detail
    assert np.all(result.pose == 0.0) and result.pose.shape == (3,)


@pytest.mark.parametrize('lengths', [
    None, 'abc', b'abc', [], [1.1, 1.3], [1.1, 1.3, 1.3, 1.3], [[1.1, 1.3, 1.3]],
    np.zeros((3, 1)) + 1.2, {'a': 1}, {1.1, 1.2, 1.3}, [1j, 1.3, 1.3], [None, 1.3, 1.3],
    [True, 1.3, 1.3], [10**400, 1.3, 1.3],
], ids=lambda v: f'set{sorted(v)}' if isinstance(v, set) else repr(v))
def test_forward_kinematics_not_three_numbers_raises(lengths):
    # (a set's id sorted: its order differs between this module compiled and
    # loaded from the bytecode cache another worker wrote, and pytest-xdist
    # refuses workers that collect different ids)
    """Not three real numbers is a programming error, as for solve (issue 14
    #11, issue 12 #11): ValueError naming the argument, no status."""
    with pytest.raises(ValueError, match='lengths must be 3 numbers'):
        fsd.forward_kinematics(MODEL, lengths)


@pytest.mark.parametrize('lengths', [
    [1e308, 1e308, 1e308], [1.7976931348623157e308, 1.3, 1.3], [1e-300, 1.3, 1.3],
    [5e-324, 5e-324, 5e-324], [1e6, 1e6, 1e6], [L_CENTRE[0], 1e-9, L_CENTRE[2]],
])
def test_forward_kinematics_absurd_lengths_are_unreachable(lengths):
    with np.errstate(all='ignore'):
        result = fsd.forward_kinematics(MODEL, lengths)
    assert result.status in (Status.UNREACHABLE, Status.NOT_CONVERGED), result
    assert np.all(result.pose == 0.0)
    assert math.isfinite(result.residual) and result.residual > 0
    assert result.detail


@pytest.mark.parametrize('initial, words', [
    ([math.nan, 0.0, 0.0], 'initial must be finite'),
    ([0.0, 5.0, 0.0], 'initial pose is unreachable'), ([0.0, 0.0, math.inf], 'finite'),
])
def test_forward_kinematics_garbage_initial_pose(initial, words):
    result = fsd.forward_kinematics(MODEL, L_CENTRE, initial)
    assert result.status == Status.INVALID_INPUT and words in result.detail
    assert np.all(result.pose == 0.0)


@pytest.mark.parametrize('initial', [[0.0, 0.0], 'x'])
def test_forward_kinematics_initial_not_three_numbers_raises(initial):
    """Not three numbers: ValueError naming ``initial`` (the one input rule)."""
    with pytest.raises(ValueError, match='^initial must be 3 numbers'):
        fsd.forward_kinematics(MODEL, L_CENTRE, initial)


def test_forward_kinematics_near_a_closure_limit_and_a_singularity():
    """Lengths of poses 1e-9 inside the crank E closure and 1e-4 rad from the
    roll singularity (on the centre's side): found again, or a status that
    says why not; never a wrong pose with status ok."""
    cases = [(boundary('crank E, surge forward')[0] - 1e-9, 0.0, 0.0),
             (0.0, boundary('E2 on rod, heave down')[0] * -1 + 1e-9, 0.0),
             (0.0, 0.0, R_STAR - 1e-4)]
    for q in cases:
        lengths = solve_rest(q).length
        result = fsd.forward_kinematics(MODEL, lengths)
        assert result.status in (Status.OK, Status.NOT_CONVERGED, Status.UNREACHABLE)
        assert np.all(np.isfinite(result.pose))
        if result.status == Status.OK:
            back = solve_rest(result.pose).length
            assert np.abs(back - lengths).max() <= 1e-12


# ----------------------------------------------------------------------------
# Regressions: bugs found by this suite, fixed; each test pins its minimal input
# ----------------------------------------------------------------------------
def test_regression_solve_lets_an_infinite_power_through():
    """Regression, fixed (solver.solve): the finiteness check sums force, rate,
    joint rates and accelerations and the conditions, but not the power
    (force x rate), which can overflow alone. Input q = (0, 0, 0),
    qd = (1e150, 0, 0), qdd = (0, 0, 0): expected no infinity (solve_batch
    says invalid_input, 'results are not finite: input too large', all 0);
    actual: status limit, power[A] = -inf (forces ~1e300, rate 1.26e150)."""
    args = ((0.0, 0.0, 0.0), (1e150, 0.0, 0.0), (0.0, 0.0, 0.0))
    batch = fsd.solve_batch(MODEL, *[[a] for a in args])
    assert batch.status[0] == Status.INVALID_INPUT
    one = fsd.solve(MODEL, *args)
    assert np.all(np.isfinite(one.power)), (one.status, one.power)
    assert one.status == Status.INVALID_INPUT


def test_regression_solve_near_singular_overflow_leaves_nan_accelerations():
    """Regression, fixed (solver.solve): when a near-singular sample's results
    overflow, only force and power are zeroed; the leg and joint accelerations
    keep their NaN/inf. Input q = (0, 0, 1.06) (Jacobian condition ~2e3),
    qd = (1e155, 0, 0), qdd = (0, 0, 0): expected no NaN (solve_batch zeroes
    every non-finite number); actual: acceleration = [nan, nan, nan] and
    joint_accelerations non-finite (status near_singular)."""
    one = fsd.solve(MODEL, (0.0, 0.0, 1.06), (1e155, 0.0, 0.0), (0.0, 0.0, 0.0))
    assert one.status == Status.NEAR_SINGULAR
    assert np.all(np.isfinite(one.acceleration)), one.acceleration
    assert np.all(np.isfinite(one.joint_accelerations)), one.joint_accelerations


def test_regression_solve_calls_finite_results_invalid_when_their_sum_overflows():
    """Regression, fixed (solver.solve): finiteness is tested on the *sum* of the
    results, which overflows although every result is finite. Input q = 0,
    qd = 0, qdd = (1.8e307, 0, 0): expected (as solve_batch) status limit with
    forces 1.7706e308, 3.7677e307, 3.7677e307 N; actual: invalid_input
    'results are not finite: input too large', all 0."""
    args = ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0), (1.8e307, 0.0, 0.0))
    batch = fsd.solve_batch(MODEL, *[[a] for a in args])
    assert batch.status[0] == Status.LIMIT and np.all(np.isfinite(batch.force))
    one = fsd.solve(MODEL, *args)
    assert one.status == batch.status[0], one.detail
    np.testing.assert_allclose(one.force, batch.force[0], rtol=1e-12)


def test_regression_empty_batch_cond_raises():
    """Regression, fixed (Solution.Q / Solution.cond): for a batch of 0 rows,
    ``sol.cond`` raises IndexError ('arrays used as indices must be of integer
    (or boolean) type': np.asarray([]) is a float array). Expected: an empty
    array, like every other field."""
    zero = np.zeros((0, 3))
    batch = fsd.solve_batch(MODEL, zero, zero, zero)
    assert np.asarray(batch.cond).shape == (0,)


@pytest.mark.parametrize('call', [
    lambda: fsd.solve(MODEL, ['0.1', '0', '0'], REST, REST),
    lambda: fsd.solve(MODEL, REST, [b'1', 0.0, 0.0], REST),
    lambda: fsd.solve_batch(MODEL, [['0.1', '0', '0']], [REST], [REST]),
    lambda: fsd.solve_batch(MODEL, [[0.0, None, 0.0]], [REST], [REST]),
], ids=['solve, str', 'solve, bytes', 'solve_batch, str', 'solve_batch, None'])
def test_regression_non_numbers_are_taken_for_numbers(call):
    """Regression, fixed (minor; solver.three_numbers, solver._as_batch): strings and
    bytes of digits pass float() and are solved as numbers, and solve_batch
    turns None into NaN (status invalid_input) where solve raises ValueError
    for the same row. Documented: 'Only a call that is not three numbers per
    argument (a programming error) raises ValueError'. Expected: ValueError;
    actual: a solution (status ok / invalid_input)."""
    with pytest.raises(ValueError):
        call()


@pytest.mark.parametrize('argument', [0, 1, 2])
def test_regression_ragged_argument_gives_numpy_message(argument):
    """Regression, fixed (minor; solver.three_numbers): an argument with a nested
    sequence, e.g. q = [0.0, [0.0], 0.0], raises numpy's ValueError 'setting
    an array element with a sequence. The requested array has an
    inhomogeneous shape ...' (from np.ndim) instead of the documented clear
    one. Expected: ValueError 'q must be 3 numbers (surge, heave, roll), got
    [0.0, [0.0], 0.0]'; actual: numpy's message, not naming the argument."""
    args = list(GOOD)
    args[argument] = [0.0, [0.0], 0.0]
    name = ('q', 'qd', 'qdd')[argument]
    with pytest.raises(ValueError, match=rf'^{name} must be'):
        fsd.solve(MODEL, *args)


@pytest.mark.parametrize('q', [
    (0.2, -0.2, 0.8), (0.2, -0.2, -0.8), (0.22, -0.05, 0.6),      # fixed by the continuation
    (0.21, -0.2, 0.8), (0.21, -0.24, -0.78), (0.215, -0.2, -0.675), (0.2, -0.25, -0.8),
])
def test_regression_forward_kinematics_calls_reachable_lengths_unreachable(q):
    """Regression, fixed (forward_kinematics): the Newton path from the central
    configuration leaves the workspace (crank E loop) and the iteration then
    declares the lengths unreachable, although they are those of a pose of
    the machine's own working mode: every q here has status ok, conditions
    below 50, det J of the centre's sign, and the straight segment from the
    centre to q stays reachable, ok and non-singular. Input: the leg lengths
    of q = (0.2, -0.2, 0.8); expected status ok, pose q; actual (first
    version): unreachable, 'these leg lengths lie outside the workspace:
    loop E: ...' (about 0.4 % of the well-conditioned poses of surge +-0.5,
    heave -0.5..1.3, roll +-1.6). The continuation in the lengths added since
    (20, then 200 steps from the initial pose's lengths) fixes the first three
    but not the others: the straight path in length space leaves the
    workspace too; e.g. q = (0.21, -0.2, 0.8) (conditions 20.2 / 17.7):
    unreachable after 460 iterations (~0.1 % of the ok poses, ~0.15 % of the
    limit ones, e.g. q = (0.1875, -0.5, 0.5))."""
    sol = solve_rest(q)
    assert sol.status == Status.OK and conditions(sol) < 50
    segment = fsd.solve_batch(MODEL, np.linspace(0, 1, 201)[:, None] * q,
                              np.zeros((201, 3)), np.zeros((201, 3)))
    assert np.all(np.isin(segment.status, [Status.OK, Status.LIMIT]))
    assert np.all(np.linalg.det(segment.jacobian) > 0)
    result = fsd.forward_kinematics(MODEL, sol.length)
    assert result.status == Status.OK, (q, result.detail)
    np.testing.assert_allclose(result.pose, q, atol=1e-9)


def test_regression_forward_kinematics_bad_initial_is_blamed_on_the_lengths():
    """Regression, fixed (minor; forward_kinematics): a non-numeric ``initial``
    is reported as 'lengths must be 3 numbers, got <the lengths>'. Input:
    lengths = the central ones, initial = 'x'. Expected: status
    invalid_input, detail naming ``initial``; actual: the detail names the
    (valid) lengths. Since the one input rule (issue 12 #11) it raises
    ValueError, still naming ``initial``."""
    with pytest.raises(ValueError) as info:
        fsd.forward_kinematics(MODEL, L_CENTRE, 'x')
    assert str(info.value).startswith('initial'), info.value


def test_regression_forward_kinematics_invalid_input_has_an_infinite_residual():
    """Regression, fixed (minor; forward_kinematics): README: 'No NaN or infinity
    ever comes out, whatever the status ... forward_kinematics returns ok,
    unreachable, not_converged or invalid_input in the same way'; but every
    invalid_input result has residual = inf. Input: lengths = [nan, 1.3, 1.3].
    Expected: a finite residual (e.g. 0); actual: inf."""
    result = fsd.forward_kinematics(MODEL, [math.nan, 1.3, 1.3])
    assert result.status == Status.INVALID_INPUT
    assert math.isfinite(result.residual)
