"""Interpolation of the twin's inputs (:mod:`.simulation`): open-loop force
histories by a cubic Hermite spline with five-point node slopes (O(dt^4)),
reference motions from samples by quintic Hermite polynomials (exact at the
rows, C2). Numpy only.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Protocol, Sequence

import numpy as np

Trajectory = tuple[np.ndarray, np.ndarray, np.ndarray]


class MotionLike(Protocol):
    """What :class:`.motions.Motion` offers (not imported: the registry stays apart)."""

    duration: float

    def trajectory(self, t: np.ndarray) -> Trajectory: ...


class SampleError(ValueError):
    """A bad sample of an input: ``name`` (``t``, ``q``, ``qd``, ``qdd``,
    ``force``), its ``row`` (0-based) and ``column`` (None: the time), and what
    is wrong with its value (``reason``), so that a caller can name where it read it.
    """

    def __init__(self, message: str, name: str, row: int, column: int | None = None,
                 reason: str = '') -> None:
        super().__init__(message)
        self.name, self.row, self.column, self.reason = name, row, column, reason or message


def finite_rows(name: str, value: object, n: int | None = None, columns: int = 3
                ) -> np.ndarray:
    """An (N, columns) array of finite numbers, or ValueError naming ``name``."""
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f'{name} must be numbers, got {value!r:.100}') from None
    if arr.ndim != 2 or arr.shape[1] != columns or (n is not None and arr.shape[0] != n):
        raise ValueError(f'{name} must have shape ({n if n is not None else "N"}, {columns}), '
                         f'got {arr.shape}')
    bad = np.argwhere(~np.isfinite(arr))
    if bad.size:
        i, j = bad[0]
        raise SampleError(f'{name}[{i}, {j}] is not finite ({arr[i, j]})', name, int(i), int(j),
                          'is not finite')
    return arr


def sample_times(t: object) -> np.ndarray:
    """Strictly increasing finite sample times (at least two), or ValueError."""
    arr = np.asarray(t, dtype=float)
    if arr.ndim != 1 or arr.size < 2:
        raise ValueError(f'times must be a list of at least 2 numbers, got shape {arr.shape}')
    if not np.all(np.isfinite(arr)):
        i = int(np.argmin(np.isfinite(arr)))
        raise SampleError(f't[{i}] is not finite', 't', i, reason='is not finite')
    steps = np.diff(arr)
    if not np.all(steps > 0):
        i = int(np.argmin(steps > 0))
        raise SampleError(f'times must increase strictly: t[{i + 1}] = {float(arr[i + 1])!r} '
                          f'after t[{i}] = {float(arr[i])!r}', 't', i + 1,
                          reason='does not increase: times must increase strictly (the row '
                          f'before: t = {float(arr[i])!r})')
    return arr


def node_slopes(t: np.ndarray, y: np.ndarray) -> np.ndarray:
    """dy/dt at every node: sum_j L_j'(t_i) y_j over the five nearest nodes
    (Lagrange basis L_j), exact for polynomials of degree <= 4.
    """
    n = t.size
    width = min(5, n)
    first = np.clip(np.arange(n) - width // 2, 0, n - width)
    nodes = first[:, None] + np.arange(width)           # (n, width) window of each node
    tw = t[nodes]
    ti = t[:, None]
    slopes = np.zeros_like(y)
    for j in range(width):
        others = [k for k in range(width) if k != j]
        dj = tw[:, j:j + 1] - tw[:, others]                          # t_j - t_k
        is_self = nodes[:, j] == np.arange(n)
        # L_j'(t_i) for j != i: prod_{k != i, j}(t_i - t_k) / prod_{k != j}(t_j - t_k)
        num = np.prod(np.where(nodes[:, others] == np.arange(n)[:, None], 1.0,
                               ti - tw[:, others]), axis=1)
        w = num / np.prod(dj, axis=1)
        # L_i'(t_i) = sum_{k != i} 1 / (t_i - t_k)
        w_self = np.sum(1.0 / dj, axis=1)
        w = np.where(is_self, w_self, w)
        slopes += w[:, None] * y[nodes[:, j]]
    return slopes


class ForceHistory:
    """Actuator forces (N) at increasing times ``t`` (s), by the cubic Hermite
    spline: one column per leg (``legs`` of them).
    """

    def __init__(self, t: Sequence[float], force: object, legs: int = 3) -> None:
        self.t = sample_times(t)
        self.start, self.end = float(self.t[0]), float(self.t[-1])
        self.force = finite_rows('force', force, self.t.size, legs)
        with np.errstate(over='ignore', invalid='ignore'):
            self.slope = node_slopes(self.t, self.force)
            # |h00|, |h01| <= 1 and |h10|, |h11| < 1: this bounds the spline on each interval
            bound = (np.abs(self.force[:-1]) + np.abs(self.force[1:]) + np.diff(self.t)[:, None]
                     * (np.abs(self.slope[:-1]) + np.abs(self.slope[1:])))
        bad = np.flatnonzero(~np.all(np.isfinite(bound), axis=1))
        if bad.size:        # the largest force among the rows the interval's slopes use
            lo = max(0, int(bad[0]) - 2)
            k = lo + int(np.argmax(np.abs(self.force[lo:bad[0] + 4]).max(axis=1)))
            raise SampleError(f'the forces of the row at t = {float(self.t[k])!r} s '
                              f'({np.abs(self.force[k]).max():.3g} N) are too large to '
                              'interpolate (the spline overflows)', 'force', k,
                              int(np.argmax(np.abs(self.force[k]))),
                              'is too large to interpolate (the spline overflows)')

    def __call__(self, times: np.ndarray) -> np.ndarray:
        """Forces (N, legs) at ``times`` (within [start, end], else ValueError)."""
        times = np.atleast_1d(np.asarray(times, dtype=float))
        if times.min() < self.start or times.max() > self.end:
            raise ValueError(f'force history spans [{self.start:g}, {self.end:g}] s; '
                             f'asked for [{times.min():g}, {times.max():g}] s')
        i = np.clip(np.searchsorted(self.t, times, side='right') - 1, 0, self.t.size - 2)
        dt = (self.t[i + 1] - self.t[i])[:, None]
        u = (times[:, None] - self.t[i][:, None]) / dt
        h00, h10 = (1 + 2 * u) * (1 - u) ** 2, u * (1 - u) ** 2
        h01, h11 = u * u * (3 - 2 * u), u * u * (u - 1)
        return (h00 * self.force[i] + h10 * dt * self.slope[i]
                + h01 * self.force[i + 1] + h11 * dt * self.slope[i + 1])


#: Quintic Hermite basis on [0, 1] (rows: value, slope, second derivative at 0,
#: then second derivative, slope, value at 1; columns: coefficients of u^0..u^5).
_QUINTIC = np.array([[1, 0, 0, -10, 15, -6], [0, 1, 0, -6, 8, -3],
                     [0, 0, 0.5, -1.5, 1.5, -0.5], [0, 0, 0, 0.5, -1, 0.5],
                     [0, 0, 0, -4, 7, -3], [0, 0, 0, 10, -15, 6]], dtype=float)


@dataclass(frozen=True)
class Reference:
    """A reference motion: ``motion(times)`` gives q, qd, qdd (each (N, dof))
    at times in [start, end] (s).
    """

    motion: Callable[[np.ndarray], Trajectory]
    start: float
    end: float

    @classmethod
    def from_motion(cls, motion: MotionLike) -> 'Reference':
        """A motion of the registry (:class:`.motions.Motion`), exact."""
        try:
            return cls(motion.trajectory, 0.0, float(motion.duration))
        except AttributeError:
            raise ValueError(f'reference must be a Reference or a motion with trajectory and '
                             f'duration, got {motion!r:.100}') from None

    @classmethod
    def from_samples(cls, t: Sequence[float], q: object, qd: object, qdd: object,
                     dof: int = 3) -> 'Reference':
        """Samples (rows of a trajectory CSV; ``dof`` coordinates) by quintic
        Hermite polynomials (C2).
        """
        times = sample_times(t)
        n = times.size
        names = ('q', 'qd', 'qdd')
        values = np.stack([finite_rows(name, value, n, dof)
                           for name, value in zip(names, (q, qd, qdd))])
        with np.errstate(over='ignore', invalid='ignore'):
            # each basis polynomial and its first two derivatives stay below 64 on [0, 1]:
            # this bounds q, qd and qdd on each interval (a step under 1 s divides them)
            h = np.diff(times)[:, None]
            ends = np.abs(values[:, :-1]) + np.abs(values[:, 1:])
            bound = 64.0 * (ends[0] + h * ends[1] + h * h * ends[2]) / np.minimum(h, 1.0) ** 2
        bad = np.argwhere(~np.isfinite(bound))
        if bad.size:            # the largest value of the interval's two rows
            i, j = (int(x) for x in bad[0])
            g, k = max(((g, k) for g in range(3) for k in (i, i + 1)),
                       key=lambda gk: abs(values[gk[0], gk[1], j]))
            raise SampleError(f'{names[g]}[{k}, {j}] = {values[g, k, j]:.3g} is too large to '
                              'interpolate (the spline overflows)', names[g], k, j,
                              'is too large to interpolate (the spline overflows)')

        def motion(at: np.ndarray) -> Trajectory:
            at = np.atleast_1d(np.asarray(at, dtype=float))
            i = np.clip(np.searchsorted(times, at, side='right') - 1, 0, n - 2)
            dt = (times[i + 1] - times[i])[:, None]
            u = (at[:, None] - times[i][:, None]) / dt
            powers = u[..., None] ** np.arange(6)                     # (N, 1, 6)
            d1 = np.concatenate([np.zeros_like(u)[..., None],
                                 np.arange(1, 6) * u[..., None] ** np.arange(5)], axis=-1)
            d2 = np.concatenate([np.zeros_like(u)[..., None].repeat(2, -1),
                                 np.arange(2, 6) * np.arange(1, 5) * u[..., None]
                                 ** np.arange(4)], axis=-1)
            ends = (values[0][i], dt * values[1][i], dt * dt * values[2][i],
                    dt * dt * values[2][i + 1], dt * values[1][i + 1], values[0][i + 1])
            out = []
            for k, basis_powers in enumerate((powers, d1, d2)):
                basis = basis_powers[:, 0, :] @ _QUINTIC.T                # (N, 6)
                out.append(sum(basis[:, m:m + 1] * ends[m] for m in range(6)) / dt ** k)
            return out[0], out[1], out[2]

        return cls(motion, float(times[0]), float(times[-1]))
