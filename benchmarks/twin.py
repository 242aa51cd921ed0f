"""The twin's real-time factor (``fsd.simulate``, RK4 at 1 kHz, closed and open
loop), kernel and Python code (its first --python-seconds) in one run, for the
3-DOF machine (``violent``) and the 6-DOF hexapod (stewart_6dof, a sum of sines
of 3 s about home, peak leg rate 1.1 m/s); the Python code timed on the first
--python-seconds of each motion; FSD_KERNEL=0: the Python code only; --out:
also the 3-DOF tracking error by feed-forward scene, and its figure.

    python -m benchmarks.twin [--repeats 11] [--quick] [--out docs/twin_tracking.png]
"""
from __future__ import annotations

import argparse
import statistics
import time
from dataclasses import replace
from pathlib import Path
from typing import Callable, Sequence

import numpy as np

import flight_sim_dynamics as fsd
from flight_sim_dynamics.config.scenes import available_scenes
from flight_sim_dynamics.core import kernel as core_kernel
from flight_sim_dynamics.core.interpolation import Reference
from flight_sim_dynamics.machines.api import servo_for_bandwidth, simulate
from flight_sim_dynamics.machines.staicu.motions import TEST_MOTIONS, get

from ._common import ROOT, header, table

#: The hexapod's motion: amplitudes (m, rad) and frequencies (Hz) of one sine
#: per coordinate about home (surge, sway, heave, roll, pitch, yaw), and its length.
HEXAPOD_SINES = ((0.04, 0.03, 0.025, 0.05, 0.04, 0.06), (1.7, 2.3, 2.9, 2.1, 2.6, 1.9))
HEXAPOD_SECONDS = 3.0


def hexapod_motion(t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """q, qd, qdd (each (N, 6)) of the hexapod's motion at times ``t``."""
    a, w = np.array(HEXAPOD_SINES[0]), 2.0 * np.pi * np.array(HEXAPOD_SINES[1])
    t = np.atleast_1d(np.asarray(t, dtype=float))[:, None]
    return a * np.sin(w * t), a * w * np.cos(w * t), -a * w * w * np.sin(w * t)


#: FSD_KERNEL=0 asks for the Python code: the kernel rows are left out (the
#: benchmark's own switch would otherwise turn the kernel back on for them).
KERNEL_WANTED = core_kernel.wanted()


def kernel_built(model) -> bool:
    """True when the model's machine has its twin loop in a built kernel, and
    FSD_KERNEL=0 does not ask for the Python code.
    """
    machine = fsd.machine_of(model)
    with core_kernel.use_kernel(True):
        return (KERNEL_WANTED and machine.integrate_rows is not None
                and machine.kernel_enabled())


def real_time_factor(run: Callable[[], fsd.Simulation], repeats: int) -> float:
    factors = []
    for _ in range(repeats):
        start = time.perf_counter()
        sim = run()
        factors.append((sim.t[-1] - sim.t[0]) / (time.perf_counter() - start))
    return statistics.median(factors)


def speed(plant, reference: Reference, repeats: int, python_s: float,
          has_kernel: bool) -> list[list[str]]:
    """Closed loop (the plant's own feed-forward) and open loop (the reference's
    inverse-dynamics forces at 1 kHz) of ``reference``: real-time factors.
    """
    t = np.linspace(reference.start, reference.end,
                    int(round((reference.end - reference.start) * 1000.0)) + 1)
    q, qd, qdd = reference.motion(t)
    forces = (t, fsd.solve_batch(plant, q, qd, qdd).force)
    initial = (q[0], qd[0])
    rows = int(round(python_s * 1000.0)) + 1
    paths = [('kernel', True)] if has_kernel else []
    out = []
    for label, on in paths + [('Python', False)]:
        ref = reference if on else replace(reference, end=reference.start + python_s)
        f = forces if on else (t[:rows], forces[1][:rows])
        n = repeats if on else min(repeats, 3)
        with core_kernel.use_kernel(on):
            closed = real_time_factor(lambda: simulate(plant, reference=ref, feedforward=plant), n)
            opened = real_time_factor(lambda: simulate(plant, forces=f, initial=initial), n)
        span = 'whole motion' if on else f'first {python_s:g} s'
        out.append([label, span, str(n), f'{closed:.2f}', f'{opened:.2f}'])
    return out


def tracking(plant: fsd.Model, motions: Sequence[str], out: Path) -> list[list[str]]:
    """Closed loop of every motion with every scene's feed-forward (and none):
    leg-length error max / RMS (mm) per run, and the figure at ``out``.
    """
    from matplotlib.figure import Figure

    servo = servo_for_bandwidth(plant)
    scenes = (*available_scenes(), 'none')
    rows, bars = [], []
    for name in motions:
        for scene in scenes:
            ff = None if scene == 'none' else fsd.load_model(scene=scene)
            e = simulate(plant, reference=get(name), feedforward=ff, servo=servo).tracking()
            worst, rms = 1e3 * e['length_max'], 1e3 * e['length_rms']
            rows.append([name, scene, f'{worst:.3g}', f'{rms:.3g}'])
            bars.append((f'{name}: {scene}', max(worst, 1e-12), max(rms, 1e-12)))
    fig = Figure(figsize=(9.0, 1.2 + 0.4 * len(bars)), dpi=110, layout='constrained')
    ax = fig.subplots()
    y = np.arange(len(bars))
    ax.barh(y, [b[1] for b in bars], left=1e-13,
            color=['black' if 'full' in b[0] else 'tab:blue' for b in bars])
    ax.plot([b[2] for b in bars], y, 'o', color='white', markeredgecolor='black')
    ax.set_xscale('log')
    ax.set_yticks(y, [b[0] for b in bars], fontsize=8)
    ax.invert_yaxis()
    ax.grid(True, axis='x', alpha=0.3)
    ax.set_xlabel('leg length tracking error, mm (bar: max, dot: RMS; log scale)')
    ax.set_title('Closed-loop tracking by feed-forward scene', fontsize='medium')
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, format='png')
    return rows


def main(argv: Sequence[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog='python -m benchmarks.twin',
                                description=__doc__.split('\n\n')[0])
    p.add_argument('--repeats', type=int, default=11, help='median of (Python code: at most 3)')
    p.add_argument('--python-seconds', type=float, default=0.5, metavar='S')
    p.add_argument('--quick', action='store_true', help='1 run, the vertical motion')
    p.add_argument('--out', type=Path, metavar='PNG',
                   help='also run the tracking table and write its figure here')
    args = p.parse_args(argv)
    if args.repeats < 1 or args.python_seconds <= 0:
        p.error('--repeats must be >= 1 and --python-seconds > 0')
    plant = fsd.load_model()
    motion = 'vertical' if args.quick else 'violent'
    repeats = 1 if args.quick else args.repeats
    python_s = 0.05 if args.quick else args.python_seconds
    factors = ['closed-loop real-time factor', 'open-loop real-time factor']
    print(header(f'3-DOF: {motion} motion; 6-DOF: stewart_6dof, '
                 f'{0.5 if args.quick else HEXAPOD_SECONDS:g} s of sines; RK4 1 kHz, median '
                 'of the runs'))
    print(table(['path', 'timed', 'runs', *factors],
                speed(plant, Reference.from_motion(get(motion)), repeats, python_s,
                      kernel_built(plant))))
    hexapod = fsd.load_model(str(ROOT / 'config' / 'stewart_6dof.yaml'))
    print()
    print(table(['6-DOF path', 'timed', 'runs', *factors],
                speed(hexapod, Reference(hexapod_motion, 0.0,
                                         0.5 if args.quick else HEXAPOD_SECONDS),
                      repeats, python_s, kernel_built(hexapod))))
    if args.out is not None:
        motions = ('vertical',) if args.quick else TEST_MOTIONS
        print()
        print(table(['motion', 'feed-forward', 'leg length max mm', 'leg length RMS mm'],
                    tracking(plant, motions, args.out)))
        print(f'wrote {args.out}')
    return 0


if __name__ == '__main__':
    raise SystemExit(main())
