"""The limiter (``cueing.limiter: inverse_dynamics``) against the usual practice.

On violent vehicle logs, both machines (their packaged params files):

(a) the limiter on the design's washout;
(b) one global gain scale (translation, tilt and rotation gains times s),
    lowered by bisection until the whole log's pure washout (``limiter: none``)
    fits: every sample's solve ``ok``; also (b') the same at the limiter's
    margins (the solve on the model the limiter judges with, its limits
    narrowed by ``cueing.margin.*``), which the usual practice need not keep.

Each against the pure washout at full gain (what the washout asks): the RMSE
of the felt specific force at the head (:func:`.metrics.felt`: design, "Cue
metrics"), and their ratio (b) / (a): how many times
more cue the usual practice gives up (and (b') / (a)). With ``preview.slope``
set in the params file (the 3-DOF machine's), (a) is the offline run's
preview (L8). Also: the share of samples the limiter
limited, the outputs whose solve is not ``ok`` (must be 0), and the planner's
CPU time per sample (washout + limiter, and the pure washout).

    python -m benchmarks.cueing_limiter [--quick]

The logs: :mod:`flight_sim_dynamics.cueing.vehicles`' (a take-off, turbulence,
a car braking hard, and violent: multi-g spikes and a 10 g crash), at 100 Hz.
"""
from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

import flight_sim_dynamics as fsd
from flight_sim_dynamics.config.machine_files import load_cueing
from flight_sim_dynamics.config.cueing import G
from flight_sim_dynamics.cueing.metrics import felt, six
from flight_sim_dynamics.cueing.planner import CueRun, Planner, run
from flight_sim_dynamics.cueing.vehicles import vehicle_log
from flight_sim_dynamics.core.status import Status
from flight_sim_dynamics.machines.api import machine_of

from ._common import ROOT, header, table

FILES = ('config/flight_sim_dynamics.yaml', 'config/stewart_6dof.yaml')
LOG_RATE = 100.0        # Hz, the vehicle logs' rate (the planner resamples them)
BISECTIONS = 12
#: the vehicle logs (cueing.vehicles), each with its own duration; --quick: the last
LOGS = ('takeoff', 'turbulence', 'braking', 'violent')


def felt_force(cue: CueRun, head: np.ndarray) -> np.ndarray:
    """(N, 3) the felt specific force at the head (:func:`.metrics.felt`) of
    the platform's samples, in the machine's coordinates.
    """
    return felt(*(six(cue.coordinates, x) for x in (cue.q, cue.qd, cue.qdd)), head)[0]


def rmse(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.sum((a - b) ** 2, axis=1))))


def gain_scale(model, params, log, bisections: int, judge=None) -> float:
    """The largest gain scale (bisection) at which every sample of the log's
    pure washout solves ``ok`` on ``judge`` (default: ``model``).
    """
    judge = model if judge is None else judge
    if not not_ok(judge, run(model, scaled(params, 1.0), *log)):
        return 1.0
    low, high = 0.0, 1.0
    for _ in range(bisections):
        s = 0.5 * (low + high)
        if not_ok(judge, run(model, scaled(params, s), *log)):
            high = s
        else:
            low = s
    return low


def ratio(b: float, a: float) -> str:
    return f'{b / a:.2f}x' if a > 0 else ('1.00x' if b == 0 else 'inf')


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
    parser.add_argument('--quick', action='store_true',
                        help=f'the log {LOGS[-1]} only, 6 bisections')
    args = parser.parse_args(argv)
    names = LOGS[-1:] if args.quick else LOGS
    bisections = 6 if args.quick else BISECTIONS
    print(header(f'limiter against one global gain scale, vehicle logs {", ".join(names)} '
                 f'at {LOG_RATE:g} Hz, felt specific force RMSE against the pure washout'))
    rows, costs = [], []
    for path in FILES:
        model = fsd.load_model(str(ROOT / path))
        params = load_cueing(ROOT / path).replace(limiter='inverse_dynamics')
        settings = params.limiter_settings
        tight = machine_of(model).tightened(model, settings['margin.stroke'],
                                            settings['margin.fraction'])
        costs.append([Path(path).stem, f'{step_cost(model, params):.1f}',
                      f"{step_cost(model, params.replace(limiter='none')):.1f}"])
        for name in names:
            v = vehicle_log(name, LOG_RATE)
            log = (v.t, v.f, v.omega)
            pure, t_pure = timed_run(model, params.replace(limiter='none'), log)
            wanted = felt_force(pure, params.head)
            limited, t_limited = timed_run(model, params, log)
            low = gain_scale(model, params, log, bisections)
            low_m = gain_scale(model, params, log, bisections, tight)
            a = rmse(felt_force(limited, params.head), wanted)
            b, b_m = (rmse(felt_force(run(model, scaled(params, s), *log), params.head), wanted)
                      for s in (low, low_m))
            rows.append([name, Path(path).stem, f'{len(limited.t):,}',
                         f'{100.0 * np.mean(limited.given_up > 0):.1f}',
                         f'{a:.3f}', f'{b:.3f}', f'{low:.3f}', ratio(b, a),
                         f'{b_m:.3f}', f'{low_m:.3f}', ratio(b_m, a),
                         str(not_ok(model, limited)),
                         f'{t_limited * 1e6:.1f}', f'{t_pure * 1e6:.1f}'])
    print(table(['log', 'params file', 'samples', 'limited %', 'RMSE limiter m/s^2',
                 'RMSE gain scale m/s^2', 'gain scale', 'ratio',
                 'RMSE gain scale at margins m/s^2', 'gain scale at margins',
                 'ratio at margins', 'limiter outputs not ok',
                 'us/sample planner', 'us/sample washout only'], rows))
    print()
    print(table(['params file', 'us/step planner, common case', 'us/step washout only'],
                costs))
    print('\nRMSE: felt specific force at the head against the pure washout at full gain; '
          'ratio: gain scale / limiter (> 1: the limiter gives up less); at margins: the '
          "gain scale fitted to the limiter's narrowed limits; us/sample: CPU "
          'time of cueing.planner.run per output sample (washout + limiter; limiter none); '
          'us/step: Planner.step on gentle motion, CPU time, best of 5 runs of 2000 steps.')


if __name__ == '__main__':
    main()
