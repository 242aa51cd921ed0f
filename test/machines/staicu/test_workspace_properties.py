"""Property-based tests (Hypothesis) over the whole workspace and beyond it.

Every example is a batch of 24..32 samples (pose, rate, acceleration) drawn
from a box wider than the workspace, so that each run covers reachable poses,
poses past every closure limit (crank D, crank E, E2 on the rod), the band
around the roll singularities of the actuator Jacobian (|roll| ~ 1.06 rad at
the central surge/heave) and motions up to 5 m/s, 10 rad/s, 10 g and
20 rad/s^2:

    surge in [-0.5, 0.5] m, heave in [-0.5, 1.3] m, roll in [-1.6, 1.6] rad,
    surge/heave rates in [-5, 5] m/s, roll rate in [-10, 10] rad/s,
    surge/heave accelerations in [-98.1, 98.1] m/s^2, roll in [-20, 20] rad/s^2.

About a third of such samples are unreachable and a few percent near a
singularity. With the ``ci`` Hypothesis profile (test/conftest.py) each test
checks a few thousand samples per run, a quarter of them in the unit tier and
the rest in the slow tier (the ``sweep`` fixture); ``FSD_HYPOTHESIS_PROFILE=long``
runs 20x more.

For every sample, whatever its status:

* no NaN or infinity in any output field, from ``solve`` or ``solve_batch``;
  ``solve`` and ``solve_batch`` agree on the status (and on the numbers);
* reachability agrees with the independent reference model
  (``reference_model.reachable``): unreachable exactly where the reference
  says a loop cannot close; unreachable rows are all zeros and name the loop;
* the status follows from the reported numbers: ``near_singular`` exactly when
  a condition figure exceeds its threshold (``model.limits``), ``limit``
  exactly when a stroke, speed or force limit is exceeded, else ``ok``;
  ``invalid_input`` never happens for these finite, moderate inputs.

For reachable samples:

* power balance against the reference's exact dE/dt, per sample, relative to
  the honest scale max(|dE/dt|, |P_A| + |P_B| + |P_C|, 1 W) (near a
  singularity the forces, hence the individual powers, get huge while their
  sum stays dE/dt): 1e-9 for ok / limit samples; for near_singular samples
  the same 1e-9 at the threshold condition (100), growing linearly with the
  condition figure (rounding errors of a solve grow like eps x condition;
  measured: <= 6e-12 below the threshold, <= 3e-13 x condition above);
* the actuator forces agree with the reference's (virtual power, a different
  method) to the same relative tolerances;
* forward kinematics takes the leg lengths back to the pose to 1e-9 for every
  reachable sample below the near-singularity thresholds (status ok, or
  limit, which only concerns strokes, speeds and forces, not the geometry).
  From the central configuration when the pose is in the machine's working
  mode (det J of the same sign as at the centre); across a singular surface
  det J = 0 the same lengths belong to another pose of the centre's mode, so
  there the iteration starts from the pose rounded to 1e-3.
"""
from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings, target
from hypothesis import strategies as st

import flight_sim_dynamics as fsd
import reference_model as rm
from flight_sim_dynamics import Status

MODEL = fsd.load_model()
PARAMS = rm.load_reference_params()
LIM = MODEL.limits
STANDARD_G = 9.80665

POSE_LO, POSE_HI = (-0.5, -0.5, -1.6), (0.5, 1.3, 1.6)
RATE_MAX = (5.0, 5.0, 10.0)                           # m/s, m/s, rad/s
ACC_MAX = (10 * STANDARD_G, 10 * STANDARD_G, 20.0)   # 10 g, 10 g, 20 rad/s^2
EXPLICIT, UNIFORM = 8, 24   # samples per Hypothesis example (see batches())

RTOL = 1e-9                          # relative tolerance below the thresholds
COND_THRESHOLD = max(LIM.max_kinematic_condition, LIM.max_jacobian_condition)
ARRAY_FIELDS = ('length', 'stroke', 'rate', 'acceleration', 'force', 'power', 'joints',
                'joint_rates', 'joint_accelerations', 'jacobian', 'beta',
                'kinematic_condition', 'jacobian_condition', 'cond')
VOID = (Status.UNREACHABLE, Status.INVALID_INPUT)
SOLVE_STATUSES = {Status.OK, Status.LIMIT, Status.NEAR_SINGULAR, Status.UNREACHABLE,
                  Status.INVALID_INPUT}
DET_CENTRE = float(np.linalg.det(fsd.solve(MODEL, (0, 0, 0), (0, 0, 0), (0, 0, 0)).jacobian))


def examples(fraction: float = 1.0) -> int:
    """max_examples for a test: a fraction of the loaded profile's (conftest.py)."""
    return max(5, int(settings.default.max_examples * fraction))


def _box(lo: float, hi: float) -> st.SearchStrategy:
    return st.floats(lo, hi, allow_nan=False, allow_infinity=False)


SAMPLE = st.tuples(
    st.tuples(*[_box(lo, hi) for lo, hi in zip(POSE_LO, POSE_HI)]),
    st.tuples(*[_box(-m, m) for m in RATE_MAX]),
    st.tuples(*[_box(-m, m) for m in ACC_MAX]))


@st.composite
def batches(draw) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One example: up to EXPLICIT samples drawn (and shrunk) by Hypothesis, which
    favours the edges of the box, zeros and simple values, followed by UNIFORM
    samples spread uniformly over the box by a numpy generator whose seed
    Hypothesis draws (drawing every float through Hypothesis would cost more
    than the solves themselves)."""
    explicit = draw(st.lists(SAMPLE, max_size=EXPLICIT))
    rng = np.random.default_rng(draw(st.integers(0, 2**64 - 1)))
    q = rng.uniform(POSE_LO, POSE_HI, (UNIFORM, 3))
    qd = rng.uniform(-1.0, 1.0, (UNIFORM, 3)) * RATE_MAX
    qdd = rng.uniform(-1.0, 1.0, (UNIFORM, 3)) * ACC_MAX
    if explicit:
        q, qd, qdd = (np.vstack([np.array([s[k] for s in explicit], dtype=float), a])
                      for k, a in enumerate((q, qd, qdd)))
    return q, qd, qdd


def condition(sol, i: int | None = None) -> float:
    """The larger of the two condition figures (of sample i of a batch)."""
    kin, jac = sol.kinematic_condition, sol.jacobian_condition
    if i is not None:
        kin, jac = kin[i], jac[i]
    return float(max(kin, jac))


def tolerance_factor(cond: np.ndarray) -> np.ndarray:
    """1 below the near-singularity threshold, condition / threshold above it."""
    return np.maximum(1.0, np.asarray(cond, dtype=float) / COND_THRESHOLD)


def assert_all_finite(sol, what: str) -> None:
    for name in ARRAY_FIELDS:
        value = np.asarray(getattr(sol, name), dtype=float)
        assert np.all(np.isfinite(value)), f'{what}: non-finite {name}: {value}'


def expected_limit(stroke, rate, force) -> bool:
    return bool(np.any((stroke < LIM.stroke_min) | (stroke > LIM.stroke_max)
                       | (np.abs(rate) > LIM.max_speed) | (np.abs(force) > LIM.max_force)))


def reference_at(q, qd, qdd) -> dict:
    with np.errstate(all='ignore'):
        return rm.reference_solve(PARAMS, q, qd, qdd)


# ----------------------------------------------------------------------------
# No non-finite output; statuses consistent with the reference and the numbers
# ----------------------------------------------------------------------------
def test_every_sample_is_finite_and_its_status_is_consistent(sweep) -> None:
    @settings(max_examples=sweep(examples(1.0)), report_multiple_bugs=False)
    @given(batches())
    def check(batch) -> None:
        q, qd, qdd = batch
        sol = fsd.solve_batch(MODEL, q, qd, qdd)
        assert_all_finite(sol, 'solve_batch')
        with np.errstate(all='ignore'):
            surely_in = rm.reachable(PARAMS, q)                  # discriminants > 1e-9
            surely_out = ~rm.reachable(PARAMS, q, margin=0.0)    # a loop cannot close
        for i in range(len(q)):
            status = sol.status[i]
            where = f'sample {i}: q={q[i].tolist()} qd={qd[i].tolist()} qdd={qdd[i].tolist()}'
            assert status in SOLVE_STATUSES, where
            assert status != Status.INVALID_INPUT, f'{where}: {sol.detail[i]}'
            if surely_in[i]:
                assert status != Status.UNREACHABLE, f'{where}: {sol.detail[i]}'
            if surely_out[i]:
                assert status == Status.UNREACHABLE, f'{where}: {status} {sol.detail[i]}'
            if status == Status.UNREACHABLE:
                assert sol.detail[i].startswith('loop '), where
                for name in ('length', 'force', 'power', 'rate', 'joints', 'jacobian'):
                    assert np.all(np.asarray(getattr(sol, name)[i]) == 0.0), (where, name)
            else:
                near = not (sol.kinematic_condition[i] <= LIM.max_kinematic_condition
                            and sol.jacobian_condition[i] <= LIM.max_jacobian_condition)
                if near:
                    assert status == Status.NEAR_SINGULAR, where
                else:
                    limit = expected_limit(sol.stroke[i], sol.rate[i], sol.force[i])
                    assert status == (Status.LIMIT if limit else Status.OK), (where, sol.detail[i])
                    assert (sol.detail[i] != '') == limit, where
            # the per-cycle entry point gives the same status and numbers
            one = fsd.solve(MODEL, q[i], qd[i], qdd[i])
            assert_all_finite(one, f'solve, {where}')
            assert one.status == status, (where, one.detail, sol.detail[i])
            if status in (Status.OK, Status.LIMIT, Status.NEAR_SINGULAR):
                rtol = 1e-12 * tolerance_factor(condition(sol, i))
                for name in ('length', 'rate', 'acceleration', 'force'):
                    a, b = getattr(one, name), getattr(sol, name)[i]
                    scale = max(float(np.max(np.abs(b))), 1.0)
                    assert np.max(np.abs(a - b)) <= rtol * scale, (where, name, a, b)

    check()


# ----------------------------------------------------------------------------
# Power balance and forces against the independent reference
# ----------------------------------------------------------------------------
def test_power_balance_and_forces_against_the_reference(sweep) -> None:
    @settings(max_examples=sweep(examples(1.0)), report_multiple_bugs=False)
    @given(batches())
    def check(batch) -> None:
        q, qd, qdd = batch
        sol = fsd.solve_batch(MODEL, q, qd, qdd)
        keep = np.array([s not in VOID for s in sol.status])
        if not keep.any():
            return
        ref = reference_at(q[keep], qd[keep], qdd[keep])
        power = sol.power[keep]
        cond = np.maximum(sol.kinematic_condition[keep], sol.jacobian_condition[keep])
        allowed = RTOL * tolerance_factor(cond)
        scale = np.maximum(np.maximum(np.abs(ref['dE_dt']), np.abs(power).sum(axis=1)), 1.0)
        balance = np.abs(power.sum(axis=1) - ref['dE_dt']) / scale
        force_scale = np.maximum(np.abs(ref['force']).max(axis=1), 1.0)
        force_error = np.abs(sol.force[keep] - ref['force']).max(axis=1) / force_scale
        target(float(np.max(balance / allowed)), label='power balance error / tolerance')
        bad = np.flatnonzero((balance > allowed) | (force_error > allowed))
        for j in bad[:1]:
            i = np.flatnonzero(keep)[j]
            raise AssertionError(
                f'sample {i} ({sol.status[i]}, condition {cond[j]:.3g}): q={q[i].tolist()} '
                f'qd={qd[i].tolist()} qdd={qdd[i].tolist()}: sum P = {power[j].sum():.17g}, '
                f'dE/dt = {ref["dE_dt"][j]:.17g} (relative {balance[j]:.3g}); force '
                f'{sol.force[i].tolist()} vs reference {ref["force"][j].tolist()} '
                f'(relative {force_error[j]:.3g}); allowed {allowed[j]:.3g}')
        # the lengths and rates agree too (pure kinematics, no singularity needed)
        np.testing.assert_allclose(sol.length[keep], ref['length'], rtol=0, atol=1e-12)
        rate_scale = np.maximum(np.abs(ref['rate']).max(axis=1, keepdims=True), 1.0)
        assert np.all(np.abs(sol.rate[keep] - ref['rate']) <= 1e-12 * rate_scale
                      * tolerance_factor(cond)[:, None])

    check()


# ----------------------------------------------------------------------------
# Forward kinematics round trip
# ----------------------------------------------------------------------------
def wrapped(a: np.ndarray) -> np.ndarray:
    """Angle differences into (-pi, pi] (the roll component of a pose)."""
    return (a + math.pi) % (2.0 * math.pi) - math.pi


def test_forward_kinematics_round_trip(sweep) -> None:
    """Leg lengths of any reachable pose give the pose back (this found the
    forward-kinematics bug pinned by test_hard_cases.py::
    test_regression_forward_kinematics_calls_reachable_lengths_unreachable).
    Poses with status limit at rest are included: that status only says a
    stroke is out of its range; the geometry, hence the round trip, is the same."""
    @settings(max_examples=sweep(examples(2.0)), report_multiple_bugs=False)
    @given(st.lists(st.tuples(*[_box(lo, hi) for lo, hi in zip(POSE_LO, POSE_HI)]),
                    min_size=1, max_size=8))
    def check(poses) -> None:
        q = np.array(poses, dtype=float)
        sol = fsd.solve_batch(MODEL, q, np.zeros_like(q), np.zeros_like(q))
        for i in range(len(q)):
            if sol.status[i] not in (Status.OK, Status.LIMIT):
                continue
            same_mode = np.sign(np.linalg.det(sol.jacobian[i])) == np.sign(DET_CENTRE)
            if same_mode:
                start = (0.0, 0.0, 0.0)
            else:   # a start within 5e-4 of the pose, if reachable (else the pose itself)
                start = tuple(np.round(q[i], 3))
                if fsd.solve(MODEL, start, (0, 0, 0), (0, 0, 0)).status in VOID:
                    start = tuple(q[i])
            result = fsd.forward_kinematics(MODEL, sol.length[i], start)
            where = (f'q={q[i].tolist()} ({sol.status[i]}, conditions '
                     f'{sol.kinematic_condition[i]:.3g}/{sol.jacobian_condition[i]:.3g}), '
                     f'start {start}')
            assert result.status == Status.OK, f'{where}: {result.status}: {result.detail}'
            error = result.pose - q[i]
            error[2] = wrapped(error[2])
            assert np.max(np.abs(error)) <= 1e-9, f'{where}: pose {result.pose.tolist()}'
            assert result.residual <= 1e-12
            assert np.all(np.isfinite(result.pose))

    check()
