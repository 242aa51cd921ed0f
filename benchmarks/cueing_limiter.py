"""The limiter (``cueing.limiter: inverse_dynamics``) against the usual practice.

On violent vehicle logs, both machines (their packaged params files):

(a) the limiter on the design's washout;
(b) one global gain scale (translation, tilt and rotation gains times s),
    lowered by bisection until the whole log's pure washout (``limiter: none``)
    fits: every sample's solve ``ok``.

Each against the pure washout at full gain (what the washout asks): the RMSE
of the felt specific force at the head (design, "Cue metrics": ``f_P = R^T
(p''_h - g_N)``, ``p_h = p + R h``), and their ratio (b) / (a): how many times
more cue the usual practice gives up. Also: the share of samples the limiter
limited, the outputs whose solve is not ``ok`` (must be 0), and the planner's
CPU time per sample (washout + limiter, and the pure washout).

    python -m benchmarks.cueing_limiter [--quick] [--seconds 40]

The logs (:func:`logs`): ordinary motion with violent moments (gusts, a car's
full stop and a bump, a crash), and aerobatics violent throughout.
"""
from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np
import yaml

import flight_sim_dynamics as fsd
from flight_sim_dynamics.cueing.params import G, cueing_params
from flight_sim_dynamics.cueing.planner import CueRun, Planner, run
from flight_sim_dynamics.core.status import Status

from ._common import ROOT, header, table

FILES = ('config/flight_sim_dynamics.yaml', 'config/stewart_6dof.yaml')
LOG_RATE = 100.0        # Hz, the vehicle logs' rate
BISECTIONS = 12


def _noise(rng: np.random.Generator, n: int, alpha: float) -> np.ndarray:
    """(n, 3) white noise through a one-pole low-pass (gain ``alpha`` a
    sample), scaled to unit RMS per column.
    """
    x = rng.standard_normal((n, 3))
    y = np.empty_like(x)
    y[0] = x[0]
    for k in range(1, n):
        y[k] = y[k - 1] + alpha * (x[k] - y[k - 1])
    return y / y.std(axis=0)


def logs(seconds: float) -> dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """Vehicle logs (t, specific force f (N, 3), angular velocity (N, 3)), body
    axes REP-103, at :data:`LOG_RATE`, seeded: three of ordinary motion with
    violent moments (what a gain lowered for the whole log pays for), and one
    violent throughout.
    """
    rng = np.random.default_rng(31)
    t = np.arange(0.0, seconds, 1.0 / LOG_RATE)
    n = len(t)
    rest = np.tile([0.0, 0.0, G], (n, 1))

    def at(fraction: float, length: float) -> np.ndarray:
        return (t >= fraction * seconds) & (t < fraction * seconds + length)

    out = {}
    # flight in light turbulence (0.4 m/s^2, 0.05 rad/s RMS), two severe gusts
    f = rest + 0.4 * _noise(rng, n, 0.1)
    w = 0.05 * _noise(rng, n, 0.08)
    for fraction, sign in ((0.3, 1.0), (0.7, -1.0)):
        f[at(fraction, 0.4)] += sign * np.array([4.0, 8.0, 15.0])
        w[at(fraction, 0.8)] += sign * np.array([0.8, 0.3, 0.2])
    out['gusts'] = (t, f, w)
    # a car on a country road (+-2 m/s^2, curves), a full stop at 1 g, a bump
    f = rest.copy()
    w = np.zeros((n, 3))
    f[:, 0] += 1.5 * np.sin(2 * np.pi * t / 7.0)
    f[:, 1] += 2.0 * np.sin(2 * np.pi * t / 5.0)
    w[:, 2] = 0.3 * np.sin(2 * np.pi * t / 5.0)
    f[:, 2] += 0.3 * _noise(rng, n, 0.3)[:, 2]
    f[at(0.5, 1.5), 0] -= 9.8
    f[at(0.8, 0.1), 2] += 3.0 * G
    out['car'] = (t, f, w)
    # a crash: calm driving, a 10 g deceleration for 0.12 s, tumbling, calm
    f = rest + 0.3 * _noise(rng, n, 0.1)
    w = np.zeros((n, 3))
    f[at(0.3, 0.12), 0] -= 10.0 * G
    f[at(0.3, 0.12), 2] += 4.0 * G
    w[at(0.3, 1.5)] = [3.0, 1.5, 2.0]
    out['crash'] = (t, f, w)
    # violent throughout: aerobatics in turbulence, 3-4 m/s^2 and 0.3-0.6 rad/s RMS
    f = rest + np.array([3.0, 3.0, 4.0]) * _noise(rng, n, 0.12)
    w = np.array([0.6, 0.4, 0.3]) * _noise(rng, n, 0.08)
    out['aerobatics'] = (t, f, w)
    return out


def _rotation(roll: np.ndarray, pitch: np.ndarray, yaw: np.ndarray) -> np.ndarray:
    """(N, 3, 3) R = Rz(yaw) Ry(pitch) Rx(roll)."""
    cr, sr, cp, sp, cy, sy = (np.cos(roll), np.sin(roll), np.cos(pitch), np.sin(pitch),
                              np.cos(yaw), np.sin(yaw))
    return np.stack([
        np.stack([cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr], -1),
        np.stack([sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr], -1),
        np.stack([-sp, cp * sr, cp * cr], -1)], -2)


def felt(cue: CueRun, head: np.ndarray, dt: float) -> np.ndarray:
    """(N, 3) the felt specific force at the head, platform axes (design, "Cue
    metrics"): the translation's acceleration from the samples' qdd, the
    head's rotational part by central differences of R h.
    """
    n = len(cue.t)
    six = {name: np.zeros(n) for name in ('surge', 'sway', 'heave', 'roll', 'pitch', 'yaw')}
    acc = {name: np.zeros(n) for name in six}
    for k, name in enumerate(cue.coordinates):
        six[name], acc[name] = cue.q[:, k], cue.qdd[:, k]
    R = _rotation(six['roll'], six['pitch'], six['yaw'])
    rh = R @ head
    rh_dd = np.gradient(np.gradient(rh, dt, axis=0), dt, axis=0)
    p_dd = np.stack([acc['surge'], acc['sway'], acc['heave']], -1)
    return np.einsum('nji,nj->ni', R, p_dd + rh_dd - np.array([0.0, 0.0, -G]))


def rmse(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.sum((a - b) ** 2, axis=1))))


def not_ok(model, cue: CueRun) -> int:
    sol = fsd.solve_batch(model, cue.q, cue.qd, cue.qdd)
    return int(sum(s is not Status.OK for s in sol.status))


def scaled(params, s: float):
    return params.replace(limiter='none', translation_gain=params.translation_gain * s,
                          tilt_gain=params.tilt_gain * s, rotation_gain=params.rotation_gain * s)


def timed_run(model, params, log) -> tuple[CueRun, float]:
    start = time.process_time()
    cue = run(model, params, *log)
    return cue, (time.process_time() - start) / len(cue.t)


def step_cost(model, params, repeats: int = 5, samples: int = 2000) -> float:
    """µs per ``Planner.step`` in the common case: gentle motion (the car's
    curves at a fifth), the limiter caught up and passing the washout's
    samples on; the best of ``repeats`` runs of ``samples`` steps (CPU time of
    this process: on a shared host, wall time counts the other processes' turns).
    """
    t = np.arange(samples) / params.rate
    f = np.tile([0.0, 0.0, G], (samples, 1))
    f[:, 0] += 0.3 * np.sin(2 * np.pi * t / 7.0)
    f[:, 1] += 0.4 * np.sin(2 * np.pi * t / 5.0)
    w = np.zeros((samples, 3))
    w[:, 2] = 0.06 * np.sin(2 * np.pi * t / 5.0)
    best = float('inf')
    for _ in range(repeats):
        planner = Planner(model, params)
        step = planner.step
        start = time.process_time()
        for k in range(samples):
            step(f[k], w[k])
        best = min(best, (time.process_time() - start) / samples)
    return best * 1e6


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--seconds', type=float, default=40.0, help='length of each log, s')
    parser.add_argument('--quick', action='store_true', help='5 s logs, 8 bisections')
    args = parser.parse_args(argv)
    seconds = 5.0 if args.quick else args.seconds
    bisections = 8 if args.quick else BISECTIONS
    print(header(f'limiter against one global gain scale, violent logs of {seconds:g} s, '
                 'felt specific force RMSE against the pure washout'))
    rows, costs = [], []
    for path in FILES:
        model = fsd.load_model(str(ROOT / path))
        with open(ROOT / path, encoding='utf-8') as stream:
            group = yaml.safe_load(stream)['flight_sim_dynamics']['ros__parameters'].get('cueing')
        params = cueing_params(group).replace(limiter='inverse_dynamics')
        dt = 1.0 / params.rate
        costs.append([Path(path).stem, f'{step_cost(model, params):.1f}',
                      f"{step_cost(model, params.replace(limiter='none')):.1f}"])
        for name, log in logs(seconds).items():
            pure, t_pure = timed_run(model, params.replace(limiter='none'), log)
            wanted = felt(pure, params.head, dt)
            limited, t_limited = timed_run(model, params, log)
            low, high = 0.0, 1.0
            if not not_ok(model, pure):
                low = 1.0
            else:
                for _ in range(bisections):
                    s = 0.5 * (low + high)
                    if not_ok(model, run(model, scaled(params, s), *log)):
                        high = s
                    else:
                        low = s
            baseline = run(model, scaled(params, low), *log)
            a = rmse(felt(limited, params.head, dt), wanted)
            b = rmse(felt(baseline, params.head, dt), wanted)
            rows.append([name, Path(path).stem, f'{len(limited.t):,}',
                         f'{100.0 * np.mean(limited.given_up > 0):.1f}',
                         f'{a:.3f}', f'{b:.3f}', f'{low:.3f}',
                         f'{b / a:.2f}x' if a > 0 else 'inf', str(not_ok(model, limited)),
                         f'{t_limited * 1e6:.1f}', f'{t_pure * 1e6:.1f}'])
    print(table(['log', 'params file', 'samples', 'limited %', 'RMSE limiter m/s^2',
                 'RMSE gain scale m/s^2', 'gain scale', 'ratio', 'limiter outputs not ok',
                 'us/sample planner', 'us/sample washout only'], rows))
    print()
    print(table(['params file', 'us/step planner, common case', 'us/step washout only'],
                costs))
    print('\nRMSE: felt specific force at the head against the pure washout at full gain; '
          'ratio: gain scale / limiter (> 1: the limiter gives up less); us/sample: CPU '
          'time of cueing.planner.run per output sample (washout + limiter; limiter none); '
          'us/step: Planner.step on gentle motion, CPU time, best of 5 runs of 2000 steps.')


if __name__ == '__main__':
    main()
