"""Status of a solve: how much its numbers can be trusted (issue: hard cases).

The string form of each member is its name, as written in the CSV ``status``
column and the node's diagnostics.
"""
from __future__ import annotations

from enum import Enum


class Status(str, Enum):
    """Outcome of a solve, from best to worst."""

    OK = 'ok'                          # every number valid
    NEAR_SINGULAR = 'near_singular'    # valid, but the mechanism is close to a singularity
    LIMIT = 'limit'                    # valid, but a stroke, speed or force limit is exceeded
    UNREACHABLE = 'unreachable'        # no such pose: a loop of eq. (7) cannot close
    INVALID_INPUT = 'invalid_input'    # non-finite or absurd input
    NOT_CONVERGED = 'not_converged'    # forward kinematics only: the iteration did not converge

    def __str__(self) -> str:
        return self.value
