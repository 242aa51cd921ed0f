"""The classical washout (design: /work/shared/design/cueing.md, "The classical
washout"; Reid and Nahon's structure, small-angle form), one sample at a time.

Per axis, ``Δf = f − f(t0)``, ``Δω = ω − ω(t0)`` (the first sample is the rest):

1. translation (x, y, z): ``p̈ = HP_t(s) k_t Δf``,
   ``HP_t = s²/(s² + 2ζ_t ω_t s + ω_t²) · s/(s + ω_b)``;
2. tilt coordination: ``f_lp = ω²/(s² + 2ζωs + ω²) k_tilt Δf`` (x -> pitch,
   y -> roll), ``pitch = −asin(f_lp,x / g)``, ``roll = +asin(f_lp,y / g)``,
   rate-limited sample by sample to ``tilt.rate_limit``;
3. rotation: ``β = HP_r(s)/s · k_r Δω``, ``HP_r = s²/(s² + 2ζ_r ω_r s + ω_r²)``;
4. pose: surge, sway, heave = p; roll = β_x + roll_tilt, pitch = β_y +
   pitch_tilt, yaw = β_z (``R = Rz(yaw) Ry(pitch) Rx(roll)``, Euler-angle rates).

Discretization: the filters are one block-diagonal continuous state-space model
(19 states) driven by the input as it is between samples, a straight line (the
design interpolates the input linearly): the model augmented with the input as
a state and its slope as a held input, discretized by zero-order hold
(``scipy.signal.cont2discrete``'s method, :func:`_zoh`) is exact for that input; so each step is one
matrix product, and rates and accelerations come from the states (the
rotational acceleration, of relative degree -1, from the states and the slope).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.linalg import expm

from ..config.cueing import G, CueingParams

#: The six channels, in the order of :class:`Desired`'s vectors (REP-103 setpoint components).
CHANNELS = ('surge', 'sway', 'heave', 'roll', 'pitch', 'yaw')

# state layout: translation (z, p, v) per axis; tilt (y, y') from f_x then f_y;
# rotation (a, a') per axis (β = a'); then the input Δf, Δω (6) as states
_T = [(3 * i, 3 * i + 1, 3 * i + 2) for i in range(3)]
_L = [(9 + 2 * j, 10 + 2 * j) for j in range(2)]
_R = [(13 + 2 * i, 14 + 2 * i) for i in range(3)]
_N = 19                 # filter states
_U = 6                  # inputs
_X = _N + _U            # augmented states
# output rows: p, p', p'' (3 each), β, β', β'' (3 each), y, y', y'' (2 each)
_P, _PD, _PDD, _B, _BD, _BDD, _Y, _YD, _YDD = 0, 3, 6, 9, 12, 15, 18, 20, 22
_OUT = 24


@dataclass(frozen=True)
class Desired:
    """One sample of the washout: pose ``q``, Euler-angle rates ``qd`` and
    accelerations ``qdd``, each a (6,) array in :data:`CHANNELS` order.
    """

    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray


def continuous_model(params: CueingParams) -> tuple[np.ndarray, np.ndarray]:
    """A (19, 19), B (19, 6) of the filters (module docstring), input Δf, Δω unscaled."""
    A, B = np.zeros((_N, _N)), np.zeros((_N, _U))
    for i, (z, p, v) in enumerate(_T):
        k, w = params.translation_gain[i], params.translation_omega[i]
        zeta, wb = params.translation_zeta[i], params.translation_omega_b[i]
        # z' = -wb z + k u (the return term's state); p'' = -w² p - 2ζw p' + (k u - wb z)
        A[z, z], B[z, i] = -wb, k
        A[p, v] = 1.0
        A[v, p], A[v, v], A[v, z], B[v, i] = -w * w, -2.0 * zeta * w, -wb, k
    for j, (y, yd) in enumerate(_L):
        k, w, zeta = params.tilt_gain[j], params.tilt_omega[j], params.tilt_zeta[j]
        A[y, yd] = 1.0
        A[yd, y], A[yd, yd], B[yd, j] = -w * w, -2.0 * zeta * w, w * w * k
    for i, (a, ad) in enumerate(_R):
        k, w, zeta = params.rotation_gain[i], params.rotation_omega[i], params.rotation_zeta[i]
        A[a, ad] = 1.0
        A[ad, a], A[ad, ad], B[ad, 3 + i] = -w * w, -2.0 * zeta * w, k
    return A, B


def _zoh(A: np.ndarray, B: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """The zero-order-hold discretization of x' = A x + B u over ``dt``,
    ``scipy.signal.cont2discrete``'s ``zoh`` (the same operations: one matrix
    exponential of ``[[A, B], [0, 0]] dt``) without importing scipy.signal
    (over a second at start-up).
    """
    n, m = A.shape[0], B.shape[1]
    em = np.vstack((np.hstack((A, B)), np.hstack((np.zeros((m, n)), np.zeros((m, m))))))
    ms = expm(dt * em)[:n, :]
    return ms[:, :n], ms[:, n:]


def step_matrix(params: CueingParams) -> np.ndarray:
    """M (19 + 24, 19 + 6 + 6): ``[x[n]; out[n]] = M [x[n-1]; u[n-1]; u[n]]``,
    x the filter states, u the input deviation (Δf, Δω), ``out`` the linear
    outputs (p, p', p'', β, β', β'', y, y', y''), the input a straight line
    between samples (module docstring).
    """
    A, B = continuous_model(params)
    rate = params.rate
    Aa = np.zeros((_X, _X))          # the states and the input; the input's slope held
    Aa[:_N, :_N], Aa[:_N, _N:] = A, B
    Ba = np.zeros((_X, _U))
    Ba[_N:, :] = np.eye(_U)
    Phi, Gam = _zoh(Aa, Ba, 1.0 / rate)
    # outputs of the new state X and the slope s: x' = A x + B u, x'' = A x' + B s
    Cx, Cs = np.zeros((_OUT, _X)), np.zeros((_OUT, _U))
    xdot = np.hstack([A, B])                          # x' as a function of X
    xddot = A @ xdot                                  # x'' without the slope
    for i, (_, p, v) in enumerate(_T):
        Cx[_P + i, p] = 1.0
        Cx[_PD + i, v] = 1.0
        Cx[_PDD + i] = xdot[v]
    for i, (_, ad) in enumerate(_R):
        Cx[_B + i, ad] = 1.0
        Cx[_BD + i] = xdot[ad]
        Cx[_BDD + i] = xddot[ad]
        Cs[_BDD + i] = B[ad]
    for j, (y, yd) in enumerate(_L):
        Cx[_Y + j, y] = 1.0
        Cx[_YD + j, yd] = 1.0
        Cx[_YDD + j] = xdot[yd]
    # [X[n]; out[n]] = S [X[n-1]; s], s = rate (u[n] - u[n-1]): in x[n-1], u[n-1], u[n]
    S = np.vstack([np.hstack([Phi, Gam]), np.hstack([Cx @ Phi, Cx @ Gam + Cs])])
    M = np.zeros((_N + _OUT, _N + 2 * _U))
    rows = list(range(_N)) + list(range(_X, _X + _OUT))       # x[n] and out[n]
    M[:, :_N] = S[rows, :_N]
    M[:, _N:_X] = S[rows, _N:_X] - rate * S[rows, _X:]
    M[:, _X:] = rate * S[rows, _X:]
    return M


def forecast_matrix(params: CueingParams, horizons: tuple[float, ...]) -> np.ndarray:
    """F (8 h, 19 + 6): the filters' free response with the input held, ``h``
    horizons ahead: rows p (3), β (3), y (2) per horizon (in that order) at
    ``t + horizons[j]`` from ``[x[n]; u[n]]``. With the input held the augmented
    model (the filters and the input as states) is autonomous, so each horizon
    is one matrix exponential: ``X(t + h) = exp(Aa h) X(t)``.
    """
    A, B = continuous_model(params)
    Aa = np.zeros((_X, _X))
    Aa[:_N, :_N], Aa[:_N, _N:] = A, B
    rows = [p for _, p, _ in _T] + [ad for _, ad in _R] + [y for y, _ in _L]
    return np.vstack([expm(Aa * h)[rows] for h in horizons])


def _tilt(y: float, yd: float, ydd: float, sign: float) -> tuple[float, float, float]:
    """``sign·asin(y/g)`` and its first two time derivatives (0 where clipped)."""
    s = y / G
    if s >= 1.0 or s <= -1.0:
        return sign * math.copysign(math.pi / 2, s), 0.0, 0.0
    c2 = 1.0 - s * s
    c = math.sqrt(c2)
    sd, sdd = yd / G, ydd / G
    return (sign * math.asin(s), sign * sd / c,
            sign * (sdd / c + s * sd * sd / (c2 * c)))


class Washout:
    """The washout of ``params`` at its output rate (``dt = 1 / params.rate``):
    :meth:`step` takes the vehicle's specific force ``f`` (3,) m/s² and angular
    velocity ``omega`` (3,) rad/s (REP-103 body axes) at one output time and
    returns the platform's :class:`Desired`. The first sample after
    construction or :meth:`reset` is the rest reference.

    :meth:`load` and :meth:`advance` are :meth:`step` in two halves, without
    allocation (the planner's loop): ``load`` takes the input and says whether
    it is finite, :attr:`input` may then be changed, ``advance`` returns the
    18 numbers q, qd, qdd (6 each) as a list.
    """

    def __init__(self, params: CueingParams) -> None:
        self.params = params
        self.dt = 1.0 / params.rate
        self._rate = float(params.rate)
        self._M = step_matrix(params)
        self._dot = self._M.dot        # np.dot's product, a little less to call
        self._rmax = params.tilt_rate_limit * self.dt      # rad per sample
        # [x (19), u[n-1] (6), u[n] (6)]: the product's operand, updated in place
        self._vec = np.zeros(_N + 2 * _U)
        self._res = np.zeros(_N + _OUT)
        self._x, self._prev, self._now = self._vec[:_N], self._vec[_N:_X], self._vec[_X:]
        self._res_x, self._res_out = self._res[:_N], self._res[_N:]
        #: the vehicle's input of the current sample (f, omega), as loaded
        self.input = np.zeros(_U)
        self._ref = np.zeros(_U)
        self._zero = np.zeros(_U)
        self.reset()

    def reset(self) -> None:
        """At rest, at home; the next sample is the new reference."""
        self._vec[:] = 0.0
        self._started = False
        self._pitch = 0.0
        self._roll = 0.0
        self.tilt_limited = (False, False)   # (pitch, roll) rate-limited at the last step

    def load(self, f: np.ndarray, omega: np.ndarray) -> bool:
        """Take one sample's input into :attr:`input`; whether it is finite."""
        u = self.input
        u[:3] = f
        u[3:] = omega
        check = u.dot(self._zero)        # 0 unless an element is NaN or infinite
        return check == 0.0

    def advance(self) -> list[float]:
        """One output sample of :attr:`input` (finite): q, qd, qdd, 6 numbers each."""
        if not self._started:
            self._ref[:] = self.input
            self._started = True
        np.subtract(self.input, self._ref, out=self._now)
        self._dot(self._vec, out=self._res)
        self._x[:] = self._res_x
        self._prev[:] = self._now
        o = self._res_out.tolist()
        pitch_w, pitch_d, pitch_dd = _tilt(o[_Y], o[_YD], o[_YDD], -1.0)
        roll_w, roll_d, roll_dd = _tilt(o[_Y + 1], o[_YD + 1], o[_YDD + 1], 1.0)
        # the rate limit (design, tilt coordination): when it holds, the tilt moves at ±r
        rmax, rate = self._rmax, self._rate
        step_p = pitch_w - self._pitch
        limited_p = step_p > rmax or step_p < -rmax
        if limited_p:
            step_p = rmax if step_p > 0 else -rmax
            pitch_d, pitch_dd = step_p * rate, 0.0
        step_r = roll_w - self._roll
        limited_r = step_r > rmax or step_r < -rmax
        if limited_r:
            step_r = rmax if step_r > 0 else -rmax
            roll_d, roll_dd = step_r * rate, 0.0
        self._pitch += step_p
        self._roll += step_r
        self.tilt_limited = (limited_p, limited_r)
        return [o[0], o[1], o[2], o[_B] + self._roll, o[_B + 1] + self._pitch, o[_B + 2],
                o[3], o[4], o[5], o[_BD] + roll_d, o[_BD + 1] + pitch_d, o[_BD + 2],
                o[6], o[7], o[8], o[_BDD] + roll_dd, o[_BDD + 1] + pitch_dd, o[_BDD + 2]]

    def ahead(self, forecast: np.ndarray, horizons: tuple[float, ...]) -> list[list[float]]:
        """The poses (six channels each) the washout would reach ``horizons``
        ahead if the input stayed as it is now (after :meth:`advance`):
        ``forecast`` is :func:`forecast_matrix` for these horizons; the tilt
        is its rate limit's reach from the current tilt.
        """
        o = np.dot(forecast, self._vec[:_X]).tolist()
        rate_limit = self.params.tilt_rate_limit
        poses = []
        for j, h in enumerate(horizons):
            p0, p1, p2, b0, b1, b2, yx, yy = o[8 * j:8 * j + 8]
            reach = rate_limit * h
            pitch = -math.asin(min(1.0, max(-1.0, yx / G)))
            roll = math.asin(min(1.0, max(-1.0, yy / G)))
            pitch = min(self._pitch + reach, max(self._pitch - reach, pitch))
            roll = min(self._roll + reach, max(self._roll - reach, roll))
            poses.append([p0, p1, p2, b0 + roll, b1 + pitch, b2])
        return poses

    def step(self, f: np.ndarray, omega: np.ndarray) -> Desired:
        """One output sample (module docstring); ValueError for a non-finite input."""
        if not self.load(f, omega):
            raise ValueError(f'non-finite input: f = {list(f)}, omega = {list(omega)}')
        out = np.array(self.advance()).reshape(3, 6)
        return Desired(out[0], out[1], out[2])
