"""The check of a body's inertia tensor, every machine's loaders': finite,
symmetric, physically possible (:func:`inertia_tensor`).
"""
from __future__ import annotations

from typing import Iterable

import numpy as np

from .machine import ModelValueError


def inertia_tensor(key: str, value: Iterable[float]) -> np.ndarray:
    """A 3x3 inertia tensor (eq. 18-19: J of each body about its centre of
    mass) must be finite, symmetric and physically possible: principal moments
    >= 0 and each no larger than the sum of the other two. Returns it
    symmetrised; :class:`~.machine.ModelValueError` naming ``key`` otherwise.
    """
    values = list(value)
    tensor = np.asarray(values, dtype=float).reshape(3, 3)
    if not np.all(np.isfinite(tensor)):     # eigvalsh would raise LinAlgError
        raise ModelValueError(key, 'inertia tensor must be finite')
    scale = max(float(np.max(np.abs(tensor))), 1e-300)
    tensor = tensor / scale                 # no overflow near 1e308 in the checks below
    if np.max(np.abs(tensor - tensor.T)) > 1e-9:
        raise ModelValueError(key, 'inertia tensor is not symmetric')
    moments = np.linalg.eigvalsh(0.5 * (tensor + tensor.T))
    if moments[0] < -1e-9:
        raise ModelValueError(key, f'inertia tensor is not positive semi-definite '
                                   f'(principal moment {moments[0] * scale:.6g})')
    if moments[2] > moments[0] + moments[1] + 1e-9:
        m = moments * scale
        raise ModelValueError(key, 'principal moments violate the triangle inequality '
                                   f'({m[2]:.6g} > {m[0]:.6g} + {m[1]:.6g})')
    return 0.5 * (tensor + tensor.T) * scale
