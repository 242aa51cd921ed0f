"""The washout (flight_sim_dynamics/cueing/washout.py) against the design's
check values (/work/shared/design/cueing.md, "Check values", limiter none,
1 kHz, within 0.5 %), its closed forms and scipy.signal.lsim of the continuous
transfer functions (an independent reference: lsim interpolates the input
linearly between samples, as the design asks; scipy.signal is imported by that
test only: importing it costs about 1.2 s, in every process that collects this
file)."""
from __future__ import annotations

import math

import numpy as np
import pytest

from flight_sim_dynamics.config.cueing import G, defaults
from flight_sim_dynamics.cueing.washout import Washout

RATE = 1000.0
REST = np.array([0.0, 0.0, G])
BASE = defaults().replace(limiter='none')
NO_TILT = BASE.replace(tilt_gain=(0.0, 0.0))
SURGE, HEAVE, ROLL, PITCH = 0, 2, 3, 4


LIMITED = []      # per sample of the last simulate(): (pitch, roll) tilt rate-limited


def simulate(params, f, omega=None):
    """q, qd, qdd (N, 6) of inputs f (N, 3) (deviations added to rest) and omega (N, 3)."""
    w = Washout(params)
    LIMITED.clear()
    n = len(f)
    omega = np.zeros((n, 3)) if omega is None else omega
    out = np.empty((3, n, 6))
    for k in range(n):
        d = w.step(REST + f[k], omega[k])
        out[0, k], out[1, k], out[2, k] = d.q, d.qd, d.qdd
        LIMITED.append(w.tilt_limited)
    return out


def times(duration):
    return np.arange(int(round(duration * RATE)) + 1) / RATE


def step_input(t, axis, amplitude, at=1.0):
    f = np.zeros((len(t), 3))
    f[t >= at, axis] = amplitude
    return f


def close(value, expected, rel=0.005):
    assert value == pytest.approx(expected, rel=rel), (value, expected)


def test_surge_step_settles_at_k_over_omega_squared_with_the_classic_false_cue():
    t = times(25.0)
    q, _, qdd = simulate(NO_TILT, step_input(t, 0, 1.0))
    k, w = 0.6, 0.8
    close(q[-1, SURGE], k / w ** 2)                       # 0.9375 m, and stays there
    assert np.ptp(q[t > 20.0, SURGE]) < 1e-3
    a = qdd[:, SURGE]
    lowest = int(np.argmin(a))
    close(a[lowest], -k * math.exp(-2.0))                 # -0.0812 m/s^2
    close(t[lowest] - 1.0, 2.5)
    crossing = np.flatnonzero((a[:-1] > 0) & (a[1:] <= 0))
    assert len(crossing) == 1
    close(t[crossing[0]] - 1.0, 1.0 / w)                  # 1.25 s
    after = t >= 1.0 + 2e-3                               # the closed form k (1 - wt) e^-wt
    tau = t[after] - 1.0
    assert np.max(np.abs(a[after] - k * (1 - w * tau) * np.exp(-w * tau))) < 2e-3


def test_heave_step_peaks_and_returns():
    t = times(60.0)
    q, _, _ = simulate(BASE, step_input(t, 2, 1.0))
    h = q[:, HEAVE]
    peak = int(np.argmax(h))
    close(h[peak], 0.2989)
    close(t[peak] - 1.0, 3.33)
    close(np.interp(21.0, t, h), 0.0143)
    assert abs(h[-1]) < 1e-4                              # back to 0


@pytest.mark.parametrize('hz, gain, phase', [(0.1, 0.229, 103.7), (0.5, 0.564, 28.6),
                                             (1.0, 0.590, 14.5)])
def test_surge_sine_gain_and_phase_lead(hz, gain, phase):
    t = times(40.0 if hz < 0.5 else 20.0)
    f = np.zeros((len(t), 3))
    f[:, 0] = np.sin(2 * np.pi * hz * t)
    _, _, qdd = simulate(NO_TILT, f)
    last = t >= t[-1] - 2.0 / hz                          # steady state: two periods
    basis = np.column_stack([np.sin(2 * np.pi * hz * t[last]), np.cos(2 * np.pi * hz * t[last])])
    (s, c), *_ = np.linalg.lstsq(basis, qdd[last, SURGE], rcond=None)
    close(math.hypot(s, c), gain)
    close(math.degrees(math.atan2(c, s)), phase)


@pytest.mark.parametrize('amplitude, pitch_deg, t90', [(1.0, -3.51, 1.94), (3.0, -10.58, 3.21),
                                                       (5.0, -17.81, 5.35)])
def test_tilt_final_angle_and_time_to_ninety_percent(amplitude, pitch_deg, t90):
    t = times(30.0)
    q, qd, _ = simulate(BASE, step_input(t, 0, amplitude))
    pitch = q[:, PITCH]
    close(math.degrees(pitch[-1]), pitch_deg)
    felt = G * np.sin(np.abs(pitch))
    first = int(np.flatnonzero(felt >= 0.9 * 0.6 * amplitude)[0])
    close(t[first] - 1.0, t90)
    peak_rate = math.degrees(np.max(np.abs(qd[:, PITCH])))
    if amplitude == 1.0:
        close(peak_rate, 2.58)                            # the rate limit never engages
    else:
        close(peak_rate, 3.0, rel=0.02)                   # it does: 3 deg/s


def test_translation_plus_tilt_dips_at_one_metre_per_second_squared():
    t = times(6.0)
    q, _, qdd = simulate(BASE, step_input(t, 0, 1.0))
    total = qdd[:, SURGE] + G * np.sin(-q[:, PITCH])
    window = (t > 1.01) & (t < 4.0)
    lowest = int(np.flatnonzero(window)[np.argmin(total[window])])
    close(total[lowest], 0.395)
    close(t[lowest] - 1.0, 0.64)


def _smooth_random(t, seed, scale):
    """Three random piecewise-linear signals from 0, their knots on samples."""
    rng = np.random.default_rng(seed)
    knots = t[::len(t) // 40]
    values = rng.normal(0, scale, (len(knots), 3))
    values[0] = 0.0
    return np.column_stack([np.interp(t, knots, values[:, i]) for i in range(3)])


def _sines(t, seed, scale):
    """Three smooth random signals from 0 (sums of sines): their slopes change
    by O(dt) a sample, so trapezoids integrate them to O(dt^2)."""
    rng = np.random.default_rng(seed)
    hz = rng.uniform(0.05, 1.0, (4, 3))
    return scale * sum(np.sin(2 * np.pi * hz[j] * t[:, None]) for j in range(4)) / 2


def _lsim(systems, inputs, t):
    """scipy.signal.lsim of each transfer function ``(num, den, input column)``
    of ``systems`` driven by that column of ``inputs`` (N, m): their outputs,
    one column each. One lsim call of all of them side by side (a block-diagonal
    state-space system of their own tf2ss realisations, the one lsim makes of a
    single (num, den)): lsim steps its samples in a Python loop, so one call
    instead of one per transfer function (15) saves about 2.5 s."""
    from scipy import linalg, signal
    blocks = [signal.tf2ss(num, den) for num, den, _ in systems]
    a = linalg.block_diag(*(A for A, _, _, _ in blocks))
    b = np.zeros((len(a), inputs.shape[1]))
    c = linalg.block_diag(*(C for _, _, C, _ in blocks))
    d = np.zeros((len(systems), inputs.shape[1]))
    row = 0
    for k, ((_, _, column), (A, B, _, D)) in enumerate(zip(systems, blocks)):
        b[row:row + len(A), column] = B[:, 0]
        d[k, column] = D[0, 0]
        row += len(A)
    return signal.lsim((a, b, c, d), inputs, t)[1].reshape(len(t), len(systems))


def test_translation_and_rotation_equal_lsim_of_the_transfer_functions():
    t = times(20.0)
    f = _smooth_random(t, 1, 1.0)
    omega = _smooth_random(t, 2, 0.3)
    q, qd, qdd = simulate(NO_TILT, f, omega)
    p = NO_TILT
    systems, outputs = [], []           # (num, den, input column), (series, channel, what)
    for i in range(3):
        k, w, z, wb = (p.translation_gain[i], p.translation_omega[i], p.translation_zeta[i],
                       p.translation_omega_b[i])
        den = np.polymul([1.0, 2 * z * w, w * w], [1.0, wb] if wb else [1.0])
        for order, series in enumerate((q, qd, qdd)):    # p = s^2/(den (s+wb)) / s^2 ...
            num = k * np.array([1.0] + [0.0] * (order + (1 if wb else 0)))
            systems.append((num, den, i))                 # input: f[:, i]
            outputs.append((series, i, ('translation', i, order)))
        k, w, z = p.rotation_gain[i], p.rotation_omega[i], p.rotation_zeta[i]
        den = [1.0, 2 * z * w, w * w]
        channel = (ROLL, PITCH, 5)[i]
        for order, series in enumerate((q, qd)):           # beta = s/den, beta' = s^2/den
            num = k * np.array([1.0] + [0.0] * (order + 1))
            systems.append((num, den, 3 + i))             # input: omega[:, i]
            outputs.append((series, channel, ('rotation', i, order)))
    refs = _lsim(systems, np.column_stack([f, omega]), t)
    assert refs.shape == (len(t), 15)
    for (series, channel, what), ref in zip(outputs, refs.T):
        assert np.max(np.abs(series[:, channel] - ref)) < 1e-6 * (1 + np.max(np.abs(ref))), what


def _integrates(x, xd, jumps=None):
    """The largest drift of x from the trapezoidal integral of xd, per channel,
    relative to the channel's range; ``jumps`` (N, channels): what xd jumps by
    just after each sample (its value there is the limit from before)."""
    pieces = 0.5 * (xd[1:] + xd[:-1])
    if jumps is not None:
        pieces += 0.5 * jumps[:-1]
    integral = np.concatenate([np.zeros((1, x.shape[1])), np.cumsum(pieces / RATE, axis=0)])
    return np.max(np.abs(integral - (x - x[0])), axis=0) / (np.max(np.abs(x), axis=0) + 1e-3)


def test_rates_and_accelerations_integrate_to_the_pose():
    """qd integrates to q and qdd to qd (trapezoids: an O(dt^2) error), on every
    channel (tilt below its rate limit). The rotational acceleration at a
    sample is the one on the interval before it (k_r times the input's slope
    there, design step 3: beta'' = s^3/(...) k_r dw): it jumps by k_r times the
    change of slope just after the sample."""
    t = times(30.0)
    omega = _sines(t, 4, 0.3)
    q, qd, qdd = simulate(BASE, _sines(t, 3, 0.1), omega)
    assert not np.any(LIMITED)
    slope = np.diff(omega, axis=0, prepend=omega[:1]) * RATE
    jumps = np.zeros_like(q)
    jumps[:-1, ROLL:] = BASE.rotation_gain * (slope[1:] - slope[:-1])
    assert np.all(_integrates(q, qd) < 1e-5)
    assert np.all(_integrates(qd, qdd, jumps) < 1e-5)


def test_the_rate_limited_tilt_moves_at_the_limit_and_its_rates_integrate_to_it():
    """While limited the tilt moves by r dt a sample at the rate r, exactly; where
    the limit engages or lets go the rate steps (the design's sample-by-sample
    limit), a trapezoid there errs by at most half the step times dt."""
    t = times(30.0)
    q, qd, _ = simulate(BASE, _sines(t, 5, 1.0))
    r, dt = BASE.tilt_rate_limit, 1.0 / RATE
    for channel, limited in ((PITCH, np.array(LIMITED)[:, 0]), (ROLL, np.array(LIMITED)[:, 1])):
        assert 1000 < limited.sum() < len(t) - 1000
        inside = np.flatnonzero(limited[1:] & limited[:-1]) + 1
        assert np.allclose(np.abs(qd[inside, channel]), r, rtol=1e-12)
        assert np.allclose(np.abs(np.diff(q[:, channel])[inside - 1]), r * dt, rtol=1e-9)
        changes = np.flatnonzero(limited[1:] != limited[:-1]) + 1
        steps = 0.5 * dt * np.abs(qd[changes, channel] - qd[changes - 1, channel]).sum()
        scale = np.max(np.abs(q[:, channel])) + 1e-3
        assert _integrates(q, qd)[channel] <= (steps + 1e-6) / scale


def test_a_constant_input_is_the_rest_whatever_it_is():
    w = Washout(BASE)
    f, omega = np.array([1.0, -2.0, 9.0]), np.array([0.1, 0.2, -0.3])
    for _ in range(100):
        d = w.step(f, omega)
    assert not np.any(d.q) and not np.any(d.qd) and not np.any(d.qdd)


def test_reset_starts_again_from_the_next_sample():
    w = Washout(BASE)
    t = times(3.0)
    f = step_input(t, 0, 2.0, at=0.5)
    first = [w.step(REST + row, np.zeros(3)).q for row in f]
    w.reset()
    again = [w.step(REST + row, np.zeros(3)).q for row in f]
    assert np.array_equal(np.array(first), np.array(again))


def test_the_free_response_is_where_the_washout_goes_with_its_input_held():
    """Washout.ahead (the limiter's look-ahead): the poses the washout reaches
    when its input stays as it is, against stepping it with the input held;
    the tilt within its rate limit's reach.
    """
    from flight_sim_dynamics.cueing.washout import forecast_matrix
    for params in (defaults(), defaults().replace(tilt_gain=np.zeros(2))):
        _check_free_response(params, forecast_matrix)


def _check_free_response(params, forecast_matrix):
    horizons = (0.05, 0.3, 1.2)
    rng = np.random.default_rng(3)
    w = Washout(params)
    w.step(np.array([0.0, 0.0, G]), np.zeros(3))
    for _ in range(700):             # some motion: every filter away from rest
        w.step(np.array([1.5, -1.0, G + 0.8]) + 0.3 * rng.standard_normal(3),
               np.array([0.2, -0.1, 0.15]) + 0.05 * rng.standard_normal(3))
    f, omega = np.array([1.2, -0.8, G + 0.5]), np.array([0.1, -0.2, 0.1])
    w.step(f, omega)
    poses = np.array(w.ahead(forecast_matrix(params, horizons), horizons))
    steps = [round(h * params.rate) for h in horizons]
    reached = {}
    for k in range(1, max(steps) + 1):
        d = w.step(f, omega)
        if k in steps:
            reached[k] = d.q
    for pose, k in zip(poses, steps):
        # translations and yaw: the linear filters exactly; roll, pitch: the
        # rotation's filter plus a tilt moving at most at its rate limit
        assert np.allclose(pose[[0, 1, 2, 5]], reached[k][[0, 1, 2, 5]], atol=1e-9)
        reach = params.tilt_rate_limit * k / params.rate
        tol = 2 * reach if params.tilt_gain.any() else 0.0
        assert np.all(np.abs(pose[3:5] - reached[k][3:5]) <= tol + 1e-9)
