"""Plain-vector arithmetic on 3-tuples of components: Python floats (one
cycle, no numpy overhead) or 1-D arrays (a batch), the same solver code for
both (:func:`backend`). ``zx(v)`` = z0 x v, the paper's ``u3~`` (eq. 10).
"""
from __future__ import annotations

import functools
import math
import operator
from types import SimpleNamespace
from typing import Tuple, Union

import numpy as np

Scalar = Union[float, np.ndarray]
Vec = Tuple[Scalar, Scalar, Scalar]


def add(a: Vec, b: Vec) -> Vec:
    return (a[0] + b[0], a[1] + b[1], a[2] + b[2])


def sub(a: Vec, b: Vec) -> Vec:
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


def scale(s: Scalar, a: Vec) -> Vec:
    return (s * a[0], s * a[1], s * a[2])


def axpy(s: Scalar, a: Vec, b: Vec) -> Vec:
    """S a + b."""
    return (s * a[0] + b[0], s * a[1] + b[1], s * a[2] + b[2])


def dot(a: Vec, b: Vec) -> Scalar:
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def cross(a: Vec, b: Vec) -> Vec:
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def zx(a: Vec) -> Vec:
    """z0 x a (the paper's u3~ a)."""
    return (-a[1], a[0], 0.0)


def to_frame(axes: tuple[Vec, Vec, Vec], v: Vec) -> Vec:
    """Components of v on the orthonormal axes (R^T v)."""
    return (dot(axes[0], v), dot(axes[1], v), dot(axes[2], v))


def from_frame(axes: tuple[Vec, Vec, Vec], c: Vec) -> Vec:
    """R c: the vector whose components on the axes are c."""
    x, y, z = axes
    return (c[0] * x[0] + c[1] * y[0] + c[2] * z[0],
            c[0] * x[1] + c[1] * y[1] + c[2] * z[1],
            c[0] * x[2] + c[1] * y[2] + c[2] * z[2])


def mat_vec(m: np.ndarray, c: Vec) -> Vec:
    """M c for a constant 3x3 matrix (nested tuple of floats) and components c."""
    return (m[0][0] * c[0] + m[0][1] * c[1] + m[0][2] * c[2],
            m[1][0] * c[0] + m[1][1] * c[1] + m[1][2] * c[2],
            m[2][0] * c[0] + m[2][1] * c[1] + m[2][2] * c[2])


_SCALAR = SimpleNamespace(
    sqrt=math.sqrt, sin=math.sin, cos=math.cos, atan2=math.atan2, hypot=math.hypot,
    tanh=math.tanh, abs=abs,
    # max(), min(), but NaN if any value is NaN, like numpy.maximum and the kernel
    maximum=lambda *v: math.nan if any(x != x for x in v) else max(v),
    minimum=lambda *v: math.nan if any(x != x for x in v) else min(v),
    clip0=lambda x: x if x > 0.0 else 0.0,
    where=lambda cond, a, b: a if cond else b,
    isfinite=math.isfinite, logical_not=operator.not_,
    all=bool, first_false=lambda ok: None, batch=False)


def _first_false(ok: np.ndarray) -> int | None:
    bad = np.flatnonzero(~ok)
    return int(bad[0]) if bad.size else None


_ARRAY = SimpleNamespace(
    sqrt=np.sqrt, sin=np.sin, cos=np.cos, atan2=np.arctan2, hypot=np.hypot,
    tanh=np.tanh, abs=np.abs,
    maximum=lambda *a: functools.reduce(np.maximum, a),
    minimum=lambda *a: functools.reduce(np.minimum, a),
    clip0=lambda x: np.maximum(x, 0.0),
    where=np.where, isfinite=np.isfinite, logical_not=np.logical_not,
    all=np.all, first_false=_first_false, batch=True)


def backend(batch: bool) -> SimpleNamespace:
    """Elementary functions for float components (False) or array components (True)."""
    return _ARRAY if batch else _SCALAR
