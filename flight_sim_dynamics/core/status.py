"""Status of a solve: how much its numbers can be trusted.

Every solve returns a status; the string form of each member is its name, as
written in the CSV ``status`` column and the node's diagnostics. From best to
worst (a solve reports the worst that applies):

================ ===========================================================
ok               every number valid
limit            valid, but a stroke, speed or force limit (``limits.*``) is
                 exceeded; ``detail`` says which
near_singular    the mechanism is close to a singularity: the kinematic
                 condition (of the connectivity matrix Q) or the condition
                 of the actuator Jacobian exceeds its threshold; the numbers
                 are what the equations give, so forces may be huge; at an
                 exact singularity the forces and powers are set to 0
unreachable      no such pose (a loop of eq. 7 cannot close, or E2 would
                 leave the rod): every number is 0
invalid_input    a non-finite input, or one so large that the results are
                 not finite: every number is 0; ``detail`` names the field
not_converged    forward kinematics only: the iteration did not converge
================ ===========================================================

No status ever comes with a NaN or an infinity in the numbers.
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


def condition_2x2(a: tuple, b: tuple, xp) -> object:
    """Exact 2-norm condition number sigma_max / sigma_min of the 2x2 matrix with
    columns a and b (first two components; floats or arrays): sigma_max^2/|det|."""
    f2 = a[0] * a[0] + a[1] * a[1] + b[0] * b[0] + b[1] * b[1]
    det = xp.abs(a[0] * b[1] - a[1] * b[0])
    sigma_max2 = 0.5 * (f2 + xp.sqrt(xp.clip0((f2 - 2.0 * det) * (f2 + 2.0 * det))))
    return sigma_max2 / det
