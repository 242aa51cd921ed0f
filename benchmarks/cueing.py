"""Motion cueing: the washout against the design's check values (limiter none,
1 kHz, % error), the planner's cost per sample streaming (both machines, both
limiters), and ``flight-sim-dynamics cue`` offline on a long log at 1 kHz
(a 10-minute turbulence log, the 1-hour time extrapolated; ``--hour``: the
3.6 M samples themselves): the hexapod (its file: the look-ahead), and the
3-DOF machine (its file: the preview, L8). ``--judge``: instead, the offline
run (``cueing.planner.run`` on a turbulence log, as ``cue`` runs it) with its
block judge (``InverseDynamicsLimiter.fits_rows``) against one ``fits`` per
sample, interleaved (docs/design/implementations.md).

    python -m benchmarks.cueing [--quick] [--hour] [--samples 20000]
    python -m benchmarks.cueing --judge [--minutes 5] [--repeats 2]
"""
from __future__ import annotations

import argparse
import math
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Sequence

import numpy as np

import flight_sim_dynamics as fsd
from flight_sim_dynamics.cli import csv_io
from flight_sim_dynamics.cli.cue import VEHICLE_COLUMNS
from flight_sim_dynamics.config.machine_files import load_cueing
from flight_sim_dynamics.config.cueing import G
from flight_sim_dynamics.cueing.planner import Planner, run
from flight_sim_dynamics.cueing.vehicles import vehicle_log
from flight_sim_dynamics.cueing.washout import Washout

from ._common import ROOT, header, table

HEXAPOD = str(ROOT / 'config' / 'stewart_6dof.yaml')
FLIGHT = str(ROOT / 'config' / 'flight_sim_dynamics.yaml')
RATE = 1000.0


def _simulate(params, axis: int, signal) -> tuple[np.ndarray, np.ndarray, np.ndarray,
                                                  np.ndarray]:
    """t, q, qd, qdd (N, 6) of the washout for a deviation ``signal(t)`` of f[axis]."""
    t = np.arange(int(signal.duration * RATE) + 1) / RATE
    w = Washout(params)
    out = np.empty((3, len(t), 6))
    zero = np.zeros(3)
    for k, tk in enumerate(t):
        f = np.array([0.0, 0.0, G])
        f[axis] += signal(tk)
        d = w.step(f, zero)
        out[0, k], out[1, k], out[2, k] = d.q, d.qd, d.qdd
    return t, out[0], out[1], out[2]


class Step:
    def __init__(self, size: float, duration: float) -> None:
        self.size, self.duration = size, duration

    def __call__(self, t: float) -> float:
        return self.size if t >= 1.0 else 0.0


class Sine:
    def __init__(self, hz: float) -> None:
        self.hz, self.duration = hz, (40.0 if hz < 0.5 else 20.0)

    def __call__(self, t: float) -> float:
        return math.sin(2 * math.pi * self.hz * t)


def check_values() -> list[list[str]]:
    """The design's check values against the washout at 1 kHz (limiter none)."""
    params = load_cueing(HEXAPOD).replace(limiter='none')
    no_tilt = params.replace(tilt_gain=(0.0, 0.0))
    rows = []

    def row(what: str, design: float, got: float, fmt: str = '.4g') -> None:
        rows.append([what, format(design, fmt), format(got, fmt),
                     f'{100 * (got - design) / abs(design):+.2f}'])

    t, q, _, qdd = _simulate(no_tilt, 0, Step(1.0, 25.0))
    a = qdd[:, 0]
    low = int(np.argmin(a))
    cross = int(np.flatnonzero((a[:-1] > 0) & (a[1:] <= 0))[0])
    row('surge step: x_inf (m)', 0.9375, q[-1, 0])
    row('surge step: lowest acceleration (m/s^2)', -0.6 * math.exp(-2), a[low])
    row('surge step: time of the lowest (s)', 2.5, t[low] - 1.0)
    row('surge step: acceleration changes sign (s)', 1.25, t[cross] - 1.0)
    t, q, _, _ = _simulate(params, 2, Step(1.0, 25.0))
    peak = int(np.argmax(q[:, 2]))
    row('heave step: peak (m)', 0.2989, q[peak, 2])
    row('heave step: time of the peak (s)', 3.33, t[peak] - 1.0)
    row('heave step: left 20 s after (m)', 0.0143, float(np.interp(21.0, t, q[:, 2])))
    for hz, gain, phase in ((0.1, 0.229, 103.7), (0.5, 0.564, 28.6), (1.0, 0.590, 14.5)):
        sine = Sine(hz)
        t, _, _, qdd = _simulate(no_tilt, 0, sine)
        last = t >= t[-1] - 2.0 / hz
        basis = np.column_stack([np.sin(2 * np.pi * hz * t[last]),
                                 np.cos(2 * np.pi * hz * t[last])])
        (s, c), *_ = np.linalg.lstsq(basis, qdd[last, 0], rcond=None)
        row(f'surge sine {hz:g} Hz: gain', gain, math.hypot(s, c))
        row(f'surge sine {hz:g} Hz: phase lead (deg)', phase, math.degrees(math.atan2(c, s)))
    for size, final, t90 in ((1.0, -3.51, 1.94), (3.0, -10.58, 3.21), (5.0, -17.81, 5.35)):
        t, q, qd, qdd = _simulate(params, 0, Step(size, 30.0))
        pitch = q[:, 4]
        felt = G * np.sin(np.abs(pitch))
        first = int(np.flatnonzero(felt >= 0.9 * 0.6 * size)[0])
        row(f'tilt {size:g} m/s^2: final pitch (deg)', final, math.degrees(pitch[-1]))
        row(f'tilt {size:g} m/s^2: time to 90 % (s)', t90, t[first] - 1.0)
        if size == 1.0:
            row('tilt 1 m/s^2: peak rate (deg/s)', 2.58, math.degrees(np.abs(qd[:, 4]).max()))
            total = qdd[:, 0] + G * np.sin(-pitch)
            window = (t > 1.01) & (t < 4.0)
            low = int(np.flatnonzero(window)[np.argmin(total[window])])
            row('tilt 1 m/s^2: translation + tilt dip (m/s^2)', 0.395, total[low])
            row('tilt 1 m/s^2: time of the dip (s)', 0.64, t[low] - 1.0)
    return rows


def streaming_us(params_file: str | None, limiter: str, samples: int) -> tuple[float, float]:
    """Median and 99th percentile of one Planner.step (µs) over a violent log."""
    model = fsd.load_model(params_file)
    params = load_cueing(params_file).replace(limiter=limiter)
    log = vehicle_log('violent', RATE)
    planner = Planner(model, params)
    f, w = log.f, log.omega
    n = len(log.t)
    times = np.empty(samples)
    clock = time.perf_counter
    for k in range(samples):
        i = k % n
        if i == 0:
            planner.reset()
        start = clock()
        planner.step(f[i], w[i])
        times[k] = clock() - start
    return float(np.median(times) * 1e6), float(np.percentile(times, 99) * 1e6)


def offline(params_file: str, limiter: str, src: Path, output: Path) -> tuple[float, float]:
    """Wall and CPU seconds (user + system: less sensitive to the machine's load)
    of ``flight-sim-dynamics cue`` of ``src`` into ``output``.
    """
    cmd = [sys.executable, '-m', 'flight_sim_dynamics', 'cue', str(src), '-o',
           str(output), '--params', params_file, '--limiter', limiter]
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def judge_pair(minutes: float, repeats: int) -> list[list[str]]:
    """Wall and CPU s of ``run(parallel=True)`` of a ``minutes`` turbulence log
    per machine, judged by blocks and by one ``fits`` per sample (each median
    of ``repeats``, interleaved), and the gain.
    """
    log = vehicle_log('turbulence', RATE, 60.0 * minutes)
    rows = []
    for label, path in (('3-DOF', FLIGHT), ('hexapod', HEXAPOD)):
        model, params = fsd.load_model(path), load_cueing(path)
        times: dict[str, list[tuple[float, float]]] = {'block': [], 'sample': []}
        for _ in range(repeats):
            for how in times:
                times[how].append(_timed_run(model, params, log, per_sample=how == 'sample'))
        (wall, cpu), (wall0, cpu0) = (np.median(times[h], axis=0) for h in ('block', 'sample'))
        rows.append([label, f'{len(log.t):,}', f'{wall:.1f}', f'{cpu:.1f}', f'{wall0:.1f}',
                     f'{cpu0:.1f}', f'{100 * (1 - wall / wall0):.0f}'])
    return rows


def _per_sample_judge(planner: Planner, wanted: np.ndarray) -> list[bool]:
    """``Planner.judge`` by the limiter's ``fits``, one sample at a time."""
    dof = len(planner.index)
    return [planner.limiter.fits(w[:dof], w[dof:2 * dof], w[2 * dof:]) for w in wanted.tolist()]


def _timed_run(model, params, log, per_sample: bool) -> tuple[float, float]:
    """Wall and CPU s (this process and the forked one) of one offline run."""
    block_judge = Planner.judge
    if per_sample:
        Planner.judge = _per_sample_judge       # the fork inherits it
    try:
        cpu = time.process_time()
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        start = time.perf_counter()
        run(model, params, log.t, log.f, log.omega, parallel=True)
        wall = time.perf_counter() - start
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
    finally:
        Planner.judge = block_judge
    return wall, (time.process_time() - cpu + after.ru_utime - before.ru_utime
                  + after.ru_stime - before.ru_stime)


def main(argv: Sequence[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog='python -m benchmarks.cueing',
                                description=__doc__.split('\n\n')[0])
    p.add_argument('--samples', type=int, default=20000, help='streaming steps timed per case')
    p.add_argument('--minutes', type=float, default=10.0, help='offline log length')
    p.add_argument('--hour', action='store_true', help='offline: the 1-hour log itself')
    p.add_argument('--quick', action='store_true',
                   help='1,000 steps, a 0.05-minute log, the check values as always')
    p.add_argument('--judge', action='store_true',
                   help='the offline run judged by blocks against sample by sample')
    p.add_argument('--repeats', type=int, default=2, help='--judge: runs of each (median)')
    args = p.parse_args(argv)
    if args.judge:
        minutes = 5.0 if args.minutes == 10.0 else args.minutes
        print(header(f'the offline run\'s judge, a {minutes:g}-minute turbulence log at '
                     f'{RATE:g} Hz, median of {args.repeats}'))
        print(table(['machine', 'samples', 'by blocks: wall s', 'CPU s',
                     'sample by sample: wall s', 'CPU s', 'gain % (wall)'],
                    judge_pair(minutes, args.repeats)))
        print('\n(cueing.planner.run(parallel=True), as flight-sim-dynamics cue runs a long '
              'log; InverseDynamicsLimiter.fits_rows against fits)')
        return 0
    samples, minutes = (1000, 0.05) if args.quick else (args.samples, args.minutes)
    if args.hour:
        minutes = 60.0
    print(header(f'motion cueing at {RATE:g} Hz'))
    checks = check_values()
    worst = max(abs(float(r[3])) for r in checks)
    print(table(['check value (limiter none, 1 kHz)', 'design', 'washout', 'error %'], checks))
    print(f'\nlargest error: {worst:.2f} % (target 0.5 %)\n')
    rows = []
    for label, path in (('3-DOF', FLIGHT), ('hexapod', HEXAPOD)):
        for limiter in ('none', 'inverse_dynamics'):
            median, p99 = streaming_us(path, limiter, samples)
            rows.append([label, limiter, f'{median:.1f}', f'{p99:.1f}'])
    print(table(['machine', 'limiter', 'us per step (median)', 'p99'], rows))
    print(f'\n(Planner.step on the violent log, {samples:,} steps a case, one process)\n')
    rows = []
    with tempfile.TemporaryDirectory(prefix='fsd_cue_') as tmp:
        log = vehicle_log('turbulence', RATE, 60.0 * minutes)
        src, n = Path(tmp) / 'vehicle.csv', len(log.t)
        csv_io.write_csv(src, VEHICLE_COLUMNS, np.column_stack([log.t, log.f, log.omega]))
        short = vehicle_log('turbulence', RATE, 1.0)     # the start-up: not per sample
        first = Path(tmp) / 'short.csv'
        csv_io.write_csv(first, VEHICLE_COLUMNS,
                         np.column_stack([short.t, short.f, short.omega]))
        for label, machine, path, limiter, suffix in (
                ('none', 'hexapod', HEXAPOD, 'none', 'csv'),
                ('inverse_dynamics', 'hexapod', HEXAPOD, 'inverse_dynamics', 'csv'),
                ('inverse_dynamics', 'hexapod', HEXAPOD, 'inverse_dynamics', 'npz'),
                ('inverse_dynamics + preview', '3-DOF', FLIGHT, 'inverse_dynamics', 'npz')):
            out = Path(tmp) / f'platform.{suffix}'
            wall0, cpu0 = offline(path, limiter, first, out)
            wall, cpu = offline(path, limiter, src, out)
            scale = (3.6e6 - len(short.t)) / (n - len(short.t))
            rows.append([label, machine, suffix, f'{n:,}', f'{wall:.1f}', f'{cpu:.1f}',
                         f'{wall0 + (wall - wall0) * scale:.0f}',
                         f'{cpu0 + (cpu - cpu0) * scale:.0f}',
                         'measured' if args.hour else
                         f'start-up + x{scale:.0f} the rest'])
    print(table(['cue, limiter', 'machine', 'output', 'samples', 'wall s', 'CPU s',
                 '1-hour log wall s', '1-hour log CPU s', 'how'], rows))
    print(f'\n(flight-sim-dynamics cue, a {minutes:g}-minute turbulence log at 1 kHz, CSV in; '
          'the 1-hour figures: the start-up (a 1-second log) plus the rest scaled; '
          'target 120 s)')
    return 0


if __name__ == '__main__':
    raise SystemExit(main())
