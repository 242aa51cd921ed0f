"""Estimation of the rates and accelerations a planner does not send: causal
(backward) finite differences of the setpoint stream (q, qd, qdd). Which
coordinates are angles, unwrapped across +-pi, the caller tells (a machine's:
:attr:`~flight_sim_dynamics.core.machine.Machine.angles`).
"""
from __future__ import annotations

import math

import numpy as np

ESTIMATORS = ('backward', 'backward2')
#: One number per pose coordinate; Vec3: three numbers (a message's roll, pitch, yaw).
Vec = tuple[float, ...]
Vec3 = tuple[float, float, float]


def wrap_angle(angle: float) -> float:
    """``angle`` wrapped to [-pi, pi)."""
    return (angle + math.pi) % (2.0 * math.pi) - math.pi


def backward_derivative(times: list[float], values: list[Vec], order: int) -> Vec:
    """Derivative at ``times[-1]`` from the last samples (causal): ``order`` 1
    ``(f_k - f_k-1) / h`` (error ``h f''/2``), 2 the parabola through the last
    three, steps unequal or not (BDF2, error ``h^2 f'''/3``); order 1 with two
    samples, zero with one.
    """
    n = len(times)
    if n < 2:
        return (0.0,) * len(values[-1])
    if order == 1 or n < 3:
        h = times[-1] - times[-2]
        return tuple([(a - b) / h for a, b in zip(values[-1], values[-2])])
    h1 = times[-1] - times[-2]
    h2 = times[-2] - times[-3]
    c0 = (2.0 * h1 + h2) / (h1 * (h1 + h2))
    c1 = -(h1 + h2) / (h1 * h2)
    c2 = h1 / (h2 * (h1 + h2))
    return tuple([c0 * a + c1 * b + c2 * c for a, b, c in zip(values[-1], values[-2], values[-3])])


class DerivativeEstimator:
    """Fill in missing rates and accelerations from the stream itself.

    Missing rates are the backward derivative of the last poses (the
    coordinates ``angles`` unwrapped across +-pi), missing accelerations that of the last rates,
    given or estimated. The history restarts on the first setpoint, after a
    gap longer than ``max_gap`` s and on :meth:`reset`; its first setpoint is
    taken at rest. With ``warm_up`` (the node) an acceleration that would
    difference that assumed rest is None (not estimated) instead.
    :meth:`update` estimates and records a setpoint; the node records one
    only once it has answered it (:meth:`estimate`, then :meth:`commit`), so
    a rejected setpoint leaves no trace in the next estimates.
    """

    def __init__(self, method: str = 'backward2', max_gap: float = 0.5,
                 warm_up: bool = False, *, angles: tuple[int, ...]) -> None:
        if method not in ESTIMATORS:
            raise ValueError(f'unknown estimator {method!r}; choose one of {ESTIMATORS}')
        self.order = 1 if method == 'backward' else 2
        self.method = method
        self.max_gap = float(max_gap)
        self.warm_up = warm_up
        self.angles = tuple(angles)
        self._t: list[float] = []
        self._q: list[Vec] = []
        self._qd: list[Vec] = []
        self._real: list[bool] = []        # rate given or differenced (not assumed)
        self._staged: tuple[float, Vec, Vec, bool] | None = None

    def reset(self) -> None:
        self._t.clear()
        self._q.clear()
        self._qd.clear()
        self._real.clear()
        self._staged = None

    @property
    def samples(self) -> int:
        """Setpoints in the history (at most 3)."""
        return len(self._t)

    def update(self, t: float, q: Vec, qd: Vec | None, qdd: Vec | None
               ) -> tuple[Vec, Vec | None]:
        """:meth:`estimate` then :meth:`commit`: (rates, accelerations), given or estimated."""
        rates = self.estimate(t, q, qd, qdd)
        self.commit()
        return rates

    def estimate(self, t: float, q: Vec, qd: Vec | None, qdd: Vec | None
                 ) -> tuple[Vec, Vec | None]:
        """The (rates, accelerations) of a setpoint, as :meth:`update`, without
        recording it: :meth:`commit` does (until the next estimate).
        Accelerations None: not estimable yet (``warm_up`` only).
        """
        ts, qs, qds, real = self._t, self._q, self._qd, self._real
        if ts and not (0.0 < t - ts[-1] <= self.max_gap):
            ts, qs, qds, real = [], [], [], []   # a restart: the history is not used
        elif qs:
            prev, q = qs[-1], list(q)
            for j in self.angles:
                q[j] = prev[j] + wrap_angle(q[j] - prev[j])
            q = tuple(q)
        ts, qs = ts + [t], qs + [q]
        known = qd is not None or len(ts) > 1
        if qd is None:
            qd = backward_derivative(ts, qs, self.order)
        if qdd is None and len(ts) > 1:
            if self.warm_up:
                # the trailing run of real rates, this one included
                n = 1
                while n < len(real) + 1 and real[-n]:
                    n += 1
                if not known or n < 2:
                    self._staged = (t, q, qd, known)
                    return qd, None
                ts, qds = ts[-n:], qds[-(n - 1):]
            qdd = backward_derivative(ts, qds + [qd], self.order)
        elif qdd is None:
            qdd = (0.0,) * len(q)
        self._staged = (t, q, qd, known)
        return qd, qdd

    def commit(self) -> None:
        """Add the setpoint of the last :meth:`estimate` to the history."""
        staged, self._staged = self._staged, None
        if staged is None:
            return
        t, q, qd, known = staged
        if self._t and not (0.0 < t - self._t[-1] <= self.max_gap):
            self.reset()
        self._t.append(t)
        self._q.append(q)
        self._qd.append(qd)
        self._real.append(known)
        if len(self._t) > 3:
            del self._t[0], self._q[0], self._qd[0], self._real[0]


def estimate_rows(t: np.ndarray, q: np.ndarray, qd: np.ndarray | None = None,
                  method: str = 'backward2', max_gap: float = 0.5,
                  angles: tuple[int, ...] | None = None, *,
                  estimator: DerivativeEstimator | None = None
                  ) -> tuple[np.ndarray, np.ndarray]:
    """Rates (``qd`` where given) and accelerations of the samples (t, q) as the
    node estimates them, row by row (:meth:`DerivativeEstimator.update`; the
    coordinates ``angles`` unwrapped); ``estimator``: one whose history the rows
    continue (e.g. the rows before them; its own method, gap and angles), else
    ``angles`` is given (TypeError if not).
    """
    if estimator is None and angles is None:
        raise TypeError('estimate_rows needs the angles (or an estimator)')
    est = DerivativeEstimator(method, max_gap, angles=angles) if estimator is None else estimator
    rates, accs = np.empty_like(q), np.empty_like(q)
    for k, (tk, qk) in enumerate(zip(np.asarray(t).tolist(), q.tolist())):
        given = None if qd is None else tuple(qd[k].tolist())
        rates[k], accs[k] = est.update(tk, tuple(qk), given, None)
    return rates, accs
