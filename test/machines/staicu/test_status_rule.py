"""The status rule (status_rule.sample_status), written once for floats and arrays.

The solver's three paths (kernel, Python single, Python batch) agree on real
samples (test_kernel.py); here the rule itself: the same verdict on floats as
on arrays for every combination of its inputs, its order of severity, and the
words of every detail, including loops A, B, C that the real mechanism never
opens first.
"""
from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from flight_sim_dynamics.core.status import BY_SEVERITY, RESULTS_NOT_FINITE, SEVERITY, Status
from flight_sim_dynamics.core.vectors import backend
from flight_sim_dynamics.machines.staicu.kinematics import LOOP_REASONS, LOOPS
from flight_sim_dynamics.machines.staicu.model import Limits
from flight_sim_dynamics.machines.staicu.status_rule import (all_finite, describe, first_bad_input,
                                                             first_open_loop, sample_status)

LIMITS = Limits()
FLOATS, ARRAYS = backend(False), backend(True)
CASES = list(itertools.product(
    (-1, 0, 8),                                  # bad_input
    (-1, 0, 5),                                  # open_loop
    (True, False),                               # finite
    (1.0, 1e3, math.nan),                        # kin
    (1.0, 1e3, math.nan),                        # jac
    ((0.0, 0.0, 0.0), (0.7, 0.0, 0.0), (0.0, -2.0, 0.0), (0.0, 0.0, 3e3)),  # stroke/rate/force
))


def _legs(which):
    stroke = (which[0], 0.0, 0.0)
    rate = (which[1], 0.0, 0.0)
    force = (which[2], 0.0, 0.0)
    return stroke, rate, force


def _expected(bad, loop, finite, kin, jac, legs):
    """The rule in words, worst first."""
    if bad >= 0:
        return SEVERITY[Status.INVALID_INPUT], bad
    if loop >= 0:
        return SEVERITY[Status.UNREACHABLE], loop
    if not (kin <= LIMITS.max_kinematic_condition and jac <= LIMITS.max_jacobian_condition):
        return SEVERITY[Status.NEAR_SINGULAR], int(finite)
    if not finite:
        return SEVERITY[Status.INVALID_INPUT], RESULTS_NOT_FINITE
    if any(legs):
        return SEVERITY[Status.LIMIT], 0
    return SEVERITY[Status.OK], 0


def test_floats_and_arrays_give_the_rule():
    """Every combination: the float backend, the array backend (all cases as one
    batch) and the rule written out in words agree."""
    columns = [np.array(c) for c in zip(*[(b, lo, f, k, j) for b, lo, f, k, j, _ in CASES])]
    legs = [_legs(c[5]) for c in CASES]
    stroke, rate, force = ([np.array([leg[i][m] for leg in legs]) for m in range(3)]
                           for i in range(3))
    codes, infos = sample_status(LIMITS, ARRAYS, *columns, stroke, rate, force)
    for i, (bad, loop, finite, kin, jac, which) in enumerate(CASES):
        one = sample_status(LIMITS, FLOATS, bad, loop, finite, kin, jac, *legs[i])
        expected = _expected(bad, loop, finite, kin, jac, which)
        assert one == expected, CASES[i]
        assert (int(codes[i]), int(infos[i])) == expected, CASES[i]


def test_a_stopped_solve_needs_no_results():
    """A solve stopped at a bad input or an open loop passes nothing else."""
    assert sample_status(LIMITS, FLOATS, bad_input=4) == (SEVERITY[Status.INVALID_INPUT], 4)
    assert sample_status(LIMITS, FLOATS, open_loop=2) == (SEVERITY[Status.UNREACHABLE], 2)
    assert sample_status(LIMITS, FLOATS) == (SEVERITY[Status.OK], 0)


@pytest.mark.parametrize('values, index', [
    ((0.0,) * 9, -1), ((math.nan,) + (0.0,) * 8, 0), ((0.0,) * 8 + (math.inf,), 8),
    ((0.0, 0.0, 0.0, -math.inf, math.nan, 0.0, 0.0, 0.0, 0.0), 3)])
def test_first_bad_input(values, index):
    assert first_bad_input(values, FLOATS) == index
    batch = first_bad_input(tuple(np.array([v, 0.0]) for v in values), ARRAYS)
    assert list(batch) == [index, -1]


@pytest.mark.parametrize('open_loops', [(), ('D',), ('A', 'C'), ('E2 on rod', 'B'), LOOPS])
def test_first_open_loop_follows_the_loop_order(open_loops):
    valid = {loop: loop not in open_loops for loop in LOOPS}
    index = min((LOOPS.index(loop) for loop in open_loops), default=-1)
    assert first_open_loop(valid, FLOATS) == index
    arrays = {loop: np.array([ok, True]) for loop, ok in valid.items()}
    assert list(first_open_loop(arrays, ARRAYS)) == [index, -1]


def test_all_finite():
    assert all_finite([1.0, -2.0, 1e308], FLOATS)
    assert not all_finite([1.0, math.inf], FLOATS) and not all_finite([math.nan], FLOATS)
    np.testing.assert_array_equal(
        all_finite([np.array([1.0, math.nan, 1.0]), np.array([1.0, 1.0, -math.inf])], ARRAYS),
        [True, False, False])


@pytest.mark.parametrize('loop', LOOPS)
def test_every_loop_is_described(loop):
    detail = describe(Status.UNREACHABLE, LOOPS.index(loop), LIMITS, ((0.0,) * 3,) * 3,
                      *((0.0,) * 3,) * 3, 0.0, 0.0)
    assert detail == f'loop {loop}: {LOOP_REASONS[loop]}'


@pytest.mark.parametrize('status, info, legs, conditions, words', [
    (Status.INVALID_INPUT, 4, (0.0, 0.0, 0.0), (0.0, 0.0), ('qd[1]', 'heave', 'nan')),
    (Status.INVALID_INPUT, RESULTS_NOT_FINITE, (0.0, 0.0, 0.0), (0.0, 0.0), ('finite',)),
    (Status.NEAR_SINGULAR, 0, (0.0, 0.0, 0.0), (1.0, 1.0), ('singularity',)),
    (Status.NEAR_SINGULAR, 1, (0.0, 0.0, 0.0), (150.0, 1.0), ('kinematic', '150', '100')),
    (Status.NEAR_SINGULAR, 1, (0.0, 0.0, 0.0), (1.0, 2e3), ('Jacobian', '2e+03', '100')),
    (Status.LIMIT, 0, (0.7, 0.0, 0.0), (1.0, 1.0), ('stroke A', '0.7', '0.6')),
    (Status.LIMIT, 0, (0.0, -2.0, 0.0), (1.0, 1.0), ('speed A', '2', '1')),
    (Status.LIMIT, 0, (0.0, 0.0, 3e3), (1.0, 1.0), ('force A', '3000', '2000')),
])
def test_describe(status, info, legs, conditions, words):
    """The detail names the input or leg, the value and the limit crossed."""
    inputs = ((0.0, 0.0, 0.0), (0.0, math.nan, 0.0), (0.0, 0.0, 0.0))
    detail = describe(status, info, LIMITS, inputs, *_legs(legs), *conditions)
    assert all(w in detail for w in words), (words, detail)


def test_ok_has_no_detail():
    assert describe(Status.OK, 0, LIMITS, ((0.0,) * 3,) * 3, *((0.0,) * 3,) * 3, 1.0, 1.0) == ''


def test_codes_are_severities():
    """The rule's codes index BY_SEVERITY (what the solver maps them with)."""
    assert [SEVERITY[s] for s in BY_SEVERITY] == list(range(len(BY_SEVERITY)))
