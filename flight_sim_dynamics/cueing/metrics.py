"""The cue metrics of a run (design: /work/shared/design/cueing.md, "Cue
metrics"): what the occupant feels against what the vehicle did, what the
actuators do, what the limiter gave up. numpy, no I/O.

At the head ``h`` (platform frame): ``f_P = Rᵀ (p̈_h − g_N)``, ``p_h = p + R h``,
``g_N = (0, 0, −g)``; ``ω_P = Rᵀ ω`` (body angular velocity), ``ω = E(q)
q̇_angles`` (S2), the angular acceleration ``E q̈ + Ė q̇`` (S3)
(:mod:`flight_sim_dynamics.core.euler`). Per axis against the vehicle's ``f_V``,
``ω_V``: RMSE, Pearson correlation, delay (the lag of the cross-correlation
peak), false cues (the felt deviation from rest and the vehicle's of opposite
signs and apart by more than :data:`FORCE_THRESHOLDS` / :data:`RATE_THRESHOLD`).

A machine's own motion beyond its coordinates (e.g. a pitch it makes by itself,
``Machine.parasitic``) is part of what the occupant feels: its angle
from the solution, relative to its value at home (the occupant's neutral),
its rates by differencing (it is not the planner's).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Mapping, Sequence

import numpy as np

from ..core.euler import euler_rate_matrix, euler_rate_matrix_derivative, rotation
from ..core.status import Status
from ..machines.api import machine_of, solve_batch
from ..config.cueing import G, CueingParams
from .planner import CueRun
from .washout import CHANNELS

#: False-cue thresholds of the design: m/s² on x, y, z; rad/s on the rates (3 deg/s).
FORCE_THRESHOLDS = (0.17, 0.17, 0.28)
RATE_THRESHOLD = math.radians(3.0)
#: Largest lag the delay estimate looks at, s.
MAX_LAG = 2.0
#: Samples solved at once (the memory of solve_batch's fields).
CHUNK = 1 << 16
#: Most (force, speed) points per leg kept for the figure.
POINTS = 20000
_REST_F = np.array([0.0, 0.0, G])
#: statuses whose solution is void (zeros): the machine's own motion there is unknown
_VOID = frozenset({Status.UNREACHABLE, Status.INVALID_INPUT})


@dataclass(frozen=True)
class AxisCues:
    """Felt against the vehicle's, per axis x, y, z (arrays (3,))."""

    rmse: np.ndarray
    correlation: np.ndarray      # NaN where either signal is constant
    delay: np.ndarray            # s, > 0: the felt cue lags the vehicle's
    false_cues: np.ndarray       # samples
    false_fraction: np.ndarray   # of all samples


@dataclass(frozen=True)
class LegUse:
    """Per leg (arrays (legs,)): what the actuators do over the run."""

    labels: tuple[str, ...]
    peak_force: np.ndarray       # N, max |f|
    rms_force: np.ndarray        # N
    peak_speed: np.ndarray       # m/s, max |dL/dt|
    peak_power: np.ndarray       # W, max |f dL/dt|
    stroke_min: np.ndarray       # m, lowest stroke reached
    stroke_max: np.ndarray       # m, highest stroke reached
    stroke_used: np.ndarray      # of the allowed range [stroke_min, stroke_max] limits
    limits: Any                  # the machine's ActuatorLimits
    statuses: Mapping[str, int]  # solver status -> samples
    force: np.ndarray            # (points, legs) N, samples for the figure
    speed: np.ndarray            # (points, legs) m/s, the same samples


@dataclass(frozen=True)
class CueMetrics:
    """The metrics of a run (:func:`cue_metrics`)."""

    samples: int
    duration: float                      # s
    felt_samples: int                    # samples whose felt motion is known (metrics of them)
    force: AxisCues                      # specific force at the head, m/s²
    rate: AxisCues                       # angular velocity, rad/s
    tilt_rate_excess: int                # samples: felt roll/pitch rate beyond the vehicle's
    #                                      by more than tilt.rate_limit
    tilt_rate_peak: float                # rad/s, the largest such difference
    legs: LegUse
    given_up_mean: float
    given_up_max: float
    given_up_fraction: float             # of samples with something given up
    limits: Mapping[str, int]            # the limit that made the limiter act -> samples
    given_up_rmse: np.ndarray            # (3,) m/s², felt specific force: output vs the
    #                                      washout's, in the machine's channels
    dropped: tuple[str, ...]             # channels the machine lacks: not cued
    felt_f: np.ndarray = field(repr=False)      # (N, 3) felt specific force
    felt_omega: np.ndarray = field(repr=False)  # (N, 3) felt angular velocity


def six(coordinates: Sequence[str], values: np.ndarray) -> np.ndarray:
    """(N, 6) in :data:`CHANNELS` order of (N, len(coordinates)) values; 0 elsewhere."""
    out = np.zeros((len(values), 6))
    for k, name in enumerate(coordinates):
        out[:, CHANNELS.index(name)] = values[:, k]
    return out


def felt(q: np.ndarray, qd: np.ndarray, qdd: np.ndarray, head: Sequence[float]
         ) -> tuple[np.ndarray, np.ndarray]:
    """Specific force ``f_P`` (N, 3) and angular velocity ``ω_P`` (N, 3) at the
    head ``h`` (platform frame), both in platform axes, of the platform's pose
    ``q`` (N, 6) (:data:`CHANNELS`, Euler-angle rates ``qd``, accelerations ``qdd``).
    """
    R = rotation(q)
    E = euler_rate_matrix(q)
    omega = np.einsum('nij,nj->ni', E, qd[:, 3:])
    eps = (np.einsum('nij,nj->ni', E, qdd[:, 3:])
           + np.einsum('nij,nj->ni', euler_rate_matrix_derivative(q, qd), qd[:, 3:]))
    r = np.einsum('nij,j->ni', R, np.asarray(head, dtype=float))
    acc = qdd[:, :3] + np.cross(eps, r) + np.cross(omega, np.cross(omega, r))
    acc[:, 2] += G                                     # p̈_h − g_N
    return np.einsum('nji,nj->ni', R, acc), np.einsum('nji,nj->ni', R, omega)


def delay(felt_signal: np.ndarray, vehicle: np.ndarray, dt: float,
          max_lag: float = MAX_LAG) -> float:
    """The lag (s) at which the cross-correlation of the two (mean removed)
    peaks, within ±``max_lag``; > 0: ``felt_signal`` lags. NaN for a constant signal.
    """
    a, b = felt_signal - felt_signal.mean(), vehicle - vehicle.mean()
    if not a.any() or not b.any():
        return math.nan
    n = len(a)
    size = 1 << int(2 * n - 1).bit_length()
    xc = np.fft.irfft(np.fft.rfft(a, size) * np.conj(np.fft.rfft(b, size)), size)
    lags = min(int(round(max_lag / dt)), n - 1)
    window = np.concatenate([xc[size - lags:], xc[:lags + 1]])   # lags -L .. L
    return (int(np.argmax(window)) - lags) * dt


def _pearson(a: np.ndarray, b: np.ndarray) -> float:
    a, b = a - a.mean(), b - b.mean()
    norm = math.sqrt(float(a @ a) * float(b @ b))
    return float(a @ b) / norm if norm > 0 else math.nan


def compare(felt_signal: np.ndarray, vehicle: np.ndarray, felt_rest: np.ndarray,
            vehicle_rest: np.ndarray, thresholds: Sequence[float], dt: float,
            max_lag: float = MAX_LAG) -> AxisCues:
    """:class:`AxisCues` of felt against vehicle (N, 3); the deviations from
    rest (``felt_rest``, ``vehicle_rest``, (3,)) decide the false cues.
    """
    n = len(vehicle)
    error = felt_signal - vehicle
    rmse = np.sqrt(np.mean(error * error, axis=0))
    corr = np.array([_pearson(felt_signal[:, i], vehicle[:, i]) for i in range(3)])
    lag = np.array([delay(felt_signal[:, i], vehicle[:, i], dt, max_lag) for i in range(3)])
    d_felt, d_vehicle = felt_signal - felt_rest, vehicle - vehicle_rest
    false = ((d_felt * d_vehicle < 0.0)
             & (np.abs(d_felt - d_vehicle) > np.asarray(thresholds, dtype=float)))
    count = false.sum(axis=0)
    return AxisCues(rmse, corr, lag, count, count / max(n, 1))


def actuator_use(model: Any, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray,
                 chunk: int = CHUNK, points: int = POINTS
                 ) -> tuple[LegUse, dict[str, np.ndarray]]:
    """The machine's inverse dynamics (``solve_batch``, ``chunk`` samples at a
    time) of its trajectory (N, coordinates): :class:`LegUse`, and the angles
    of the motion the machine makes by itself (``Machine.parasitic``: name -> (N,),
    NaN where the solution is void: unreachable, invalid input).
    """
    machine = machine_of(model)
    n, legs = len(q), len(machine.legs)
    peak_f, sum_f2 = np.zeros(legs), np.zeros(legs)
    peak_v, peak_p = np.zeros(legs), np.zeros(legs)
    s_min, s_max = np.full(legs, np.inf), np.full(legs, -np.inf)
    statuses: dict[str, int] = {}
    own = {name: np.zeros(n) for name in machine.parasitic}
    every = max(1, n // points)
    kept_f, kept_v = [], []
    for start in range(0, n, chunk):
        part = slice(start, min(n, start + chunk))
        sol = solve_batch(model, q[part], qd[part], qdd[part])
        force, speed = np.asarray(sol.force), np.asarray(sol.rate)
        peak_f = np.maximum(peak_f, np.abs(force).max(axis=0))
        sum_f2 += (force * force).sum(axis=0)
        peak_v = np.maximum(peak_v, np.abs(speed).max(axis=0))
        peak_p = np.maximum(peak_p, np.abs(np.asarray(sol.power)).max(axis=0))
        stroke = np.asarray(sol.stroke)
        s_min, s_max = np.minimum(s_min, stroke.min(axis=0)), np.maximum(s_max, stroke.max(axis=0))
        names, counts = np.unique(np.array([s.value for s in sol.status]), return_counts=True)
        for name, count in zip(names.tolist(), counts.tolist()):
            statuses[name] = statuses.get(name, 0) + count
        void = np.array([s in _VOID for s in sol.status])
        for name, angle in machine.parasitic.items():
            own[name][part] = np.where(void, np.nan, angle(sol))
        first = (-start) % every
        kept_f.append(force[first::every])
        kept_v.append(speed[first::every])
    limits = machine.actuator_limits(model)
    allowed = limits.stroke_max - limits.stroke_min
    use = LegUse(labels=machine.leg_labels or machine.legs, peak_force=peak_f,
                 rms_force=np.sqrt(sum_f2 / max(n, 1)), peak_speed=peak_v, peak_power=peak_p,
                 stroke_min=s_min, stroke_max=s_max, stroke_used=(s_max - s_min) / allowed,
                 limits=limits, statuses=dict(sorted(statuses.items())),
                 force=np.concatenate(kept_f), speed=np.concatenate(kept_v))
    return use, own


def cue_metrics(model: Any, run: CueRun, params: CueingParams,
                max_lag: float = MAX_LAG) -> CueMetrics:
    """The metrics of ``run`` (:func:`.planner.run`) on ``model`` with the
    head and tilt rate limit of ``params``.
    """
    n = len(run.t)
    dt = 1.0 / params.rate
    legs, own = actuator_use(model, run.q, run.qd, run.qdd)
    q, qd, qdd = (six(run.coordinates, x) for x in (run.q, run.qd, run.qdd))
    # what the limiter gave up: the felt cue of its output against the washout's, both in
    # the machine's channels, without its own motion
    if run.desired_q is run.q:               # limiter none: nothing given up
        gap = np.zeros((n, 3))
    else:
        wished = (six(run.coordinates, x)
                  for x in (run.desired_q, run.desired_qd, run.desired_qdd))
        gap = felt(q, qd, qdd, params.head)[0] - felt(*wished, params.head)[0]
    machine = machine_of(model)
    home = solve_batch(model, *(np.zeros((1, len(run.coordinates))),) * 3)
    for name, angle in own.items():          # the machine's own motion (module docstring)
        i = CHANNELS.index(name)
        q[:, i] = angle - float(np.asarray(machine.parasitic[name](home))[0])
        if n > 1:
            qd[:, i] = np.gradient(q[:, i], dt)
            qdd[:, i] = np.gradient(qd[:, i], dt)
    f_p, w_p = felt(q, qd, qdd, params.head)
    # where the machine's own motion is unknown (a void solution), nothing is felt for sure
    known = np.isfinite(f_p).all(axis=1) & np.isfinite(w_p).all(axis=1)
    f_k, w_k, vf, vw = f_p[known], w_p[known], run.f[known], run.omega[known]
    force = compare(f_k, vf, _REST_F, run.f[0], FORCE_THRESHOLDS, dt, max_lag)
    rate = compare(w_k, vw, np.zeros(3), run.omega[0], (RATE_THRESHOLD,) * 3, dt, max_lag)
    added = np.abs(w_k[:, :2] - vw[:, :2]).max(axis=1)     # rotation felt, not made
    given = np.asarray(run.given_up, dtype=float)
    acted = np.array([bool(x) for x in run.limit])
    names, counts = np.unique(np.asarray(run.limit[acted], dtype=str), return_counts=True)
    return CueMetrics(
        samples=n, felt_samples=int(known.sum()),
        duration=float(run.t[-1] - run.t[0]) if n else 0.0, force=force, rate=rate,
        tilt_rate_excess=int((added > params.tilt_rate_limit).sum()),
        tilt_rate_peak=float(added.max()) if len(added) else 0.0,
        legs=legs, given_up_mean=float(given.mean()) if n else 0.0,
        given_up_max=float(given.max()) if n else 0.0,
        given_up_fraction=float((given > 0).mean()) if n else 0.0,
        limits=dict(zip(names.tolist(), counts.tolist())),
        given_up_rmse=np.sqrt(np.mean(gap * gap, axis=0)), dropped=run.dropped,
        felt_f=f_p, felt_omega=w_p)

