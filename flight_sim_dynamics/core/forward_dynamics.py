"""Forward dynamics from the affine terms of a machine's inverse dynamics:
f = M(q) qdd + b(q, qd) (``Machine.affine_terms``, its equations in the machine's
own module), solved for qdd. Numpy only.
"""
from __future__ import annotations

import math

import numpy as np

from .status import Status

#: Largest condition number of M solved: beyond it, qdd would not reproduce f to 1e-8.
MAX_MASS_CONDITION = 1e8


def solve_accelerations(M: np.ndarray, b: np.ndarray, force: np.ndarray
                        ) -> tuple[np.ndarray, Status, str]:
    """Qdd with M qdd = force - b (LU) and ok; or zeros, near_singular (M too
    ill-conditioned) or invalid_input (not finite).
    """
    if not np.all(np.isfinite(M)):
        return np.zeros(len(b)), Status.NEAR_SINGULAR, 'exact singularity: M is not finite'
    sigma = np.linalg.svd(M, compute_uv=False)
    if not (sigma[-1] > 0.0 and sigma[0] <= sigma[-1] * MAX_MASS_CONDITION):
        condition = sigma[0] / sigma[-1] if sigma[-1] > 0 else math.inf
        return np.zeros(len(b)), Status.NEAR_SINGULAR, (
            f'condition of M {condition:.3g} > {MAX_MASS_CONDITION:g}: '
            'accelerations cannot be resolved')
    qdd = np.linalg.solve(M, force - b)
    if not np.all(np.isfinite(qdd)):
        return np.zeros(len(b)), Status.INVALID_INPUT, 'results are not finite: input too large'
    return qdd, Status.OK, ''
