"""The digital twin's figures (flight_sim_dynamics.core.simulation, docs/twin.md).

* speed: the real-time factor of the closed loop (RK4 at 1 kHz, the
  ``violent`` motion, full feed-forward, the full plant) and of the open loop
  in this process through the public API, and the cost of one RK4 stage;
* what accuracy buys: the tracking error (max and RMS; surge, heave, roll and
  leg lengths) of the closed loop on the paper's three motions and on
  ``violent``, for the feed-forward of every packaged scene and for none, at
  one servo bandwidth (default gains: a critically damped leg of the plant's
  leg-space mass, :meth:`Servo.for_bandwidth`), the plant the full model with
  the packaged limits;
* open-loop error growth: the inverse-dynamics forces of a 6 s motion near
  the workspace's edge (:func:`edge_motion`) fed back open loop, RK4 at 1 kHz:
  the largest pose error up to every 0.5 s.

Prints figures and tables; writes them to out/twin.md, or with
``--update-docs`` between the markers of docs/twin.md.

    python -m benchmarks.twin [--bandwidth 5] [--repeats 3] [--quick] [--update-docs]
"""
from __future__ import annotations

import argparse
import math
import statistics
import sys
import time
from pathlib import Path
from typing import Sequence

import numpy as np

import flight_sim_dynamics as fsd
from flight_sim_dynamics.cli.bench_report import machine_header
from flight_sim_dynamics.cli.csv_io import atomic_output
from flight_sim_dynamics.config.scenes import available_scenes
from flight_sim_dynamics.core import forward_dynamics as fd
from flight_sim_dynamics.core.motions import TEST_MOTIONS, get
from flight_sim_dynamics.core.simulation import (DEFAULT_BANDWIDTH_HZ, DEFAULT_DAMPING,
                                                 Servo, simulate)

ROOT = Path(__file__).resolve().parents[1]
DEFAULT_OUT = Path('out') / 'twin.md'
DOCS = ROOT / 'docs' / 'twin.md'
BEGIN, END = '<!-- twin-benchmark:begin -->', '<!-- twin-benchmark:end -->'
EDGE_DURATION = 6.0
#: The edge motion: (offset, amplitude, frequency Hz) per coordinate; every
#: sample ok, strokes up to 0.549 m of the 0.6 m limit.
EDGE_TERMS = ((0.0, 0.1, 0.35), (0.3, 0.15, 0.25), (0.0, 0.3, 0.3))


def edge_motion(t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """q, qd, qdd (each (N, 3)) of offset + amplitude sin(2 pi f t) per coordinate."""
    t = np.atleast_1d(np.asarray(t, dtype=float))[:, None]
    offset, amplitude, hz = (np.array(c) for c in zip(*EDGE_TERMS))
    w = 2.0 * math.pi * hz
    return (offset + amplitude * np.sin(w * t), amplitude * w * np.cos(w * t),
            -amplitude * w * w * np.sin(w * t))


def table(header: Sequence[str], rows: Sequence[Sequence[str]]) -> str:
    lines = ['| ' + ' | '.join(header) + ' |',
             '| ' + ' | '.join([':---'] + ['---:'] * (len(header) - 1)) + ' |']
    lines += ['| ' + ' | '.join(row) + ' |' for row in rows]
    return '\n'.join(lines) + '\n'


def speed_rows(plant: fsd.Model, repeats: int, motion: str) -> list[list[str]]:
    """Real-time factors (median of ``repeats`` runs) and per-stage costs."""
    reference = get(motion)
    closed, opened = [], []
    t, q, qd, qdd = reference.sampled(1000.0)
    forces = (t, fsd.solve_batch(plant, q, qd, qdd).force)
    for _ in range(repeats):
        start = time.perf_counter()
        simulate(plant, reference=reference, feedforward=plant)
        closed.append(reference.duration / (time.perf_counter() - start))
        start = time.perf_counter()
        simulate(plant, forces=forces)
        opened.append(reference.duration / (time.perf_counter() - start))
    state = (q[len(q) // 2], qd[len(q) // 2])
    M, b, _ = fd.affine_terms(plant, *state)
    stage = [_time_us(lambda: fd.affine_terms(plant, *state)),
             _time_us(lambda: fd.solve_accelerations(M, b, b)),
             _time_us(lambda: fsd.solve(plant, state[0], state[1], (0.0, 0.0, 0.0)))]
    return [[f'closed loop, RK4 1 kHz, {motion}, full feed-forward: real-time factor',
             f'{statistics.median(closed):.2f}'],
            [f'open loop, RK4 1 kHz, {motion}: real-time factor',
             f'{statistics.median(opened):.2f}'],
            ['M and b (four `fsd.solve`): median per stage', f'{stage[0]:.1f} us'],
            ['cond(M) and LU solve: median per stage', f'{stage[1]:.1f} us'],
            ['one `fsd.solve`: median', f'{stage[2]:.1f} us']]


def _time_us(call, n: int = 2000) -> float:
    times = []
    for _ in range(n):
        start = time.perf_counter_ns()
        call()
        times.append(time.perf_counter_ns() - start)
    return statistics.median(times) / 1e3


def tracking_rows(plant: fsd.Model, servo: Servo, motions: Sequence[str],
                  scenes: Sequence[str]) -> list[list[str]]:
    """One row per (motion, feed-forward): max / RMS errors, mm and mrad."""
    rows = []
    for name in motions:
        for scene in (*scenes, 'none'):
            feedforward = None if scene == 'none' else fsd.load_model(scene=scene)
            sim = simulate(plant, reference=get(name), feedforward=feedforward, servo=servo)
            e = sim.tracking()
            cells = [f"{1e3 * e[f'{k}_max']:.3g} / {1e3 * e[f'{k}_rms']:.3g}"
                     for k in ('surge', 'heave', 'roll', 'length')]
            rows.append([name, scene, *cells, f'{np.max(np.abs(sim.rate)):.2f}',
                         f'{np.max(np.abs(sim.force)):.0f}', str(sim.outcome)])
    return rows


def growth_rows(plant: fsd.Model, step_s: float = 0.5) -> list[list[str]]:
    """Open loop on the edge motion: the largest pose error up to every 0.5 s."""
    t = np.arange(int(round(EDGE_DURATION * 1000)) + 1) / 1000.0
    q, qd, qdd = edge_motion(t)
    sol = fsd.solve_batch(plant, q, qd, qdd)
    sim = simulate(plant, forces=(t, sol.force), initial=(q[0], qd[0]))
    n = len(sim.t)
    error = np.abs(sim.q - q[:n])
    rows = []
    for end in np.arange(step_s, EDGE_DURATION + 1e-9, step_s):
        upto = sim.t <= end + 1e-9
        if sim.t[-1] + 1e-9 < end:
            rows.append([f'{end:.1f}', '-', '-', f'stopped at {sim.t[-1]:.3f} s: {sim.outcome}'])
            break
        rows.append([f'{end:.1f}', f'{error[upto, :2].max():.2e}', f'{error[upto, 2].max():.2e}',
                     str(sim.outcome) if end >= EDGE_DURATION - 1e-9 else ''])
    peak = ['peak condition (kinematic / Jacobian) on the motion',
            f'{np.max(sol.kinematic_condition):.3g} / {np.max(sol.jacobian_condition):.3g}']
    statuses = ', '.join(sorted({str(s) for s in sol.status}))
    return rows + [[peak[0], peak[1], '', ''], ['statuses of the motion', statuses, '', '']]


def report(args: argparse.Namespace, argv: Sequence[str]) -> str:
    plant = fsd.load_model()
    servo = Servo.for_bandwidth(plant, args.bandwidth, DEFAULT_DAMPING)
    motions = ('vertical',) if args.quick else TEST_MOTIONS
    scenes = ('full',) if args.quick else tuple(available_scenes())
    out = [f'Servo: {args.bandwidth:g} Hz, damping {DEFAULT_DAMPING:g}: kp = '
           + ', '.join(f'{k:.0f}' for k in servo.kp) + ' N/m, kd = '
           + ', '.join(f'{k:.0f}' for k in servo.kd) + ' N s/m (legs A, B, C); plant: full '
           f'model, limits {plant.limits.max_force:g} N, {plant.limits.max_speed:g} m/s; '
           'RK4 step 1 ms\n',
           '### Speed\n', table(['figure', 'value'],
                                speed_rows(plant, args.repeats, 'vertical' if args.quick
                                           else 'violent')),
           '### Tracking error by feed-forward scene\n',
           table(['motion', 'feed-forward', 'surge max / RMS mm', 'heave max / RMS mm',
                  'roll max / RMS mrad', 'leg length max / RMS mm', 'peak leg rate m/s',
                  'peak force N', 'outcome'],
                 tracking_rows(plant, servo, motions, scenes))]
    if not args.quick:
        out += ['### Open-loop error growth, 6 s motion near the workspace edge\n',
                table(['up to t s', 'surge/heave max error m', 'roll max error rad', 'note'],
                      growth_rows(plant))]
    out += ['### Machine and command\n', '\n'.join(machine_header(argv)).replace(
        'flight-sim-dynamics bench', 'python -m benchmarks.twin') + '\n']
    return '\n'.join(out)


def write(text: str, update_docs: bool, out: str) -> str:
    if not update_docs:
        path = Path(out)
        path.parent.mkdir(parents=True, exist_ok=True)
        with atomic_output(path) as f:
            f.write(text.encode())
        return str(path)
    doc = DOCS.read_text()
    try:
        head, rest = doc.split(BEGIN, 1)
        _, tail = rest.split(END, 1)
    except ValueError:
        raise SystemExit(f'{DOCS}: markers {BEGIN} ... {END} not found') from None
    with atomic_output(DOCS) as f:
        f.write(f'{head}{BEGIN}\n{text}{END}{tail}'.encode())
    return str(DOCS)


def main(argv: Sequence[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    p = argparse.ArgumentParser(prog='python -m benchmarks.twin',
                                description=__doc__.split('\n\n')[0])
    where = p.add_mutually_exclusive_group()
    where.add_argument('--out', default=str(DEFAULT_OUT), metavar='MD',
                       help=f'page to write (default {DEFAULT_OUT})')
    where.add_argument('--update-docs', action='store_true',
                       help='write between the markers of docs/twin.md instead')
    p.add_argument('--bandwidth', type=float, default=DEFAULT_BANDWIDTH_HZ, metavar='HZ',
                   help=f'servo bandwidth of the gains (default {DEFAULT_BANDWIDTH_HZ:g} Hz)')
    p.add_argument('--repeats', type=int, default=3, help='timed runs, median of (3)')
    p.add_argument('--quick', action='store_true',
                   help='smoke run: one motion, one scene, no growth table (figures meaningless)')
    args = p.parse_args(argv)
    if not (math.isfinite(args.bandwidth) and args.bandwidth > 0) or args.repeats < 1:
        p.error('--bandwidth must be > 0 and --repeats >= 1')
    text = report(args, argv)
    print(text)
    print(f'wrote {write(text, args.update_docs, args.out)}', file=sys.stderr)
    return 0


if __name__ == '__main__':
    sys.exit(main())
