"""Status of a solve: how much its numbers can be trusted.

A member's string form is its name (CSV ``status`` column, diagnostics).
From best to worst; a solve reports the worst that applies:

================ ===========================================================
ok               every number valid
limit            valid, but a stroke, speed or force limit is exceeded
near_singular    the kinematic condition (of Q) or the actuator Jacobian's
                 exceeds its threshold; at an exact singularity the
                 non-finite numbers are 0
unreachable      a loop of eq. 7 cannot close (or E2 would leave the rod):
                 every number is 0
invalid_input    a non-finite input, or results that overflow: every number 0
not_converged    forward kinematics only: the iteration did not converge
================ ===========================================================

Never a NaN or an infinity. Each machine writes its rule once, for floats and
arrays alike (in its own package under :mod:`flight_sim_dynamics.machines`),
and its kernel transcribes it.
"""
from __future__ import annotations

import sys
from enum import Enum

#: Stand-in for an infinite condition number (exact singularity): finite by design.
SINGULAR = sys.float_info.max


class Status(str, Enum):
    """Outcome of a solve."""

    OK = 'ok'
    LIMIT = 'limit'
    NEAR_SINGULAR = 'near_singular'
    UNREACHABLE = 'unreachable'
    INVALID_INPUT = 'invalid_input'
    NOT_CONVERGED = 'not_converged'

    def __str__(self) -> str:
        return self.value


#: Severity order of the solve statuses (higher is worse).
SEVERITY = {Status.OK: 0, Status.LIMIT: 1, Status.NEAR_SINGULAR: 2, Status.UNREACHABLE: 3,
            Status.INVALID_INPUT: 4}
BY_SEVERITY = sorted(SEVERITY, key=SEVERITY.get)


#: ``info`` of a sample whose results overflow.
RESULTS_NOT_FINITE = -1
