"""Estimation of the rates and accelerations a planner does not send, without
ROS: causal (backward) finite differences of the setpoint stream.
"""
from __future__ import annotations

from .inputs import Vec3, wrap_angle

ESTIMATORS = ('backward', 'backward2')


def backward_derivative(times: list[float], values: list[Vec3], order: int) -> Vec3:
    """Derivative at ``times[-1]`` from the last samples (causal).

    ``order`` 1: two-point backward difference ``(f_k - f_k-1) / h`` (error
    ``h f''/2``). ``order`` 2: derivative at ``t_k`` of the parabola through
    the last three samples (BDF2, error ``h^2 f'''/3`` on a uniform grid);
    the steps may be unequal. Falls back to order 1 with two samples and to
    zero with one.
    """
    n = len(times)
    if n < 2:
        return (0.0, 0.0, 0.0)
    if order == 1 or n < 3:
        h = times[-1] - times[-2]
        f1, f0 = values[-1], values[-2]
        return ((f1[0] - f0[0]) / h, (f1[1] - f0[1]) / h, (f1[2] - f0[2]) / h)
    h1 = times[-1] - times[-2]
    h2 = times[-2] - times[-3]
    c0 = (2.0 * h1 + h2) / (h1 * (h1 + h2))
    c1 = -(h1 + h2) / (h1 * h2)
    c2 = h1 / (h2 * (h1 + h2))
    f0, f1, f2 = values[-1], values[-2], values[-3]
    return (c0 * f0[0] + c1 * f1[0] + c2 * f2[0],
            c0 * f0[1] + c1 * f1[1] + c2 * f2[1],
            c0 * f0[2] + c1 * f1[2] + c2 * f2[2])


class DerivativeEstimator:
    """Fill in missing rates and accelerations from the stream itself.

    Each :meth:`update` takes the pose of one setpoint (stamp in seconds) and
    the measured twist/acceleration when the planner sent them (None
    otherwise). Missing rates are the backward derivative of the last poses;
    missing accelerations the backward derivative of the last rates (the
    measured ones when they came, else the estimated ones), so a pose-only
    stream gets its accelerations from a second difference of poses.
    Roll is unwrapped across +-pi before differencing.

    The history restarts (rates and accelerations estimated as zero, i.e. the
    motion is assumed to start from rest) on the first setpoint, after a gap
    longer than ``max_gap`` seconds, and on :meth:`reset`.
    """

    def __init__(self, method: str = 'backward2', max_gap: float = 0.5) -> None:
        if method not in ESTIMATORS:
            raise ValueError(f'unknown estimator {method!r}; choose one of {ESTIMATORS}')
        self.order = 1 if method == 'backward' else 2
        self.method = method
        self.max_gap = float(max_gap)
        self._t: list[float] = []
        self._q: list[Vec3] = []
        self._qd: list[Vec3] = []

    def reset(self) -> None:
        self._t.clear()
        self._q.clear()
        self._qd.clear()

    def update(self, t: float, q: Vec3, qd: Vec3 | None, qdd: Vec3 | None
               ) -> tuple[Vec3, Vec3]:
        """Record a setpoint and return its (rates, accelerations): the given
        ones where present, estimates otherwise.
        """
        if self._t and not (0.0 < t - self._t[-1] <= self.max_gap):
            self.reset()
        if self._q:
            prev = self._q[-1]
            q = (q[0], q[1], prev[2] + wrap_angle(q[2] - prev[2]))
        self._t.append(t)
        self._q.append(q)
        if qd is None:
            qd = backward_derivative(self._t, self._q, self.order)
        self._qd.append(qd)
        if qdd is None:
            qdd = backward_derivative(self._t, self._qd, self.order)
        if len(self._t) > 3:
            del self._t[0], self._q[0], self._qd[0]
        return qd, qdd


