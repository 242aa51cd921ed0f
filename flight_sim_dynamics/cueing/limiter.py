"""The limiter between the washout and the machine: every output sample within
every limit of the machine by its own inverse dynamics (design:
/work/shared/design/cueing.md, "What the limiter must guarantee"; method and
measurements: docs/design/cueing_limiter.md, (L1)-(L8)).

Contract (:mod:`.planner` calls it): ``make_limiter(model, params) -> limiter``
with ``reset()`` and ``step(q, qd, qdd) -> Limited`` (one output sample every
``1 / params.rate`` s, machine coordinates, home = 0). Its own parameters
(``cueing.<name>``) are declared in :data:`..config.cueing.LIMITER_SPECS` and
arrive in :attr:`CueingParams.limiter_settings`.

The method, a reference governor with a braking look-ahead
(cueing_limiter.md, (L1)-(L7)): the limiter keeps its own state (q, qd, qdd),
the last sample it published. Each cycle it takes the candidate that follows
the washout (the washout's own sample when the state has caught up with it,
else the washout's acceleration plus a bounded pull-back) and accepts it when
the machine's solve, on a copy of the model whose limits are tightened by the
margins, is ``ok`` both for the sample and for the point where a braking from
it would stop. Otherwise it blends the acceleration towards braking,
``a = (1 - lam) a_brake + lam a_w``, bisecting on ``lam``; ``lam = 0``, the
braking itself, is the fallback. ``given_up = 1 - lam``. A look-ahead (L7)
lowers the gain on the washout smoothly before its free response (the
planner's, input held) leaves a coordinate's range; offline, the preview
(:mod:`.preview`, L8) replaces it, judged by :meth:`InverseDynamicsLimiter.fitting_gain`.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..core.status import Status
from ..machines.api import machine_of



#: Bisection steps on lam when the candidate fails (lam resolution 2^-steps).
BISECTION_STEPS = 6
#: Bisection steps of the preview's fitting gain (L8; resolution 2^-steps).
FIT_BISECTION_STEPS = 8
#: The state has caught up with the washout when the washout's sample is this
#: close to the state's continuation (L1): position (m or rad), rate (m/s or rad/s).
CATCH_UP_POSITION = 1e-6
CATCH_UP_RATE = 1e-4
#: The same for an angle (rad, rad/s): the rotation's acceleration (from the
#: input's slope) and the rate-limited tilt are not quite (L1)'s continuation,
#: so a state off the washout keeps a residue under the pull-back (about 1e-5
#: rad and 2e-4 rad/s on a turbulence log, which then never caught up:
#: cueing_limiter.md, L1); a catch-up step of 1e-3 rad/s is far below what a
#: rider feels.
CATCH_UP_ANGLE = 1e-5
CATCH_UP_ANGLE_RATE = 1e-3
#: How much further than the braking's stop point (L3) the limits must hold,
#: along its way, in the fastest coordinate (m or rad).
STOP_DISTANCE = 1e-4
#: The braking's interior poses solved when it is long (L3): at most this far
#: apart (m or rad), at most this many (a longer braking is refused: with the
#: default braking, 2 m/s^2 or rad/s^2, rates up to about 1.1 m/s or rad/s).
INTERIOR_STEP = 0.025
INTERIOR_POINTS = 12
#: While the limiter passes the washout's samples on, an angle's sample is
#: passed on this close to the continuation (rad, rad/s): the design's tilt rate
#: limit steps the tilt's rate (by up to 0.31 rad/s in cueing.vehicles' logs), and
#: the limiter adds nothing to a washout that fits (translations: as above).
TRACK_ANGLE = 1e-3
TRACK_ANGLE_RATE = 0.5
#: Periods of motion beyond the braking's stop point that must be within the
#: limits too (L3): the margin of the limits that have none of their own
#: (unreachable poses).
STOP_MARGIN = 2

#: The washout's free response is looked at these fractions of ``ahead.horizon``
#: ahead (L7).
AHEAD_FRACTIONS = (0.25, 0.5, 1.0)

#: The actuators' kinds of limit (:class:`~..core.machine.LimitUsage` names);
#: any other kind a machine reports is a joint's (``joint_angle``).
ACTUATOR_LIMITS = ('stroke', 'speed', 'force')

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


def _floats(value: Any) -> list[float]:
    """A sample's numbers as a list of floats (the hot path works on them:
    for six numbers Python's floats are quicker than numpy's ufuncs).
    """
    if type(value) is np.ndarray:
        return value.astype(float, copy=False).ravel().tolist()
    return [float(v) for v in value]


class InverseDynamicsLimiter:
    """``limiter: inverse_dynamics`` (module docstring; cueing_limiter.md).
    The state (:attr:`q`, :attr:`qd`, :attr:`qdd`) is the last sample published.
    """

    def __init__(self, model: Any, settings: Any, rate: float) -> None:
        self.machine = machine_of(model)
        self.model = model
        self.dt = 1.0 / float(rate)
        self._c, self._h = self.dt * self.dt / 6.0, 0.5 * self.dt      # _advance's
        self.stop_margin = STOP_MARGIN * self.dt
        if self.machine.tightened is None:
            raise ValueError(f'cueing.limiter inverse_dynamics: the machine '
                             f'{self.machine.name!r} gives no margins of its limits '
                             '(Machine.tightened); use limiter none')
        try:
            self.tight = self.machine.tightened(model, float(settings['margin.stroke']),
                                                float(settings['margin.fraction']))
        except ValueError as exc:
            raise ValueError(f'cueing.margin: {exc}') from None
        linear = [unit == 'm' for unit in self.machine.units]
        braking = [float(v) for v in settings['braking']]
        recovery = [float(v) for v in settings['recovery.acceleration']]
        # per coordinate: 1 / braking deceleration, largest pull-back acceleration
        self.braking = [braking[0] if lin else braking[1] for lin in linear]
        self.inverse_braking = [1.0 / b for b in self.braking]
        self.recovery = [recovery[0] if lin else recovery[1] for lin in linear]
        omega = float(settings['recovery.omega'])
        self.kp, self.kd = omega * omega, 2.0 * omega
        # (L1) the catch-up gate, per coordinate: caught up, and passing the washout on
        self.catch_up = ([CATCH_UP_POSITION if lin else CATCH_UP_ANGLE for lin in linear],
                         [CATCH_UP_RATE if lin else CATCH_UP_ANGLE_RATE for lin in linear])
        self.track = ([CATCH_UP_POSITION if lin else TRACK_ANGLE for lin in linear],
                      [CATCH_UP_RATE if lin else TRACK_ANGLE_RATE for lin in linear])
        self.gain_down = float(settings['gain.down']) * self.dt
        self.gain_up = float(settings['gain.up']) * self.dt
        self.gain_min = float(settings['gain.minimum'])
        self._solve = self.machine.solve
        # (L4) the pull-back's reach: each coordinate's range at rest from home
        ranges = [(-self._axis_range(i, -1.0), self._axis_range(i, 1.0))
                  for i in range(self.machine.dof)]
        self.low, self.high = [r[0] for r in ranges], [r[1] for r in ranges]
        # (L7) the look-ahead: the limit that ends each range, the horizons
        rest = [0.0] * self.machine.dof
        self.range_limit = []
        for i in range(self.machine.dof):
            ends = []
            for end, sign in ((self.low[i], -1.0), (self.high[i], 1.0)):
                q = list(rest)
                q[i] = end + sign * 1e-3
                ends.append(self._limit_name(self._solve(self.tight, q, rest, rest)))
            self.range_limit.append(ends)
        self._ranges = list(zip(self.low, self.high, self.range_limit))    # _look_ahead's
        self.gain_ahead = float(settings['gain.ahead']) * self.dt
        self.ahead_min = max(self.gain_min, float(settings['ahead.minimum']))
        horizon = float(settings['ahead.horizon'])
        #: how far ahead (s) the planner gives the washout's free response (empty: none)
        self.horizons: tuple[float, ...] = (
            tuple(f * horizon for f in AHEAD_FRACTIONS) if self.gain_ahead > 0.0 else ())
        self.reset()

    def _axis_range(self, i: int, sign: float, largest: float = 4.0) -> float:
        """How far coordinate ``i`` goes from home towards ``sign`` at rest,
        the others at home, within the tightened limits (bisection to 1e-4 of
        ``largest``, m or rad, out from home in steps of 1 %): where the
        pull-back aims for a washout beyond it.
        """
        rest = [0.0] * self.machine.dof

        def fits(x: float) -> bool:
            q = list(rest)
            q[i] = sign * x
            return self._solve(self.tight, q, rest, rest).status is Status.OK

        step = 0.01 * largest       # out from home first: the range may have islands
        low = 0.0
        while low + step <= largest and fits(low + step):
            low += step
        high = min(low + step, largest)
        while high - low > 1e-5 * largest:
            mid = 0.5 * (low + high)
            low, high = (mid, high) if fits(mid) else (low, mid)
        return low

    def reset(self) -> None:
        """At rest at home, caught up (the washout starts there)."""
        n = self.machine.dof
        self._q, self._qd, self._qdd = [0.0] * n, [0.0] * n, [0.0] * n
        self.gain, self._gain_limit = 1.0, ''
        # (L7) the gain ahead of a motion the ranges cannot take, the limit that ends
        # the range, and the gain the last cycle used (its rate scales the washout's rate)
        self.ahead_gain, self._ahead_limit, self._ahead_target = 1.0, '', 1.0
        self._used = self._ahead_used = 1.0
        self._tracking = True       # the last sample published was the washout's own

    @property
    def q(self) -> np.ndarray:
        return np.array(self._q)

    @property
    def qd(self) -> np.ndarray:
        return np.array(self._qd)

    @property
    def qdd(self) -> np.ndarray:
        return np.array(self._qdd)

    # -- checks ------------------------------------------------------------

    def _advance(self, q: list, qd: list, a0: list, a1: list) -> tuple[list, list]:
        """:func:`advance` on floats, the same operations in the same order."""
        dt = self.dt
        c, h = dt * dt / 6.0, 0.5 * dt
        return ([x + dt * v + c * (2.0 * u + w) for x, v, u, w in zip(q, qd, a0, a1)],
                [v + h * (u + w) for v, u, w in zip(qd, a0, a1)])

    def _braking(self, qd: list) -> tuple[float, list]:
        """(L3) The time ``tau`` a braking from rate ``qd`` takes (each
        coordinate at most its braking deceleration, all stopping together,
        a straight line in pose space) and its deceleration ``-qd / tau``
        (``tau`` at least one period: at rest, no deceleration).
        """
        tau = max([abs(v) * k for v, k in zip(qd, self.inverse_braking)])
        scale = -1.0 / (tau if tau > self.dt else self.dt)
        return tau, [v * scale for v in qd]

    def _refused(self, q: list, qd: list, a: list) -> Any:
        """(L2) None when the sample (q, qd, a) and the braking from it are within
        the tightened limits, else what refuses it: the solution that is not
        ok, or a limit's name (:meth:`_refusal` names it). Three solves: the
        sample's, and both ends of the braking from it (L3): its first step
        ramps from ``a`` to the braking's deceleration (:func:`advance`), to
        (q2, qd2), its fastest point; then it decelerates constantly to rest
        at ``q2 + tau2 qd2 / 2``, checked :data:`STOP_MARGIN` periods of the
        sample's rate further, with the rate qd2 (the worst of the way); a long
        braking's interior poses too (:data:`INTERIOR_STEP`; too long: refused).
        """
        tight, solve, ok = self.tight, self._solve, Status.OK
        sol = solve(tight, q, qd, a)
        if sol.status is not ok:
            return sol
        # _braking and _advance written out (the same operations in the same order)
        dt, inverse = self.dt, self.inverse_braking
        tau = max([abs(v) * k for v, k in zip(qd, inverse)])
        scale = -1.0 / (tau if tau > dt else dt)
        brake = [v * scale for v in qd]
        c, h = self._c, self._h
        q2 = [x + dt * v + c * (2.0 * u + w) for x, v, u, w in zip(q, qd, a, brake)]
        qd2 = [v + h * (u + w) for v, u, w in zip(qd, a, brake)]
        sol = solve(tight, q2, qd2, brake)
        if sol.status is not ok:
            return sol
        speeds = [abs(v) for v in qd2]
        tau = max([v * k for v, k in zip(speeds, inverse)])
        scale = -1.0 / (tau if tau > dt else dt)
        brake = [v * scale for v in qd2]
        half, extra = 0.5 * tau, self.stop_margin
        fastest = max(speeds)
        # STOP_DISTANCE further along the way: however slow, it never creeps onto
        # the boundary of a limit that has no margin of its own (unreachable)
        step = STOP_DISTANCE / fastest if fastest > 0.0 else 0.0
        ahead = half + step
        stop = [x + ahead * v + extra * w for x, v, w in zip(q2, qd2, qd)]
        sol = solve(tight, stop, qd2, brake)
        if sol.status is not ok:
            return sol
        # a long braking (fast): points between its ends too, at most INTERIOR_STEP
        # (m or rad) apart; one longer than INTERIOR_POINTS such steps is refused
        # (the limiter's own speed limit: the workspace need not be convex)
        length = max([abs(x - y) for x, y in zip(stop, q2)])
        if length > INTERIOR_STEP:
            m = int(length / INTERIOR_STEP)
            if m > INTERIOR_POINTS:
                return 'speed'
            for j in range(1, m + 1):
                f = j / (m + 1.0)
                sol = solve(tight, [x + f * (y - x) for x, y in zip(q2, stop)], qd2, brake)
                if sol.status is not ok:
                    return sol
        return None

    def _refusal(self, refused: Any) -> str:
        """The name of the limit a refusal of :meth:`_refused` stands for (a
        solution's found only for the refusal behind the published sample).
        """
        return refused if type(refused) is str else self._limit_name(refused)

    def _limit_name(self, sol: Any) -> str:
        """Which limit a solve on the tightened model exceeds."""
        status = sol.status
        if status is Status.NEAR_SINGULAR:
            return 'condition'
        if status is Status.UNREACHABLE:
            return 'unreachable'
        if status is not Status.LIMIT:
            return 'overflow'
        # the machine's limit rule (the status' own): the most used limit's kind
        usage = self.machine.limit_usage(self.tight, sol)
        kind = usage.names[int(np.argmax(usage.usage))].split()[0]
        return kind if kind in ACTUATOR_LIMITS else 'joint_angle'

    # -- the cycle -----------------------------------------------------------

    def _publish(self, q: list, qd: list, qdd: list, lam: float, limit: str) -> tuple:
        """Publish the sample (the new state); (L6) the gain's update: lowered
        in a cycle that gives up cue, raised back towards 1 in one that does not.
        """
        self._q, self._qd, self._qdd = q, qd, qdd
        self._tracking = False
        gain = self.gain
        given_up = 1.0 - lam * self._used
        if lam < 1.0:
            self.gain = max(self.gain_min, gain - self.gain_down)
            self._gain_limit = limit
        elif gain < 1.0:
            self.gain = min(1.0, gain + self.gain_up)
            limit = self._gain_limit
        elif self._used < 1.0:
            limit = self._ahead_limit
        return q, qd, qdd, given_up, limit

    def _look_ahead(self, q: list, ahead: Any) -> None:
        """(L7) Move :attr:`ahead_gain` towards the largest gain (at most 1) at
        which the washout's sample ``q`` and its free response ``ahead`` (poses)
        stay within each coordinate's range (:meth:`_axis_range`): down by
        ``gain.ahead`` per second, up by ``gain.up``. ``ahead`` None: towards
        the last target (the planner gives the free response every few cycles).
        """
        if ahead is not None:
            target, limit = 1.0, ''
            ranges = self._ranges
            for pose in [q] + [_floats(p) for p in ahead]:
                for x, (lo, hi, ends) in zip(pose, ranges):
                    if x > hi and hi < target * x:
                        target, limit = hi / x, ends[1]
                    elif x < lo and lo > target * x:
                        target, limit = lo / x, ends[0]
            self._ahead_target = target
            if limit:
                self._ahead_limit = limit
        target, gain = self._ahead_target, self.ahead_gain
        if target < gain:
            self.ahead_gain = max(target, gain - self.gain_ahead, self.ahead_min)
        elif gain < 1.0:
            self.ahead_gain = min(target, gain + self.gain_up)

    def step(self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray,
             ahead: Any = None) -> Limited:
        """The sample to publish for the washout's sample (q, qd, qdd);
        ``ahead``: the washout's free response at :attr:`horizons` (poses, L7),
        or None.
        """
        q, qd, qdd, given_up, limit = self.step_lists(_floats(q), _floats(qd), _floats(qdd),
                                                      ahead)
        return Limited(np.array(q), np.array(qd), np.array(qdd), given_up, limit)

    def fits(self, q: list, qd: list, qdd: list) -> bool:
        """Whether the washout's own sample (lists of floats) is accepted (L2)
        when the state has caught up with it (L1): a function of the sample
        alone, so that a whole log's can be judged ahead, in another process
        (:func:`.planner.run`).
        """
        return self._refused(q, qd, qdd) is None

    def fits_rows(self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> np.ndarray:
        """:meth:`fits` of each row of q, qd, qdd (N, dof), bit for bit: the
        sample's solve and both ends of its braking (L2, L3) as three
        :func:`solve_batch` calls on the rows still accepted, the same
        operations in the same order as :meth:`_refused` on numpy's columns;
        a row whose braking is long enough for interior poses goes to
        :meth:`_refused` itself. A second implementation of the acceptance,
        kept for ``flight-sim-dynamics cue`` (docs/design/implementations.md).
        """
        tight, solve, ok = self.tight, self.machine.solve_batch, Status.OK
        q, qd, a = (np.asarray(v, dtype=float) for v in (q, qd, qdd))
        accepted = np.zeros(len(q), dtype=bool)
        rows = np.flatnonzero(solve(tight, q, qd, a).status == ok) if len(q) else []
        if len(rows) == 0:
            return accepted
        q, qd, a = q[rows], qd[rows], a[rows]
        dt, inverse = self.dt, np.array(self.inverse_braking)
        c, h = self._c, self._h
        tau = np.max(np.abs(qd) * inverse, axis=1)
        brake = qd * (-1.0 / np.where(tau > dt, tau, dt))[:, None]
        q2 = q + dt * qd + c * (2.0 * a + brake)
        qd2 = qd + h * (a + brake)
        keep = np.flatnonzero(solve(tight, q2, qd2, brake).status == ok)
        if keep.size == 0:
            return accepted
        rows, q, qd, a, q2, qd2 = rows[keep], q[keep], qd[keep], a[keep], q2[keep], qd2[keep]
        speeds = np.abs(qd2)
        tau = np.max(speeds * inverse, axis=1)
        brake = qd2 * (-1.0 / np.where(tau > dt, tau, dt))[:, None]
        fastest = np.max(speeds, axis=1)
        with np.errstate(divide='ignore'):
            step = np.where(fastest > 0.0, STOP_DISTANCE / fastest, 0.0)
        ahead = 0.5 * tau + step
        stop = q2 + ahead[:, None] * qd2 + self.stop_margin * qd
        keep = solve(tight, stop, qd2, brake).status == ok
        long = np.max(np.abs(stop - q2), axis=1) > INTERIOR_STEP
        accepted[rows[keep & ~long]] = True
        for i in np.flatnonzero(keep & long):
            accepted[rows[i]] = self._refused(q[i].tolist(), qd[i].tolist(),
                                              a[i].tolist()) is None
        return accepted

    def fitting_gain(self, q: list, qd: list, qdd: list) -> tuple[float, str]:
        """(L8) The largest gain k in [0, 1] (:data:`FIT_BISECTION_STEPS` of
        bisection) at which the washout's sample scaled, k (q, qd, qdd), is
        accepted (L2) once caught up (:meth:`fits`), and the limit that refuses
        the sample above it ('' when k = 1).
        """
        refused = self._refused(q, qd, qdd) if _finite(q + qd + qdd) else 'overflow'
        if refused is None:
            return 1.0, ''
        low, high = 0.0, 1.0
        for _ in range(FIT_BISECTION_STEPS):
            k = 0.5 * (low + high)
            sq, sqd, sqdd = [k * x for x in q], [k * x for x in qd], [k * x for x in qdd]
            r = self._refused(sq, sqd, sqdd) if _finite(sq + sqd + sqdd) else 'overflow'
            if r is None:
                low = k
            else:
                high, refused = k, r
        return low, self._refusal(refused)

    def step_lists(self, q: list, qd: list, qdd: list, ahead: Any = None,
                   fits: bool | None = None) -> tuple:
        """:meth:`step` on lists of floats (the planner's), without the arrays:
        (q, qd, qdd, given_up, limit), the lists the limiter's state (not to be
        changed). ``fits``: :meth:`fits` of the sample, if judged ahead (None:
        judged here when needed).
        """
        x_q, x_qd, x_a = self._q, self._qd, self._qdd
        if not (math.isfinite(sum(q)) and math.isfinite(sum(qd)) and math.isfinite(sum(qdd))):
            if not all(map(math.isfinite, q + qd + qdd)):
                # (L5) nothing to follow: brake to rest and hold there
                brake = self._braking(x_qd)[1]
                return self._publish(*self._advance(x_q, x_qd, x_a, brake), brake, 0.0, INPUT)
        if self.horizons and (ahead is not None or self._ahead_target < 1.0
                              or self.ahead_gain < 1.0):
            self._look_ahead(q, ahead)
        gain = min(self.gain, self.ahead_gain)
        # the look-ahead gain's rate, where it is the one used (it changes slowly;
        # the adaptive gain's steps are left to the pull-back):
        # (k w)' = k w' + k' w, (k w)'' ~ k w'' + 2 k' w'
        rate = ((gain - self._used) / self.dt
                if gain == self.ahead_gain and self._used == self._ahead_used
                else 0.0)
        self._used, self._ahead_used = gain, self.ahead_gain
        if gain == 1.0:
            # (L1) the state's continuation with the washout's acceleration,
            # against the washout's sample
            pq, pqd = self._advance(x_q, x_qd, x_a, qdd)
            tol_q, tol_qd = self.track if self._tracking else self.catch_up
            if all([abs(x - y) <= t for x, y, t in zip(pq, q, tol_q)]) and \
                    all([abs(x - y) <= t for x, y, t in zip(pqd, qd, tol_qd)]):
                # caught up: the washout's own sample, if it fits (invisible, bit for bit)
                if (self._refused(q, qd, qdd) is None) if fits is None else fits:
                    self._tracking = True
                    self._q, self._qd, self._qdd = q, qd, qdd
                    return q, qd, qdd, 0.0, ''
        else:
            # (L6) the washout times the gain
            q, qd, qdd = ([gain * v for v in q],
                          [gain * v + rate * x for v, x in zip(qd, q)],
                          [gain * a + 2.0 * rate * v for a, v in zip(qdd, qd)])
            pq, pqd = self._advance(x_q, x_qd, x_a, qdd)
        # (L4) the washout's acceleration plus a bounded, critically damped
        # pull-back towards the washout's sample, or, for a coordinate beyond its
        # range (:meth:`_axis_range`), towards the end of the range, at rest
        kp, kd = self.kp, self.kd
        a_w = []
        for a, x, v, p, pv, lo, hi, r, rb in zip(qdd, q, qd, pq, pqd, self.low, self.high,
                                                 self.recovery, self.braking):
            if x > hi:
                x, v = hi, 0.0
            elif x < lo:
                x, v = lo, 0.0
            # the position's pull gently (a false cue), the rate's difference at up to
            # the braking deceleration (a rate left over from limiting drifts far);
            # min(r, max(-r, e)) written out, the same comparisons
            e = -kp * (p - x)
            e = e if e > -r else -r
            d = -kd * (pv - v)
            d = d if d > -rb else -rb
            a_w.append(a + (e if e < r else r) + (d if d < rb else rb))
        c_q, c_qd = self._advance(x_q, x_qd, x_a, a_w)
        limit = self._refused(c_q, c_qd, a_w) if _finite(c_q) else 'overflow'
        if limit is None:
            return self._publish(c_q, c_qd, a_w, 1.0, '')
        # (L2)-(L3) blend towards braking: the largest lam that is accepted
        brake = self._braking(x_qd)[1]
        low, high = 0.0, 1.0
        for _ in range(BISECTION_STEPS):
            lam = 0.5 * (low + high)
            a = [(1.0 - lam) * b + lam * w for b, w in zip(brake, a_w)]
            c_q, c_qd = self._advance(x_q, x_qd, x_a, a)
            refused = self._refused(c_q, c_qd, a) if _finite(c_q) else 'overflow'
            if refused is not None:
                high, limit = lam, refused
            else:
                low = lam
        a = brake if low == 0.0 else [(1.0 - low) * b + low * w for b, w in zip(brake, a_w)]
        return self._publish(*self._advance(x_q, x_qd, x_a, a), a, low,
                             self._refusal(limit))


def _finite(values: list) -> bool:
    return math.isfinite(sum(values)) or all(map(math.isfinite, values))


def make_limiter(model: Any, params: Any) -> PassThrough | InverseDynamicsLimiter:
    """The limiter ``params.limiter`` names for ``model``."""
    if params.limiter == 'none':
        return PassThrough()
    if params.limiter != 'inverse_dynamics':
        raise ValueError(f"unknown limiter {params.limiter!r} (inverse_dynamics or none)")
    return InverseDynamicsLimiter(model, params.limiter_settings, params.rate)
