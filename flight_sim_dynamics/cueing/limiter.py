"""The limiter between the washout and the machine: every output sample within
every limit of the machine by its own inverse dynamics (design:
/work/shared/design/cueing.md, "What the limiter must guarantee"; method and
measurements: docs/design/cueing_limiter.md).

Contract (:mod:`.planner` calls it): ``make_limiter(model, params) -> limiter``
with ``reset()`` and ``step(q, qd, qdd) -> Limited`` (one output sample every
``1 / params.rate`` s, machine coordinates, home = 0). :data:`LIMITER_SPECS`:
the limiter's own parameters (``cueing.<name>``); :mod:`.params` reads them
(so this module must not import :mod:`.params`).

The method, a reference governor with a braking look-ahead
(cueing_limiter.md, (L1)-(L6)): the limiter keeps its own state (q, qd, qdd),
the last sample it published. Each cycle it takes the candidate that follows
the washout (the washout's own sample when the state has caught up with it,
else the washout's acceleration plus a bounded pull-back) and accepts it when
the machine's solve, on a copy of the model whose limits are tightened by the
margins, is ``ok`` both for the sample and for the point where a braking from
it would stop. Otherwise it blends the acceleration towards braking,
``a = (1 - lam) a_brake + lam a_w``, bisecting on ``lam``; ``lam = 0``, the
braking itself, is the fallback. ``given_up = 1 - lam``.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, fields, replace
from typing import Any

import numpy as np

from ..core.parameter_spec import ParamSpec
from ..core.status import Status
from ..machines.api import machine_of


def _spec(name: str, kind: str, default: Any, description: str, unit: str = '',
          **kw: Any) -> ParamSpec:
    return ParamSpec('cueing.' + name, kind, default, description, unit, required=False, **kw)


#: The limiter's keys of the ``cueing`` group (names ``cueing.<...>``, required=False).
LIMITER_SPECS: tuple[ParamSpec, ...] = (
    _spec('margin.stroke', 'double', 0.01,
          "stroke the limiter keeps free at each end of every actuator's travel", 'm',
          minimum=0.0, maximum=1.0),
    _spec('margin.fraction', 'double', 0.05,
          'fraction of the speed, force, condition and joint-angle limits the limiter keeps '
          'free', minimum=0.0, maximum=0.5),
    _spec('braking', 'double_array', [5.0, 5.0],
          'deceleration of the braking the limiter keeps in reserve (translations m/s^2, '
          'rotations rad/s^2): larger brakes later and gives up less cue, with a harder stop',
          'm/s^2, rad/s^2', minimum=0.0, exclusive_minimum=True, maximum=1000.0, length=2),
    _spec('recovery.omega', 'double', 2.0,
          'bandwidth of the pull-back that returns the platform to the washout after '
          'limiting (critically damped)', 'rad/s', minimum=0.0, exclusive_minimum=True,
          maximum=100.0),
    _spec('recovery.acceleration', 'double_array', [0.5, 0.5],
          'largest pull-back acceleration while returning to the washout (translations '
          'm/s^2, rotations rad/s^2)', 'm/s^2, rad/s^2', minimum=0.0, maximum=1000.0,
          length=2),
)

#: Bisection steps on lam when the candidate fails (lam resolution 2^-steps).
BISECTION_STEPS = 6
#: The state has caught up with the washout when the washout's sample is this
#: close to the state's continuation (L1): position (m or rad), rate (m/s or rad/s).
CATCH_UP_POSITION = 1e-6
CATCH_UP_RATE = 1e-4
#: Periods of motion beyond the braking's stop point that must be within the
#: limits too (L3): the margin of the limits that have none of their own
#: (unreachable poses).
STOP_MARGIN = 2

#: :attr:`Limited.limit` of a non-finite desired sample (held: braking to rest).
INPUT = 'input'


@dataclass(frozen=True, slots=True)
class Limited:
    """One sample as the limiter lets it through: q, qd, qdd (machine
    coordinates); ``given_up`` in [0, 1] (0: nothing); ``limit`` the limit that
    made it ('' when none): ``stroke``, ``speed``, ``force``, ``joint_angle``,
    ``condition``, ``unreachable``, ``overflow`` (a candidate too large to
    solve) or ``input`` (a non-finite desired sample).
    """

    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    given_up: float = 0.0
    limit: str = ''


class PassThrough:
    """``limiter: none``: the washout's sample as it is."""

    def reset(self) -> None:
        """Nothing to forget."""

    def step(self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> Limited:
        """The sample itself."""
        return Limited(q, qd, qdd)


def advance(q: np.ndarray, qd: np.ndarray, a0: np.ndarray, a1: np.ndarray,
            dt: float) -> tuple[np.ndarray, np.ndarray]:
    """The limiter's one integration rule (L1): position and rate after ``dt``
    from (q, qd) with the acceleration going linearly from ``a0`` to ``a1``:
    ``qd + dt (a0 + a1) / 2``, ``q + dt qd + dt^2 (2 a0 + a1) / 6``.
    """
    return (q + dt * qd + (dt * dt / 6.0) * (2.0 * a0 + a1),
            qd + (0.5 * dt) * (a0 + a1))


def tightened(model: Any, stroke: float, fraction: float) -> Any:
    """A copy of ``model`` whose limits keep the margins free: strokes (or leg
    lengths) ``stroke`` inside each end, every other limit (speed, force,
    conditions, joint angles) scaled by ``1 - fraction``. ValueError for a
    limit this does not know (a new one must be given a margin here) and for a
    stroke margin that leaves no travel.
    """
    limits = model.limits
    changes: dict[str, float] = {}
    for f in fields(limits):
        name, value = f.name, getattr(limits, f.name)
        if name == 'warn_fraction' or value is None:
            continue
        if name in ('stroke_min', 'length_min'):
            changes[name] = value + stroke
        elif name in ('stroke_max', 'length_max'):
            changes[name] = value - stroke
        elif name in ('max_speed', 'max_force') or name.endswith('_condition') \
                or name.endswith('_max_angle'):
            changes[name] = value * (1.0 - fraction)
        else:
            raise ValueError(f'the limiter has no margin for the limit {name!r}')
    low = changes.get('stroke_min', changes.get('length_min'))
    high = changes.get('stroke_max', changes.get('length_max'))
    if low is not None and high is not None and not low < high:
        raise ValueError(f'cueing.margin.stroke {stroke:g} m leaves no travel '
                         f'({low:g} >= {high:g})')
    return replace(model, limits=replace(limits, **changes))


class InverseDynamicsLimiter:
    """``limiter: inverse_dynamics`` (module docstring; cueing_limiter.md)."""

    def __init__(self, model: Any, settings: Any, rate: float) -> None:
        self.machine = machine_of(model)
        self.model = model
        self.dt = 1.0 / float(rate)
        self.stop_margin = STOP_MARGIN * self.dt
        self.tight = tightened(model, float(settings['margin.stroke']),
                               float(settings['margin.fraction']))
        self.tight_limits = self.machine.actuator_limits(self.tight)
        linear = np.array([unit == 'm' for unit in self.machine.units])
        braking = np.asarray(settings['braking'], dtype=float)
        recovery = np.asarray(settings['recovery.acceleration'], dtype=float)
        # per coordinate: 1 / braking deceleration, largest pull-back acceleration
        self.inverse_braking = 1.0 / np.where(linear, braking[0], braking[1])
        self.recovery = np.where(linear, recovery[0], recovery[1])
        omega = float(settings['recovery.omega'])
        self.kp, self.kd = omega * omega, 2.0 * omega
        self._solve = self.machine.solve
        self.reset()

    def reset(self) -> None:
        """At rest at home, caught up (the washout starts there)."""
        n = self.machine.dof
        self.q, self.qd, self.qdd = np.zeros(n), np.zeros(n), np.zeros(n)

    # -- checks ------------------------------------------------------------

    def _braking(self, qd: np.ndarray) -> tuple[float, np.ndarray]:
        """(L3) The time ``tau`` a braking from rate ``qd`` takes (each
        coordinate at most its braking deceleration, all stopping together,
        a straight line in pose space) and its deceleration ``-qd / tau``
        (``tau`` at least one period: at rest, no deceleration).
        """
        tau = float(np.max(np.abs(qd) * self.inverse_braking))
        return tau, qd * (-1.0 / max(tau, self.dt))

    def _refused(self, q: np.ndarray, qd: np.ndarray, a: np.ndarray) -> str:
        """(L2) '' when the sample (q, qd, a) and the braking from it are within
        the tightened limits, else the limit that refuses it. Three solves: the
        sample's, and both ends of the braking from it (L3): its first step
        ramps from ``a`` to the braking's deceleration (:func:`advance`), to
        (q2, qd2), its fastest point; then it decelerates constantly to rest
        at ``q2 + tau2 qd2 / 2``, checked :data:`STOP_MARGIN` periods of the
        sample's rate further, with the rate qd2 (the worst of the way).
        """
        tight, solve = self.tight, self._solve
        sol = solve(tight, q, qd, a)
        if sol.status is not Status.OK:
            return self._limit_name(sol)
        brake = self._braking(qd)[1]
        q2, qd2 = advance(q, qd, a, brake, self.dt)
        sol = solve(tight, q2, qd2, brake)
        if sol.status is not Status.OK:
            return self._limit_name(sol)
        tau, brake = self._braking(qd2)
        sol = solve(tight, q2 + (0.5 * tau) * qd2 + self.stop_margin * qd, qd2, brake)
        if sol.status is not Status.OK:
            return self._limit_name(sol)
        return ''

    def _limit_name(self, sol: Any) -> str:
        """Which limit a solve on the tightened model exceeds."""
        status = sol.status
        if status is Status.NEAR_SINGULAR:
            return 'condition'
        if status is Status.UNREACHABLE:
            return 'unreachable'
        if status is not Status.LIMIT:
            return 'overflow'
        lim = self.tight_limits
        stroke = sol.stroke
        if (stroke < lim.stroke_min).any() or (stroke > lim.stroke_max).any():
            return 'stroke'
        if (np.abs(sol.rate) > lim.max_speed).any():
            return 'speed'
        if (np.abs(sol.force) > lim.max_force).any():
            return 'force'
        return 'joint_angle'

    # -- the cycle -----------------------------------------------------------

    def _publish(self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray, given_up: float,
                 limit: str) -> Limited:
        self.q, self.qd, self.qdd = q, qd, qdd
        return Limited(q, qd, qdd, given_up, limit)

    def step(self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> Limited:
        """The sample to publish for the washout's sample (q, qd, qdd)."""
        x_q, x_qd, x_a, dt = self.q, self.qd, self.qdd, self.dt
        if not math.isfinite(float(np.sum(q) + np.sum(qd) + np.sum(qdd))) and not (
                np.isfinite(q).all() and np.isfinite(qd).all() and np.isfinite(qdd).all()):
            # (L5) nothing to follow: brake to rest and hold there
            brake = self._braking(x_qd)[1]
            return self._publish(*advance(x_q, x_qd, x_a, brake, dt), brake, 1.0, INPUT)
        # (L1) the state's continuation with the washout's acceleration, against
        # the washout's sample
        pq, pqd = advance(x_q, x_qd, x_a, qdd, dt)
        e, ed = pq - q, pqd - qd
        if (np.abs(e) <= CATCH_UP_POSITION).all() and (np.abs(ed) <= CATCH_UP_RATE).all():
            # caught up: the washout's own sample, if it fits (invisible, bit for bit)
            if not self._refused(q, qd, qdd):
                return self._publish(np.array(q, dtype=float), np.array(qd, dtype=float),
                                     np.array(qdd, dtype=float), 0.0, '')
        # (L4) the washout's acceleration plus a bounded, critically damped pull-back
        with np.errstate(over='ignore', invalid='ignore'):
            pull = np.clip(-self.kp * e - self.kd * ed, -self.recovery, self.recovery)
            a_w = qdd + pull
        c_q, c_qd = advance(x_q, x_qd, x_a, a_w, dt)
        limit = self._refused(c_q, c_qd, a_w) if np.isfinite(c_q).all() else 'overflow'
        if not limit:
            return self._publish(c_q, c_qd, a_w, 0.0, '')
        # (L2)-(L3) blend towards braking: the largest lam that is accepted
        brake = self._braking(x_qd)[1]
        low, high = 0.0, 1.0
        for _ in range(BISECTION_STEPS):
            lam = 0.5 * (low + high)
            a = (1.0 - lam) * brake + lam * a_w
            c_q, c_qd = advance(x_q, x_qd, x_a, a, dt)
            refused = self._refused(c_q, c_qd, a) if np.isfinite(c_q).all() else 'overflow'
            if refused:
                high, limit = lam, refused
            else:
                low = lam
        a = brake if low == 0.0 else (1.0 - low) * brake + low * a_w
        return self._publish(*advance(x_q, x_qd, x_a, a, dt), a, 1.0 - low, limit)


def make_limiter(model: Any, params: Any) -> PassThrough | InverseDynamicsLimiter:
    """The limiter ``params.limiter`` names for ``model``."""
    if params.limiter == 'none':
        return PassThrough()
    if params.limiter != 'inverse_dynamics':
        raise ValueError(f"unknown limiter {params.limiter!r} (inverse_dynamics or none)")
    return InverseDynamicsLimiter(model, params.limiter_settings, params.rate)
